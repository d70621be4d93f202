"""Worlds no one tuned for: random tracks and tunnel courses from a seed, the F1TENTH/TUM/ROS file
formats in and out (centre-line CSV, race-line CSV, map YAML + image), tight hairpins driven
instead of refused, and names that work wherever a track is taken."""

import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("shapely", reason="pip install 'roar-platform[tracks]' (make setup installs it)")

from conftest import ROOT  # noqa: E402
from roar.tracks import Track, TrackError, get  # noqa: E402
from roar.tracks.names import split_names  # noqa: E402
from roar.tracks.occupancy_map import load_map, save_map, track_map  # noqa: E402
from roar.tracks.random_track import rounded_polygon  # noqa: E402
from roar.tracks.track_files import (centreline_csv, load_centreline_csv, load_raceline_csv,  # noqa: E402
                                     raceline_csv)
from roar.autopilot.speed_profile import curvature  # noqa: E402


def roar(*argv, cwd=None):
    return subprocess.run([sys.executable, "-m", "roar.cli", *argv], capture_output=True, text=True, timeout=300,
                          cwd=cwd)


def hairpin(width=2.2, radius=0.8) -> Track:
    """A keyhole: two long legs and a hairpin of `radius` at their end (tighter than half the width)."""
    return Track("hairpin", rounded_polygon([(0, -4), (20, 0), (0, 4)], [2.0, radius, 2.0]), width)


# --- random tracks ------------------------------------------------------------------------------------

def test_a_seed_names_one_track_the_same_everywhere():
    a, b = get("random:7"), get("random:7")
    assert a.fingerprint == b.fingerprint and a.name == "random:7"
    # the same on every machine: these figures were taken when the generator was written
    assert (round(a.length_m, 3), len(a.centerline)) == (37.2, 333)
    assert np.allclose(a.centerline[[0, 100]], [[-4.015136, 2.820242], [-4.311706, -6.937805]], atol=1e-6)
    assert get("random:8").fingerprint != a.fingerprint


@pytest.mark.parametrize("seed", range(1, 31))
def test_random_tracks_keep_their_parameters_and_never_meet_themselves(seed):
    track = get(f"random:{seed}")
    assert 20 <= track.length_m <= 60 and track.width_m == 1.2
    assert 1 / curvature(track.centerline).max() >= 1.5 * 0.98
    assert len(track.walls) == 2 and track.uniform_width  # one infield, no part narrowed by another


def test_random_track_parameters_shape_the_track():
    wide = get("random:3,width=2.2,radius=1,length=60-100")
    assert wide.width_m == 2.2 and 60 <= wide.length_m <= 100 and 1 / curvature(wide.centerline).max() >= 0.98

    def straight_share(track):
        return float(np.mean(curvature(track.centerline) < 1e-3))

    loose = [straight_share(get(f"random:{s},straightness=0")) for s in range(1, 9)]
    tight = [straight_share(get(f"random:{s},straightness=1")) for s in range(1, 9)]
    assert np.mean(tight) > np.mean(loose) + 0.2


@pytest.mark.parametrize("name, fragment", [
    ("random:", "seed must be a whole number"), ("random:x", "seed must be a whole number"),
    ("random:1,width=9", "width must be"), ("random:1,radius=0.1", "radius must be"),
    ("random:1,length=50-20", "length must be"), ("random:1,length=nan-40", "length must be"),
    ("random:1,straightness=2", "straightness must be"), ("random:1,colour=red", "unknown parameter"),
    ("random:1,width=wide", "width needs a number"), ("random:1,length=11-11,radius=20", "no track with these"),
    ("tunnel:1,width=9", "width must be"), ("tunnel:1,cones=999", "cones must be"),
    ("tunnel:q", "seed must be"), ("tunnel:1,doors=2", "unknown parameter"),
    ("nowhere", "unknown track"), ("", "empty"),
])
def test_bad_world_names_fail_in_one_line(name, fragment):
    with pytest.raises(TrackError) as e:
        get(name)
    assert fragment in str(e.value) and "\n" not in str(e.value)


def test_track_lists_keep_parameters_with_their_name():
    assert split_names("oval,random:3,width=2.2,radius=1,tunnel:2,oval") == \
        ["oval", "random:3,width=2.2,radius=1", "tunnel:2"]


# --- tight bends, close parts -------------------------------------------------------------------------

