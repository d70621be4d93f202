"""Drive the simulated car round a track with a simple built-in controller whose commands go
through the firmware logic as control messages, exactly as a host would send them to a car.

    python -m roar_sim.lap [--track oval|figure-eight|FILE.json] [--laps 2] [--speed 1.5]
                           [--plot out/lap.png] [--realtime] [--gui]

Prints lap times, the maximum and RMS cross-track error and wall contacts, and plots the track
and the driven path coloured by speed.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from roar.protocol import encode, spec
from roar_sim import plotting
from roar_sim.actuators import HALF_RANGE_US
from roar_sim.firmware_core import CoreLoadError
from roar_sim.harness import SimCar, SimConfig
from roar_sim.plant import MOTOR_MAX_SPEED_RAD_S, WHEEL_RADIUS_M, WHEELBASE_M, CarState
from roar_sim.track import Track, TrackError, get

SEND_PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s] 50 Hz, like a real host
MAX_SPEED_M_S = MOTOR_MAX_SPEED_RAD_S * WHEEL_RADIUS_M  # [m/s] at full throttle
ESC_DEADBAND_US = 25  # [us] the emulated ESC's, used for feed-forward
N = spec.CONTROL_NEUTRAL_US


@dataclass
class PurePursuit:
    """Steer towards a point on the centre line `lookahead_m + gain * v` ahead; hold speed with
    feed-forward plus a proportional term."""

    track: Track
    target_speed_m_s: float = 1.5  # [m/s]
    lookahead_m: float = 0.5  # [m]
    lookahead_gain_s: float = 0.3  # [s]
    max_steer_rad: float = 0.4  # [rad] the servo's end-points
    speed_kp: float = 0.3  # throttle fraction per m/s of error

    def command(self, s: CarState, seg: int) -> tuple[int, int]:
        """(throttle_us, steering_us) for the current state; `seg` is the car's centre-line
        segment from Track.project."""
        tr = self.track
        ld = self.lookahead_m + self.lookahead_gain_s * max(0.0, s.speed)
        pts, lengths = tr.centerline, tr.segment_lengths
        i, travelled = seg, 0.0
        while travelled < ld:
            travelled += lengths[i]
            i = (i + 1) % len(pts)
        gx, gy = pts[i]
        alpha = math.atan2(gy - s.y, gx - s.x) - s.yaw
        steer = math.atan2(2 * WHEELBASE_M * math.sin(alpha), ld)  # left positive
        steer_us = N - steer / self.max_steer_rad * HALF_RANGE_US  # right = above neutral
        frac = self.target_speed_m_s / MAX_SPEED_M_S + self.speed_kp * (self.target_speed_m_s - s.speed)
        frac = max(0.0, min(1.0, frac))
        throttle_us = N + ESC_DEADBAND_US + frac * (HALF_RANGE_US - ESC_DEADBAND_US)
        clamp = lambda v: int(round(max(spec.CONTROL_MIN_US, min(spec.CONTROL_MAX_US, v))))  # noqa: E731
        return clamp(throttle_us), clamp(steer_us)


@dataclass
class LapResult:
    track: Track
    lap_times_s: list[float] = field(default_factory=list)
    cross_track_m: list[float] = field(default_factory=list)
    path: list[tuple[float, float, float]] = field(default_factory=list)  # (x, y, speed)
    wall_contacts: int = 0  # control periods with the car touching a wall

    @property
    def max_cross_track_m(self) -> float:
        return max((abs(e) for e in self.cross_track_m), default=0.0)

    @property
    def rms_cross_track_m(self) -> float:
        return float(np.sqrt(np.mean(np.square(self.cross_track_m)))) if self.cross_track_m else 0.0


def drive_laps(track: Track, laps: int = 2, speed: float = 1.5, config: SimConfig | None = None,
               progress: bool = False, timeout_s: float | None = None) -> LapResult:
    result = LapResult(track)
    controller = PurePursuit(track, target_speed_m_s=speed)
    timeout_s = timeout_s or 3 * laps * track.length_m / speed + 10
    bar = _progress_bar(laps, track.name) if progress else None
    with SimCar(track, config) as sim:
        sim.write(encode(N, N))  # arm: the car boots latched until it hears neutral
        sim.run(SEND_PERIOD_S)
        hint, s_prev, travelled, lap_start = None, 0.0, 0.0, 0.0
        while len(result.lap_times_s) < laps and sim.time_s < timeout_s:
            state = sim.state()
            hint, s_now, cte = track.project((state.x, state.y), hint)
            sim.write(encode(*controller.command(state, hint)))
            sim.run(SEND_PERIOD_S)
            ds = (s_now - s_prev + track.length_m / 2) % track.length_m - track.length_m / 2
            travelled, s_prev = travelled + ds, s_now
            result.cross_track_m.append(cte)
            result.path.append((state.x, state.y, state.speed))
            result.wall_contacts += sim.plant.wall_contacts() > 0
            if travelled >= track.length_m * (len(result.lap_times_s) + 1):
                result.lap_times_s.append(sim.time_s - lap_start)
                lap_start = sim.time_s
            if bar:
                bar.update(max(0.0, min(laps, travelled / track.length_m) - bar.n))
        sim.write(encode(N, N))
        sim.run(SEND_PERIOD_S)
    if bar:
        bar.close()
    return result


def _progress_bar(laps: int, name: str):
    from tqdm import tqdm

    return tqdm(total=laps, desc=f"driving {name}", unit="lap", mininterval=0.5, file=sys.stderr,
                bar_format="{desc}: {bar} {n:.2f}/{total} laps [{elapsed}]")


def report(result: LapResult) -> str:
    lines = [f"track {result.track.name}: {result.track.length_m:.1f} m, width {result.track.width_m:.1f} m"]
    for i, t in enumerate(result.lap_times_s, 1):
        lines.append(f"  lap {i}: {t:6.2f} s  ({result.track.length_m / t:.2f} m/s average)")
    lines.append(f"laps completed: {len(result.lap_times_s)}, total {sum(result.lap_times_s):.2f} s (simulated)")
    lines.append(f"cross-track error: max {result.max_cross_track_m:.3f} m, RMS {result.rms_cross_track_m:.3f} m")
    lines.append(f"wall contacts: {result.wall_contacts}")
    return "\n".join(lines)


def plot(result: LapResult):
    """The track and the driven path coloured by speed; returns the figure."""
    fig, ax = plotting.subplots(figsize=(8, 6))
    plotting.draw_track(ax, result.track)
    p = np.array(result.path)
    plotting.draw_path(fig, ax, p[:, 0], p[:, 1], p[:, 2])
    times = ", ".join(f"{t:.2f} s" for t in result.lap_times_s)
    ax.set_title(f"{result.track.name}: laps {times}\nmax cross-track {result.max_cross_track_m:.2f} m, "
                 f"wall contacts {result.wall_contacts}", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    return fig


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--track", default="oval", help="oval, figure-eight, or a track .json file (default: oval)")
    parser.add_argument("--laps", type=int, default=2, help="laps to drive (default: 2)")
    parser.add_argument("--speed", type=float, default=1.5, help="target speed in m/s (default: 1.5)")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="write the track and driven path to this PNG")
    parser.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    parser.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    args = parser.parse_args(argv)
    if not 1 <= args.laps <= 100:
        parser.error("--laps must be 1..100")
    if not 0.2 <= args.speed <= MAX_SPEED_M_S:
        parser.error(f"--speed must be 0.2..{MAX_SPEED_M_S:.1f} m/s")
    plotting.check_png_argument(parser, args.plot)
    try:
        track = get(args.track)
        result = drive_laps(track, args.laps, args.speed, SimConfig(realtime=args.realtime, gui=args.gui),
                            progress=True)
    except (TrackError, CoreLoadError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(report(result))
    if args.plot and not plotting.save(lambda: plot(result), args.plot):
        return 1
    return 0 if len(result.lap_times_s) == args.laps else 2


if __name__ == "__main__":
    sys.exit(main())
