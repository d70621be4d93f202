"""The MIT challenge's stack in the simulator: cones and markers found by colour under changing
light and camera noise, placed with the pose at the frame's capture time when frames arrive late,
and a short scored run of the whole stack (particle filter, local grid, camera, high-level
planner, arc RRT, follower, firmware) through `roar challenge`."""

import math
import subprocess
import sys

import pytest

from conftest import ROOT
from roar.autopilot import Command
from roar.localization.pose_history import PoseHistory
from roar.tracks import get
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar.vision.objects import ObjectDetector
from roar_sim import robots
from roar_sim.plants.racecar import Racecar
from roar_sim.runs.challenge import challenge
from roar_sim.sensors.camera_noise import ShakyCamera
from roar_sim.world.scene import Light

SIZE = (320, 240)
LIGHTS = {"default": None, "dim": Light.dim(0.35), "dark": Light.dim(0.2), "bright": Light.dim(1.5),
          "warm lamp": Light.tinted((1.0, 0.75, 0.45)), "cold": Light.tinted((0.6, 0.75, 1.0)),
          "low side light": Light(direction=(1.0, 0.0, 0.3))}


@pytest.fixture(scope="module")
def cone_and_marker():
    """A car 2 m before tunnel:3's first marker, and 2 m before its second cone."""
    track = get("tunnel:3")
    views = []
    for thing in (track.course.markers[0], track.course.cones[1]):
        _, s, _ = track.project(thing[:2])
        plant = Racecar(track, pose=track.pose_at(s - 2.0))
        for _ in range(40):
            plant.step()
        views.append((plant, thing))
    yield views
    for plant, _ in views:
        plant.close()


@pytest.mark.parametrize("light", list(LIGHTS))
def test_cones_and_markers_are_found_in_any_light(cone_and_marker, light):
    detector = ObjectDetector(SIMULATED_CAR_CAMERA.model(*SIZE))
    for (plant, thing), kind in zip(cone_and_marker, ("marker", "cone")):
        plant.world.light = LIGHTS[light]
        s = plant.state()
        for seed in range(3):  # the camera's shake and noise
            rgb, depth = ShakyCamera(plant, *SIZE, seed)()
            found = detector.detect(rgb, depth, (s.x, s.y, s.yaw), 0.0)
            assert [d.kind for d in found] == [kind], (light, found)
            assert math.hypot(found[0].x - thing[0], found[0].y - thing[1]) < 0.15, (light, found)
        plant.world.light = None


def test_late_frames_are_placed_with_the_pose_at_their_capture():
    """Driving at ~1.5 m/s towards a cone, a frame arrives 0.4 s after its capture: placed with the
    pose then, the cone lands where it stands; placed with the pose on arrival, 0.6 m off."""
    track = get("tunnel:3")
    cone, s = next((c, s) for c in track.course.cones for s in [track.project(c)[1]]
                   if abs(math.remainder(track.pose_at(s)[2] - track.pose_at(s - 5.0)[2], math.tau)) < 0.01)
    detector = ObjectDetector(SIMULATED_CAR_CAMERA.model(*SIZE))
    history = PoseHistory()
    with robots.get("esc")(track, pose=track.pose_at(s - 5.0)) as bot:
        bot.arm()
        frame = None
        while True:
            obs = bot.observe()
            history.add(obs.t_s, (obs.x, obs.y, obs.yaw))
            if frame is None and obs.speed > 1.4:
                frame = (obs.t_s, *bot.plant.camera(*SIZE))
            if frame is not None and obs.t_s >= frame[0] + 0.4:
                break
            bot.send(Command(0.5, 0.0))
            bot.wait(0.02)
        taken, rgb, depth = frame
        then = detector.detect(rgb, depth, history.at(taken), taken)
        now = detector.detect(rgb, depth, (obs.x, obs.y, obs.yaw), taken)
    assert len(then) == 1 and then[0].kind == "cone"
    assert math.hypot(then[0].x - cone[0], then[0].y - cone[1]) < 0.15
    assert math.hypot(now[0].x - cone[0], now[0].y - cone[1]) > 0.45


def test_the_planners_minimum_turning_radius_is_the_cars():
    """At walking pace and full lock the simulated ESC car's rear axle turns on a circle of the
    radius the planners are given (wheelbase / tan(full-lock angle))."""
    import numpy as np

    from roar.planning.rrt import R_MIN_M

    with robots.get("esc")(None) as bot:
        bot.arm()
        points = []
        for k in range(400):
            obs = bot.observe()
            if k > 150:  # steered and rolling steadily
                points.append((obs.x, obs.y))
            bot.send(Command(0.12, -1.0))
            bot.wait(0.02)
    p = np.array(points)
    a = np.c_[2 * p, np.ones(len(p))]
    cx, cy, c = np.linalg.lstsq(a, (p ** 2).sum(axis=1), rcond=None)[0]
    assert math.sqrt(c + cx ** 2 + cy ** 2) == pytest.approx(R_MIN_M, rel=0.05)


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """(result, its MCAP or None) of one run for two tests (xdist_group "short_challenge"): tunnel:3
    to 14 m along its route, recorded where the record extra is installed."""
    try:
        import foxglove  # noqa: F401
        path = tmp_path_factory.mktemp("challenge") / "challenge.mcap"
    except ImportError:
        path = None
    return challenge(get("tunnel:3"), goal_m=14.0, seed=2, log=path), path


