"""The composed board logic (parser -> failsafe -> RC override -> brake FSM -> outputs), as the
Nano, the ESP32 and the simulator run it."""

import pytest

from roar.protocol import spec
from roar_sim.core.car import Car, CarConfig, ChannelCalibration
from roar_sim.core.library import ControlSource

N = spec.CONTROL_NEUTRAL_US
TIMEOUT = spec.TIMING_FAILSAFE_TIMEOUT_US


class Clock:
    """Drives a Car like a board's main loop: 1 kHz loop, 50 Hz output frames."""

    def __init__(self, car):
        self.car, self.t = car, 0

    def run(self, us, send=None, every=20_000):
        out = None
        end = self.t + us
        while self.t < end:
            if send is not None and self.t % every == 0:
                self.car.feed(send, self.t)
            out = self.car.step(self.t, self.t // spec.TIMING_SERVO_FRAME_US)
            self.t += 1000
        return out


def armed_car(config=None):
    car = Car(config)
    car.boot()
    clock = Clock(car)
    clock.run(40_000, b"(1500,1500)\n")
    return car, clock


def test_boot_banner_and_latched_start():
    car = Car()
    car.boot()
    clock = Clock(car)
    out = clock.run(100_000, b"(1700,1300)")
    assert (out.throttle_us, out.steering_us, out.source) == (N, N, ControlSource.FAILSAFE)
    assert car.replies() == ["READY 1\n", "FAILSAFE\n"]  # FAILSAFE once, not per message


def test_neutral_arms_then_commands_drive():
    car, clock = armed_car()
    assert car.replies() == ["READY 1\n", "ARMED\n"]
    out = clock.run(100_000, b"(1700,1300)")
    assert (out.throttle_us, out.steering_us, out.source) == (1700, 1300, ControlSource.HOST)


def test_errors_answer_one_line_each_and_keep_outputs():
    car, clock = armed_car()
    clock.run(40_000, b"(1600,1600)")
    car.replies()
    car.feed(b"(999,1500)(15a0,1500)x\n(1500,1500", clock.t)
    car.feed(b"\n", clock.t)
    assert car.replies() == ["ERR range\n", "ERR syntax\n", "ERR garbage\n", "ERR unterminated\n"]
    out = clock.run(10_000)
    assert (out.throttle_us, out.steering_us) == (1600, 1600)


def test_silence_trips_failsafe_within_the_timeout():
    car, clock = armed_car()
    clock.run(100_000, b"(1700,1200)", every=20_000)
    car.replies()
    last_command = clock.t - 20_000
    out = clock.run(TIMEOUT - 20_000)
    assert out.throttle_us == 1700  # not before the timeout
    out = clock.run(2_000)
    assert clock.t - 1000 - last_command > TIMEOUT
    assert (out.throttle_us, out.steering_us, out.source, out.latched) == (N, N, ControlSource.FAILSAFE, True)
    assert car.replies() == ["FAILSAFE\n"]
    out = clock.run(100_000, b"(1700,1200)")  # stale non-neutral stream does not restart the car
    assert out.throttle_us == N


def test_rc_override_wins_over_host_and_failsafe():
    car, clock = armed_car()
    clock.run(60_000, b"(1700,1300)")
    for i in range(spec.RC_LOCK_PULSES):
        car.rc_pulse(0, 1600, clock.t + i * 20_000)
        car.rc_pulse(1, 1900, clock.t + i * 20_000 + 500)
    clock.t += spec.RC_LOCK_PULSES * 20_000
    out = clock.run(1_000)
    assert (out.throttle_us, out.steering_us, out.source) == (1600, 1900, ControlSource.RC)


def test_trim_and_end_points_apply_to_outputs():
    cfg = CarConfig(throttle=ChannelCalibration(trim_us=20), steering=ChannelCalibration(min_us=1200, max_us=1800))
    car, clock = armed_car(cfg)
    out = clock.run(40_000, b"(1500,2000)")
    assert (out.throttle_us, out.steering_us) == (1520, 1800)


def test_forward_to_reverse_uses_the_sequence_and_can_be_disabled():
    car, clock = armed_car()
    clock.run(100_000, b"(1800,1500)")
    seen = [clock.run(1000, b"(1300,1500)", every=1000).throttle_us for _ in range(150)]
    assert seen[0] == N and spec.TIMING_BRAKE_TAP_US in seen and seen[-1] == 1300
    car, clock = armed_car(CarConfig(brake_fsm_enabled=False))
    clock.run(100_000, b"(1800,1500)")
    assert clock.run(1000, b"(1300,1500)", every=1000).throttle_us == 1300


def test_invalid_calibration_is_refused():
    with pytest.raises(ValueError, match="invalid channel calibration"):
        Car(CarConfig(steering=ChannelCalibration(min_us=1900, max_us=1100)))


def test_python_car_config_defaults_mirror_the_core():
    """The binding's CarConfig restates the core's defaults; they must not drift apart."""
    from roar_sim.core.car import default_config_from_core
    from roar_sim.core.library import ffi

    core, py = default_config_from_core(), CarConfig().to_c()
    names = [name for name, _ in ffi.typeof("roar_car_config_t").fields if name != "reserved"]
    assert len(names) == 12
    for name in names:
        assert getattr(core, name) == getattr(py, name), name
