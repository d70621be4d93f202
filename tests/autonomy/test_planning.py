"""roar.planning on its own (no simulator): the arc geometry against its closed-form formulas,
Dubins curves against OMPL's and their own ends, the footprint's rasterised collision, the grid's
frame, the arc RRT (r_min, collision-free paths, reversing and its cap, the wider of two gaps,
re-planning that keeps the valid tree, bad inputs in one line), the Dubins RRT* (rewiring keeps
costs consistent and shortens), the path follower (pose jumps, late paths, reversing, slowing for
bends, braking rather than swerving for a late cone), the high-level planner's marker rule, the
pose history, the SORT tracker and the camera's view (no miss round a corner)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roar.localization.pose_history import PoseHistory
from roar.planning import (ArcRRT, DubinsRRTStar, FollowerState, Footprint, NoPath, Path, PathFollower, PlanningGrid,
                           arcs, dubins)
from roar.planning.arcs import arc_poses
from roar.planning.dubins import dubins_poses
from roar.planning.mission import Mission
from roar.tracks.occupancy_map import OccupancyMap
from roar.vision.objects import Detection
from roar.vision.tracking import Tracker

RES = 0.05  # [m]
R_MIN = 0.77  # [m]


def corridor_map(length_m=12.0, width_m=2.0, blocks=()) -> OccupancyMap:
    """A straight corridor along x from 0 to length_m, y from 0 to width_m, walls round it; blocks
    (x0, y0, x1, y1) [m] of wall inside."""
    w, h = int(length_m / RES) + 4, int(width_m / RES) + 4
    occ = np.zeros((h, w), bool)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True
    for x0, y0, x1, y1 in blocks:
        occ[h - 2 - int(y1 / RES):h - 2 - int(y0 / RES), 2 + int(x0 / RES):2 + int(x1 / RES)] = True
    return OccupancyMap(occ, ~occ, RES, (-2 * RES, -2 * RES, 0.0))


# -- arcs ------------------------------------------------------------------------------------------

@settings(max_examples=200, deadline=None)
@given(st.floats(-3, 3), st.floats(-3, 3), st.floats(-math.pi, math.pi), st.floats(0.2, 4), st.floats(0.01, 1.4),
       st.sampled_from([-1, 1]))
def test_an_arc_matches_the_closed_form_formulas(x, y, heading, dist, bearing, side):
    bearing *= side
    px, py = x + dist * math.cos(heading + bearing), y + dist * math.sin(heading + bearing)  # a point ahead
    a = arcs(x, y, heading, px, py, r_min_m=0.0)
    v_left = np.array([-math.sin(heading), math.cos(heading)])
    d = np.array([px - x, py - y])
    r = 0.5 * d @ d / (d @ v_left)
    c = np.array([x, y]) + r * v_left
    ps, pd = np.array([x, y]) - c, np.array([px, py]) - c
    phi = math.atan2(ps[0] * pd[1] - ps[1] * pd[0], ps @ pd)
    assert float(a.radius_m) == pytest.approx(r, rel=1e-9)
    assert (float(a.centre_x), float(a.centre_y)) == pytest.approx(tuple(c), abs=1e-6)
    assert float(a.angle_rad) == pytest.approx(phi, abs=1e-9)
    assert float(a.length_m) == pytest.approx(abs(phi * r), rel=1e-9)
    assert math.remainder(float(a.end_heading) - heading - phi, math.tau) == pytest.approx(0, abs=1e-9)
    assert (float(a.radius_m) > 0) == (bearing > 0)  # centre to the left for a point on the left
    end = arc_poses(x, y, heading, float(a.radius_m), float(a.angle_rad), float(a.length_m), 1, 0.05)[-1]
    assert end[:2] == pytest.approx((px, py), abs=1e-6)


def test_arcs_tighter_than_r_min_cost_infinity_and_reversing_arcs_end_at_the_point():
    # a point 1 m ahead and 1 m left: radius 1 m
    a = arcs(0.0, 0.0, 0.0, 1.0, 1.0, r_min_m=0.9)
    assert float(a.radius_m) == pytest.approx(1.0) and math.isfinite(float(a.length_m))
    assert math.isinf(float(arcs(0.0, 0.0, 0.0, 1.0, 1.0, r_min_m=1.1).length_m))
    assert float(arcs(0.0, 0.0, 0.0, 2.0, 0.0, 0.5).length_m) == pytest.approx(2.0)  # straight ahead
    assert math.isinf(float(arcs(0.0, 0.0, 0.0, -2.0, 0.0, 0.5).length_m))  # straight behind: not ahead
    back = arcs(0.0, 0.0, 0.0, -1.0, 1.0, 0.5, reverse=True)  # behind and left, reversing
    assert int(back.direction) == -1 and math.isfinite(float(back.length_m))
    poses = arc_poses(0.0, 0.0, 0.0, float(back.radius_m), float(back.angle_rad), float(back.length_m), -1, 0.05)
    assert poses[-1, :2] == pytest.approx((-1.0, 1.0), abs=1e-9)
    assert poses[-1, 2] == pytest.approx(float(back.end_heading))
    assert poses[-1, 2] == pytest.approx(-math.pi / 2)  # backing into a bay on the left: nose points right
    many = arcs(np.zeros(3), np.zeros(3), np.array([0.0, math.pi / 2, math.pi]), 1.0, 1.0, 0.5)
    assert many.length_m.shape == (3,)


# -- Dubins ----------------------------------------------------------------------------------------

def test_dubins_curves_end_at_their_goal_and_their_starts_are_shortest():
    rng = np.random.default_rng(1)
    a, b = rng.uniform(-3, 3, (400, 3)), rng.uniform(-3, 3, (400, 3))
    d = dubins(a, b, R_MIN)
    for i in range(400):
        end = dubins_poses(a[i], d, i, 0.05)[-1]
        assert np.hypot(*(end[:2] - b[i, :2])) < 1e-9
        assert abs(math.remainder(end[2] - b[i, 2], math.tau)) < 1e-9
        part = min(rng.uniform(0.1, 3.0), float(d.length_m[i]))  # a shortest path's start is a shortest path
        mid = dubins_poses(a[i], d, i, 0.05, upto_m=part)[-1]
        assert float(dubins(a[i], mid, R_MIN).length_m[0]) == pytest.approx(part, abs=1e-6)
    # a pure turn (one circle: no straight) costs its arc, not a circle more
    phi = 1.948
    assert float(dubins([0, 0, 0], [R_MIN * math.sin(phi), -R_MIN * (1 - math.cos(phi)), -phi], R_MIN).length_m[0]) \
        == pytest.approx(phi * R_MIN)


def test_dubins_lengths_equal_ompls():
    ob = pytest.importorskip("ompl.base", reason="pip install ompl==2.0.1")
    space = ob.DubinsStateSpace(R_MIN)
    rng = np.random.default_rng(2)
    a, b = rng.uniform(-3, 3, (200, 3)), rng.uniform(-3, 3, (200, 3))
    ours = dubins(a, b, R_MIN).length_m
    s1, s2 = space.allocState(), space.allocState()
    for i in range(200):
        for s, q in ((s1, a[i]), (s2, b[i])):
            s.setX(q[0])
            s.setY(q[1])
            s.setYaw(q[2])
        assert ours[i] == pytest.approx(space.distance(s1, s2), abs=1e-9)


# -- grid and footprint ----------------------------------------------------------------------------

def test_a_maps_cells_land_where_the_map_draws_them():
    grid = PlanningGrid.from_map(corridor_map(blocks=[(5.0, 0.0, 5.5, 1.0)]))
    assert grid.blocked_at([(5.2, 0.5), (5.2, 1.5), (3.0, 1.0), (-0.5, 1.0)]).tolist() == [True, False, False, True]
    assert grid.with_discs([(3.0, 1.0)], 0.1).blocked_at([(3.0, 1.0), (3.08, 1.0), (3.2, 1.0)]).tolist() == \
        [True, True, False]


def test_the_footprint_is_rasterised_over_the_cars_rectangle_not_its_centre():
    free = np.zeros((200, 200), bool)
    fp = Footprint(rear_m=0.1, front_m=0.4, half_width_m=0.15, margin_m=0.0)
    pose = (5.0, 5.0, 0.0)
    for (x, y), hit in (((5.38, 5.13), True), ((5.45, 5.0), False), ((4.92, 4.87), True), ((5.2, 5.2), False),
                        ((5.2, 5.0), True)):
        blocked = free.copy()
        blocked[int(x / RES), int(y / RES)] = True  # one cell
        assert fp.fits(PlanningGrid(blocked, RES, 0.0, 0.0), [pose]) is not hit, (x, y)
    turned = free.copy()
    turned[int(4.87 / RES), int(5.38 / RES)] = True  # the same corner cell with the car facing +y... rotated away
    assert fp.fits(PlanningGrid(turned, RES, 0.0, 0.0), [pose])
    assert not fp.fits(PlanningGrid(turned, RES, 0.0, 0.0), [(5.0, 5.0, math.pi / 2)])  # ...and into it
    assert fp.first_collision(PlanningGrid(free, RES, 0.0, 0.0), [(1.0, 1.0, 0.0), (0.05, 1.0, 0.0)]) == 1  # off grid

    # round obstacles, exactly: a cone 0.1 m round just clear of the front, touching it, off a corner
    assert not fp.touches_discs([pose], [(5.52, 5.0)], 0.1) and fp.touches_discs([pose], [(5.49, 5.0)], 0.1)
    assert not fp.touches_discs([pose], [(5.48, 5.23)], 0.1)  # 0.113 m from the corner (5.4, 5.15)
    assert fp.touches_discs([pose], [(5.46, 5.21)], 0.1)  # 0.085 m from the corner
    assert fp.touches_discs([(0.0, 0.0, 0.0), pose], [(5.1, 5.0)], 0.1)  # under the car, at the second pose
    assert not fp.touches_discs([pose], [(4.75, 5.0)], 0.1)  # 0.15 m behind its rear
    assert not fp.touches_discs([pose], np.zeros((0, 2)), 0.1)


# -- arc RRT ---------------------------------------------------------------------------------------

def slalom() -> PlanningGrid:
    return PlanningGrid.from_map(corridor_map(blocks=[(3.0, 0.0, 3.3, 1.2), (6.0, 0.8, 6.3, 2.0)]))


def assert_drivable(planner, path, grid, goal):
    fp = planner.footprint
    assert fp.fits(grid, path.poses)
    assert math.hypot(path.poses[-1, 0] - goal[0], path.poses[-1, 1] - goal[1]) <= planner.goal_tolerance_m
    steps = np.hypot(*np.diff(path.poses[:, :2], axis=0).T)
    assert steps.max() <= grid.resolution_m + 1e-9  # dense: what a follower tracks is what was checked


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_arc_rrt_finds_a_collision_free_path_of_drivable_arcs(seed):
    grid = slalom()
    rrt = ArcRRT(grid, r_min_m=R_MIN, seed=seed)
    path = rrt.plan((1.0, 1.0, 0.0), (10.5, 1.0), max_iterations=20_000)
    assert_drivable(rrt, path, grid, (10.5, 1.0))
    t = rrt.tree
    assert np.all(np.abs(t.radius[1:]) >= R_MIN)  # no edge tighter than the car turns
    assert 9.0 < path.length_m < 20.0


def test_shortcutting_keeps_a_chain_of_drivable_arcs_and_never_lengthens_it():
    grid = slalom()
    for seed in range(5):
        plain = ArcRRT(grid, r_min_m=R_MIN, seed=seed, reverse=False).plan((1.0, 1.0, 0.0), (10.5, 1.0),
                                                                            max_iterations=20_000)
        rrt = ArcRRT(grid, r_min_m=R_MIN, seed=seed, reverse=False, smooth=True)
        smooth = rrt.plan((1.0, 1.0, 0.0), (10.5, 1.0), max_iterations=20_000)
        assert_drivable(rrt, smooth, grid, (10.5, 1.0))
        assert smooth.length_m <= plain.length_m + 1e-6
        better = ArcRRT(grid, r_min_m=R_MIN, seed=seed, reverse=False, improve=500)
        assert better.plan((1.0, 1.0, 0.0), (10.5, 1.0), max_iterations=20_000).length_m <= plain.length_m + 1e-6
        nodes = rrt._branch
        assert np.all(np.abs(rrt.tree.radius[nodes[1:]]) >= R_MIN)
        # each arc leaves its parent along the parent's heading: the chain has no kinks
        for k in nodes[1:]:
            start = rrt.edge_poses(k)[0]
            parent = rrt.tree.pose(int(rrt.tree.parent[k]))
            assert abs(math.remainder(math.atan2(start[1] - parent[1], start[0] - parent[0]) - parent[2],
                                      math.tau)) < 0.1


def test_a_path_ends_where_the_car_has_room_to_overshoot_its_stop():
    grid = PlanningGrid.from_map(corridor_map())  # its end wall at x = 12 m
    for seed in range(3):
        rrt = ArcRRT(grid, r_min_m=R_MIN, seed=seed, stop_room_m=0.25)
        path = rrt.plan((1.0, 1.0, 0.0), (11.45, 1.0), max_iterations=20_000)
        x, y, th = path.poses[-1]
        on = 0.25 * path.direction[-1]  # overshooting the way it drives in: ahead, or back when reversing
        assert rrt.footprint.fits(grid, [(x + on * math.cos(th), y + on * math.sin(th), th)])


def test_the_arc_rrt_reverses_out_of_a_dead_end():
    grid = PlanningGrid.from_map(corridor_map(length_m=4.0, width_m=1.2))  # too narrow to turn round in
    rrt = ArcRRT(grid, r_min_m=R_MIN, seed=1, step_m=1.0)
    path = rrt.plan((3.0, 0.6, 0.0), (0.8, 0.6), max_iterations=20_000)
    assert_drivable(rrt, path, grid, (0.8, 0.6))
    assert (path.direction < 0).any()


def reversing_runs(path) -> list[float]:
    """[m] the lengths of a path's stretches driven backwards in a row."""
    steps = np.hypot(*np.diff(path.poses[:, :2], axis=0).T)
    runs, run = [], 0.0
    for back, step in zip(path.direction[1:] < 0, steps):
        run = run + step if back else 0.0
        runs.append(run)
    return runs or [0.0]


