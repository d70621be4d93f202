"""The host encoder and strict decoder."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from roar.protocol import ControlCommand, ControlError, decode, encode
from roar.protocol import spec

valid_us = st.integers(spec.CONTROL_MIN_US, spec.CONTROL_MAX_US)


def test_neutral_is_the_example_message():
    assert encode(1500, 1500) == spec.CONTROL_EXAMPLE.encode() == b"(1500,1500)"


def test_throttle_comes_first():
    assert encode(1200, 1800) == b"(1200,1800)"
    assert decode(b"(1200,1800)") == ControlCommand(throttle_us=1200, steering_us=1800)


@given(valid_us, valid_us)
def test_round_trip(throttle, steering):
    message = encode(throttle, steering)
    assert len(message) == spec.CONTROL_MAX_MESSAGE_BYTES
    assert decode(message) == ControlCommand(throttle, steering)


@pytest.mark.parametrize("throttle, steering, fragment", [
    (999, 1500, "throttle_us 999 us is outside 1000..2000"),
    (1500, 2001, "steering_us 2001 us is outside"),
    (1500.0, 1500, "must be an integer"),
    (True, 1500, "must be an integer"),
    ("1500", 1500, "must be an integer"),
])
def test_encode_rejects_with_one_line(throttle, steering, fragment):
    with pytest.raises(ControlError) as err:
        encode(throttle, steering)
    assert fragment in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("message, reason", [
    (b"(999,1500)", "range"),
    (b"(1500,1500", "incomplete"),
    (b"(15a0,1500)", "syntax"),
    (b"(15000,1500)", "too_long"),
    (b"x(1500,1500)", "garbage"),
    (b"(1500,1500)(1500,1500)", "extra bytes"),
    (b"(1500,1500)\n", "extra bytes"),
    (b"", "incomplete"),
])
def test_decode_rejects_with_reason(message, reason):
    with pytest.raises(ControlError, match=f"\\({reason}\\)"):
        decode(message)


def test_decode_rejects_non_bytes():
    with pytest.raises(ControlError, match="expected bytes"):
        decode("(1500,1500)")


def test_control_error_is_a_value_error():
    assert issubclass(ControlError, ValueError)
