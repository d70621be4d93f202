"""The racing line and the lap limit: `roar race --line optimal` (the ESC car following the
minimum-curvature line) on the built-in tracks and five random ones, its best flying lap against
the racing line's physical-limit lap (target <= 1.05, no wall contact), the racing-line limit
against the centre line's (target: below it wherever the track is wider than the car and its
margin), and the line itself against TUM's trajectory_planning_helpers.opt_min_curv on the same
track and bounds (target: curvature and limit lap within 3 %; the package is installed for this
comparison only, into build/bench-tph, never into the project's dependencies)."""

import subprocess
import sys
from pathlib import Path

import numpy as np

from roar.autopilot.racing_line import _resample, racing_line
from roar.autopilot.speed_profile import curvature, lap_time, speed_profile
from roar.tracks import get
from roar.tracks.track import BUILTIN
from roar_sim.robots.esc import LIMITS
from roar_sim.runs.race import optimal_line, race, robots

TITLE = "racing line: best flying lap / racing-line limit (target <= 1.05, no wall contact); vs TUM's opt_min_curv"
TRACKS = [*sorted(BUILTIN), *(f"random:{seed}" for seed in range(1, 6))]
LAPS = 3
TARGET = 1.05
TUM_WITHIN = 0.03  # the two lines' curvature and limit lap within 3 %
TPH = Path(__file__).resolve().parent.parent / "build" / "bench-tph"
TPH_PINS = ["trajectory-planning-helpers==0.79", "quadprog==0.1.14"]  # tph pins quadprog 0.1.7, which fails here


def run() -> None:
    for name in TRACKS:
        track = get(name)
        result = race(track, laps=LAPS, waypoints=optimal_line(track).points)
        flying = result.lap_times_s[1:]
        below = result.racing_limit_lap_s < result.limit_lap_s
        limits = (f"limit {result.racing_limit_lap_s:5.2f} s racing line, {result.limit_lap_s:5.2f} s centre line "
                  f"({'below' if below else 'NOT below: MISSED'})")
        if not flying:
            print(f"  {name:10} {limits}; MISSED: {result.shortfall(LAPS, 0)}")
            continue
        ratio = min(flying) / result.racing_limit_lap_s
        verdict = "ok" if ratio <= TARGET and result.wall_contacts == 0 else \
            f"MISSED by {ratio - TARGET:+.3f}: {where_slow(result)}" if result.wall_contacts == 0 else \
            f"MISSED: touched a wall in {result.wall_contacts} control periods"
        print(f"  {name:10} {limits}; best flying lap {min(flying):6.2f} s = {ratio:.3f} x  {verdict}")
    compare_with_tum()


def where_slow(result) -> str:
    """Why a flying lap fell short: the share of the racing line's limit speed driven on average,
    and where it was driven furthest below it."""
    line = optimal_line(result.track)
    speeds = line.speeds(LIMITS)
    p = np.array(result.path)
    flying = p[p[:, 4] >= result.lap_times_s[0]]
    nearest = np.argmin(np.linalg.norm(flying[:, None, :2] - line.points[None], axis=2), axis=1)
    share = flying[:, 2] / speeds[nearest]
    worst = int(np.argmin(share))
    cause = "braking and accelerating later and softer than the limits (the ESC's brake sequence and the " \
        "speed loop's lag), and" if share.mean() < 0.97 else "the line cut short of its apexes, and"
    return (f"{cause} driven at {share.mean():.0%} of the line's limit speed on average, least at "
            f"{flying[worst, 3]:.1f} m ({flying[worst, 2]:.2f} of {speeds[nearest[worst]]:.2f} m/s)")


def _tph():
    """TUM's trajectory_planning_helpers, installed into build/bench-tph on first use; None with
    the reason printed when it cannot be."""
    if str(TPH) not in sys.path:
        sys.path.insert(0, str(TPH))
    try:
        import trajectory_planning_helpers as tph

        return tph
    except ImportError:
        pass
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--disable-pip-version-check",
                           "--target", str(TPH), *TPH_PINS], capture_output=True, text=True)
    try:
        import trajectory_planning_helpers as tph

        return tph
    except ImportError as e:
        print(f"  TUM comparison skipped: trajectory_planning_helpers does not install here ({e}; pip said: "
              f"{proc.stderr.strip().splitlines()[-1:] or 'nothing'})")
        return None


def _tum_line(tph, centre: np.ndarray, halves: np.ndarray, clearance: float) -> np.ndarray:
    """TUM's minimum-curvature line as their own pipeline makes it: cubic splines through the
    centre line, then the iterative QP (iqp_handler) until its curvature linearisation holds."""
    n = len(centre)
    reftrack = np.column_stack([centre, halves[:, 1], halves[:, 0]])  # x, y, right, left
    coeffs_x, coeffs_y, m, normals = tph.calc_splines.calc_splines(path=np.vstack([centre, centre[:1]]))
    spline_len = tph.calc_spline_lengths.calc_spline_lengths(coeffs_x, coeffs_y)
    psi, kappa, dkappa = tph.calc_head_curv_an.calc_head_curv_an(coeffs_x, coeffs_y, np.arange(n), np.zeros(n),
                                                                 calc_dcurv=True)
    alpha, reftrack, normals, *_ = tph.iqp_handler.iqp_handler(
        reftrack, normals, m, spline_len, psi, kappa, dkappa, kappa_bound=10.0, w_veh=2 * clearance,
        print_debug=False, plot_debug=False, stepsize_interp=0.25, iters_min=3, curv_error_allowed=0.01)
    return reftrack[:, :2] + alpha[:, None] * normals


def compare_with_tum() -> None:
    tph = _tph()
    if tph is None:
        return
    clearance = robots.get("esc").half_width_m
    for name in ("oval", "figure-eight", "random:2,width=2.2,radius=1", "random:4,width=2.2,radius=1"):
        track = get(name)
        ours = racing_line(track, clearance)
        centre, _, halves = _resample(track, 0.25)  # the points ours moves, the same for TUM's
        theirs = _tum_line(tph, centre, halves, clearance)
        k_ours, k_theirs = curvature(ours.points), curvature(theirs)
        lap_ours = lap_time(ours.points, speed_profile(ours.points, LIMITS))
        lap_theirs = lap_time(theirs, speed_profile(theirs, LIMITS))
        bend_ours, bend_theirs = _bending(ours.points), _bending(theirs)
        close = abs(lap_ours / lap_theirs - 1) <= TUM_WITHIN and abs(bend_ours / bend_theirs - 1) <= TUM_WITHIN
        verdict = "ok" if close else (f"MISSED: the two lines differ by more than {TUM_WITHIN:.0%} (a discrete "
                                      f"second difference here, TUM's cubic splines there)")
        print(f"  vs TUM {name:28} integral of curvature^2 {bend_ours:6.3f} ours / {bend_theirs:6.3f} TUM 1/m; max "
              f"curvature {k_ours.max():.3f} / {k_theirs.max():.3f} 1/m; limit lap {lap_ours:.2f} / {lap_theirs:.2f} "
              f"s  {verdict}")


def _bending(points: np.ndarray) -> float:
    """[1/m] the integral of curvature squared along a closed line: what both lines minimise."""
    ds = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    return float(np.sum(curvature(points) ** 2 * ds))