def test_a_path_reverses_no_farther_in_a_row_than_allowed_counting_what_the_car_just_reversed():
    grid = PlanningGrid.from_map(corridor_map(length_m=12.0, width_m=2.0))
    for seed in range(3):  # facing the wrong way, the goal 6 m behind: a turn, not 6 m backwards blind
        rrt = ArcRRT(grid, r_min_m=R_MIN, seed=seed, max_reverse_m=1.0)
        path = rrt.plan((8.0, 1.0, 0.0), (2.0, 1.0), max_iterations=20_000)
        assert_drivable(rrt, path, grid, (2.0, 1.0))
        assert max(reversing_runs(path)) <= 1.0 + grid.resolution_m
        assert np.all(rrt.tree.reversed <= 1.0 + 1e-9)
        # the car has just reversed its metre: the path may not begin backwards
        again = rrt.replan(tuple(path.poses[0]), (2.0, 1.0), max_iterations=20_000, reversed_m=1.0)
        assert again.direction[1] > 0
        assert max(reversing_runs(again)) <= 1.0 + grid.resolution_m
    blind = [max(reversing_runs(ArcRRT(grid, r_min_m=R_MIN, seed=s).plan((8.0, 1.0, 0.0), (2.0, 1.0),
                                                                          max_iterations=20_000)))
             for s in range(3)]
    assert max(blind) > 1.5  # unlimited, a plain RRT does back down the corridor: the limit is what stopped it


