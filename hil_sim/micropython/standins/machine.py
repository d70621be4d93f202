"""`machine` for board programs under the suite: pins, PWM and the watchdog record what the
program does to them, with the simulated time (sim.now_us), and input pins take levels the test
program sets, calling their interrupt handlers on edges.

    machine.log = []              then every write: [(t_us, "pin", id, value) | (t_us, "pwm", id, freq, duty_u16) | ...]
    machine.pins[id].drive(1)     the test program drives an input (edges call irq handlers)
"""

import sim

log = None  # a list to record every write into (None: not recorded)
on_output = None  # called as on_output(pin_id, value) when a program sets an output pin
pins = {}  # id -> the latest Pin made on it
pwms = {}  # id -> the latest PWM on it
watchdogs = []
resets = []


def _record(*entry):
    if log is not None:
        log.append((sim.now_us,) + entry)


class Pin:
    IN, OUT, OPEN_DRAIN = 1, 3, 7
    PULL_UP, PULL_DOWN = 1, 2
    IRQ_FALLING, IRQ_RISING = 2, 1

    def __init__(self, id, mode=-1, pull=-1, value=None):
        self.id, self.mode = id, mode
        self._value = 0 if value is None else int(bool(value))
        self._irq = None
        self._trigger = 0
        pins[id] = self
        if value is not None:
            _record("pin", id, self._value)

    def init(self, mode=-1, pull=-1, value=None):
        self.mode = mode
        if value is not None:
            self.value(value)

    def value(self, v=None):
        if v is None:
            return self._value
        v = int(bool(v))
        if v != self._value or self.mode == Pin.OUT:
            self._value = v
            _record("pin", self.id, v)
            if on_output is not None:
                on_output(self.id, v)

    def on(self):
        self.value(1)

    def off(self):
        self.value(0)

    def __call__(self, v=None):
        return self.value(v)

    def irq(self, handler=None, trigger=3, hard=False):
        self._irq, self._trigger = handler, trigger
        return None

    # --- the test program's side ---------------------------------------------------------------
    def drive(self, v):
        """An input level from the outside world; an edge calls the irq handler."""
        v = int(bool(v))
        if v == self._value:
            return
        self._value = v
        edge = Pin.IRQ_RISING if v else Pin.IRQ_FALLING
        if self._irq is not None and self._trigger & edge:
            self._irq(self)


class PWM:
    def __init__(self, pin, freq=0, duty_u16=None, duty_ns=None, duty=None):
        self.pin = pin
        self._freq = freq
        self._duty_u16 = 0
        self._duty_ns = None
        pwms[pin.id] = self
        if duty_u16 is not None:
            self.duty_u16(duty_u16)
        elif duty_ns is not None:
            self.duty_ns(duty_ns)
        else:
            _record("pwm", pin.id, self._freq, 0)

    def freq(self, f=None):
        if f is None:
            return self._freq
        self._freq = f
        _record("pwm", self.pin.id, f, self._duty_u16)

    def duty_u16(self, d=None):
        if d is None:
            return self._duty_u16
        if not 0 <= d <= 65535:
            raise ValueError("duty_u16 must be 0..65535")
        self._duty_u16, self._duty_ns = int(d), None
        _record("pwm", self.pin.id, self._freq, self._duty_u16)

    def duty_ns(self, ns=None):
        if ns is None:
            return self._duty_ns if self._duty_ns is not None else self._duty_u16 * 1000000000 // (65535 * self._freq)
        if ns < 0:
            raise ValueError("duty_ns must be >= 0")
        self._duty_ns = int(ns)
        self._duty_u16 = min(65535, int(ns) * self._freq * 65535 // 1000000000)
        _record("pwm_ns", self.pin.id, self._freq, self._duty_ns)

    def deinit(self):
        _record("pwm", self.pin.id, 0, 0)


class WDT:
    def __init__(self, id=0, timeout=5000):
        self.timeout_ms = timeout
        self.fed_us = sim.now_us
        self.longest_gap_us = 0
        watchdogs.append(self)

    def feed(self):
        self.longest_gap_us = max(self.longest_gap_us, sim.now_us - self.fed_us)
        self.fed_us = sim.now_us


def time_pulse_us(pin, level, timeout_us=1000000):
    raise NotImplementedError("the boards time echoes with pin interrupts, not time_pulse_us")


def reset():
    resets.append(sim.now_us)
    raise SystemExit("machine.reset()")


def freq(f=None):
    return 240000000


def unique_id():
    return b"\x24\x0a\xc4\x00\x00\x01"