def test_a_hairpin_tighter_than_half_the_width_gets_its_inner_wall():
    track = hairpin()
    assert 1 / curvature(track.centerline).max() == pytest.approx(0.8, abs=0.02)
    outer, inner = track.walls
    assert len(track.walls) == 2
    import shapely

    area = track.region
    # every centre-line point is in the driving area, at least 0.75 m from every wall
    for point in track.centerline[::5]:
        assert area.contains(shapely.Point(*point))
        assert min(shapely.LinearRing(w).distance(shapely.Point(*point)) for w in track.walls) > 0.75
    # the infield's tip lies beyond the hairpin's centre, where the folded inner edges meet
    assert inner[:, 0].max() < 20 - 0.8 and inner[:, 0].max() > 10


def test_parts_closer_than_their_widths_are_parted_by_a_wall_midway():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    waist = np.stack([5 * np.cos(t), 2 * np.sin(t) * (0.25 + 0.75 * np.cos(t) ** 2)], 1)  # 1.0 m apart at x = 0
    track = Track("waist", waist, 1.2)
    assert not track.uniform_width and track.half_widths.min() == pytest.approx((1.0 - 0.06) / 2, abs=0.01)
    import shapely

    # the infield runs on through the waist as a wall between the two parts: no short cut across
    assert len(track.walls) == 2 and not track.region.contains(shapely.Point(0, 0))
    assert shapely.Polygon(track.walls[1]).contains(shapely.Point(0, 0))


# --- files: centre line, race line, map -------------------------------------------------------------

def test_a_centre_line_csv_with_widths_per_point_round_trips(tmp_path):
    track = hairpin()
    halves = track.half_widths.copy()
    halves[:, 1] *= 0.8  # the right wall nearer than the left
    asymmetric = Track("asym", track.centerline, track.width_m, halves)
    path = tmp_path / "asym_centerline.csv"
    path.write_text(centreline_csv(asymmetric))
    back = get(str(path))
    assert back.name == "asym" and np.allclose(back.centerline, asymmetric.centerline, atol=1e-4)
    assert np.allclose(back.half_widths, asymmetric.half_widths, atol=1e-4)
    assert back.region.area == pytest.approx(asymmetric.region.area, rel=1e-3)


def test_repeated_points_are_dropped_from_a_csv_and_refused_in_json_as_the_doc_says(tmp_path):
    """docs/worlds.md: a CSV's point within 1 cm of the one before, and a last point repeating the
    first (as TUM's closed files end), are dropped; JSON refuses both, in one line."""
    import json


    circle = [(3 * np.cos(t), 3 * np.sin(t)) for t in np.linspace(0, 2 * np.pi, 40, endpoint=False)]
    rows = [*circle[:5], (circle[4][0] + 0.004, circle[4][1]), *circle[5:], circle[0]]
    path = tmp_path / "circle_centerline.csv"
    path.write_text("".join(f"{x:.4f}, {y:.4f}, 0.6, 0.6\n" for x, y in rows))
    assert len(load_centreline_csv(path).centerline) == 40
    doc = (ROOT / "docs" / "worlds.md").read_text()
    assert "are dropped" in doc and "JSON refuses both" in doc
    for name, line in (("repeat", [*circle, circle[0]]), ("close", rows[:-1])):
        bad = tmp_path / f"{name}.json"
        bad.write_text(json.dumps({"name": name, "width_m": 1.2, "centerline": [list(p) for p in line]}))
        with pytest.raises(TrackError, match=str(bad)):
            get(str(bad))


def test_a_hairpin_at_f1tenth_width_from_a_csv_is_raced_without_touching_a_wall(tmp_path):
    from roar_sim.runs.race import race

    path = tmp_path / "keyhole_centerline.csv"
    path.write_text(centreline_csv(hairpin()))
    result = race(get(str(path)), laps=1)
    assert len(result.lap_times_s) == 1 and result.wall_contacts == 0


def test_a_race_line_csv_is_read_and_written_in_tums_format(tmp_path):
    t = np.linspace(0, 2 * np.pi, 100, endpoint=False)
    points = np.stack([3 * np.cos(t), 2 * np.sin(t)], 1)
    path = tmp_path / "raceline.csv"
    path.write_text("# a comment\n" + raceline_csv(points, np.full(100, 2.5)))
    assert path.read_text().splitlines()[1] == "# s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2"
    first = [float(v) for v in path.read_text().splitlines()[2].split(";")]
    assert first[3] == pytest.approx(0.0, abs=0.05)  # heading north at (3, 0): psi is 0 there
    assert first[4] == pytest.approx(3 / 4, rel=0.05)  # an ellipse's curvature at the end of its long axis
    line = load_raceline_csv(path)
    assert np.allclose(line.points, points, atol=1e-4) and np.allclose(line.speeds, 2.5)


