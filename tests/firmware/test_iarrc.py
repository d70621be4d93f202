"""The IARRC car's controller (firmware/core iarrc.h): every mode transition, with SBUS frames
from a simulated transmitter, setpoints from a host and the battery, on the core's clock (and
across the 32-bit wrap); the quadrature decoder, the speed estimate and the PID's anti-windup."""

from roar.protocol import encode, encode_setpoint, spec
from roar_sim.core.iarrc import IarrcController
from roar_wire import sbus

FRAME_US = 7_000  # [us] between SBUS frames
HOST_US = 20_000  # [us] between host setpoints
OFF, MANUAL, AUTO = 1000, 1500, 2000  # [us] mode switch positions
RUN, STOP = 1000, 2000  # [us] stop switch positions
NEUTRAL = spec.CONTROL_NEUTRAL_US


class World:
    """A controller with a transmitter and a host around it, on a 1 ms control loop."""

    def __init__(self, start_us: int = 1_000_000) -> None:
        self.c = IarrcController()
        self.t = start_us
        self.tx = {"throttle": NEUTRAL, "steering": NEUTRAL, "mode": OFF, "stop": RUN}
        self.tx_on = True  # the transmitter's frames reach the receiver
        self.tx_failsafe = False  # the receiver says it lost the transmitter
        self.setpoint: tuple[int, int] | None = None  # the host sends this every 20 ms, or nothing
        self.status = self.c.control(self.t)
        self._next_frame = self.t
        self._next_host = self.t

    def frame(self) -> bytes:
        ch = [sbus.us_to_raw(NEUTRAL)] * 16
        ch[0], ch[2] = sbus.us_to_raw(self.tx["steering"]), sbus.us_to_raw(self.tx["throttle"])
        ch[4], ch[5] = sbus.us_to_raw(self.tx["mode"]), sbus.us_to_raw(self.tx["stop"])
        return sbus.encode(ch, spec.SBUS_FLAG_FAILSAFE if self.tx_failsafe else 0)

    def run(self, seconds: float) -> dict:
        end = self.t + int(seconds * 1e6)
        while self.t < end:
            self.t += 1000
            if self.t >= self._next_frame:
                self._next_frame += FRAME_US
                if self.tx_on:
                    self.c.sbus(self.frame(), self.t - 3000)
            if self.t >= self._next_host:
                self._next_host += HOST_US
                if self.setpoint is not None:
                    self.c.host(encode_setpoint(*self.setpoint), self.t)
            self.status = self.c.control(self.t)
        return self.status

    def mode(self, seconds: float = 0.1) -> str:
        return self.run(seconds)["mode"]


def armed(start_us: int = 1_000_000) -> World:
    w = World(start_us)
    assert w.mode() == "disarmed"
    return w


def test_boot_goes_to_disarmed_and_waits_for_the_switch_to_be_seen_at_off():
    w = World()
    assert w.status["mode"] == "disarmed"
    w.tx["mode"] = MANUAL  # the switch already at manual at power-up: no driving
    assert w.mode(0.5) == "disarmed"
    w.tx["mode"] = OFF
    assert w.mode() == "disarmed"
    w.tx["mode"] = MANUAL
    assert w.mode() == "manual"


def test_manual_follows_the_transmitter_through_the_brake_sequence():
    w = armed()
    w.tx.update(mode=MANUAL, throttle=1700, steering=1300)
    st = w.run(0.2)
    assert st["mode"] == "manual" and abs(st["throttle_us"] - 1700) <= 1 and abs(st["steering_us"] - 1300) <= 1
    w.tx["throttle"] = 1200  # reverse after forward: neutral, tap, neutral, then reverse
    pulses = [w.run(0.001)["throttle_us"] for _ in range(80)]
    assert pulses[0] == NEUTRAL and spec.TIMING_BRAKE_TAP_US in pulses and abs(pulses[-1] - 1200) <= 1


def test_manual_and_autonomous_swap_by_the_switch_and_off_disarms():
    w = armed()
    w.setpoint = (0, NEUTRAL)
    w.tx["mode"] = MANUAL
    assert w.mode() == "manual"
    w.tx["mode"] = AUTO
    assert w.mode() == "autonomous"
    w.tx["mode"] = MANUAL
    assert w.mode() == "manual"
    w.tx["mode"] = OFF
    st = w.run(0.1)
    assert st["mode"] == "disarmed" and st["throttle_us"] == NEUTRAL


def test_autonomous_needs_a_host_and_a_silent_one_stops_the_car_until_it_asks_for_zero():
    w = armed()
    w.tx["mode"] = AUTO
    assert w.run(0.1)["failsafe"] == "host_silent"  # no host: not driving
    w.setpoint = (0, NEUTRAL)
    st = w.run(0.1)
    assert (st["mode"], st["failsafe"]) == ("autonomous", "none")
    w.setpoint = (1500, 1400)
    st = w.run(0.1)
    assert st["mode"] == "autonomous" and st["throttle_us"] > NEUTRAL and st["steering_us"] == 1400
    w.setpoint = None  # the host goes quiet
    st = w.run(0.3)
    assert (st["mode"], st["failsafe"], st["throttle_us"]) == ("failsafe", "host_silent", NEUTRAL)
    w.setpoint = (1500, 1400)  # back, but asking for speed straight away: stays stopped
    assert w.mode(0.2) == "failsafe"
    w.setpoint = (0, NEUTRAL)  # a zero-speed setpoint re-arms it, as neutral re-arms an ESC car
    assert w.mode(0.1) == "autonomous"