@pytest.mark.xdist_group("short_challenge")
def test_a_short_challenge_run_touches_no_cone_and_counts_each_object_once(short_run):
    """tunnel:3 to 14 m along its route: a cone to pass, two markers within the bonus rule's reach."""
    result, _ = short_run
    assert result.finished and result.time_s < 14.0 / 0.7, result.report()
    assert not result.cones_touched and result.wall_contacts == 0, result.report()
    (cone_p, cone_r), (marker_p, marker_r) = result.precision_recall().values()
    assert result.seen_within["cone"] and result.seen_within["marker"]
    assert min(cone_p, cone_r, marker_p, marker_r) == 1.0, result.report()
    assert result.markers_taken, result.report()
    assert result.localization.rms_position_m() < 0.1
    assert result.plans >= 10 and len(result.paths) >= 10
    assert result.score == pytest.approx(result.time_s + 5.0 * len(result.cones_touched)
                                         - 2.0 * len(result.markers_taken))


def test_two_teams_run_the_course_concurrently_each_seeing_the_other_as_an_obstacle():
    """The challenge's concurrent round on tunnel:3 to 12 m: the second car starts 2 s after the
    first, from the same start, on its own stack (to it the first car is an unmapped obstacle that
    moves, and its red parts no cone); both finish touching no cone, no wall and not each other, and a
    marker both drove over counts for both. (`make bench` runs the whole course on tunnel:1..10.)"""
    from roar_sim.runs.challenge import challenge_teams

    result = challenge_teams(get("tunnel:3"), 2, goal_m=12.0, seed=2)
    report = result.report(2)
    assert len(result.teams) == 2 and all(team.finished for team in result.teams), report
    assert result.starts_s[1] - result.starts_s[0] >= 2.0 and not result.contacts, report
    first, second = result.teams
    for team in (first, second):
        assert not team.cones_touched and team.wall_contacts == 0, report
    assert first.markers_taken & second.markers_taken, report  # shared: each car scores the ones it took
    assert second.localization.rms_position_m() < 0.1, report  # its own filter, the first car in its scans
    assert second.precision_recall()["cone"] == (1.0, 1.0), report  # the first car's red rims are no cone
    assert math.dist(second.true_path[0], first.true_path[0]) < 0.1  # the same start; its time from its own


@pytest.mark.xdist_group("short_challenge")
def test_a_challenge_run_records_its_detections_plans_trees_and_grid(short_run):
    """The run's record (roar_sim.links.sim_log): the plans, their trees, the local grid, the camera
    at its rate, a filter step per firmware step, and the cones found, also as Foxglove's scene.
    (In lockstep, as every challenge run: it keeps to no clock.)"""
    pytest.importorskip("foxglove", reason="pip install foxglove-sdk (the project's record extra)")
    from roar.replay import messages, read_log

    result, path = short_run
    assert result.finished
    c = read_log(path).channels
    assert c["/planning/path"].count == len(result.paths) and c["/planning/tree"].count >= 5
    assert c["/localization/local_grid"].count >= 5 and c["/camera/image"].rate_hz == pytest.approx(10, abs=0.5)
    assert c["/localization/steps"].count == c["/sim/firmware"].count
    grid = next(m for _, _, m in messages(path, ["/localization/local_grid"]))
    assert grid.column_count * grid.row_stride == len(grid.data) and set(grid.data) <= {0, 50, 100}
    cones = [m for _, _, m in messages(path, ["/perception/cones"])]
    found = [(p.position.x, p.position.y) for p in cones[-1].poses]
    assert found and all(min(math.dist(f, o[:2]) for o in result.course.cones) < 0.4 for f in found)
    scene = [m for _, _, m in messages(path, ["/perception/scene"])][-1]  # the same, for Foxglove's 3D panel
    assert [(round(c.pose.position.x, 6), round(c.pose.position.y, 6)) for c in scene.entities[0].cylinders] == \
        [(round(x, 6), round(y, 6)) for x, y in found]


def test_the_plan_example_finds_a_drivable_path():

    example = ROOT / "examples" / "plan.py"
    result = subprocess.run([sys.executable, str(example)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    length = float(result.stdout.split(" m in ")[0])
    assert 10.0 < length < 16.0, result.stdout  # 12 m along the corridors' centre: less inside a bend, more round a cone


def roar(*args, timeout=240):
    return subprocess.run([sys.executable, "-m", "roar.cli", "challenge", *args], capture_output=True, text=True,
                          timeout=timeout)


def test_roar_challenge_prints_the_score_and_plots_the_run(tmp_path):
    plot = tmp_path / "run.png"
    result = roar("tunnel:3", "--to", "8", "--oracle", "--plot", str(plot), "--cone-penalty", "7")
    assert result.returncode == 0, result.stderr[-2000:]
    first = result.stdout.splitlines()[0]
    assert first.startswith("challenge tunnel:3 (pose oracle): finished in ") and "(+7 s each)" in first, first
    assert "score" in first and plot.stat().st_size > 20_000
    assert result.stdout.splitlines().count(f"plot: {plot}") == 1  # said once


@pytest.mark.parametrize("args, says", [
    (["oval"], "not a tunnel world"),
    (["tunnel:x"], "the seed must be a whole number"),
    (["tunnel:3", "--fps", "0"], "--fps: must be a finite number"),
    (["tunnel:3", "--to", "900"], "--to must be 2.."),
    (["tunnel:3", "--seed", "-1"], "must be a whole number 0..10^18"),
    (["tunnel:3", "--plot", "out.txt"], ".png"),
    (["tunnel:3", "--teams", "5"], "--teams: must be a whole number 1..4"),
])
def test_bad_input_ends_in_one_line(args, says):
    result = roar(*args, timeout=60)
    assert result.returncode != 0 and says in result.stderr, result.stderr
    assert "Traceback" not in result.stderr and len(result.stderr.strip().splitlines()) <= 2
