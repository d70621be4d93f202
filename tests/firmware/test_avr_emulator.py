"""The real Nano firmware binary (ATmega328P ELF built offline with avr-gcc and the Arduino core)
running in simavr: control messages into UART0, pulse widths measured on D5 (ESC) and D6
(steering), RC receiver pulses injected on D3/D4."""

import statistics
import time

import pytest

from conftest import wait_for
from roar.protocol import encode, spec

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

simavr = pytest.importorskip("roar_sim.emulators.simavr")
if simavr.available():
    pytest.skip(simavr.available(), allow_module_level=True)

TOLERANCE_US = 10  # [us] per pulse: other interrupts delay an edge now and then (as on hardware)
FRAME_S = spec.TIMING_SERVO_FRAME_US / 1e6
SEND_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6
FAILSAFE_S = spec.TIMING_FAILSAFE_TIMEOUT_US / 1e6
N = spec.CONTROL_NEUTRAL_US


@pytest.fixture
def nano():
    with simavr.EmulatedNano() as car:
        car.run(0.05)  # boot: Serial.begin() before the first byte
        yield car


def stream(nano, throttle, steering, seconds):
    """A host sending one command every 20 ms."""
    for _ in range(round(seconds / SEND_S)):
        nano.write(encode(throttle, steering) + b"\n")
        nano.run(SEND_S)


def widths(nano, pin, since_s):
    return [w for _, w in nano.pulses(pin, since_s)]


def assert_holds(values, expected):
    errors = sorted(abs(w - expected) for w in values)
    assert len(errors) >= 5, f"only {len(errors)} pulses"
    assert statistics.median(errors) <= 1.0, f"median error {statistics.median(errors):.2f} us"
    assert errors[int(0.99 * (len(errors) - 1))] <= TOLERANCE_US, f"worst {errors[-1]:.2f} us"


def test_boots_latched_at_neutral_and_says_ready(nano):
    nano.run(0.3)
    assert nano.lines()[0][1] == "READY 1"
    assert_holds(widths(nano, "D5", 0.05), N)
    assert_holds(widths(nano, "D6", 0.05), N)
    stream(nano, 1700, 1500, 0.2)  # forward before neutral: ignored, the car says why
    assert "FAILSAFE" in [text for _, text in nano.lines()]
    assert_holds(widths(nano, "D5", 0.05), N)


@pytest.mark.parametrize("throttle, steering", [(1500, 1500), (1600, 1400), (2000, 1000), (1000, 2000),
                                                (1734, 1266), (1501, 1999)])
def test_pulses_follow_commands(nano, throttle, steering):
    stream(nano, N, N, 0.1)  # arm
    if throttle < N:  # reverse needs the brake sequence first; it is tested below
        stream(nano, throttle, steering, 0.5)
    start = nano.time_s
    stream(nano, throttle, steering, 0.5)
    settled = start + 3 * FRAME_S
    assert_holds(widths(nano, "D5", settled), throttle)
    assert_holds(widths(nano, "D6", settled), steering)
    rises = [r for r, _ in nano.pulses("D5", settled)]
    periods = [b - a for a, b in zip(rises, rises[1:])]
    assert all(abs(p - FRAME_S) < 0.0005 for p in periods)


def test_malformed_input_changes_nothing_and_is_answered(nano):
    stream(nano, N, N, 0.1)
    stream(nano, 1600, 1400, 0.2)
    start = nano.time_s
    for bad in (b"(1500,99999)\n", b"(15x0,1500)\n", b"(2500,1500)\n"):
        nano.write(bad)
        nano.run(0.05)
    replies = [text for t, text in nano.lines() if t >= start]
    assert replies == ["ERR too_long", "ERR syntax", "ERR range"]
    assert_holds(widths(nano, "D5", start), 1600)
    assert_holds(widths(nano, "D6", start), 1400)