def test_with_room_m_the_wider_gap_beside_a_cone_is_taken():
    # a cone 0.95 m from one wall of a 2.4 m corridor: a gap the car fits with 0.2 m to spare, and a wide one
    grid = PlanningGrid.from_map(corridor_map(length_m=10.0, width_m=2.4)).with_discs([(5.0, 0.95)], 0.2)

    def narrow(room_m: float) -> int:
        count = 0
        for seed in range(20):
            rrt = ArcRRT(grid, r_min_m=R_MIN, seed=seed, room_m=room_m, smooth=True, improve=300)
            path = rrt.plan((1.0, 1.2, 0.0), (9.0, 1.2), max_iterations=1000)
            assert_drivable(rrt, path, grid, (9.0, 1.2))
            count += np.interp(5.0, path.poses[:, 0], path.poses[:, 1]) < 0.95
        return count

    assert narrow(0.3) == 0
    assert narrow(0.0) >= 2  # by length alone the first gap found is kept, narrow or not


def test_replanning_keeps_the_still_valid_tree_and_routes_round_what_appeared():
    grid = PlanningGrid.from_map(corridor_map(length_m=14.0, width_m=2.4))
    rrt = ArcRRT(grid, r_min_m=R_MIN, seed=4)
    first = rrt.plan((1.0, 1.2, 0.0), (13.0, 1.2), max_iterations=20_000)
    size = len(rrt.tree)
    pose = tuple(first.poses[len(first.poses) // 5])  # the car has driven a fifth of it
    on = first.poses[first.poses[:, 0] > pose[0] + 3.0]  # a box drops onto the path 3 m further
    box = on[0, :2]
    new_grid = grid.with_discs([box], 0.3)
    second = rrt.replan(pose, (13.0, 1.2), new_grid, max_iterations=20_000)
    assert 0 < rrt.kept_nodes < size + 1
    assert_drivable(rrt, second, new_grid, (13.0, 1.2))
    assert np.hypot(*(second.poses[0, :2] - pose[:2])) <= 0.6  # from a node of the old path near the car
    for k in range(1, len(rrt.tree)):  # every edge kept or grown fits the new grid
        assert rrt.footprint.fits(new_grid, rrt.edge_poses(k))


def test_bad_inputs_end_in_one_line():
    grid = slalom()
    rrt = ArcRRT(grid, seed=1)
    for start, goal, words in (((1.0, 1.0, 0.0), (3.1, 0.5), "the goal (3.10, 0.50) is inside a wall"),
                               ((3.1, 0.5, 0.0), (10.0, 1.0), "the start (3.10, 0.50) is in collision"),
                               ((1.0, 1.0, 0.0), (40.0, 1.0), "the goal (40.00, 1.00) is inside a wall or an obstacle, or off the map")):
        with pytest.raises(NoPath, match="^no path: " + words.replace("(", r"\(").replace(")", r"\)")):
            rrt.plan(start, goal, max_iterations=100)
    walled = PlanningGrid.from_map(corridor_map(blocks=[(6.0, 0.0, 6.3, 2.0)]))
    with pytest.raises(NoPath, match="not connected to the start"):
        ArcRRT(walled).plan((1.0, 1.0, 0.0), (10.0, 1.0))
    full = corridor_map()
    with pytest.raises(NoPath, match="^no path: the map has no free space"):
        PlanningGrid.from_map(OccupancyMap(np.ones_like(full.occupied), np.zeros_like(full.free), RES, full.origin))
    with pytest.raises(NoPath, match=r"^no path: none found in 5 samples"):
        ArcRRT(grid, seed=1, goal_bias=0.0).plan((1.0, 1.0, 0.0), (10.5, 1.0), max_iterations=5)
    for bad in ((1.0, math.nan, 0.0), "here", (1.0,)):
        with pytest.raises(ValueError, match="^start"):
            rrt.plan(bad, (10.0, 1.0))
    with pytest.raises(ValueError, match="^goal must be"):
        rrt.plan((1.0, 1.0, 0.0), (1.0,))
    assert "\n" not in str(NoPath("x"))


# -- Dubins RRT* -----------------------------------------------------------------------------------

def test_rrt_star_rewires_to_a_shorter_path_with_consistent_costs():
    grid = slalom()
    star = DubinsRRTStar(grid, r_min_m=R_MIN, seed=3)
    early = DubinsRRTStar(grid, r_min_m=R_MIN, seed=3, stop_at_first=True)
    goal = (10.5, 1.0, 0.0)
    first = early.plan((1.0, 1.0, 0.0), goal, max_iterations=4000)
    best = star.plan((1.0, 1.0, 0.0), goal, max_iterations=4000)
    assert_drivable(star, best, grid, goal)
    assert abs(math.remainder(best.poses[-1, 2] - goal[2], math.tau)) <= math.radians(30)
    assert star.rewires > 0
    assert best.length_m <= first.length_m + 1e-6
    t = star.tree
    edge = dubins(t.poses()[t.parent[1:]], t.poses()[1:], R_MIN).length_m
    assert np.allclose(t.cost[1:], t.cost[t.parent[1:]] + edge, atol=1e-6)  # every cost is its branch's length


# -- the follower ----------------------------------------------------------------------------------

def straight_path(x0=0.0, x1=10.0, y=0.0, direction=1) -> Path:
    xs = np.arange(x0, x1 + 1e-9, 0.05)
    return Path(np.stack([xs, np.full_like(xs, y), np.zeros_like(xs)], axis=1), np.full(len(xs), direction, np.int8))


def test_the_follower_holds_its_target_off_the_path_and_fast_forwards_when_back():
    f = PathFollower(lookahead_m=0.6)
    assert f.step((0.0, 0.0, 0.0)).state == FollowerState.WAITING
    f.set_path(straight_path())
    s = f.step((1.0, 0.05, 0.0))
    assert s.state == FollowerState.FOLLOWING and s.target[0] == pytest.approx(1.6, abs=0.06)
    assert s.curvature < 0  # left of the path: steer right
    held = f.step((1.5, 2.0, 0.0))  # the pose jumps 2 m off the path
    assert held.state == FollowerState.OFF_PATH and held.target == s.target and held.index == s.index
    back = f.step((4.02, 0.0, 0.0))  # ...and back on, further along
    assert back.state == FollowerState.FOLLOWING
    assert f.path.poses[back.index, 0] == pytest.approx(4.05, abs=1e-6)  # the first point not yet passed
    assert f.fast_forwards >= 1
    behind = f.step((2.0, 0.0, 0.0))  # a jump back never winds the index back
    assert behind.index == back.index
    assert f.step((9.95, 0.0, 0.0)).state == FollowerState.DONE


def test_a_late_path_is_followed_from_where_the_car_is_now():
    f = PathFollower()
    f.set_path(straight_path())  # made when the car was at x = 0; it is at 3.3 by the time it arrives
    s = f.step((3.32, 0.0, 0.0))
    assert f.path.poses[s.index, 0] == pytest.approx(3.35, abs=1e-6)
    assert s.speed_m_s > 0


def test_the_follower_slows_for_a_bend_ahead_in_time_to_take_it():
    from roar.planning.follower import BRAKE_M_S2, LATERAL_M_S2

    r, straight = 0.8, 4.0  # [m] 4 m straight, then a quarter turn 0.8 m round
    xs = np.arange(0.0, straight, 0.02)
    a = np.arange(0.0, math.pi / 2, 0.02 / r)
    poses = np.vstack([np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1),
                       np.stack([straight + r * np.sin(a), r - r * np.cos(a), a], axis=1)])
    path = Path(poses, np.ones(len(poses), np.int8))
    fast = PathFollower(max_speed_m_s=4.0)
    bend = math.sqrt(LATERAL_M_S2 * r)  # [m/s] the bend's own speed
    for x in (0.0, 1.5, 2.5):
        follower = PathFollower(max_speed_m_s=4.0)
        follower.set_path(path)
        before = straight - x
        want = bend if before <= 1.5 else min(4.0, math.sqrt(bend ** 2 + 2 * BRAKE_M_S2 * before))
        assert follower.step((x, 0.0, 0.0), 3.0).speed_m_s == pytest.approx(want, abs=0.05)
    assert fast.entry_speed(path) == pytest.approx(min(4.0, math.sqrt(bend ** 2 + 2 * BRAKE_M_S2 * straight)), abs=0.05)
    late = Path(poses[poses[:, 0] > 3.2], np.ones(int(np.sum(poses[:, 0] > 3.2)), np.int8))  # the bend 0.8 m on
    assert fast.entry_speed(late) == pytest.approx(bend, abs=0.05)
    assert fast.path is None  # asking changes nothing
    # a cone seen late 3 m ahead, the way round it bending at once: at 2 m/s the car brakes (it stops in
    # 1.33 m, short of the cone); at walking pace it takes the way round; with the cone 1 m ahead it
    # swerves (braking would not stop it short)
    follower = PathFollower(max_speed_m_s=2.0)
    assert follower.brake_rather(late, 2.0, shut_m=3.0, front_m=0.44)
    assert not follower.brake_rather(late, 0.8, shut_m=3.0, front_m=0.44)
    assert not follower.brake_rather(late, 2.0, shut_m=1.0, front_m=0.44)
    assert not follower.brake_rather(path, 2.0, shut_m=3.0, front_m=0.44)  # a way round it can take at speed


def test_reversing_steers_the_wheels_the_other_way():
    f = PathFollower()
    f.set_path(Path(np.stack([np.arange(0.0, -5.0, -0.05), np.zeros(100), np.zeros(100)], axis=1),
                    np.full(100, -1, np.int8)))
    s = f.step((0.0, 0.2, 0.0))  # backing along -x, 0.2 m to the left of the path
    assert s.direction == -1
    # reversing, the tail goes where the wheels point: to bring it back right, steer right
    assert s.curvature < 0
    assert PathFollower().step((0.0, 0.2, 0.0)).curvature == 0.0


# -- high level, history, tracking -----------------------------------------------------------------

def test_a_marker_is_pursued_only_when_its_bonus_beats_the_detour():
    route = np.stack([np.linspace(0, 20, 201), np.zeros(201)], axis=1)
    near, far = (2.5, 0.3), (2.5, 1.8)
    m = Mission(route, bonus_s=0.5, speed_m_s=1.5)
    assert m.goal((0.0, 0.0, 0.0), markers=[near])[1] == "marker"
    assert m.goal((0.0, 0.0, 0.0), markers=[far])[1] == "route"
    assert Mission(route, bonus_s=5.0, speed_m_s=1.5).goal((0.0, 0.0, 0.0), markers=[far]) == (far, "marker")
    m.update((2.5, 0.3, 0.0), [near])
    assert m.taken == [near]
    assert m.goal((2.6, 0.0, 0.0), markers=[near])[1] == "route"  # taken: not again
    assert m.goal((17.0, 0.0, 0.0))[1] == "finish"
    other = (12.0, 0.2)
    assert m.goal((10.0, 0.0, 0.0), markers=[other]) == (other, "marker")
    m.abandon()  # no way to it
    assert m.goal((10.0, 0.0, 0.0), markers=[other])[1] == "route"
    grid = PlanningGrid.from_map(corridor_map(length_m=22.0, blocks=[(6.0, 0.0, 8.0, 2.0)]))
    goal, _ = m.goal((0.0, 1.0, 0.0), grid)
    assert not grid.blocked_at([goal])[0]


def test_pose_history_interpolates_the_pose_at_a_frames_capture():
    h = PoseHistory(seconds=1.0)
    for k in range(100):
        t = k * 0.02
        h.add(t, (t, 0.0, math.remainder(3.0 + t, math.tau)))
    assert h.at(1.51) == pytest.approx((1.51, 0.0, math.remainder(4.51, math.tau)), abs=1e-9)
    assert h.at(0.5) is None  # older than kept
    assert h.at(5.0)[0] == pytest.approx(1.98)


def test_sort_counts_each_object_once_and_drops_what_is_seen_once():
    rng = np.random.default_rng(0)
    objects = [("cone", 3.0, 1.0), ("cone", 3.4, -0.2), ("marker", 5.0, 0.0)]
    tracker = Tracker()
    for k in range(30):
        t = k * 0.1
        dets = [Detection(kind, x + rng.normal(0, 0.05), y + rng.normal(0, 0.05), t, 2.0, 50)
                for kind, x, y in objects if not (k % 7 == 3 and kind == "marker")]  # sometimes missed
        if k == 10:
            dets.append(Detection("cone", 1.0, 2.0, t, 2.0, 9))  # a glint, once
        tracker.update(dets, t)
    cones, markers = tracker.objects("cone"), tracker.objects("marker")
    assert len(cones) == 2 and len(markers) == 1
    assert all(min(math.hypot(o.x - x, o.y - y) for _, x, y in objects) < 0.08 for o in cones + markers)
    assert not any(math.hypot(t.x - 1.0, t.y - 2.0) < 0.3 for t in tracker.tracks)
    for k in range(30, 60):  # out of view for 3 s: confirmed objects stay where they were
        tracker.update([], k * 0.1, in_view=lambda x, y: False)
    assert len(tracker.objects()) == 3
    assert all(min(math.hypot(o.x - x, o.y - y) for _, x, y in objects) < 0.08 for o in tracker.objects())


def test_a_cone_round_a_corner_is_not_missed_but_one_in_plain_view_is():
    from roar.vision.geometry import SIMULATED_CAR_CAMERA
    from roar.vision.view import CameraView

    known = corridor_map(length_m=12.0, width_m=4.0, blocks=[(4.0, 0.0, 4.3, 3.0)])  # a wall with a gap at the top
    view = CameraView(SIMULATED_CAR_CAMERA.model(320, 240), known)
    pose = (2.0, 1.0, 0.0)  # the camera 0.39 m ahead, at (2.39, 1)
    assert view.sees(pose, 3.5, 1.0)
    assert not view.sees(pose, 5.5, 1.0)  # behind the wall
    assert not view.sees(pose, 2.7, 1.0)  # too near: it fills the frame's bottom
    assert not view.sees(pose, 3.0, 3.5)  # outside the field of view
    assert not view.sees(pose, 8.0, 1.0) and not CameraView(view.camera).sees(pose, 8.0, 1.0)  # too far
    assert CameraView(view.camera).sees(pose, 5.5, 1.0)  # with no map, walls hide nothing
    tracker = Tracker()
    objects = [("cone", 3.5, 1.0), ("cone", 5.5, 1.0)]
    for k in range(5):  # both seen (the car was elsewhere)
        tracker.update([Detection(kind, x, y, k * 0.1, 2.0, 50) for kind, x, y in objects], k * 0.1)
    assert len(tracker.objects("cone")) == 2
    for k in range(5, 25):  # now nothing is detected from the pose: the one in plain view is gone
        tracker.update([], k * 0.1, in_view=lambda x, y: view.sees(pose, x, y))
    kept = tracker.objects("cone")
    assert len(kept) == 1 and math.hypot(kept[0].x - 5.5, kept[0].y - 1.0) < 0.05


def test_the_course_driver_stands_until_it_has_seen_then_drives_along_the_route():
    from roar.localization.local_grid import LocalGrid
    from roar.planning.course_driver import CourseDriver
    from roar.vision.geometry import SIMULATED_CAR_CAMERA

    known = corridor_map(length_m=12.0, width_m=2.0)
    route = np.array([(0.5, 1.0), (11.0, 1.0)])
    camera = SIMULATED_CAR_CAMERA.model(160, 120)
    driver = CourseDriver(known, route, camera, LocalGrid(10.0, RES, known), wheelbase_m=0.325, max_steer_rad=0.4,
                          max_speed_m_s=5.0, seed=1)
    grey, far = np.full((120, 160, 3), 128, np.uint8), np.full((120, 160), np.inf)
    pose, commands = (1.0, 1.0, 0.0), []
    for k in range(40):  # 0.8 s standing at the start, a frame every 0.1 s from 0.3 s on
        t = k * 0.02
        frames = [(grey, far, t - 0.3)] if k >= 15 and k % 5 == 0 else []
        commands.append(driver.step(t, pose, 0.0, frames))
    first_go = next(k for k, c in enumerate(commands) if c.throttle > 0)
    assert all(c.throttle == 0.0 and c.steering == 0.0 for c in commands[:first_go])
    assert driver.frames >= 3 and first_go >= 25  # the third frame came at 0.5 s: not before
    assert driver.plans >= 1 and driver.follower.path is not None and not driver.exploring
    assert driver.follower.path.poses[-1, 0] > 4.0  # towards the route's next goal, 4 m on
    assert not driver.objects("cone") and abs(commands[-1].steering) < 0.2
