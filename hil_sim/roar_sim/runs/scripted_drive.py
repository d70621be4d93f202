"""Drive the firmware's own car logic with a scripted host session and show what the ESC and the
steering servo receive: arming, driving, the brake/reverse sequence, malformed messages, the
failsafe after the host goes quiet, and an RC transmitter taking over.

    python -m roar_sim.runs.scripted_drive [--plot out/scripted_drive.png]

The car logic is the board loop of the C++ firmware core (CarBoard::poll, host build): 1 kHz,
50 Hz output frames, the board's 32-bit microsecond counter, exactly as on a Nano.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

from roar.cli.sdk import ArgumentParser, ExitStatus, path_option, run_command
from roar.protocol import ControlError, decode, encode, spec
from roar_sim.core.lockstep import LOOP_US
from roar_sim.core.car import CarBoard, CarOutputs
from roar_sim.world import plotting

FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us] output frame period
SEND_US = spec.TIMING_HOST_SEND_PERIOD_US  # [us] host resend period


@dataclass(frozen=True)
class Segment:
    """What the host (and the RC transmitter) do for a while."""

    label: str
    duration_us: int
    message: bytes | None  # sent every SEND_US; None = host silent
    rc: tuple[int, int] | None = None  # (throttle, steering) receiver pulses at 50 Hz


SCRIPT = [
    Segment("boot: host sends forward while latched", 200_000, encode(1650, 1500)),
    Segment("host sends neutral: car arms", 200_000, encode(1500, 1500)),
    Segment("forward, steering right", 800_000, encode(1700, 1800)),
    Segment("reverse: neutral/tap/neutral first", 600_000, encode(1300, 1400)),
    Segment("malformed messages are rejected", 40_000, b"(1300,2500)\n(13x0,1500)\n"),
    Segment("host goes quiet: failsafe", 600_000, None),
    Segment("RC transmitter takes over", 600_000, None, rc=(1600, 1200)),
    Segment("RC gone, host re-arms with neutral", 300_000, encode(1500, 1500)),
]


@dataclass(frozen=True)
class Sample:
    t_us: int
    out: CarOutputs


@dataclass
class Trace:
    samples: list[Sample]  # one per loop iteration
    replies: list[tuple[int, str]]  # (t, reply line from the car)
    marks: list[tuple[int, str]]  # (t, segment label)
    valid_sends: list[int]  # times the host sent a valid message

    def failsafe_delay_us(self) -> int | None:
        """From the host's last valid message to the car latching, for the first failsafe after arming."""
        armed = next((s.t_us for s in self.samples if not s.out.latched), None)
        if armed is None:
            return None
        tripped = next((s.t_us for s in self.samples if s.t_us > armed and s.out.latched), None)
        if tripped is None:
            return None
        return tripped - max(t for t in self.valid_sends if t < tripped)


def run(script: list[Segment] = SCRIPT) -> Trace:
    board = CarBoard(loop_us=LOOP_US, frame_us=FRAME_US)
    board.begin()
    trace = Trace([], [], [], [])
    samples, replies, marks = trace.samples, trace.replies, trace.marks
    t = 0
    for seg in script:
        marks.append((t, seg.label))
        board.rc(seg.rc)
        end = t + seg.duration_us
        while t < end:
            if seg.message is not None and t % SEND_US == 0:
                board.serial_in(seg.message)
                if _is_valid(seg.message):
                    trace.valid_sends.append(t)
            board.run(1)
            samples.append(Sample(t, board.outputs))
            replies += [(t, line) for line in board.serial_out().decode("ascii").splitlines()]
            t += LOOP_US
    return trace


def _is_valid(message: bytes) -> bool:
    try:
        decode(message.strip())
    except ControlError:
        return False
    return True


def changes(samples: list[Sample]) -> list[Sample]:
    """Samples where any output, the control source or the brake phase changed."""
    out, prev = [], None
    for s in samples:
        key = (s.out.throttle_us, s.out.steering_us, s.out.source, s.out.brake_phase)
        if key != prev:
            out.append(s)
            prev = key
    return out


def print_trace(trace: Trace, file=None) -> None:
    file = file or sys.stdout
    samples, replies, marks = trace.samples, trace.replies, trace.marks
    events = [(s.t_us, 0, s) for s in changes(samples)] + [(t, 1, r) for t, r in replies] + \
             [(t, -1, label) for t, label in marks]
    print(f"{'time':>8}  {'ESC':>5}  {'servo':>5}  {'source':<8} {'brake phase':<15} car says", file=file)
    for t, kind, item in sorted(events, key=lambda e: (e[0], e[1])):
        if kind == -1:
            print(f"{t / 1e6:7.3f}s  -- {item}", file=file)
        elif kind == 0:
            o = item.out
            print(f"{t / 1e6:7.3f}s  {o.throttle_us:5d}  {o.steering_us:5d}  {o.source.name.lower():<8} "
                  f"{o.brake_phase.name.lower():<15}", file=file)
        else:
            print(f"{t / 1e6:7.3f}s  {'':5}  {'':5}  {'':8} {'':15} {item}", file=file)


def plot(samples, marks):
    """Both pulse widths over time, failsafe and RC periods shaded; returns the figure."""
    t = [s.t_us / 1e6 for s in samples]
    fig, ax = plotting.subplots(figsize=(11, 4.5))
    ax.step(t, [s.out.throttle_us for s in samples], where="post", label="ESC (D5)", lw=1.6)
    ax.step(t, [s.out.steering_us for s in samples], where="post", label="steering servo (D6)", lw=1.2)
    colours = {"FAILSAFE": "#f4cccc", "RC": "#d9ead3"}
    start = None
    for i, s in enumerate(samples + [None]):
        src = s.out.source.name if s else None
        if start is not None and (s is None or src != samples[start].out.source.name):
            name = samples[start].out.source.name
            if name in colours:
                ax.axvspan(t[start], t[i - 1], color=colours[name], alpha=0.7, lw=0)
            start = None
        if s is not None and start is None:
            start = i
    for tm, label in marks:
        ax.axvline(tm / 1e6, color="grey", lw=0.5, ls=":")
        ax.text(tm / 1e6 + 0.01, 2035, label, rotation=90, va="top", ha="left", fontsize=7, color="dimgrey")
    ax.set_ylim(950, 2050)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("pulse width [us]")
    ax.set_title("Firmware core: pulses sent to the ESC and servo (red: failsafe, green: RC override)")
    ax.legend(loc="lower right", fontsize=8)
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = ArgumentParser(prog="python -m roar_sim.runs.scripted_drive", description=__doc__)
    parser.add_argument("--plot", type=path_option, metavar="PNG", help="write a plot of the pulses to this PNG file")
    args = parser.parse_args(argv)
    plotting.check_png_argument(parser, args.plot)
    trace = run()
    print_trace(trace)
    delay = trace.failsafe_delay_us()
    print(f"\n{len(trace.samples)} loop iterations at 1 kHz, {len(trace.replies)} reply lines from the car.")
    if delay is not None:
        print(f"Failsafe: neutral {delay / 1000:.0f} ms after the host's last valid message "
              f"(timeout {spec.TIMING_FAILSAFE_TIMEOUT_US / 1000:.0f} ms, checked every {LOOP_US / 1000:.0f} ms).")
    if args.plot and not plotting.save(lambda: plot(trace.samples, trace.marks), args.plot):
        return ExitStatus.ERROR
    return ExitStatus.OK


if __name__ == "__main__":
    sys.exit(run_command("make trace", main))