def test_failsafe_drives_d5_to_neutral_after_silence(nano):
    stream(nano, N, N, 0.1)
    stream(nano, 1700, 1600, 0.3)
    last_command = nano.sent_at[-1] / simavr.F_CPU
    nano.run(0.6)
    neutral_from = next(r for r, w in nano.pulses("D5", last_command) if abs(w - N) <= TOLERANCE_US)
    assert FAILSAFE_S <= neutral_from - last_command <= FAILSAFE_S + 2 * FRAME_S
    assert all(abs(w - 1700) <= TOLERANCE_US for w in widths(nano, "D5", last_command)[:10])  # held until then
    assert_holds(widths(nano, "D5", neutral_from), N)
    assert_holds(widths(nano, "D6", neutral_from), N)
    assert [text for t, text in nano.lines() if t > last_command] == ["FAILSAFE"]


def test_forward_to_reverse_goes_through_the_brake_sequence_on_d5(nano):
    stream(nano, N, N, 0.1)
    stream(nano, 1700, N, 0.3)
    start = nano.time_s
    stream(nano, 1300, N, 0.4)
    sequence = []  # (width, frames) runs of equal pulses on D5
    for w in widths(nano, "D5", start):
        level = round(w / 10) * 10
        if sequence and sequence[-1][0] == level:
            sequence[-1][1] += 1
        else:
            sequence.append([level, 1])
    levels = [level for level, _ in sequence]
    assert levels[levels.index(1500):] == [1500, spec.TIMING_BRAKE_TAP_US, 1500, 1300], sequence
    steps = sequence[levels.index(1500):][:3]
    step_frames = max(1, round(spec.TIMING_BRAKE_STEP_US / spec.TIMING_SERVO_FRAME_US))
    assert all(frames >= step_frames for _, frames in steps), sequence  # each step >= the step time


def test_rc_override_pulses_win(nano):
    stream(nano, N, N, 0.1)
    stream(nano, 1600, 1400, 0.2)
    nano.rc(3, 1800)
    nano.rc(4, 1200)
    start = nano.time_s
    stream(nano, 1600, 1400, 0.5)  # the host keeps sending: the transmitter still wins
    settled = start + 0.15  # three pulses to lock on, and a frame to take effect
    assert_holds(widths(nano, "D5", settled), 1800)
    assert_holds(widths(nano, "D6", settled), 1200)
    nano.rc(3, None)
    nano.rc(4, None)
    released = nano.time_s
    stream(nano, 1600, 1400, 0.5)
    assert_holds(widths(nano, "D5", released + 0.2), 1600)  # back to the host after the RC timeout
    assert_holds(widths(nano, "D6", released + 0.2), 1400)


def test_the_host_library_drives_the_emulated_nano_over_a_pty():
    """Real time: the pyserial transport of roar.Vehicle talks to UART0 through simavr's pty."""
    from roar import Vehicle

    proc, path = simavr.EmulatedNano.serve_pty(4.0)
    pulses, lines = [], []
    started = time.monotonic()
    try:
        with Vehicle(f"serial://{path}") as car:
            time.sleep(0.3)
            car.drive(throttle=0.4, steering=-0.2)
            assert wait_for(lambda: "ARMED" in car.replies, timeout_s=2)
            time.sleep(1.0)
            commanded_at = time.monotonic() - started
        out, _ = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    wall = time.monotonic() - started
    for line in out.splitlines():
        kind, *rest = line.split(" ", 3)
        if kind == "P":
            pulses.append((rest[0], int(rest[1]) / simavr.F_CPU, int(rest[2]) / simavr.CYCLES_PER_US))
        elif kind == "U":
            lines.append(rest[1] if len(rest) > 1 else "")
    assert proc.returncode == 0
    assert wall >= 3.9  # locked to real time: 4 emulated seconds took 4 wall seconds
    d5 = [w for pin, t, w in pulses if pin == "D5" and 0.5 < t < commanded_at - 0.1]
    d6 = [w for pin, t, w in pulses if pin == "D6" and 0.5 < t < commanded_at - 0.1]
    assert_holds(d5, 1700)
    assert_holds(d6, 1400)
    neutral_end = [w for pin, t, w in pulses if pin == "D5" and t > commanded_at + 0.3]
    assert_holds(neutral_end, N)  # the Vehicle sent neutral on leaving the block


