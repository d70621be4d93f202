"""Lane detection on simulator frames with known ground truth, on recorded frames, and the
camera-only lap: the lane driver laps both tracks with no pose in its control path."""

import math

import numpy as np
import pytest

pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")
pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.autopilot.agent import Observation  # noqa: E402
from roar.vision.geometry import BirdsEye  # noqa: E402
from roar.vision.lanes import LaneDetector, debug_view  # noqa: E402
from roar_sim.world.obstacles import add_box  # noqa: E402
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar_sim.plants.racecar import Racecar  # noqa: E402
from roar_sim.world.bullet import pb  # noqa: E402
from roar_sim.runs.lane_course import LANE_CAMERA, LaneCourse
from roar_sim.runs.race import race  # noqa: E402
from roar.tracks import get  # noqa: E402

W, H = LANE_CAMERA


@pytest.fixture(scope="module")
def oval():
    plant = Racecar(get("oval"))
    yield plant
    plant.close()


def frame_at(plant, offset_m, heading_rad, back_m=1.5):
    """The camera frame with the car offset_m left of the oval's centre line and turned
    heading_rad anticlockwise from it, on the straight (back_m before the start)."""
    x0, y0, yaw0 = plant.world.start_pose()
    nx, ny = -math.sin(yaw0), math.cos(yaw0)
    pb.resetBasePositionAndOrientation(
        plant.car, [x0 + offset_m * nx - back_m * math.cos(yaw0), y0 + offset_m * ny - back_m * math.sin(yaw0), 0.05],
        pb.getQuaternionFromEuler([0, 0, yaw0 + heading_rad]), physicsClientId=plant.client)
    for _ in range(30):
        plant.step()
    s = plant.state()
    track = get("oval")
    i, _, cte = track.project((s.x, s.y))
    a, b = track.centerline[i], track.centerline[(i + 1) % len(track.centerline)]
    true_heading = (s.yaw - math.atan2(b[1] - a[1], b[0] - a[0]) + math.pi) % (2 * math.pi) - math.pi
    return plant.camera(W, H)[0], cte, true_heading


@pytest.mark.parametrize("offset_m,heading_rad", [(0, 0), (0.15, 0), (-0.2, 0.05), (0.1, -0.08), (0.25, 0.1),
                                                  (-0.3, -0.1)])
def test_the_lane_offset_and_heading_match_the_ground_truth(oval, offset_m, heading_rad):
    rgb, cte, true_heading = frame_at(oval, offset_m, heading_rad)
    lanes = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(W, H))).detect(rgb)
    assert lanes.source == "yellow" and lanes.left is not None and lanes.right is not None
    assert abs(lanes.offset_m - cte) <= 0.05
    assert abs(lanes.heading_rad - true_heading) <= math.radians(3)
    # Both edges a road's width (1.0 m between the lines' middles) apart, in metres in the car's
    # frame, where they are both in view (the far part of a thin line reads a little wide).
    assert lanes.left.y(1.0) - lanes.right.y(1.0) == pytest.approx(1.0, abs=0.1)


def test_recorded_frames_give_the_same_lanes_and_a_debug_view(oval, tmp_path):
    from PIL import Image

    rgb, cte, _ = frame_at(oval, 0.12, 0.0)
    Image.fromarray(rgb).save(tmp_path / "frame.png")
    np.save(tmp_path / "frame.npy", rgb)
    live = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(W, H))).detect(rgb)
    for recorded in (np.asarray(Image.open(tmp_path / "frame.png")), np.load(tmp_path / "frame.npy")):
        detector = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(W, H)))
        assert detector.detect(recorded).offset_m == pytest.approx(live.offset_m, abs=1e-9)
    fig = debug_view(detector, rgb)
    fig.savefig(tmp_path / "debug.png")
    assert (tmp_path / "debug.png").stat().st_size > 20_000
    birds_eye = fig.axes[1]  # in metres, and a legend that says what its numbers are
    assert (birds_eye.get_xlabel(), birds_eye.get_ylabel()) == ("to the left [m]", "ahead [m]")
    assert birds_eye.get_xlim()[0] > 0 > birds_eye.get_xlim()[1] and 0 < birds_eye.get_ylim()[0] < birds_eye.get_ylim()[1]
    texts = [t.get_text() for t in birds_eye.get_legend().get_texts()]
    assert texts and all("fit confidence" in t for t in texts)


