"""Every timed state of the firmware core expires once and stays expired, whatever time passes:
silences up to 2^33 us (two wraps of a 32-bit microsecond counter), starting at random clock
phases, checked at every step, and densely around each point where a 32-bit comparison would
have seen the old event as fresh again (the event's time + k * 2^32).

The last test runs the real board loop (CarBoard on the memory HAL, a wrapping 32-bit counter
as on a board) through the issue's case: RC locked at 1900/1500, then silence past 2^32 us."""

from hypothesis import given
from hypothesis import strategies as st

from roar.protocol import spec
from roar_sim.core.car import BrakeFsm, CarBoard, CommandWatchdog, RcOverride
from roar_sim.core.junior import JuniorControl, L298nDriver
from roar_sim.core.library import ControlSource, RcChannel, WatchdogEvent

WRAP = 2**32  # [us] the period of a board's 32-bit microsecond counter
N = spec.CONTROL_NEUTRAL_US
FRAME = spec.TIMING_SERVO_FRAME_US

# The clock when the last event happens: anywhere, or just before a wrap of the 32-bit counter.
phases = st.tuples(st.integers(0, 3), st.one_of(st.integers(0, WRAP - 1), st.integers(WRAP - 2_000_000, WRAP - 1)))


def at(phase: tuple[int, int]) -> int:
    wraps, offset = phase
    return wraps * WRAP + offset


def looks(timeout: int):
    """When the loop looks after the last event [us after it], up to 2^33: random times, and
    times around each k * 2^32 where a 32-bit comparison would find the event fresh again for
    `timeout`. A single look right there is the case a latch cannot hide."""
    danger = [k * WRAP + d for k in (1, 2) for d in (-1, 0, 1, timeout // 2, timeout, timeout + 1)]
    return st.lists(st.one_of(st.integers(1, 2**33), st.sampled_from(danger)), min_size=1,
                    max_size=30).map(lambda offsets: sorted(set(offsets)))


@given(phases, looks(spec.TIMING_FAILSAFE_TIMEOUT_US))
def test_the_failsafe_trips_once_and_stays_latched(phase, offsets):
    t0 = at(phase)
    wd = CommandWatchdog()
    assert wd.accept(N, N, t0) == (True, WatchdogEvent.ARMED)
    timeout = spec.TIMING_FAILSAFE_TIMEOUT_US
    tripped = []
    for dt in offsets:
        if wd.poll(t0 + dt) == WatchdogEvent.TRIPPED:
            tripped.append(dt)
        assert wd.latched is (dt > timeout), dt
    assert tripped == [dt for dt in offsets if dt > timeout][:1]
    assert wd.accept(1700, N, t0 + offsets[-1] + 1)[0] is (offsets[-1] + 1 <= timeout)


@given(phases, looks(spec.RC_SIGNAL_TIMEOUT_US))
def test_rc_presence_ends_with_its_pulses_and_never_returns(phase, offsets):
    t_last = at(phase) + spec.RC_LOCK_PULSES * FRAME
    rc = RcOverride()
    for i in reversed(range(spec.RC_LOCK_PULSES)):
        rc.pulse(RcChannel.THROTTLE, 1900, t_last - i * FRAME)
        rc.pulse(RcChannel.STEERING, 1500, t_last - i * FRAME)
    assert rc.active(t_last)
    for dt in offsets:
        assert rc.active(t_last + dt) is (dt <= spec.RC_SIGNAL_TIMEOUT_US), dt


@given(phases, looks(spec.JUNIOR_FAILSAFE_TIMEOUT_US))
def test_the_junior_stops_once_requests_stop_and_stays_stopped(phase, offsets):
    t0 = at(phase)
    junior = JuniorControl()
    assert junior.apply_query("forward=True&left_spd=0.5&right_spd=0.5", t0) == (3, None)
    for dt in offsets:
        expected = (500, 500) if dt <= spec.JUNIOR_FAILSAFE_TIMEOUT_US else (0, 0)
        assert junior.duties(t0 + dt) == expected, dt


@given(phases, looks(spec.L298N_DEAD_TIME_US))
def test_the_l298n_dead_time_ends_once(phase, offsets):
    """A side that reverses coasts for exactly the dead time from when it stopped, then drives in
    the new direction from then on, however long it waited."""
    t0 = at(phase)
    drv = L298nDriver()
    left, _ = drv.step(500, 500, t0)
    assert left.in1 and left.duty == 500
    coast_from = t0 + 1
    left, _ = drv.step(-500, -500, coast_from)
    assert (left.in1, left.in2, left.duty) == (False, False, 0)
    for dt in offsets:
        left, right = drv.step(-500, -500, coast_from + dt)
        reversing = dt >= spec.L298N_DEAD_TIME_US
        assert (left.in2, left.duty) == ((True, 500) if reversing else (False, 0)), dt
        assert right == left


@given(phases, st.lists(st.one_of(st.integers(FRAME, 2**33), st.integers(WRAP - FRAME, WRAP + FRAME)),
                        min_size=8, max_size=8))
def test_each_brake_step_ends_at_the_first_look_after_it_is_due(phase, gaps):
    """Forward, then reverse with the FSM looked at after long gaps (each at least a frame and a
    step, frames advancing with time): every look moves the sequence on, none restarts a step."""
    t = at(phase)
    frames = 0
    fsm = BrakeFsm()
    outs = [fsm.step(1700, t, frames)]
    for gap in gaps:
        t += gap
        frames += gap // FRAME
        outs.append(fsm.step(1300, t, frames))
    tap = spec.TIMING_BRAKE_TAP_US
    assert outs == [1700, N, N, tap, tap, N, N, 1300, 1300]


def test_rc_does_not_come_back_after_the_clock_wraps_in_the_real_board_loop():
    """The reproduction from the safety review, on CarBoard with the board's 32-bit counter: RC
    locked at 1900/1500, then silence; the car fails safe; 2^32 us later it must still be in
    failsafe at every loop iteration, not back on the stale RC command."""
    board = CarBoard(loop_us=1_000, start_us=WRAP - 3_000_000)  # the counter wraps 3 s after boot
    board.begin()
    board.serial_in(b"(1500,1500)")
    board.rc((1900, 1500))
    board.run(200)
    assert board.outputs.source == ControlSource.RC and board.outputs.throttle_us == 1900
    board.rc(None)
    last_pulse_loop = board.loops - 1
    board.run(500)
    assert board.outputs.source == ControlSource.FAILSAFE and board.outputs.throttle_us == N
    danger = last_pulse_loop + WRAP // 1_000  # [loops] where a 32-bit age of the pulse is ~0 again
    while board.loops < danger - 1_000:
        board.run(min(1_000_000, danger - 1_000 - board.loops))
        assert board.outputs.source == ControlSource.FAILSAFE
    seen = set()
    for _ in range(2_000):  # every loop iteration from 1 s before to 1 s after the danger point
        board.run(1)
        seen.add((board.outputs.source, board.outputs.throttle_us, board.wire[0]))
    assert seen == {(ControlSource.FAILSAFE, N, N)}
    assert board.hal.watchdog_feeds == board.loops  # the loop fed the hardware watchdog every iteration
