"""Calibration: [-1, 1] -> microseconds per channel, validated, stored as TOML."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from roar.calibration import Calibration, CalibrationError, ChannelCalibration, check_unit, default_path


@st.composite
def channels(draw):
    lo = draw(st.integers(1000, 1999))
    hi = draw(st.integers(lo + 1, 2000))
    trim = draw(st.integers(lo, hi))
    return ChannelCalibration(trim_us=trim, min_us=lo, max_us=hi, reversed=draw(st.booleans()))


@st.composite
def calibrations(draw):
    """Every calibration the library accepts: a throttle trim within the arm window with a
    forward side (max_us above it, or min_us below it when reversed), any valid steering."""
    trim = draw(st.integers(1475, 1525))
    reversed_ = draw(st.booleans())
    lo = draw(st.integers(1000, trim - 1 if reversed_ else trim))
    hi = draw(st.integers(trim if reversed_ else trim + 1, 2000))
    throttle = ChannelCalibration(trim_us=trim, min_us=lo, max_us=hi, reversed=reversed_)
    return Calibration(throttle=throttle, steering=draw(channels()))


@given(channels(), st.floats(-1, 1), st.floats(-1, 1))
def test_mapping_is_monotonic_and_stays_within_the_end_points(ch, a, b):
    ua, ub = ch.to_us(a), ch.to_us(b)
    assert ch.min_us <= ua <= ch.max_us
    if a <= b:
        assert (ua >= ub) if ch.reversed else (ua <= ub)


@given(channels())
def test_zero_is_trim_and_the_ends_are_the_end_points(ch):
    assert ch.to_us(0.0) == ch.trim_us
    low, high = (ch.max_us, ch.min_us) if ch.reversed else (ch.min_us, ch.max_us)
    assert ch.to_us(-1.0) == low and ch.to_us(1.0) == high


def test_default_is_the_protocol_range():
    c = Calibration()
    assert [c.steering.to_us(v) for v in (-1, -0.5, 0, 0.5, 1)] == [1000, 1250, 1500, 1750, 2000]


@pytest.mark.parametrize("kwargs, words", [
    (dict(trim_us=2100, max_us=2000), "min_us <= trim_us <= max_us"),
    (dict(min_us=1600, trim_us=1500), "min_us <= trim_us"),
    (dict(min_us=1500, trim_us=1500, max_us=1500), "must differ"),
    (dict(trim_us="1500"), "trim_us: must be an integer"),
    (dict(trim_us=1500.0), "trim_us: must be an integer"),
    (dict(max_us=True), "max_us: must be an integer"),
    (dict(reversed=1), "reversed: must be true or false"),
])
def test_bad_channels_are_rejected(kwargs, words):
    with pytest.raises(ValueError, match=words):
        ChannelCalibration(**kwargs)


def test_a_channel_has_no_other_keys():
    with pytest.raises(TypeError, match="offset"):
        ChannelCalibration(offset=3)


def test_a_calibration_is_made_of_channels():
    with pytest.raises(ValueError, match="steering: must be a ChannelCalibration"):
        Calibration(steering={"trim_us": 1500})


def test_file_round_trip(tmp_path):
    c = Calibration(throttle=ChannelCalibration(trim_us=1490, min_us=1200, max_us=1800, reversed=True),
                    steering=ChannelCalibration(trim_us=1520))
    path = tmp_path / "sub" / "calibration.toml"
    c.save(path)
    assert Calibration.load(path) == c
    assert not list(path.parent.glob("*.tmp"))


def test_missing_keys_take_defaults(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[steering]\ntrim_us = 1530\n")
    c = Calibration.load(path)
    assert c.steering.trim_us == 1530 and c.throttle == ChannelCalibration()


@pytest.mark.parametrize("text, words", [
    ("[steering]\ntrim_us = 2500\n", "steering: need 1000 <= min_us"),
    ("[steering]\ntrim = 1500\n", "steering.trim: not a key of a channel (use trim_us, min_us, max_us, reversed)"),
    ("[wheels]\n", "wheels: not a section of a calibration (use throttle and steering)"),
    ("steering = 3\n", "steering: must be a table of trim_us"),
    ("[steering\n", "not valid TOML"),
    ("[throttle]\nreversed = \"yes\"\n", "throttle.reversed: must be true or false, got 'yes'"),
    ("[throttle]\ntrim_us = 1500.0\n", "throttle.trim_us: must be an integer [us], got 1500.0"),
    ("[throttle]\ntrim_us = 1530\n", "throttle trim_us 1530 is more than 25 us from 1500"),
])
def test_bad_files_give_one_line_errors(tmp_path, text, words):
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(CalibrationError) as e:
        Calibration.load(path)
    assert words in str(e.value) and "\n" not in str(e.value) and str(path) in str(e.value)


def test_unreadable_file(tmp_path):
    with pytest.raises(CalibrationError, match="cannot read"):
        Calibration.load(tmp_path / "missing.toml")


def test_default_path_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    assert default_path() == tmp_path / "roar" / "calibration.toml"


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 1.01, -2, True, "0.5", None])
def test_command_values_outside_the_unit_range_are_rejected(value):
    with pytest.raises(ValueError, match="throttle"):
        check_unit("throttle", value)


def test_numpy_numbers_are_accepted():
    np = pytest.importorskip("numpy")
    assert check_unit("steering", np.float32(0.5)) == 0.5


@given(calibrations())
def test_every_accepted_calibration_arms_the_car_and_drives_it_both_ways(cal):
    """Against the firmware core: the neutral this calibration sends arms a car that booted
    latched, and its +1/-1 throttle and steering then come out of the car as sent (reverse
    after the brake sequence)."""
    from roar_sim.core.car import Car
    from roar_sim.core.library import ControlSource

    car = Car()
    car.boot()
    t = 0

    def hold(throttle, steering, ms):
        nonlocal t
        message = cal.message(throttle, steering)
        out = None
        for _ in range(ms):
            if t % 20_000 == 0:
                car.feed(message, t)
            out = car.step(t, t // 20_000)
            t += 1000
        return out

    out = hold(0, 0, 40)
    assert "ARMED\n" in car.replies() and out.source == ControlSource.HOST and not out.latched
    for throttle, steering in ((1, 1), (-1, -1), (0, 0)):
        out = hold(throttle, steering, 200)
        assert (out.throttle_us, out.steering_us) == (cal.throttle.to_us(throttle), cal.steering.to_us(steering))
    assert hold(1, 0, 40).throttle_us != hold(0, 0, 40).throttle_us  # +1 really moves the throttle


@pytest.mark.parametrize("throttle, words", [
    (dict(trim_us=1530), "more than 25 us from 1500"),
    (dict(trim_us=1474), "more than 25 us from 1500"),
    (dict(trim_us=1500, max_us=1500, min_us=1000), "could not drive forward"),
    (dict(trim_us=1500, min_us=1500, max_us=2000, reversed=True), "could not drive forward"),
])
def test_calibrations_that_would_not_arm_or_drive_are_refused(throttle, words):
    with pytest.raises(ValueError, match=words):
        Calibration(throttle=ChannelCalibration(**throttle))


def test_the_issue_file_with_a_1530_trim_fails_in_one_line(tmp_path):
    path = tmp_path / "t.toml"
    path.write_text("[throttle]\ntrim_us = 1530\n")
    with pytest.raises(CalibrationError) as e:
        Calibration.load(path)
    assert "would never arm" in str(e.value) and "\n" not in str(e.value)
