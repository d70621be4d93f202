"""The command watchdog of the firmware core: fires on every silence longer than the timeout,
never earlier, latches, and only a neutral command re-arms it."""

from hypothesis import given
from hypothesis import strategies as st

from roar.protocol import spec
from roar_sim.core.car import CommandWatchdog
from roar_sim.core.library import WatchdogEvent

TIMEOUT = spec.TIMING_FAILSAFE_TIMEOUT_US


def test_boots_latched_and_neutral_arms():
    wd = CommandWatchdog()
    assert wd.latched
    assert wd.accept(1700, 1500, 0) == (False, WatchdogEvent.NONE)
    assert wd.accept(1500, 1800, 10) == (True, WatchdogEvent.ARMED)
    assert not wd.latched


def test_trips_one_microsecond_after_the_timeout():
    wd = CommandWatchdog()
    wd.accept(1500, 1500, 1_000)
    assert wd.poll(1_000 + TIMEOUT) == WatchdogEvent.NONE
    assert wd.poll(1_000 + TIMEOUT + 1) == WatchdogEvent.TRIPPED
    assert wd.poll(1_000 + TIMEOUT + 2) == WatchdogEvent.NONE  # reported once
    assert wd.latched


def test_latched_until_neutral():
    wd = CommandWatchdog()
    wd.accept(1500, 1500, 0)
    wd.poll(TIMEOUT + 1)
    assert wd.accept(1800, 1500, TIMEOUT + 10)[0] is False
    assert wd.accept(1500 + spec.TIMING_ARM_WINDOW_US + 1, 1500, TIMEOUT + 20)[0] is False
    assert wd.accept(1500 - spec.TIMING_ARM_WINDOW_US, 1500, TIMEOUT + 30) == (True, WatchdogEvent.ARMED)
    assert wd.accept(1800, 1500, TIMEOUT + 40) == (True, WatchdogEvent.NONE)


def test_a_late_command_still_counts_the_silence():
    """Even if the loop never polled during the silence, the command that ends it finds the car tripped."""
    wd = CommandWatchdog()
    wd.accept(1500, 1500, 0)
    wd.accept(1700, 1500, 1)
    ok, ev = wd.accept(1700, 1500, TIMEOUT + 2)
    assert (ok, ev) == (False, WatchdogEvent.TRIPPED)


@given(st.lists(st.integers(1, 2 * TIMEOUT), min_size=1, max_size=100), st.integers(0, 2**32 - 1),
       st.integers(100, 50_000))
def test_fires_on_every_silence_longer_than_the_timeout_and_never_earlier(gaps, t0, poll_every):
    """Commands (all neutral, so the car re-arms each time) arrive after random gaps; the loop
    polls every `poll_every` us in between (from 0.1 ms: the boards' loops run at 1 kHz; polled every
    microsecond, one example made half a million calls a gap). The watchdog trips in exactly the
    gaps longer than the timeout, at the first poll after last + timeout, never before."""
    wd = CommandWatchdog()
    t = t0
    assert wd.accept(1500, 1500, t)[0]
    for gap in gaps:
        last, trips = t, []
        p = last + poll_every
        while p < last + gap:
            if wd.poll(p) == WatchdogEvent.TRIPPED:
                trips.append(p)
            p += poll_every
        t = last + gap
        ok, ev = wd.accept(1500, 1500, t)
        assert ok
        if gap > TIMEOUT:
            fired_at = trips[0] if trips else t
            assert len(trips) <= 1 and fired_at > last + TIMEOUT
            assert fired_at - (last + TIMEOUT) <= poll_every
            assert ev == WatchdogEvent.ARMED  # it had latched, the neutral command re-armed it
        else:
            assert trips == [] and ev == WatchdogEvent.NONE