def test_losing_the_transmitter_fails_safe_and_only_off_brings_it_back():
    for lose in ("silence", "failsafe_flag"):
        w = armed()
        w.tx.update(mode=MANUAL, throttle=1700)
        assert w.mode() == "manual"
        if lose == "silence":
            w.tx_on = False
        else:
            w.tx_failsafe = True
        st = w.run(0.15)
        assert (st["mode"], st["failsafe"], st["throttle_us"]) == ("failsafe", "rc_lost", NEUTRAL), lose
        w.tx_on, w.tx_failsafe = True, False  # back, switch still at manual: stays failsafe
        assert w.mode(0.3) == "failsafe"
        w.tx["mode"] = OFF
        assert w.mode() == "disarmed"


def test_a_transmitter_that_leaves_while_disarmed_must_show_off_again():
    w = armed()
    w.tx_on = False
    w.run(0.3)
    w.tx.update(mode=MANUAL)  # back with the switch at manual
    w.tx_on = True
    assert w.mode(0.3) == "disarmed"


def test_the_stop_switch_wins_from_every_mode_and_releases_only_through_off():
    for start in (OFF, MANUAL, AUTO):
        w = armed()
        w.setpoint = (800, NEUTRAL)
        w.tx["mode"] = start
        w.run(0.1)
        w.tx["stop"] = STOP
        st = w.run(0.05)
        assert (st["mode"], st["throttle_us"]) == ("emergency", NEUTRAL), start
        w.tx["stop"] = RUN  # released, switch still where it was: stays stopped unless off
        assert w.mode() == ("disarmed" if start == OFF else "emergency")
        w.tx["mode"] = OFF
        assert w.mode() == "disarmed"


def test_a_low_battery_cuts_off_and_needs_recovery_and_off():
    w = armed()
    w.c.battery(1264)  # 11.2 V (8.862 mV per count)
    w.tx["mode"] = MANUAL
    assert w.mode() == "manual" and not w.status["battery_low"]
    w.c.battery(1174)  # 10.4 V: the warning only
    assert w.mode() == "manual" and w.status["battery_low"]
    w.c.battery(1083)  # 9.6 V: cutoff
    st = w.run(0.05)
    assert (st["mode"], st["failsafe"], st["throttle_us"]) == ("failsafe", "battery", NEUTRAL)
    w.tx["mode"] = OFF
    assert w.mode() == "disarmed"
    w.tx["mode"] = MANUAL
    assert w.mode() == "disarmed"  # still below cutoff + hysteresis
    w.c.battery(1174)  # 10.4 V: above 9.9 + 0.3
    assert w.mode() == "manual"


def test_the_failsafes_hold_across_the_32_bit_clock_wrap_and_long_silences():
    w = armed(start_us=(1 << 32) - 200_000)  # the board's 32-bit counter wraps 0.2 s from now
    w.setpoint = (0, NEUTRAL)
    w.tx["mode"] = AUTO
    assert w.mode(0.5) == "autonomous"
    w.setpoint = None
    w.tx_on = False
    w.t += 1 << 33  # a silence of 2^33 us: nothing comes back to life
    st = w.run(0.01)
    assert st["mode"] == "failsafe" and st["throttle_us"] == NEUTRAL and not st["rc_present"]


def test_host_control_messages_are_not_setpoints():
    w = armed()
    results = w.c.host(encode(1600, 1500) + encode_setpoint(-300, 1500), w.t)
    assert results[10] == spec.PARSE_RESULT_OK and results[-1] == spec.PARSE_RESULT_SETPOINT
    assert w.run(0.01)["setpoint_mm_s"] == -300


def test_the_encoder_gives_speed_and_distance():
    w = armed()
    counts_per_m = 10240 * 1000 // 207
    for i in range(1, 101):  # 1 m/s for 0.1 s, 1 ms apart
        w.c.encoder(counts_per_m * i // 1000, w.t + i * 1000)
    st = w.c.control(w.t + 100_000)
    assert 980 <= st["speed_mm_s"] <= 1020 and 95 <= st["distance_mm"] <= 101
    for i in range(101, 201):  # then 2 m/s: the estimate follows (its window slides)
        w.c.encoder(counts_per_m * (100 + 2 * (i - 100)) // 1000, w.t + i * 1000)
    st = w.c.control(w.t + 200_000)
    assert 1980 <= st["speed_mm_s"] <= 2020 and 295 <= st["distance_mm"] <= 301


def test_the_pid_does_not_wind_up_while_saturated():
    w = armed()
    w.setpoint = (0, NEUTRAL)
    w.tx["mode"] = AUTO
    assert w.mode() == "autonomous"
    w.setpoint = (5000, NEUTRAL)  # far beyond what the (stationary) car reaches
    integrals = []
    for _ in range(10):
        st = w.run(0.1)
        integrals.append(st["pid_integral_mm"])
        assert st["mode"] == "autonomous" and st["throttle_us"] == spec.CONTROL_MAX_US
    assert integrals[-1] == integrals[0] == integrals[4]  # saturated: it stopped integrating
