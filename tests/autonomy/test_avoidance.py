"""TFmini avoidance: the simulated laser reads what a TFmini would (range, rate, noise), boxes
stand where they are put, and the lane driver's IARRC rule -- keep to one lane, change lanes
for what the laser finds ahead in it -- decides as it should; then the course: a lap past three
boxes without touching one."""

import math

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.autopilot.lane_agent import (CREEP_M_S, FRONT_M, LANE_OFFSET_M, MIN_LOOKAHEAD_M, SHIFT_SLOPE,  # noqa: E402
                                       SWITCH_HOLD_S, SWITCH_M, LanePlanner, LaneState, Seen)
from roar.vision.lanes import Lanes, Line  # noqa: E402
from roar.vision.occupancy import Occupancy  # noqa: E402
from roar_sim.sensors import tfmini  # noqa: E402
from roar_sim.robots.esc import MODEL  # noqa: E402
from roar_sim.world.obstacles import BOX_HALF_M, add_box, box_course, place_boxes  # noqa: E402
from roar_sim.plants.racecar import Racecar  # noqa: E402
from roar_sim.world.bullet import pb  # noqa: E402
from roar.tracks import get  # noqa: E402

PERIOD_S = 0.02


@pytest.fixture(scope="module")
def plant():
    p = Racecar(get("oval"))
    for _ in range(40):
        p.step()
    yield p
    p.close()


def test_the_laser_reads_a_box_ahead_to_within_its_accuracy_and_100_times_a_second(plant):
    s = plant.state()
    box = add_box(plant.world, s.x + 2.5, s.y)
    try:
        laser = tfmini.Tfmini(plant, seed=3)
        truth = 2.5 - BOX_HALF_M - tfmini.MOUNT_X_M
        by_sample: dict[int, set] = {}
        for _ in range(200):  # 1 s at the physics' 200 Hz: each sample read twice
            plant.step()
            by_sample.setdefault(int(plant.time_s * tfmini.RATE_HZ + 1e-9), set()).add(laser.read())
        assert len(by_sample) in (100, 101) and all(len(v) == 1 for v in by_sample.values())  # 100 Hz
        samples = [v.pop() for v in by_sample.values()]
        assert len(set(samples)) > 5  # noisy
        error = np.array(samples) - truth
        assert abs(error.mean()) < 0.01 and 0.005 < error.std() < 0.03  # 4 cm as two standard deviations
        assert all(round(r * 100) == pytest.approx(r * 100, abs=1e-6) for r in samples)  # centimetres
    finally:
        pb.removeBody(box, physicsClientId=plant.client)


def test_nothing_in_range_or_too_close_reads_none(plant):
    s = plant.state()
    box = add_box(plant.world, s.x + tfmini.MOUNT_X_M + 0.15 + BOX_HALF_M, s.y)  # 0.15 m from the nose
    try:
        plant.step()
        assert tfmini.Tfmini(plant).read() is None
    finally:
        pb.removeBody(box, physicsClientId=plant.client)
    far = Racecar(None)  # no track, no walls: nothing within 12 m
    try:
        far.step()
        assert tfmini.Tfmini(far).read() is None
    finally:
        far.close()


def test_boxes_stand_in_the_lanes_of_the_course():
    track = get("course")
    spots = box_course(track, 3)
    assert [o for _, o in spots] == [-LANE_OFFSET_M, LANE_OFFSET_M, -LANE_OFFSET_M]
    assert all(b - a >= 3.5 for (a, _), (b, _) in zip(spots, spots[1:]))
    p = Racecar(track)
    try:
        for body, (s_m, offset) in zip(place_boxes(p.world, track, spots), spots):
            (x, y, z), _ = pb.getBasePositionAndOrientation(body, physicsClientId=p.client)
            _, _, cte = track.project((x, y))
            assert cte == pytest.approx(offset, abs=0.01) and z == pytest.approx(BOX_HALF_M)
    finally:
        p.close()


def straight_road(y_centre: float = 0.0) -> Lanes:
    """The road's centre y_centre [m] to the car's left, straight ahead, seen by the yellow line."""
    line = Line((0.0, 0.0, y_centre), 1.0, np.array([[0.5, y_centre], [2.4, y_centre]]))
    return Lanes(None, None, line, line, "yellow", (0.0, y_centre))


def planner() -> LanePlanner:
    return LanePlanner(MODEL, PERIOD_S, keep_lane=True)


def test_the_driver_keeps_to_the_right_lane():
    plan = planner().step(Seen(straight_road(), 1.0))
    assert plan.state is LaneState.FOLLOWING and plan.goal[1] == pytest.approx(-LANE_OFFSET_M)


def test_something_ahead_in_its_lane_sends_it_to_the_other_lane_and_back():
    p = planner()
    in_right_lane = straight_road(LANE_OFFSET_M)  # the car in the right lane's middle
    plan = p.step(Seen(in_right_lane, 1.0, laser_m=SWITCH_M - 0.1))
    assert p.side == 1 and p.switches == 1
    # the followed line is a ramp across, laid from the car: the goal point rides it
    assert plan.goal == pytest.approx((MIN_LOOKAHEAD_M, SHIFT_SLOPE * (1.0 * PERIOD_S + MIN_LOOKAHEAD_M)))
    p.step(Seen(in_right_lane, 1.0, laser_m=SWITCH_M - 0.2))  # the box still ahead of the car: stay
    assert p.side == 1 and p.switches == 1
    in_left_lane = straight_road(-LANE_OFFSET_M)
    p.step(Seen(in_left_lane, 1.0, laser_m=1.5))  # something in the left lane at once: no flip-flop
    assert p.side == 1 and p.switches == 1
    change_s = 2 * LANE_OFFSET_M / SHIFT_SLOPE / 1.0  # [s] the ramp's length at 1 m/s
    for _ in range(round(change_s / PERIOD_S) - 6):  # three steps taken above, three left
        plan = p.step(Seen(in_right_lane, 1.0))
    assert plan.state is LaneState.CHANGING and plan.goal[1] == pytest.approx(2 * LANE_OFFSET_M)  # the goal is across
    for _ in range(3):
        plan = p.step(Seen(in_right_lane, 1.0))
    assert plan.state is LaneState.FOLLOWING and plan.goal[1] == pytest.approx(2 * LANE_OFFSET_M)  # ... and so is the car
    assert SWITCH_HOLD_S < change_s
    p.step(Seen(in_left_lane, 1.0, laser_m=1.5))  # the next box, in the left lane
    assert p.side == -1 and p.switches == 2