def test_a_track_written_as_a_map_is_a_world_again(tmp_path):
    track = get("random:5")
    save_map(tmp_path / "r5_map.yaml", track_map(track))
    image = (tmp_path / "r5_map.png")
    from PIL import Image

    with Image.open(image) as im:
        assert im.mode == "L" and "resolution: 0.05" in (tmp_path / "r5_map.yaml").read_text()
    grid = load_map(tmp_path / "r5_map.yaml")
    assert grid.free.sum() * 0.05 ** 2 == pytest.approx(track.region.area, rel=0.03)
    # no centre line beside it: found midway between the walls, anticlockwise
    found = get(str(tmp_path / "r5_map.yaml"))
    assert found.length_m == pytest.approx(track.length_m, rel=0.02)
    distance = np.min(np.linalg.norm(found.centerline[:, None] - track.centerline[None], axis=2), axis=1)
    assert distance.max() < 0.1
    # with one beside it (the F1TENTH collection's layout), that one, and the map's walls
    (tmp_path / "r5_centerline.csv").write_text(centreline_csv(track))
    given = get(str(tmp_path / "r5_map.yaml"))
    assert np.allclose(given.centerline, track.centerline, atol=1e-4) and given.start_pose == pytest.approx(
        track.start_pose, abs=1e-3)
    assert given.region.area == pytest.approx(grid.free.sum() * 0.05 ** 2, rel=0.02)


def test_map_pixels_follow_the_yaml_thresholds_and_negate(tmp_path):
    from PIL import Image

    pixels = np.full((20, 30), 205, np.uint8)
    pixels[5:15, 5:25] = 250
    pixels[0, 0] = 0
    Image.fromarray(pixels).save(tmp_path / "m.pgm")
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [-1.0, -2.0, 0.0]\n")
    grid = load_map(tmp_path / "m.yaml")
    assert grid.free.sum() == 200 and grid.occupied.sum() == 1 and grid.occupied[0, 0]
    assert np.allclose(grid.to_world([0], [19])[0], [-0.95, -1.95])  # the bottom-left cell's centre
    (tmp_path / "n.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 1\n")
    negated = load_map(tmp_path / "n.yaml")  # white is occupied: grey too (205/255 > 0.65)
    assert negated.occupied.sum() == 599 and negated.free.sum() == 1 and negated.free[0, 0]


NOT_AN_IMAGE = b"this is not a picture"


@pytest.mark.parametrize("name, text, fragment", [
    ("c.csv", "# x_m, y_m, w_tr_right_m, w_tr_left_m\n0, 0, 1.1\n", "expected 4 finite numbers"),
    ("c.csv", "0, 0, 1.1, 1.1\n1, nan, 1.1, 1.1\n", "expected 4 finite numbers"),
    ("c.csv", "0, 0, 1.1, 1.1\n1, 0, 0, 1.1\n", "widths to the walls must be positive"),
    ("c.csv", "0, 0, 1.1, -1\n", "widths to the walls must be positive"),
    ("c.csv", "# nothing\n", "no points"),
    ("c.csv", "0, 0, 1e9, 1\n", "beyond"),
    ("r.csv", "0; 0; 0; 0; 0; 1\n", "expected 7 finite numbers"),
    ("r.csv", "0; 0; 0; 0; 0; inf; 0\n", "expected 7 finite numbers"),
    ("m.yaml", "image: m.png\norigin: [0, 0, 0]\n", "needs resolution"),
    ("m.yaml", "image: x.png\nresolution: 0.05\norigin: [0, 0, 0]\n", "does not exist"),
    ("m.yaml", "image: bad.png\nresolution: 0.05\norigin: [0, 0, 0]\n", "not an image"),
    ("m.yaml", "image: m.png\nresolution: 0\norigin: [0, 0, 0]\n", "resolution must be"),
    ("m.yaml", "image: m.png\nresolution: .nan\norigin: [0, 0, 0]\n", "resolution must be"),
    ("m.yaml", "image: m.png\nresolution: 0.05\norigin: [50000, 0, 0]\n", "from the world's origin"),
    ("m.yaml", "image: m.png\nresolution: 0.05\norigin: [0, 0]\n", "origin must be"),
    ("m.yaml", "image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.9\n", "must be below"),
    ("m.yaml", "image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 2\n", "negate must be 0 or 1"),
    ("m.yaml", "image: [m.png\n", "not valid YAML"),
    ("m.yaml", "- just\n- a list\n", "a mapping"),
    ("m.yaml", "image: m.png\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.1\nfree_thresh: 0.05\n"
     "negate: 1\n", "no free cells"),
])
def test_bad_input_in_every_new_format_fails_in_one_line_naming_the_file(tmp_path, name, text, fragment):
    from PIL import Image

    Image.fromarray(np.full((40, 40), 254, np.uint8)).save(tmp_path / "m.png")
    (tmp_path / "bad.png").write_bytes(NOT_AN_IMAGE)
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(TrackError) as e:
        load_raceline_csv(path) if name == "r.csv" else load_centreline_csv(path) if name == "c.csv" else \
            load_map(path)
    assert fragment in str(e.value) and str(path) in str(e.value) and "\n" not in str(e.value)