def test_a_flood_of_random_bytes_neither_hangs_nor_drives_the_car(nano):
    """Line noise at full rate (seeded): the loop keeps its 50 Hz frames, garbage never counts as
    a command, so the failsafe takes the car to neutral; a neutral message re-arms it after."""
    import random

    rng = random.Random(1234)
    stream(nano, N, N, 0.1)
    stream(nano, 1600, 1400, 0.2)
    start = nano.time_s
    for _ in range(25):  # 0.5 s of noise, ~230 bytes per 20 ms (the line's capacity)
        noise = bytes(rng.choice(b"0123456789(),\n\r x\xff") for _ in range(230))
        nano.write(noise)
        nano.run(SEND_S)
    rises = [r for r, _ in nano.pulses("D5", start)]
    assert len(rises) >= 24 and all(abs(b - a - FRAME_S) < 0.001 for a, b in zip(rises, rises[1:]))
    neutral_from = next(r for r, w in nano.pulses("D5", start) if abs(w - N) <= TOLERANCE_US)
    assert neutral_from - start <= FAILSAFE_S + 2 * FRAME_S
    assert_holds(widths(nano, "D5", neutral_from), N)
    stream(nano, N, N, 0.1)
    rearmed = nano.time_s
    stream(nano, 1600, 1500, 0.3)
    assert_holds(widths(nano, "D5", rearmed + 3 * FRAME_S), 1600)


def test_a_hung_loop_resets_the_board_which_boots_at_neutral_and_latched():
    """The hardware watchdog, proved on the real binary: a test build whose loop hangs for good
    once the car outputs throttle 1777 us. While the loop hangs, the Timer1 interrupt keeps that
    pulse on the ESC; the watchdog resets the chip within timing.loop_watchdog_us, and the board
    prints its boot line again and sends neutral pulses, latched, while the host still asks
    for 1777."""
    from roar_sim.toolchains import avr

    hang = avr.HANG_THROTTLE_US
    with simavr.EmulatedNano(avr.build(variant="hang")) as nano:
        nano.run(0.05)
        stream(nano, N, N, 0.1)
        stream(nano, hang, N, 1.5)
        hung = [r for r, w in nano.pulses("D5") if abs(w - hang) <= TOLERANCE_US]
        assert hung, "the loop never output the hang throttle"
        boots = [t for t, text in nano.lines() if text == "READY 1"]
        assert len(boots) == 2, nano.lines()
        watchdog_s = spec.TIMING_LOOP_WATCHDOG_US / 1e6
        # The loop hung at most one frame before the first hang pulse went out.
        assert hung[0] - FRAME_S < boots[1] < hung[0] + 1.1 * watchdog_s
        assert hung[-1] < boots[1]  # the stale pulse ends with the reset
        after = widths(nano, "D5", boots[1])
        assert_holds(after, N)
        assert len(after) > 40  # ~1 s of frames since the reset: the rebooted loop keeps running
        assert "FAILSAFE" in [text for t, text in nano.lines() if t > boots[1]]  # booted latched


def test_the_normal_build_does_not_reset_when_it_outputs_that_throttle(nano):
    """The hang is the test build's alone: the real firmware drives 1777 us and keeps running."""
    from roar_sim.toolchains import avr

    stream(nano, N, N, 0.1)
    start = nano.time_s
    stream(nano, avr.HANG_THROTTLE_US, N, 0.6)
    assert [text for _, text in nano.lines()].count("READY 1") == 1
    assert_holds(widths(nano, "D5", start + 3 * FRAME_S), avr.HANG_THROTTLE_US)


# --- signed control on the Nano: key in its EEPROM, attacks refused, a reset opens no replay ----

def _signed_nano_lines(nano, since_s):
    return [text for _, text in nano.lines(since_s)]


