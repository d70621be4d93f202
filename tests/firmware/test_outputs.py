"""Output mapping, RC override and L298N mixing of the firmware core."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from roar.protocol import spec
from roar_sim.core.car import RcOverride, calibration_valid, map_pulse

# --- output mapping ---------------------------------------------------------------------------
from roar_sim.core.junior import L298nDriver
from roar_sim.core.library import RcChannel


def test_trim_moves_the_pulse():
    assert map_pulse(1500, trim_us=30) == 1530
    assert map_pulse(1500, trim_us=-20) == 1480


def test_end_points_clamp():
    assert map_pulse(2000, min_us=1100, max_us=1900) == 1900
    assert map_pulse(1000, min_us=1100, max_us=1900) == 1100


@given(st.integers(0, 65535), st.integers(-32768, 32767), st.integers(0, 65535), st.integers(0, 65535))
def test_hard_clamp_whatever_the_calibration(cmd, trim, lo, hi):
    assert spec.CONTROL_MIN_US <= map_pulse(cmd, trim, lo, hi) <= spec.CONTROL_MAX_US


@given(st.integers(1000, 2000), st.integers(-499, 499), st.integers(1000, 2000), st.integers(1000, 2000))
def test_valid_calibration_stays_inside_its_end_points(cmd, trim, a, b):
    lo, hi = min(a, b), max(a, b)
    assert calibration_valid(trim, lo, hi)
    assert lo <= map_pulse(cmd, trim, lo, hi) <= hi


@pytest.mark.parametrize("trim, lo, hi", [(0, 1900, 1100), (500, 1000, 2000), (-600, 1000, 2000)])
def test_invalid_calibrations(trim, lo, hi):
    assert not calibration_valid(trim, lo, hi)


# --- RC override ------------------------------------------------------------------------------

PERIOD = 20_000  # [us] a 50 Hz receiver


def feed_rc(rc, throttle, steering, t0, n):
    t = t0
    for _ in range(n):
        rc.pulse(RcChannel.THROTTLE, throttle, t)
        rc.pulse(RcChannel.STEERING, steering, t + 1000)
        t += PERIOD
    return t


def test_needs_lock_pulses_on_both_channels():
    rc = RcOverride()
    t = feed_rc(rc, 1600, 1400, 0, spec.RC_LOCK_PULSES - 1)
    assert not rc.active(t)
    t = feed_rc(rc, 1600, 1400, t, 1)
    assert rc.active(t) and rc.command() == (1600, 1400)


def test_one_channel_is_not_enough():
    rc = RcOverride()
    for i in range(10):
        rc.pulse(RcChannel.THROTTLE, 1600, i * PERIOD)
    assert not rc.active(10 * PERIOD)


def test_absent_after_the_signal_timeout():
    rc = RcOverride()
    t = feed_rc(rc, 1600, 1400, 0, 5)
    last = t - PERIOD  # the throttle channel's last pulse, the older of the two
    assert rc.active(last + spec.RC_SIGNAL_TIMEOUT_US)
    assert not rc.active(last + spec.RC_SIGNAL_TIMEOUT_US + 1)


def test_invalid_pulse_breaks_the_lock_and_values_are_clamped():
    rc = RcOverride()
    t = feed_rc(rc, 2050, 950, 0, 5)
    assert rc.active(t) and rc.command() == (2000, 1000)
    rc.pulse(RcChannel.THROTTLE, 800, t)  # receiver failsafe value
    assert not rc.active(t)


# --- L298N ------------------------------------------------------------------------------------


def test_reversal_has_zero_duty_dead_time():
    drv = L298nDriver(dead_time_us=5000)
    left, _ = drv.step(800, 800, 0)
    assert (left.in1, left.in2, left.duty) == (True, False, 800)
    for t in (1000, 3000, 5999):
        left, _ = drv.step(-800, -800, t)
        assert (left.in1, left.in2, left.duty) == (False, False, 0), t
    left, _ = drv.step(-800, -800, 6000)
    assert (left.in1, left.in2, left.duty) == (False, True, 800)


def test_same_direction_after_a_stop_needs_no_dead_time():
    drv = L298nDriver(dead_time_us=5000)
    drv.step(500, 500, 0)
    drv.step(0, 0, 100)
    left, _ = drv.step(500, 500, 200)
    assert left.duty == 500


@given(st.lists(st.tuples(st.integers(-1000, 1000), st.integers(1, 4000)), max_size=200))
def test_never_reverses_without_dead_time(steps):
    drv = L298nDriver(dead_time_us=5000)
    t, last_dir, coast_since = 0, 0, 0
    driven_dir = 0
    for duty, gap in steps:
        t += gap
        side, _ = drv.step(duty, 0, t)
        assert not (side.in1 and side.in2)
        d = 1 if side.in1 else (-1 if side.in2 else 0)
        assert (d == 0) == (side.duty == 0)
        if d == 0 and last_dir != 0:
            coast_since = t
        if d != 0 and driven_dir == -d:
            assert last_dir == 0 and t - coast_since >= 5000
        if d != 0:
            driven_dir = d
        last_dir = d