def test_the_race_command_says_what_is_wrong_with_a_track_file_in_one_line(tmp_path):
    (tmp_path / "t.csv").write_text("0, 0, 1.1\n")
    out = roar("race", "--track", str(tmp_path / "t.csv"))
    assert out.returncode == 1 and out.stderr.count("\n") == 1 and "expected 4 finite numbers" in out.stderr


# --- tunnels ------------------------------------------------------------------------------------------

def test_a_tunnel_course_keeps_cones_passable_people_by_the_walls_and_the_map_walls_only(tmp_path):
    import shapely

    track = get("tunnel:3")
    course = track.course
    assert get("tunnel:3").course == course  # deterministic
    assert len(course.cones) >= 4 and len(course.markers) >= 3 and len(course.people) >= 3
    area = track.region
    for x, y in course.cones:
        assert area.contains(shapely.Point(x, y))
        widest_gap = max(w for w in (track.width_m / 2 - abs(track.project((x, y))[2]) + track.width_m / 2,))
        assert widest_gap - 0.1 >= 0.6 + track.width_m / 2  # a passage of 0.6 m beside it, at least
    for x, y in course.people:
        assert min(shapely.LinearRing(w).distance(shapely.Point(x, y)) for w in track.walls) < 0.35
    grid = track_map(track)
    cells = np.round(grid.to_cells(np.array([*course.cones, *course.people]))).astype(int)
    assert grid.free[cells[:, 1], cells[:, 0]].all()  # not in the map: where they stand is free floor
    assert math.dist(course.start[:2], course.goal[:2]) > 3