def test_the_birds_eye_view_is_metric_near_and_far():
    """The camera model is the simulated camera: where its link is, and a pinhole's pixel centres
    (OpenCV's) in the renderer's frames -- a straight's edge lines, painted 0.5 m either side of
    its centre, read there from 1 m to 2.3 m ahead, within a centimetre and a half."""
    from roar_sim.plants.racecar import CAMERA_LINK
    from roar_sim.robots.esc import EscCar

    with EscCar(get("random:31")) as car:  # it starts on a straight
        car.run(0.1)
        link_z = pb.getLinkState(car.plant.car, CAMERA_LINK, physicsClientId=car.plant.client)[0][2]
        rgb, _ = car.plant.camera(*LANE_CAMERA)
    assert link_z == pytest.approx(SIMULATED_CAR_CAMERA.z_m, abs=0.001)
    detector = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(*LANE_CAMERA)))
    for _ in range(3):
        lanes = detector.detect(rgb)
    for edge, side in ((lanes.left, 1), (lanes.right, -1)):
        near = edge.points[edge.points[:, 0] <= 2.3]
        assert len(near) >= 4 and np.abs(near[:, 1] - side * 0.5).max() <= 0.015, near


def test_nothing_on_the_road_means_no_lanes(oval):
    rgb = np.full((H, W, 3), 64, np.uint8)  # bare asphalt
    lanes = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(W, H))).detect(rgb)
    assert lanes.centre is None and lanes.source == "none" and lanes.offset_m is None


def test_the_lane_driver_never_reads_the_pose():
    from roar_sim.robots.esc import EscCar

    track = get("oval")
    with EscCar(track) as sim:
        course = LaneCourse(sim)
        a, b = course.agent(0.9), course.agent(0.9)
        a.setup()
        b.setup()
        obs = sim.observe()
        blind = Observation(obs.t_s, math.nan, math.nan, math.nan, obs.speed, math.nan)
        assert a.step(obs) == b.step(blind)


@pytest.mark.parametrize("name", ["oval", "figure-eight"])
def test_camera_only_laps_stay_on_the_road_and_near_the_autopilots_pace(name):
    track = get(name)
    by_camera = race(track, laps=2, lateral="lane")
    by_pose = race(track, laps=2)
    assert len(by_camera.lap_times_s) == 2 and by_camera.wall_contacts == 0
    assert by_camera.max_cross_track_m <= 0.15
    assert min(by_camera.lap_times_s) <= 1.3 * min(by_pose.lap_times_s)


# --- obstacles by depth: the ground-plane occupancy grid ----------------------------------------

def test_a_box_ahead_lands_in_its_cells_and_the_floor_stays_free(oval):
    from roar.vision.occupancy import occupancy

    rgb, _, _ = frame_at(oval, 0.0, 0.0)
    s = oval.state()
    box = add_box(oval.world, s.x + 1.5, s.y + 0.2)  # its near face 1.4 m ahead, 0.1..0.3 m left
    try:
        _, depth = oval.camera(256, 192)
        grid = occupancy(depth, SIMULATED_CAR_CAMERA.model(256, 192))
    finally:
        pb.removeBody(box, physicsClientId=oval.client)
    assert abs(grid.plane[2]) > 0.99 and abs(grid.plane[3]) < 0.02  # the floor found level, at z = 0
    cells = [grid.cell_xy(r, c) for r, c in zip(*np.nonzero(grid.occupied))]
    in_road = [(x, y) for x, y in cells if abs(y) < 0.45]  # the walls (at +-0.6 m) aside
    assert in_road, "the box was not seen"
    for x, y in in_road:  # within one cell of the box's near face and its sides
        assert 1.4 - 0.1 <= x <= 1.6 + 0.1 and 0.1 - 0.1 <= y <= 0.3 + 0.1, (x, y)
    assert grid.nearest_ahead(0.25) == pytest.approx(1.45, abs=0.1)
    assert occupancy(oval.camera(256, 192)[1], SIMULATED_CAR_CAMERA.model(256, 192)).nearest_ahead(0.25) is None  # box gone


def test_the_lane_driver_stops_for_a_box_in_its_lane():
    from roar.autopilot.agent import Runner
    from roar_sim.robots.esc import EscCar
    from roar_sim.runs.race import PERIOD_S

    track = get("oval")
    with EscCar(track) as sim:
        x0, y0, _ = sim.plant.world.start_pose()
        box = add_box(sim.plant.world, x0 + 2.4, y0)
        sim.arm()
        Runner(sim, LaneCourse(sim).agent(0.9), PERIOD_S).run(until=lambda obs: obs.t_s > 5.0)
        s = sim.state()
        touching = pb.getContactPoints(sim.plant.car, box, physicsClientId=sim.plant.client)
    assert not touching and abs(s.speed) < 0.05
    assert 0.8 < s.x - x0 < 2.4 - 0.1 - 0.3  # it drove, and stopped short of the box
