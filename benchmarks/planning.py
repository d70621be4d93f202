"""Planning and the MIT challenge (roar.planning, roar.vision.objects, roar_sim.runs.challenge):

- planners on 50 seeded start/goal pairs in tunnel worlds with cones (goal: within 0.3 m of a
  point 6-12 m along the corridors), each with the same collision checker (the car's rectangle on
  the map with the cones drawn in) and the same sampling box: this project's arc RRT (ahead and
  reversing; also with its path shortcut) and Dubins RRT* (ahead only), OMPL's RRT, RRT* and RRT-Connect in Reeds-Shepp space
  and RRT in Dubins space. Success within 0.2 s and 1 s, median path length (at 1 s), median time
  to a first path. Targets: the arc RRT's success at 1 s >= OMPL RRT's; the Dubins RRT*'s median
  length <= 1.1 x OMPL RRT*'s at the same 1 s (OMPL's Reeds-Shepp car may reverse, ours may not);
- the challenge on 10 tunnel worlds with the whole stack, beside a pose-oracle run of the same
  stack: targets finish 10/10, 0 cones touched, median time <= 1.2 x the oracle's; and the camera's
  cones and markers: precision and recall >= 0.95 each, for the objects that came within 4 m in
  view;
- the challenge's concurrent round, two teams on each of the 10 worlds (the second car 2 s behind):
  target both finish on 8 of 10, 0 car-to-car contacts.

    python -m benchmarks.planning planners|challenge|teams"""

from __future__ import annotations

import math
import sys
import time
from benchmarks import pool

import numpy as np

TITLE = ("planning: arc RRT and Dubins RRT* against OMPL on 50 tunnel start/goal pairs; the challenge on 10 "
         "tunnels (finish 10/10, 0 cones, <= 1.2 x the oracle's time; detection precision and recall >= 0.95); "
         "two teams at once (both finish on 8/10, 0 contacts)")
PAIRS_PER_WORLD, WORLDS = 5, 10
BUDGETS_S = (0.2, 1.0)
GOAL_M = 0.3
TEAMS_TARGET = 8  # of the 10 worlds where both teams finish, run concurrently
LENGTH_RATIO_TARGET = 1.1
CHALLENGE_SEEDS = range(1, 11)
TIME_RATIO_TARGET = 1.2
DETECTION_TARGET = 0.95


def pairs():
    """[(world name, start pose, goal point)]: 5 per tunnel world, seeded."""
    from roar.planning import Footprint, PlanningGrid
    from roar.tracks import get
    from roar.tracks.occupancy_map import track_map
    from roar.tracks.tunnel import CONE_RADIUS_M

    out = []
    fp = Footprint()
    for seed in range(1, WORLDS + 1):
        name = f"tunnel:{seed},cones=6"
        track = get(name)
        grid = PlanningGrid.from_map(track_map(track)).with_discs(track.course.cones, CONE_RADIUS_M)
        rng = np.random.default_rng(seed)
        while sum(p[0] == name for p in out) < PAIRS_PER_WORLD:
            s = rng.uniform(0, track.length_m)
            start = track.pose_at(s)
            goal = track.pose_at(s + rng.uniform(6.0, 12.0))[:2]
            if fp.fits(grid, [start]) and not grid.blocked_at([goal])[0]:
                out.append((name, start, goal))
    return out


def _grid(name: str):
    from roar.planning import PlanningGrid
    from roar.tracks import get
    from roar.tracks.occupancy_map import track_map
    from roar.tracks.tunnel import CONE_RADIUS_M

    track = get(name)
    return PlanningGrid.from_map(track_map(track)).with_discs(track.course.cones, CONE_RADIUS_M)


def _ours(kind: str, grid, start, goal, budget: float):
    from roar.planning import ArcRRT, DubinsRRTStar, NoPath

    arc = kind.startswith("arc RRT")
    planner = ArcRRT(grid, seed=0, smooth=kind.endswith("shortcut")) if arc else DubinsRRTStar(grid, seed=0)
    began = time.perf_counter()
    try:
        path = planner.plan(start, goal, budget_s=budget)
    except NoPath:
        return None, None
    first = time.perf_counter() - began if arc else planner.first_found_s
    return path.length_m, first


