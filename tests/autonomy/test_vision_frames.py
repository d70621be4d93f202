"""`roar vision FOLDER`: the perception over recorded frames writes a debug view per frame (and a
video), reads the same lanes as live, finds a box in a recorded depth image, and refuses bad
folders and frames in one line."""

import math
import warnings

import numpy as np
import pytest

pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")
pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.cli.main import main  # noqa: E402
from roar.vision.geometry import BirdsEye, cv2  # noqa: E402
from roar.vision.lanes import LaneDetector  # noqa: E402
from roar_sim.world.obstacles import add_box  # noqa: E402
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar_sim.plants.racecar import Racecar  # noqa: E402
from roar_sim.runs.lane_course import LANE_CAMERA  # noqa: E402
from roar.tracks import get  # noqa: E402

W, H = LANE_CAMERA


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Three frames of the car on the oval's straight with a box 1.6 m ahead, as PNG + depth NPY,
    and the lanes a live detector saw in them."""
    folder = tmp_path_factory.mktemp("frames")
    plant = Racecar(get("oval"))
    x, y, _ = plant.world.start_pose()
    add_box(plant.world, x + 1.7, y)  # its near face 1.6 m ahead of the car's reference point
    live = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(W, H)))
    seen = []
    for i in range(3):
        for _ in range(10):
            plant.step()
        rgb, depth = plant.camera(W, H)
        cv2().imwrite(str(folder / f"f{i:03d}.png"), rgb[:, :, ::-1])
        np.save(folder / f"f{i:03d}_depth.npy", depth)
        seen.append(live.detect(rgb))
    plant.close()
    return folder, seen


def test_every_frame_gets_its_views_a_line_and_the_video(recorded, tmp_path, capsys):
    folder, seen = recorded
    assert main(["vision", str(folder), "--out", str(tmp_path), "--video", str(tmp_path / "lanes.mp4")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 4 and lines[-1].startswith("3 frames")
    for i, (line, lanes) in enumerate(zip(lines, seen)):
        assert (tmp_path / f"f{i:03d}_lanes.png").stat().st_size > 20_000
        assert (tmp_path / f"f{i:03d}_occupancy.png").stat().st_size > 10_000
        assert f"offset {lanes.offset_m:+.3f} m" in line  # the same lanes as live
        assert f"heading {math.degrees(lanes.heading_rad):+.1f} deg" in line
        distance = float(line.split("obstacle ahead ")[1].split(" m")[0])
        assert distance == pytest.approx(1.65, abs=0.1)  # the box's near face, within one cell
    video = cv2().VideoCapture(str(tmp_path / "lanes.mp4"))
    assert int(video.get(cv2().CAP_PROP_FRAME_COUNT)) == 3


def test_bad_folders_and_frames_fail_in_one_line(tmp_path, capsys):
    assert main(["vision", str(tmp_path / "nowhere")]) == 1
    assert main(["vision", str(tmp_path)]) == 1  # empty
    (tmp_path / "a.png").write_bytes(b"not a png")
    assert main(["vision", str(tmp_path), "--out", str(tmp_path / "out")]) == 1
    (tmp_path / "a.png").unlink()
    np.save(tmp_path / "b.npy", np.zeros((4, 4), np.float32))
    assert main(["vision", str(tmp_path), "--out", str(tmp_path / "out")]) == 1
    assert main(["vision", str(tmp_path), "--fov", "0"]) == 1
    errors = capsys.readouterr().err.splitlines()
    assert len(errors) == 5 and all(e.startswith("roar vision: error: ") for e in errors), errors
    assert "does not exist" in errors[0] and "no frames" in errors[1] and "not an image" in errors[2]
    assert "H x W x 3" in errors[3] and "--fov" in errors[4]


@pytest.mark.parametrize("rgb, depth, words", [
    ((2, 2), None, "a.npy is 2x2: a frame is at least 16x16 px"),
    ((240, 320), np.full((2, 2), np.nan, np.float32), "a_depth.npy is 2x2, its frame 320x240"),
    ((240, 320), np.zeros((240, 320, 3), np.float32), "a_depth.npy: want an H x W array of depths"),
    ((240, 320), np.array(["far"] * 4).reshape(2, 2), "a_depth.npy: want an H x W array of depths"),
])
def test_frames_too_small_and_depth_that_does_not_fit_its_frame_are_refused(tmp_path, capsys, rgb, depth, words):
    np.save(tmp_path / "a.npy", np.full((*rgb, 3), 90, np.uint8))
    if depth is not None:
        np.save(tmp_path / "a_depth.npy", depth)
    assert main(["vision", str(tmp_path), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("roar vision: error: ") and words in err and "\n" not in err, err


def test_depth_that_is_not_a_number_is_counted_and_a_frame_without_lines_is_quiet(tmp_path, capfd):
    """A frame where no line is seen draws its views without a warning; NaN depth pixels are
    counted in the frame's line (and left out of the occupancy grid)."""
    np.save(tmp_path / "a.npy", np.full((240, 320, 3), 90, np.uint8))
    depth = np.full((240, 320), 3.0, np.float32)
    depth[:10, :10] = np.nan
    depth[20, 20] = np.inf
    np.save(tmp_path / "a_depth.npy", depth)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # matplotlib's "no artists with labels" would raise here
        assert main(["vision", str(tmp_path), "--out", str(tmp_path / "out")]) == 0
    out, err = capfd.readouterr()
    assert "a.npy: lines none; obstacle ahead" in out and "(101 of 76800 depth pixels not a number)" in out
    assert err == "", err


def test_a_race_records_the_frames_its_driver_saw_for_roar_vision(tmp_path, capsys):
    from roar_sim.runs.race import PERIOD_S, race

    # 0.25 s: a dozen frames (roar vision draws two figures a frame, 0.3 s each)
    result = race(get("oval"), laps=1, lateral="lane", timeout_s=0.25, frames=tmp_path / "rec")
    frames = sorted((tmp_path / "rec").glob("*.png"))
    assert len(frames) == len(result.path) and len(frames) >= 0.25 / PERIOD_S - 2
    assert all((tmp_path / "rec" / f"{f.stem}_depth.npy").exists() for f in frames)
    assert main(["vision", str(tmp_path / "rec"), "--out", str(tmp_path / "out")]) == 0
    assert capsys.readouterr().out.count("lines yellow") >= len(frames) - 2  # the straight ahead of the start
