"""The brake/reverse FSM of the firmware core, through the C ABI."""

from hypothesis import given
from hypothesis import strategies as st

from roar.protocol import spec
from roar_sim.core.car import BrakeFsm
from roar_sim.core.library import BrakePhase

N, TAP, STEP = spec.CONTROL_NEUTRAL_US, spec.TIMING_BRAKE_TAP_US, spec.TIMING_BRAKE_STEP_US
FRAME = spec.TIMING_SERVO_FRAME_US


def drive(fsm, schedule, t0=0, dt=1000):
    """schedule: list of (command, duration_us); returns [(t, out)] sampled every dt."""
    t, out = t0, []
    for cmd, dur in schedule:
        end = t + dur
        while t < end:
            out.append((t, fsm.step(cmd, t, (t - t0) // FRAME)))
            t += dt
    return out


def runs(trace):
    """[(value, start, end)] runs of equal outputs."""
    result = []
    for t, v in trace:
        if result and result[-1][0] == v:
            result[-1][2] = t
        else:
            result.append([v, t, t])
    return result


def test_forward_then_reverse_goes_through_neutral_tap_neutral():
    trace = drive(BrakeFsm(), [(1700, 100_000), (1300, 200_000)])
    values = [r[0] for r in runs(trace)]
    assert values == [1700, N, TAP, N, 1300]
    for value, start, end in runs(trace)[1:4]:
        assert end - start + 1000 >= STEP  # each step at least the configured time


def test_each_step_spans_an_output_frame():
    """With 50 Hz frames, a 10 ms step must still last until a frame has carried its value."""
    fsm = BrakeFsm()
    trace = drive(fsm, [(1700, 50_000), (1300, 200_000)])
    taps = [t for t, v in trace if v == TAP]
    frames_during_tap = {t // FRAME for t in taps}
    assert len(frames_during_tap) >= 2 or taps[-1] - taps[0] >= FRAME - 1000


def test_reverse_from_rest_also_needs_the_sequence_at_boot():
    values = [r[0] for r in runs(drive(BrakeFsm(), [(1300, 200_000)]))]
    assert values == [N, TAP, N, 1300]


def test_reverse_after_completed_sequence_passes_straight_through():
    fsm = BrakeFsm()
    drive(fsm, [(1700, 50_000), (1300, 200_000)])
    assert fsm.phase == BrakePhase.REVERSE_READY
    values = [r[0] for r in runs(drive(fsm, [(1500, 50_000), (1200, 50_000)], t0=250_000))]
    assert values == [N, 1200]


def test_forward_during_sequence_cancels_it():
    fsm = BrakeFsm()
    values = [r[0] for r in runs(drive(fsm, [(1700, 50_000), (1300, 5_000), (1800, 50_000), (1300, 200_000)]))]
    assert values == [1700, N, 1800, N, TAP, N, 1300]


def test_non_blocking_each_call_returns_at_once():
    fsm = BrakeFsm()
    fsm.step(1700, 0, 0)
    assert fsm.step(1300, 1, 0) == N  # no wait inside step: the sequence advances with time
    assert fsm.phase == BrakePhase.NEUTRAL1


commands = st.sampled_from([1000, 1200, 1449, 1450, 1499, 1500, 1501, 1600, 2000])
gaps = st.one_of(st.integers(1, 3_000), st.integers(1, 40_000))


def assert_sequence_invariant(trace):
    """trace: [(t, out)]. After a forward output (or boot), a reverse output other than the tap
    needs, right before it, neutral >= STEP, the tap >= STEP, neutral >= STEP; until that has
    happened every reverse output must be the tap, right after neutral held >= STEP."""
    rs = runs(trace)
    dur = [b[1] - a[1] for a, b in zip(rs, rs[1:])]
    ready = False
    for i, (v, _, _) in enumerate(rs):
        if v > N:
            ready = False
        elif v < N and not ready:
            triple = i >= 3 and [r[0] for r in rs[i - 3:i]] == [N, TAP, N] and min(dur[i - 3:i]) >= STEP
            if triple:
                ready = True
            else:
                assert v == TAP, f"reverse {v} without the full neutral/tap/neutral sequence: {rs[max(0, i - 4):i + 1]}"
                assert i >= 1 and rs[i - 1][0] == N and dur[i - 1] >= STEP, f"tap without neutral first: {rs[:i + 1]}"


@given(st.lists(st.tuples(commands, gaps), min_size=1, max_size=300), st.integers(0, 2**32 - 1))
def test_never_forward_to_reverse_except_through_the_sequence(schedule, t0):
    """Invariant over random commands and random timing, from any clock value (so across the
    32-bit wrap of the car's clock), with 50 Hz output frames."""
    fsm = BrakeFsm()
    t, frame_clock, frames, trace = t0, 0, 0, []
    for cmd, gap in schedule:
        t += gap
        frame_clock += gap
        frames += frame_clock // FRAME
        frame_clock %= FRAME
        trace.append((t, fsm.step(cmd, t, frames)))
    assert_sequence_invariant(trace)


def test_invariant_checker_catches_a_direct_reversal():
    import pytest
    with pytest.raises(AssertionError):
        assert_sequence_invariant([(0, 1700), (1000, 1300)])
    with pytest.raises(AssertionError):
        assert_sequence_invariant([(0, 1700), (1000, N), (2000, TAP), (20_000, N), (40_000, 1300)])
    assert_sequence_invariant([(0, 1700), (1000, N), (12_000, TAP), (23_000, N), (34_000, 1300)])