def _ompl(kind: str, grid, start, goal, budget: float):
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    from roar.planning import Footprint
    from roar.planning.rrt import R_MIN_M, REGION_MARGIN_M

    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    planner, space_name = kind.removeprefix("OMPL ").split()
    space = ob.ReedsSheppStateSpace(R_MIN_M) if space_name == "(RS)" else ob.DubinsStateSpace(R_MIN_M)
    lo = np.maximum(np.minimum(start[:2], goal) - REGION_MARGIN_M, (grid.x0, grid.y0))
    hi = np.minimum(np.maximum(start[:2], goal) + REGION_MARGIN_M,
                    (grid.x0 + grid.shape[0] * grid.resolution_m, grid.y0 + grid.shape[1] * grid.resolution_m))
    bounds = ob.RealVectorBounds(2)
    for axis in (0, 1):
        bounds.setLow(axis, float(lo[axis]))
        bounds.setHigh(axis, float(hi[axis]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    fp = Footprint()
    ss.setStateValidityChecker(lambda s: fp.fits(grid, [(s.getX(), s.getY(), s.getYaw())]))
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(grid.resolution_m / space.getMaximumExtent())
    s0 = space.allocState()
    s0.setX(float(start[0]))
    s0.setY(float(start[1]))
    s0.setYaw(float(start[2]))

    class Near(ob.GoalRegion):
        def __init__(self):
            super().__init__(si)
            self.setThreshold(GOAL_M)

        def distanceGoal(self, st):
            return math.hypot(st.getX() - goal[0], st.getY() - goal[1])

    ss.setStartState(s0)
    target = Near()
    ss.setGoal(target)
    ss.setPlanner({"RRT": og.RRT, "RRT*": og.RRTstar, "RRT-Connect": og.RRTConnect}[planner](si))
    began = time.perf_counter()
    solved = ss.solve(budget)
    took = time.perf_counter() - began
    if not (solved and ss.haveExactSolutionPath()):
        return None, None
    return float(ss.getSolutionPath().length()), took


PLANNERS = ["arc RRT", "arc RRT, shortcut", "Dubins RRT*", "OMPL RRT (RS)", "OMPL RRT* (RS)", "OMPL RRT-Connect (RS)", "OMPL RRT (Dubins)"]


def _one(task):
    kind, name, start, goal = task
    grid = _grid(name)
    run = _ours if not kind.startswith("OMPL") else _ompl
    out = {}
    for budget in BUDGETS_S:
        out[budget] = run(kind, grid, start, goal, budget)
    return kind, out


def planners() -> None:
    try:
        import ompl  # noqa: F401
    except ImportError:
        print("  OMPL is not installed (pip install ompl==2.0.1): no comparison")
        return
    tasks = [(kind, *p) for p in pairs() for kind in PLANNERS]
    results: dict[str, list] = {k: [] for k in PLANNERS}
    with pool() as workers:
        for kind, out in workers.map(_one, tasks):
            results[kind].append(out)
    n = len(tasks) // len(PLANNERS)
    rows = {}
    print(f"  {n} start/goal pairs in {WORLDS} tunnel worlds with 6 cones each; goal within {GOAL_M:g} m")
    print(f"  {'planner':<24}{'ok <= 0.2 s':>12}{'ok <= 1 s':>11}{'median length':>15}{'median time':>13}")
    for kind, runs in results.items():
        ok02 = sum(r[0.2][0] is not None for r in runs)
        ok1 = [r[1.0] for r in runs if r[1.0][0] is not None]
        length = float(np.median([r[0] for r in ok1])) if ok1 else math.nan
        first = float(np.median([r[1] for r in ok1 if r[1] is not None])) if ok1 else math.nan
        rows[kind] = (len(ok1), length)
        print(f"  {kind:<24}{ok02:>9}/{n}{len(ok1):>8}/{n}{length:>13.2f} m{first * 1000:>10.0f} ms")
    arc_ok, ompl_ok = rows["arc RRT"][0], rows["OMPL RRT (RS)"][0]
    print(f"  arc RRT success at 1 s {arc_ok}/{n} vs OMPL RRT's {ompl_ok}/{n}  "
          f"{'ok' if arc_ok >= ompl_ok else 'MISSED'}")
    ratio = rows["Dubins RRT*"][1] / rows["OMPL RRT* (RS)"][1]
    print(f"  Dubins RRT* median length {ratio:.2f} x OMPL RRT*'s (target <= {LENGTH_RATIO_TARGET:g})  "
          f"{'ok' if ratio <= LENGTH_RATIO_TARGET else 'MISSED'}")


def _challenge(task):
    from roar.tracks import get
    from roar_sim.runs.challenge import challenge

    name, oracle = task
    began = time.perf_counter()
    r = challenge(get(name), oracle=oracle)
    return name, oracle, r.finished, r.time_s, len(r.cones_touched), len(r.markers_taken), r.score, \
        r.precision_recall(), time.perf_counter() - began


def challenge_runs() -> None:
    tasks = [(f"tunnel:{s}", oracle) for s in CHALLENGE_SEEDS for oracle in (False, True)]
    rows = {}
    with pool() as workers:
        for name, oracle, finished, t, cones, markers, score, pr, wall in workers.map(_challenge, tasks):
            rows[(name, oracle)] = (finished, t, cones, markers, score, pr)
            who = "oracle" if oracle else "filter"
            print(f"  {name:<10} {who}: {'finished' if finished else 'DID NOT FINISH'} {t:6.2f} s, cones {cones}, "
                  f"markers {markers}, score {score:6.2f} s; cones P/R {pr['cone'][0]:.2f}/{pr['cone'][1]:.2f}, "
                  f"markers P/R {pr['marker'][0]:.2f}/{pr['marker'][1]:.2f} (wall {wall:.0f} s)", flush=True)
    filt = [v for (n, o), v in rows.items() if not o]
    orac = [v for (n, o), v in rows.items() if o]
    finished = sum(v[0] for v in filt)
    cones = sum(v[2] for v in filt)
    print(f"  finished {finished}/{len(filt)} (target all)  {'ok' if finished == len(filt) else 'MISSED'}")
    print(f"  cones touched {cones} (target 0)  {'ok' if cones == 0 else 'MISSED'}")
    both = [(rows[(n, False)][1], rows[(n, True)][1]) for (n, o) in rows if not o and rows[(n, False)][0]
            and rows[(n, True)][0]]
    if both:
        t_f, t_o = float(np.median([a for a, _ in both])), float(np.median([b for _, b in both]))
        s_f = float(np.median([v[4] for v in filt]))
        s_o = float(np.median([v[4] for v in orac]))
        print(f"  median time {t_f:.2f} s vs the oracle's {t_o:.2f} s: {t_f / t_o:.2f} x (target <= "
              f"{TIME_RATIO_TARGET:g})  {'ok' if t_f / t_o <= TIME_RATIO_TARGET else 'MISSED'}; median score "
              f"{s_f:.2f} s vs {s_o:.2f} s")
    for kind in ("cone", "marker"):
        p = min(v[5][kind][0] for v in filt)
        r = min(v[5][kind][1] for v in filt)
        print(f"  {kind}s by camera, worst world: precision {p:.2f}, recall {r:.2f} (target >= "
              f"{DETECTION_TARGET:g} each)  {'ok' if min(p, r) >= DETECTION_TARGET else 'MISSED'}")


def _teams(name: str):
    from roar.tracks import get
    from roar_sim.runs.challenge import challenge_teams

    began = time.perf_counter()
    r = challenge_teams(get(name), 2)
    return name, r, time.perf_counter() - began


def teams_runs() -> None:
    both, contacts = 0, 0
    with pool() as workers:
        for name, r, wall in workers.map(_teams, [f"tunnel:{s}" for s in CHALLENGE_SEEDS]):
            finished = len(r.teams) == 2 and all(t.finished for t in r.teams)
            both += finished
            contacts += len(r.contacts)
            cars = "; ".join(f"car {i + 1} {'finished' if t.finished else 'DID NOT FINISH'} {t.time_s:6.2f} s, "
                             f"cones {len(t.cones_touched)}" for i, t in enumerate(r.teams))
            print(f"  {name:<10} two teams: {cars}; car-to-car contacts {len(r.contacts)} (wall {wall:.0f} s)",
                  flush=True)
            if not finished or r.contacts:
                print("\n".join("      " + line for line in r.report(2).splitlines()), flush=True)
    print(f"  both teams finished on {both}/{len(CHALLENGE_SEEDS)} (target >= {TEAMS_TARGET})  "
          f"{'ok' if both >= TEAMS_TARGET else 'MISSED'}; car-to-car contacts {contacts} (target 0)  "
          f"{'ok' if contacts == 0 else 'MISSED'}")


def run(_args=None) -> None:
    print("  planners:", flush=True)
    planners()
    print("  challenge:", flush=True)
    challenge_runs()
    print("  two teams at once:", flush=True)
    teams_runs()


if __name__ == "__main__":
    parts = {"planners": planners, "challenge": challenge_runs, "teams": teams_runs}
    for part in sys.argv[1:] or list(parts):
        parts[part]()