def test_signed_control_on_the_emulated_nano_refuses_every_attack_and_survives_a_reset(nano):
    import random

    from roar_wire import signing

    key = bytes(range(16))
    nano.write(b"KEY " + key.hex().encode() + b"\n")
    nano.run(0.2)
    assert _signed_nano_lines(nano, 0.05)[-2:] == [f"KEY {signing.fingerprint(key)}", "SESSION 00000001"]
    stored = nano.eeprom()
    assert stored[:2] == b"RK" and key in stored

    rng = random.Random(30)
    sent, counter, t0 = [], 0, nano.time_s
    for _ in range(10):  # the owner drives: signed, in order
        counter += rng.randint(1, 5)
        message = signing.sign(encode(1500 if not sent else 1650, 1500), key, 1, counter)
        sent.append(message)
        nano.write(message)
        nano.run(SEND_S)
    assert "ARMED" in _signed_nano_lines(nano, t0)
    assert_holds(widths(nano, "D5", t0 + 0.1), 1650)

    # an attacker, for longer than the failsafe timeout: replays, reordered, forged, unsigned
    t1 = nano.time_s
    attacks = [rng.choice(sent) for _ in range(8)] + [sent[3], sent[1]]
    attacks += [signing.sign(encode(2000, 1000), bytes(16), 1, counter + 1 + i) for i in range(5)]
    attacks += [signing.sign(encode(2000, 1000), key, 2, counter + 1 + i) for i in range(5)]
    attacks += [sent[-1].replace(b"(1650", b"(1950")] + [encode(2000, 1000)] * 5
    for message in attacks:
        nano.write(message)
        nano.run(SEND_S)
    refusals = [t for t in _signed_nano_lines(nano, t1) if t.startswith("ERR")]
    assert len(refusals) == len(attacks)  # every one refused, each with its reason
    assert {t.split()[1] for t in refusals} == {"replay", "forged", "unsigned"}
    assert "FAILSAFE" in _signed_nano_lines(nano, t1)  # refused messages do not feed the failsafe
    assert max(widths(nano, "D5", t1)) <= 1650 + TOLERANCE_US  # never 1950 or 2000
    assert_holds(widths(nano, "D5", t1 + FAILSAFE_S + 0.1), N)

    # a reset draws a new session from the EEPROM: the old messages are forged now
    nano.reset()
    t2 = nano.time_s
    nano.run(0.3)
    assert _signed_nano_lines(nano, t2)[:2] == ["READY 1", "SESSION 00000002"]
    for message in sent:
        nano.write(message)
        nano.run(SEND_S)
    assert all(t.startswith("ERR forged") for t in _signed_nano_lines(nano, t2)[2:])
    assert_holds(widths(nano, "D5", t2 + 0.05), N)


def test_roar_key_set_and_a_signed_vehicle_on_the_emulated_nano_over_its_pty(capsys):
    """The user's path, in real time over the pty: `roar key set` stores the key in the Nano's
    EEPROM; a Vehicle (with the key file) drives it; one without the key cannot."""
    from roar import Vehicle
    from roar.cli import main

    proc, path = simavr.EmulatedNano.serve_pty(7.0)
    marks = {}
    started = time.monotonic()
    try:
        assert main(["key", "set", f"serial://{path}"]) == 0
        assert "now takes only messages signed" in capsys.readouterr().out
        with Vehicle(f"serial://{path}") as car:
            car.drive(throttle=0.4)
            assert wait_for(lambda: "ARMED" in car.replies, timeout_s=2)
            marks["signed"] = time.monotonic() - started
            time.sleep(1.0)
            marks["signed_end"] = time.monotonic() - started
        with Vehicle(f"serial://{path}", key=False) as car:
            car.drive(throttle=0.4)
            marks["unsigned"] = time.monotonic() - started
            time.sleep(1.2)
            marks["unsigned_end"] = time.monotonic() - started
            assert car.errors > 10 and any(r.startswith("ERR unsigned") for r in car.replies)
        out, _ = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    d5 = [(int(r) / simavr.F_CPU, int(w) / simavr.CYCLES_PER_US)
          for kind, pin, r, w in (ln.split(" ", 3) for ln in out.splitlines() if ln.startswith("P ")) if pin == "D5"]
    # (emulated time runs a little behind the wall clock: compare with margins)
    assert_holds([w for t, w in d5 if marks["signed"] + 0.3 < t < marks["signed_end"] - 0.1], 1700)
    assert_holds([w for t, w in d5 if marks["unsigned"] + 0.3 < t < marks["unsigned_end"] - 0.1], N)
