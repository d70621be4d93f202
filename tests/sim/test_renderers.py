"""The two renderers of the simulated camera -- PyBullet's TinyRenderer and its EGL plugin
(OpenGL without a window) -- draw the same world: the lane detector finds the same lines in
both, within 2 cm, from poses along tracks of every kind; EGL draws the track (it drew it blank
before the scene's meshes became OBJ files) and says nothing on stdout."""

import math

import numpy as np
import pytest
import shapely

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")

from roar.tracks import get  # noqa: E402
from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye  # noqa: E402
from roar.vision.lanes import LaneDetector  # noqa: E402
from roar_sim.world import renderer as renderers  # noqa: E402
from roar_sim.world.scene import World  # noqa: E402

SIZE = (320, 240)  # [px] the lane driver's camera
AGREE_M = 0.02  # [m] the promise: the same lines within 2 cm
SURE = 0.75  # a line found in this share of the detector's bands is compared by its fit
STEER_M = 2.0  # [m] ahead: as far as the lane driver steers by (its goal is at most 2.2 m out)


@pytest.fixture(scope="module")
def egl_works():
    world = World(None, 1 / 240, renderer="egl")
    name = world.renderer_name
    world.close()
    if name != "egl":
        pytest.skip("the EGL renderer cannot start here: apt install libegl1 libegl-mesa0")


def poses(track, count: int, rng: np.random.Generator):
    """Camera poses along the centre line, a little off it and askew, as a driving car's."""
    step = len(track.centerline) // count
    for i in range(0, step * count, step):
        (x, y), (nx, ny) = track.centerline[i], track.normals[i]
        ahead = track.centerline[(i + 1) % len(track.centerline)] - track.centerline[i]
        off = rng.uniform(-0.12, 0.12)  # [m]
        yield x + off * nx, y + off * ny, math.atan2(ahead[1], ahead[0]) + rng.uniform(-0.1, 0.1)


def frame(world: World, pose) -> np.ndarray:
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    cam = SIMULATED_CAR_CAMERA
    position = (x + cam.x_m * c, y + cam.x_m * s, cam.z_m)
    return world.render(position, yaw, cam.pitch_rad, *SIZE, cam.fov_deg)


@pytest.mark.parametrize("name", ["oval", "random:31", "random:31,width=2.2,radius=1"])
def test_both_renderers_show_the_same_lane_lines(egl_works, name):
    track = get(name)
    tiny, egl = World(track, 1 / 240, renderer="tiny"), World(track, 1 / 240, renderer="egl")
    assert (tiny.renderer_name, egl.renderer_name) == ("tiny", "egl")
    compared, windows = 0, []
    try:
        for pose in poses(track, 8, np.random.default_rng(7)):
            lines = []
            for world in (tiny, egl):
                detector = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(*SIZE)))
                rgb, depth = frame(world, pose)
                for _ in range(3):  # the detector follows its lines from frame to frame
                    lanes = detector.detect(rgb)
                lines.append(lanes)
                assert np.isfinite(depth).all() and depth.min() > 0.05
            for side in ("left", "right", "yellow"):
                a, b = getattr(lines[0], side), getattr(lines[1], side)
                if a is None or b is None:  # only a line seen in few bands may be missed by the other
                    assert (a or b) is None or (a or b).confidence < SURE, f"{name} at {pose}: {side} seen by one only"
                    continue
                for one, other in ((a, b), (b, a)):  # each window's centre from the other's windows' polyline
                    polyline = shapely.LineString(other.points)
                    for point in map(shapely.Point, one.points):
                        if 0.0 < polyline.project(point) < polyline.length:  # beside it, not beyond its ends
                            windows.append(polyline.distance(point))
                if min(a.confidence, b.confidence) >= SURE:  # fits through enough windows to compare
                    x = np.linspace(max(a.points[:, 0].min(), b.points[:, 0].min()),  # where both saw it, up
                                    min(a.points[:, 0].max(), b.points[:, 0].max(), STEER_M), 10)  # to STEER_M
                    gap = (np.abs(a.y(x) - b.y(x)) / np.sqrt(1 + a.slope(x) ** 2)).max()  # square to the line
                    assert gap <= AGREE_M, f"{name} at {pose}: {side} lines {gap * 100:.1f} cm apart"
                    compared += 1
    finally:
        tiny.close()
        egl.close()
    assert compared >= 6  # most of the 8 poses show a line both see well
    assert np.percentile(windows, 95) <= AGREE_M  # and nearly every window of every line agrees


def test_egl_draws_the_track_and_says_nothing(egl_works, capfd):
    track = get("oval")
    world = World(track, 1 / 240, renderer="egl")
    try:
        pose = (*track.centerline[0], math.atan2(*(track.centerline[1] - track.centerline[0])[::-1]))
        for _ in range(3):
            rgb, depth = frame(world, pose)
    finally:
        world.close()
    road = np.median(rgb[-60:].reshape(-1, 3), axis=0)  # the road just ahead, not the sky's grey-blue
    assert abs(road[2] - road[0]) < 12 and road.mean() < 100, road
    assert depth[-1].max() < 1.0  # the floor just ahead, not the far plane
    assert capfd.readouterr().out == ""


def test_a_renderer_is_chosen_by_name_block_or_environment(monkeypatch):
    monkeypatch.delenv(renderers.ENV, raising=False)
    assert renderers.wanted() == "tiny" and renderers.wanted("egl") == "egl"
    monkeypatch.setenv(renderers.ENV, "egl")
    assert renderers.wanted() == "egl"
    with renderers.chosen("tiny"):
        assert renderers.wanted() == "tiny" and renderers.wanted("egl") == "egl"
    monkeypatch.setenv(renderers.ENV, "vulkan")
    with pytest.raises(ValueError, match="ROAR_RENDERER='vulkan': choose one of egl, tiny"):
        renderers.wanted()


def test_the_renderer_option_is_the_lane_drivers():
    from roar.cli.sdk import UserError
    from roar_sim.runs import race

    with pytest.raises(UserError, match="--renderer draws the lane driver's camera: it needs --driver lane"):
        race.main(["--renderer", "egl"])
