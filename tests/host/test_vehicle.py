"""The Vehicle API and its sender, over the loopback transport (no car needed)."""

import threading

import pytest

from conftest import wait_for
from roar import Calibration, ChannelCalibration, LinkLost, TransportError, Vehicle
from roar.protocol import decode, encode

NEUTRAL = encode(1500, 1500)


def sent(car):
    return car.transport.messages()


def test_first_message_is_neutral_and_commands_go_out_at_once():
    with Vehicle("loop://", rate_hz=5) as car:  # slow resend: only an immediate send can explain it
        assert wait_for(lambda: sent(car))[0] == NEUTRAL
        car.drive(throttle=0.5, steering=-1.0)
        assert wait_for(lambda: sent(car)[-1] == encode(1750, 1000), timeout_s=0.15)


def test_the_latest_command_is_resent_at_the_fixed_rate():
    with Vehicle("loop://", rate_hz=50) as car:
        car.drive(0.2, 0.0)
        wait_for(lambda: len(sent(car)) >= 15, timeout_s=3)
        times = [t for t, data in car.transport.writes if data == encode(1600, 1500)]
    assert len(times) >= 10
    gaps = sorted(b - a for a, b in zip(times, times[1:]))
    assert 0.012 < gaps[len(gaps) // 2] < 0.035  # median period ~20 ms


def test_stale_commands_are_never_queued():
    with Vehicle("loop://") as car:
        wait_for(lambda: sent(car))
        for i in range(2000):
            car.drive(throttle=(i % 100) / 100)
        car.drive(throttle=0.3)
        assert wait_for(lambda: sent(car)[-1] == encode(1650, 1500))
        assert len(sent(car)) < 500  # thousands of calls, far fewer messages: the latest wins


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_leaving_the_block_sends_neutral_even_on_exceptions(exc):
    with pytest.raises(exc):
        with Vehicle("loop://") as car:
            car.drive(0.8, 0.5)
            wait_for(lambda: sent(car)[-1] != NEUTRAL)
            raise exc
    assert sent(car)[-1] == NEUTRAL
    count = len(sent(car))
    threading.Event().wait(0.1)
    assert len(sent(car)) == count  # and nothing after it


@pytest.mark.parametrize("value", [float("nan"), float("inf"), 1.5, "fast"])
def test_bad_values_raise_and_leave_the_command_unchanged(value):
    with Vehicle("loop://") as car:
        car.drive(0.5, 0.5)
        with pytest.raises(ValueError):
            car.drive(throttle=value)
        with pytest.raises(ValueError):
            car.steering = value
        assert (car.throttle, car.steering) == (0.5, 0.5)


def test_calibration_shapes_the_pulses(tmp_path):
    cal = Calibration(throttle=ChannelCalibration(trim_us=1480, min_us=1300, max_us=1700, reversed=True),
                      steering=ChannelCalibration(trim_us=1520))
    with Vehicle("loop://", calibration=cal) as car:
        car.drive(1.0, 0.0)
        assert car.pulses_us() == (1300, 1520)
        assert wait_for(lambda: sent(car)[-1] == encode(1300, 1520))
    path = tmp_path / "c.toml"
    cal.save(path)
    with Vehicle("loop://", calibration=path) as car:
        assert car.calibration == cal


def test_stop_is_neutral():
    with Vehicle("loop://") as car:
        car.drive(0.5, 0.5)
        car.stop()
        assert wait_for(lambda: sent(car)[-1] == NEUTRAL)


def test_stop_reaches_the_wire_even_when_a_command_follows_at_once():
    with Vehicle("loop://", rate_hz=5) as car:
        car.drive(0.5)
        wait_for(lambda: sent(car)[-1] == encode(1750, 1500))
        car.stop()  # e.g. re-arming a car after a failsafe: the neutral must not be coalesced away
        car.drive(0.3)
        assert wait_for(lambda: sent(car)[-1] == encode(1650, 1500))
    messages = sent(car)
    assert NEUTRAL in messages[messages.index(encode(1750, 1500)):messages.index(encode(1650, 1500))]


def test_car_lines_are_surfaced():
    with Vehicle("loop://") as car:
        car.transport.inject("ERR range", "FAILSAFE")
        assert wait_for(lambda: list(car.replies) == ["ERR range", "FAILSAFE"])
        assert car.errors == 1


def test_link_loss_without_reconnect_raises_on_the_next_call():
    with Vehicle("loop://?fail_after=3", reconnect=False) as car:
        assert wait_for(lambda: not car.connected)
        with pytest.raises(LinkLost, match="link cut"):
            car.drive(0.1)


def test_link_loss_with_reconnect_reopens_and_resends():
    with Vehicle("loop://?fail_after=3") as car:
        car.drive(0.4)
        assert wait_for(lambda: car.transport.opened >= 2)
        car.transport.link.fail_after = -1
        assert wait_for(lambda: car.connected and sent(car)[-1] == encode(1700, 1500))


def test_closed_vehicle_refuses_commands():
    car = Vehicle("loop://")
    car.close()
    car.close()
    with pytest.raises(TransportError, match="closed"):
        car.drive(0.1)


@pytest.mark.parametrize("rate", [0, 1000, float("nan"), "50"])
def test_send_rate_must_keep_the_failsafe_fed(rate):
    with pytest.raises(ValueError, match="rate_hz"):
        Vehicle("loop://", rate_hz=rate)


def test_every_message_is_a_valid_control_message():
    with Vehicle("loop://") as car:
        for v in (-1, -0.33, 0, 0.77, 1):
            car.drive(v, -v)
    assert all(decode(m) for m in sent(car))


def test_raw_pulses_stay_on_the_wire_when_the_car_says_ready():
    """A car that boots (READY) after send_pulses: learning its protocol version must not put the
    Vehicle's own (neutral) command back over the raw pulses (calibration holds them)."""
    with Vehicle("loop://", rate_hz=50) as car:
        car.send_pulses(1600, 1300)
        assert wait_for(lambda: sent(car) and sent(car)[-1] == encode(1600, 1300))
        car.transport.inject("READY 1")
        assert wait_for(lambda: car.protocol_version == 1)
        n = len(sent(car))
        assert wait_for(lambda: len(sent(car)) >= n + 5)
        assert set(sent(car)[n:]) == {encode(1600, 1300)}
        car.drive(0.0, 0.0)  # the Vehicle's own command again: a READY now re-sends it as the car takes it
        assert wait_for(lambda: sent(car)[-1] == NEUTRAL)