def grid_with(x_m: float, y_m: float) -> Occupancy:
    """An occupancy grid with one occupied cell at (x_m, y_m) in the car's frame."""
    rows, cols = 37, 40
    occupied = np.zeros((rows, cols), bool)
    empty = Occupancy(occupied, np.zeros((rows, cols), int), (0.0, 0.0, 1.0, 0.0))
    row, col = round((x_m - empty.x0) / empty.cell_m - 0.5), round((empty.y_left - y_m) / empty.cell_m - 0.5)
    occupied[row, col] = True
    return empty


def test_what_the_depth_camera_finds_in_its_lane_switches_where_the_laser_looks_past_it():
    p = planner()
    road = straight_road(LANE_OFFSET_M)  # the car in the right lane's middle
    p.step(Seen(road, 1.0, grid=grid_with(FRONT_M + SWITCH_M + 0.3, 0.0)))  # too far yet
    assert p.side == -1
    plan = p.step(Seen(road, 1.0, grid=grid_with(FRONT_M + SWITCH_M - 0.3, 0.0), laser_m=None))
    assert p.side == 1 and plan.state is LaneState.CHANGING  # the other lane is clear: no stop, it moves across
    p = planner()
    p.step(Seen(road, 1.0, grid=grid_with(FRONT_M + 1.0, 2 * LANE_OFFSET_M)))  # in the other lane
    assert p.side == -1


def test_the_box_it_changes_lanes_for_is_not_in_its_path_nor_is_a_stopped_car_stuck_behind_it():
    """The path checked for obstacles is the ramp the car will drive: a box 1.2 m ahead in the lane
    it leaves at 1.3 m/s is beside that path, not a reason to brake. Stopped behind one (seen
    late), the ramp still moves across, at CREEP_M_S, until the path is clear."""
    box = grid_with(1.2, 0.0)
    road = straight_road(LANE_OFFSET_M)  # the car in the right lane's middle, the box dead ahead
    p = planner()
    plan = p.step(Seen(road, 1.3, grid=box, laser_m=1.2 - FRONT_M - 0.15))
    assert p.side == 1 and plan.state is LaneState.CHANGING and plan.target_speed_m_s > 1.0
    p = planner()
    p.side = 1  # changing lanes, the line still in the right lane's middle, stopped at a box 0.7 m ahead, 0.1 m left
    creep_s = 2 * LANE_OFFSET_M / (CREEP_M_S * SHIFT_SLOPE)  # [s] for the ramp to reach the other lane
    states = [p.step(Seen(road, 0.0, grid=grid_with(0.7, 0.1))).state for _ in range(round(creep_s / PERIOD_S))]
    assert states[0] is LaneState.OBSTACLE and LaneState.CHANGING in states  # it moved off ...
    assert states[-1] is LaneState.FOLLOWING  # ... and is across, in the other lane


@pytest.mark.parametrize("laser_m,y_centre", [
    (SWITCH_M + 0.1, LANE_OFFSET_M),  # still far
    (None, LANE_OFFSET_M),  # nothing in range
    (1.0, LANE_OFFSET_M + 0.35),  # a wall beside the road: the hit is 0.35 m outside the lane's middle
    (1.0, -LANE_OFFSET_M),  # the car in the other lane's middle: the hit is there, not in its lane
])
def test_what_is_not_ahead_in_its_lane_does_not_switch(laser_m, y_centre):
    p = planner()
    p.step(Seen(straight_road(y_centre), 1.0, laser_m=laser_m))
    assert p.side == -1 and p.switches == 0


def test_without_a_laser_the_driver_keeps_to_the_centre():
    plan = LanePlanner(MODEL, PERIOD_S).step(Seen(straight_road(), 1.0, laser_m=1.0))
    assert plan.goal[1] == pytest.approx(0.0)


def test_the_laser_hit_is_placed_at_the_nose():
    """Where the planner looks for the hit: FRONT_M + the reading, as the sensor is mounted."""
    assert FRONT_M == pytest.approx(tfmini.MOUNT_X_M)
    assert math.isfinite(SWITCH_M) and SWITCH_M < tfmini.MAX_RANGE_M


def test_a_lap_of_the_course_passes_three_boxes_without_touching_one():
    """The IARRC rule on the obstacle course: three boxes, alternately in the right and the left
    lane; the car keeps right, changes lanes for each, and touches neither a box nor a wall. At
    each box it is in the other lane."""
    from roar_sim.runs.race import race

    track = get("course")
    spots = box_course(track, 3)
    result = race(track, laps=1, lateral="lane", boxes=spots, avoid=True)
    assert len(result.lap_times_s) == 1 and result.box_contacts == 0 and result.wall_contacts == 0
    for s_box, offset in spots:
        at = min(range(len(result.path)), key=lambda i: abs(result.path[i][3] - s_box))
        assert result.cross_track_m[at] * offset < 0 and abs(result.cross_track_m[at] - offset) > 0.35
