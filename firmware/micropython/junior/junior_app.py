"""The ROAR Junior on MicroPython: HTTP control on port 81 exactly as the original robot takes
it (GET /?forward=True&left_spd=0.5&right_spd=0.5, parameters applied in order, the reply body
the ultrasonic distance in cm), driving an L298N, with the failsafe the original lacked: no
request for 500 ms stops the motors. The logic is roar_junior (the twin of the C++ core);
this file is the glue: Wi-Fi, the asyncio server, pins, the ranger, the watchdog.

The loop never blocks: it runs every millisecond (poll, pins, ranger trigger, watchdog), each
connection is its own task with its own bounded request reader, and the echo is timed by pin
interrupts (machine.time_pulse_us would hold the loop for the whole echo, up to 23 ms). At most MAX_CLIENTS connections are served: a new one replaces the quietest, and one
quiet for CLIENT_TIMEOUT_MS is closed, so idle connections cannot lock a driver out.
"""

import asyncio
import time

import config
import machine
import network
from roar_clock import Clock
from roar_console import Console
from roar_junior import INCOMPLETE, HttpRequestReader, JuniorBoard
from roar_wire import signing, spec

LOOP_MS = 1  # [ms] loop period
CONSOLE_POLL_MS = 10  # [ms] between reads of the console in the window after a reset
PING_MS = 60  # [ms] between ultrasonic pings (echoes die out)
MAX_ECHO_US = 23500  # [us] an echo longer than 4 m and back is no echo
MAX_CLIENTS = 4  # connections served at once
CLIENT_TIMEOUT_MS = spec.JUNIOR_IDLE_CLOSE_US // 1000  # [ms] a connection quiet this long is closed
READ_BYTES = 256  # [bytes] read from a connection at a time
WATCHDOG_MS = max(1000, spec.TIMING_LOOP_WATCHDOG_US // 1000)  # [ms] the ESP32's watchdog takes >= 1 s
PWM_FULL = 65535  # duty_u16 at full scale
SOUND_MM_PER_MS = 343  # [mm/ms] = 343 m/s in air at 20 C
WPA_WPA2_PSK = 4  # ESP-IDF's WIFI_AUTH_WPA_WPA2_PSK, for firmware that names it neither way


class Motors:
    """The L298N: direction pins and the enable pins' PWM; written only when they change."""

    def __init__(self):
        P = machine.Pin
        self.in_pins = [P(config.LEFT_IN1, P.OUT, value=0), P(config.LEFT_IN2, P.OUT, value=0),
                        P(config.RIGHT_IN1, P.OUT, value=0), P(config.RIGHT_IN2, P.OUT, value=0)]
        freq = spec.L298N_PWM_FREQUENCY_HZ
        self.enable = [machine.PWM(P(config.ENABLE_LEFT), freq=freq, duty_u16=0),
                       machine.PWM(P(config.ENABLE_RIGHT), freq=freq, duty_u16=0)]
        self.written = None

    def write(self, pins):
        if pins == self.written:
            return
        self.written = pins
        for side, (in1, in2, duty) in enumerate(pins):
            self.in_pins[2 * side].value(in1)
            self.in_pins[2 * side + 1].value(in2)
            self.enable[side].duty_u16(duty * PWM_FULL // spec.L298N_DUTY_FULL_SCALE)


class Ranger:
    """The HC-SR04: a trigger pulse every PING_MS, high for one loop period (it needs >= 10 us;
    it fires on the falling edge), so the loop never waits; the echo's width is timed by pin
    interrupts."""

    def __init__(self):
        self.trigger = machine.Pin(config.ULTRASONIC_TRIGGER, machine.Pin.OUT, value=0)
        self.echo = machine.Pin(config.ULTRASONIC_ECHO, machine.Pin.IN)
        self.echo.irq(self._edge, machine.Pin.IRQ_RISING | machine.Pin.IRQ_FALLING)
        self.distance_cm = 0  # 0: no echo
        self._rise = 0
        self._last_ping = -PING_MS

    def _edge(self, pin):
        now = time.ticks_us()
        if pin.value():
            self._rise = now
        else:
            width = time.ticks_diff(now, self._rise)
            self.distance_cm = width * SOUND_MM_PER_MS // 20000 if 0 < width <= MAX_ECHO_US else 0

    def step(self, now_ms):
        """Every loop: end the trigger pulse, or start the next one when it is due."""
        if self.trigger.value():
            self.trigger.value(0)
        elif now_ms - self._last_ping >= PING_MS:
            self._last_ping = now_ms
            self.trigger.value(1)


class Junior:
    def __init__(self, board):
        self.clock = Clock()
        self.board = board
        self.motors = Motors()
        self.ranger = Ranger()
        self.watchdog = None
        self.clients = []  # [task, last active ms]

    async def loop(self):
        """Every LOOP_MS: the failsafe and dead time (board.poll), pins, ranger, watchdog."""
        self.watchdog = machine.WDT(timeout=WATCHDOG_MS)
        next_tick = time.ticks_ms()
        while True:
            now = self.clock.now()
            self.motors.write(self.board.poll(now))
            self.ranger.step(now)
            self._close_quiet(now)
            self.watchdog.feed()
            next_tick = time.ticks_add(next_tick, LOOP_MS)
            await asyncio.sleep_ms(max(0, time.ticks_diff(next_tick, time.ticks_ms())))

    def _close_quiet(self, now):
        for client in self.clients:
            if now - client[1] > CLIENT_TIMEOUT_MS:
                client[0].cancel()

    async def serve(self, reader, writer):
        """One connection: requests read by its own bounded reader, answered in order."""
        if len(self.clients) >= MAX_CLIENTS:  # full: the quietest one makes room
            min(self.clients, key=lambda c: c[1])[0].cancel()
        me = [asyncio.current_task(), self.clock.now()]
        self.clients.append(me)
        request = HttpRequestReader()
        try:
            while True:
                data = await reader.read(READ_BYTES)
                if not data:
                    break
                me[1] = self.clock.now()
                while data:
                    used, state = request.feed(data)
                    data = data[used:]
                    if state == INCOMPLETE:
                        break
                    reply, keep = self.board.respond(request, self.ranger.distance_cm, self.clock.now())
                    writer.write(reply)
                    await writer.drain()
                    if not keep:
                        return
                    request.reset()
        except (OSError, asyncio.CancelledError):
            pass
        finally:
            self.clients.remove(me)
            writer.close()


def connect_wifi():
    """Join config.WIFI_SSID, or open the robot's own network; returns its address."""
    if config.WIFI_SSID:
        wlan = network.WLAN(network.STA_IF)
        wlan.active(True)
        wlan.connect(config.WIFI_SSID, config.WIFI_PASSWORD)
        for _ in range(100):
            if wlan.isconnected():
                return wlan.ifconfig()[0]
            time.sleep_ms(100)
        print("Wi-Fi: could not join %r; opening %r instead" % (config.WIFI_SSID, config.AP_SSID))
        wlan.active(False)
    ap = network.WLAN(network.AP_IF)
    ap.active(True)
    # WPA2 must be asked for: a password alone leaves the network open
    wpa2 = getattr(network, "AUTH_WPA_WPA2_PSK", None) or getattr(network.WLAN, "SEC_WPA_WPA2", WPA_WPA2_PSK)
    ap.config(essid=config.AP_SSID, password=config.AP_PASSWORD, authmode=wpa2)
    return ap.ifconfig()[0]


def console_window(board, console):
    """The serial console is free until the ranger takes its pins: for serial_window_us after
    a reset a computer can stop the program or set the key (key lines answered here)."""
    start = time.ticks_ms()
    while time.ticks_diff(time.ticks_ms(), start) < spec.JUNIOR_SERIAL_WINDOW_US // 1000:
        for line in board.serial_in(console.read(READ_BYTES)):
            console.write(line + spec.SERIAL_REPLY_LINE_END)
        time.sleep_ms(CONSOLE_POLL_MS)


async def main():
    board = JuniorBoard()
    console = Console()
    for line in board.boot(signing.FileNvm(config.KEY_FILE)):
        console.write(line + spec.SERIAL_REPLY_LINE_END)
    console_window(board, console)
    address = connect_wifi()
    print("ROAR Junior: http://%s:%d/?forward=True&left_spd=0.5&right_spd=0.5" % (address, spec.JUNIOR_CONTROL_PORT))
    junior = Junior(board)
    await asyncio.start_server(junior.serve, "0.0.0.0", spec.JUNIOR_CONTROL_PORT)
    await junior.loop()