def test_roar_world_plots_a_tunnel_and_writes_its_map_route_and_course(tmp_path):
    (tmp_path / "maps").mkdir()  # a folder that is not there is not made: a typo makes none
    out = roar("world", "tunnel:2", "--plot", "t.png", "--save", "maps/t2_map.yaml", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "cones" in out.stdout and (tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"
    written = sorted(p.name for p in (tmp_path / "maps").iterdir())
    assert written == ["t2_centerline.csv", "t2_course.yaml", "t2_map.png", "t2_map.yaml"]
    again = get(str(tmp_path / "maps/t2_map.yaml"))
    assert again.course == get("tunnel:2").course and again.length_m == pytest.approx(get("tunnel:2").length_m, rel=1e-3)


def test_roar_track_plots_saves_and_computes_the_racing_line(tmp_path):
    out = roar("track", "random:4", "--plot", "r.png", "--save", "r4.json", "--line", "--save-line", "r4_line.csv",
               cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "racing line for the ESC car: limit lap" in out.stdout
    assert np.allclose(get(str(tmp_path / "r4.json")).centerline, get("random:4").centerline, atol=1e-4)
    assert len(load_raceline_csv(tmp_path / "r4_line.csv").points) > 100
    bad = roar("track", "tunnel:1", "--save", "t.csv", cwd=tmp_path)
    assert bad.returncode == 1 and "save it as a map .yaml" in bad.stderr and bad.stderr.count("\n") == 1


def test_a_tunnel_world_stands_its_cones_and_people_in_the_simulator():
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar_sim.robots.esc import EscCar
    from roar_sim.world import floor

    track = get("tunnel:3")
    with EscCar(track) as car:
        world = car.plant.world
        assert len(world.cones) == len(track.course.cones) and len(world.people) == len(track.course.people)
        scan = car.plant.lidar()
        assert np.isfinite(scan).any()
    x, y, _ = track.course.markers[0]
    assert floor.colour_at(track, (x, y)) == floor.MARKER_RGB
    assert [p.rgb for p in floor.paints(track)] == [floor.MARKER_RGB]  # no lane paint in a tunnel


# --- the autopilot on tracks no one tuned for ---------------------------------------------------------

@pytest.mark.parametrize("seed", range(1, 11))
def test_the_pose_based_autopilot_laps_random_tracks_without_touching_a_wall(seed):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar_sim.runs.race import race

    result = race(get(f"random:{seed}"), laps=2)
    assert len(result.lap_times_s) == 2 and result.wall_contacts == 0
    assert result.racing_limit_lap_s < result.limit_lap_s  # the racing line is the faster limit


def test_the_racing_line_keeps_its_clearance_and_beats_the_centre_line():
    from roar.autopilot.racing_line import racing_line
    from roar_sim.robots.esc import LIMITS

    track = get("random:2,width=2.2,radius=1")
    line = racing_line(track, 0.4)
    import shapely

    walls = [shapely.LinearRing(w) for w in track.walls]
    assert min(min(w.distance(shapely.Point(*p)) for w in walls) for p in line.points[::4]) > 0.4 - 0.02
    assert line.lap_time_s(LIMITS) < 0.97 * track.length_m and line.max_curvature < curvature(track.centerline).max()
    narrow = racing_line(get("oval"), 0.6)  # no room to move: the centre line itself
    assert np.abs(narrow.offsets_m).max() < 0.02


def test_roar_race_follows_the_optimal_line_or_a_race_line_file(tmp_path):
    out = roar("race", "--track", "random:6", "--line", "optimal", "--laps", "1")
    assert out.returncode == 0, out.stderr
    assert "on the racing line" in out.stdout and "x the racing line's" in out.stdout and "wall contacts: 0" in out.stdout
    roar("track", "random:6", "--line", "--save-line", str(tmp_path / "line.csv"))
    again = roar("race", "--track", "random:6", "--line", str(tmp_path / "line.csv"), "--laps", "1")
    assert again.returncode == 0 and "lap 1:" in again.stdout
    off = roar("race", "--track", "oval", "--line", str(tmp_path / "line.csv"))
    assert off.returncode == 1 and "outside the track" in off.stderr and off.stderr.count("\n") == 1


def test_random_and_tunnel_names_work_in_the_gym_and_the_sim_url():
    pytest.importorskip("gymnasium", reason="pip install gymnasium (make setup installs it)")
    import gymnasium

    env = gymnasium.make("roar_sim.gym_env:roar/Race-v0", track="random:9")
    try:
        observation, _ = env.reset(seed=1)
        observation, *_ = env.step(np.array([0.5, 0.0], np.float32))
        assert env.unwrapped.track.name == "random:9"
    finally:
        env.close()
    from roar import Vehicle

    with Vehicle("sim://?track=tunnel:2") as car:
        car.wait_armed(timeout_s=5)
        assert car.state() is not None


def test_tunnels_of_one_seed_with_other_counts_paint_their_own_markers():
    """The floor's paint is made once per shape and markings in a process: a tunnel with more
    people draws its markers elsewhere, and must not lend its floor to the plain one."""
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar_sim.world import floor

    crowded, plain = get("tunnel:3,people=8"), get("tunnel:3")
    assert crowded.course.markers != plain.course.markers
    floor.paints(crowded)
    x, y, _ = plain.course.markers[0]
    assert floor.colour_at(plain, (x, y)) == floor.MARKER_RGB


@pytest.mark.parametrize("seed", [1, 4])
def test_a_saved_track_reads_back_with_the_bends_it_was_written_with(tmp_path, seed):
    """Written at a micrometre, read back: the same length and the same tightest bend (at 0.1 mm,
    a 2.04 m bend read back as 2.01 m)."""
    from roar.tracks.track_files import to_json

    track = get(f"random:{seed}")
    (tmp_path / "t.json").write_text(to_json(track))
    (tmp_path / "t_centerline.csv").write_text(centreline_csv(track))
    tightest = 1 / curvature(track.centerline).max()
    for path in (tmp_path / "t.json", tmp_path / "t_centerline.csv"):
        again = get(str(path))
        assert again.length_m == pytest.approx(track.length_m, rel=1e-6)
        assert 1 / curvature(again.centerline).max() == pytest.approx(tightest, rel=1e-4), path.name
