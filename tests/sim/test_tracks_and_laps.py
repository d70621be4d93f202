"""Tracks (built-in and from files) and the built-in controller driving laps through the firmware."""

import json

import numpy as np
import pytest

from roar.cli.sdk import run_command
from roar_sim.runs import race
from roar.tracks import Track, TrackError, get
from roar.tracks.track import BUILTIN, oval
from roar.tracks.track_files import load_json, to_json


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_builtin_tracks_are_valid_closed_loops(name):
    tr = get(name)
    assert tr.length_m > 10 and len(tr.centerline) >= 100
    left, right = tr.edges()
    assert np.allclose(np.linalg.norm(left - right, axis=1), tr.width_m)
    assert len(tr.walls) == (3 if name == "figure-eight" else 2)  # outside, and the infield(s)
    for wall in tr.walls:  # every wall half the width from the centre line
        d = np.min(np.linalg.norm(wall[:, None, :] - tr.centerline[None, :, :], axis=2), axis=1)
        assert np.all(d > tr.width_m / 2 - 0.02) and np.median(d) == pytest.approx(tr.width_m / 2, abs=0.01)


def test_file_round_trip(tmp_path):
    path = tmp_path / "t.json"
    path.write_text(to_json(oval()))
    loaded = get(str(path))
    assert loaded.name == "oval" and np.allclose(loaded.centerline, oval().centerline, atol=1e-4)


CIRCLE = [[round(float(np.cos(a)), 3), round(float(np.sin(a)), 3)] for a in np.linspace(0, 6.2, 16)]


@pytest.mark.parametrize("content, fragment", [
    ("{", "not valid JSON"),
    ('{"width_m": 1}', "needs 'width_m' and 'centerline'"),
    ('{"width_m": 1, "centerline": [[0, 0]], "colour": 1}', "unknown keys"),
    ('{"width_m": 1, "centerline": [[0, "a"]]}', "number pairs"),
    ('{"width_m": 1, "centerline": [[0, 0], [1, 0], [1, 1]]}', "at least 8 points"),
    ('{"width_m": 9, "centerline": ' + json.dumps(CIRCLE) + '}', "width_m must be"),
    ('{"width_m": 1, "centerline": ' + json.dumps([[i * 0.5, 0] for i in range(8)]) + '}', "apart"),
])
def test_bad_track_files_give_one_line_errors(tmp_path, content, fragment):
    path = tmp_path / "bad.json"
    path.write_text(content)
    with pytest.raises(TrackError) as err:
        load_json(path)
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_unknown_track_name():
    with pytest.raises(TrackError, match="unknown track 'moon'"):
        get("moon")


def test_projection_signs():
    tr = oval()  # anticlockwise; starts mid bottom straight heading +x
    x, y, _ = tr.start_pose
    _, s, cte = tr.project((x + 0.5, y + 0.2))
    assert cte == pytest.approx(0.2, abs=1e-6) and s == pytest.approx(0.5, abs=0.05)
    assert tr.project((x, y - 0.3))[2] == pytest.approx(-0.3, abs=1e-6)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_projection_near_a_hint_in_plain_floats_equals_numpys(name):
    """project() searches a small window in plain floats and a large one with numpy: the same
    segment, position and cross-track error, to the last bits."""
    tr = get(name)
    rng = np.random.default_rng(7)
    for _ in range(300):
        hint = int(rng.integers(len(tr.centerline)))
        p = tr.centerline[hint] + rng.uniform(-0.7, 0.7, 2)
        for window in (1, 6, 12):
            near = tr.project(p, hint, window)
            idx = np.arange(hint - window, hint + window + 1) % len(tr.centerline)
            a, d = tr.centerline[idx], tr._segments[idx]
            t = np.clip(((p - a) * d).sum(axis=1) / tr._segments_sq[idx], 0, 1)
            k = int(np.argmin(np.linalg.norm(a + t[:, None] * d - p, axis=1)))
            assert near[0] == idx[k]
            assert near[1] == pytest.approx(tr.arc_start[idx[k]] + t[k] * tr.segment_lengths[idx[k]], abs=1e-12)
            assert abs(near[2]) == pytest.approx(np.linalg.norm(a[k] + t[k] * d[k] - p), abs=1e-12)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_the_autopilot_laps_every_builtin_track_without_touching_a_wall(name):
    result = race.race(get(name), laps=2)
    assert len(result.lap_times_s) == 2
    assert result.wall_contacts == 0 and result.max_cross_track_m < 0.35  # walls are 0.6 m from the centre
    flying = result.lap_times_s[1] / result.limit_lap_s
    assert 1.0 < flying <= 1.15  # close to the physical limit, never (impossibly) faster than it
    assert result.slowest_m_s > -0.1  # it never rolls backwards (beyond settling on its wheels)


def test_the_heading_pid_also_laps_without_touching_a_wall():
    result = race.race(get("oval"), laps=2, lateral="pid")
    assert len(result.lap_times_s) == 2 and result.wall_contacts == 0 and result.max_cross_track_m < 0.45


def test_the_autopilot_brakes_for_the_oval_corners_through_the_firmware():
    """The oval's corners are slower than its straights; the ESC has no brake, so the autopilot
    commands reverse and the firmware's brake/reverse sequence turns it into braking."""
    result = race.race(get("oval"), laps=2)
    assert result.braking_periods >= 5  # (at the half reverse it brakes straight with, after lifting off first)
    assert result.slowest_m_s > -0.1
    corner = [v for x, y, v, *_ in result.path[len(result.path) // 2:] if abs(x) > 2.5]
    straight = [v for x, y, v, *_ in result.path[len(result.path) // 2:] if abs(x) < 0.5]
    assert max(corner) < max(straight) - 0.4


def test_race_cli_prints_report_and_plot(tmp_path, capsys):
    png = tmp_path / "race.png"
    assert race.main(["--laps", "1", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "lap 1:" in out and "x the centre line's limit" in out and "x the racing line's" in out and "wall contacts: 0" in out
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_race_follows_a_waypoint_file(tmp_path, capsys):
    from roar.autopilot import save_waypoints

    path = tmp_path / "line.txt"
    save_waypoints(path, get("oval").centerline)
    assert race.main(["--laps", "1", "--waypoints", str(path)]) == 0
    assert "laps completed: 1" in capsys.readouterr().out


@pytest.mark.parametrize("args, fragment", [(["--laps", "0"], "--laps"), (["--margin", "2"], "--margin"),
                                            (["--plot", "x.jpg"], ".png")])
def test_race_cli_rejects_bad_arguments(args, fragment, capsys):
    assert run_command("roar race", race.main, args) == 1
    assert fragment in capsys.readouterr().err


@pytest.mark.parametrize("args", [["--track", "nowhere.json"], ["--waypoints", "/nonexistent.txt"]])
def test_race_cli_bad_files_are_one_line(args, capsys):
    assert run_command("roar race", race.main, args) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("roar race: error:") and "\n" not in err


# --- tracks a car cannot drive are refused in one line; big and far tracks run ---------------------

def lemniscate(a: float, y_scale: float = 1.0, n: int = 600) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([a * np.cos(t) / (1 + np.sin(t) ** 2), y_scale * a * np.sin(t) * np.cos(t) / (1 + np.sin(t) ** 2)], 1)


def circle(r: float, cx: float = 0.0, spacing: float = 0.5) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, max(16, int(2 * np.pi * r / spacing)), endpoint=False)
    return np.stack([cx + r * np.cos(t), r * np.sin(t)], 1)


@pytest.mark.parametrize("points, width, fragment", [
    (circle(0.25, spacing=0.05), 1.0, "no car here turns tighter than 0.3 m"),
    (np.array([[0, 0], [1, 0], [2, 0], [3, 0], [2, 0], [1, 0.5], [0.5, 1], [0, 0.5]], float), 0.5,
     "no car here turns tighter"),  # a hairpin whose neighbours coincide
    (lemniscate(20, y_scale=0.3), 0.8, "crosses itself at"),  # an X too shallow to drive through
    (np.stack([5 * np.cos(np.linspace(0, 2 * np.pi, 200, endpoint=False)),
               2 * np.sin(np.linspace(0, 2 * np.pi, 200, endpoint=False)) *
               (0.08 + 0.92 * np.cos(np.linspace(0, 2 * np.pi, 200, endpoint=False)) ** 2)], 1), 1.0,
     "too close for a wall between them"),  # a waist too narrow for two lanes and a wall
    (np.vstack([circle(3), circle(3)[:1]]), 1.0, "the last point repeats the first"),
    (circle(120, spacing=1.5), 1.0, "must fit in a 200 m square"),
    (circle(3, cx=2000), 1.0, "within 1000 m of the origin"),
])
def test_tracks_a_car_cannot_drive_are_refused_in_one_line(points, width, fragment):
    with pytest.raises(TrackError) as err:
        Track("t", points, width)
    assert fragment in str(err.value) and "\n" not in str(err.value)


def test_a_figure_eight_crossing_is_allowed():
    track = Track("eight", lemniscate(4.4), 1.2)  # crosses at 90 degrees: accepted, not raised
    assert track.length_m > 20 and len(track.centerline) == 600


@pytest.mark.parametrize("width", ["true", "\"1\"", "null"])
def test_width_must_be_a_number_in_a_file(tmp_path, width):
    path = tmp_path / "t.json"
    path.write_text(f'{{"width_m": {width}, "centerline": {json.dumps(CIRCLE)}}}')
    with pytest.raises(TrackError, match="width_m must be a number"):
        load_json(path)


def test_a_track_far_from_the_origin_has_ground_under_it():
    from roar.protocol import encode
    from roar_sim.robots.esc import EscCar

    with EscCar(Track("far", circle(5, cx=100), 1.5)) as sim:
        for _ in range(100):
            sim.write(encode(1700 if sim.time_s > 0.1 else 1500, 1500))
            sim.run(0.02)
        s = sim.state()
        assert s.speed > 0.5 and 94 < s.x < 106  # driving, not falling off the edge of the world


def test_a_100_m_track_runs_in_well_under_a_gigabyte(tmp_path):
    """The painted floor and its mesh are bounded whatever the track's size."""
    import subprocess
    import sys

    # VmHWM, this process's own peak: getrusage's ru_maxrss keeps the peak of the process it was
    # forked from (the suite's, hundreds of MB) across exec
    script = ("import re, sys, numpy as np\n"
              "from roar.tracks.track import Track\nfrom roar_sim.robots.esc import EscCar\n"
              "t = np.linspace(0, 2 * np.pi, 300, endpoint=False)\n"
              "with EscCar(Track('big', np.stack([49 * np.cos(t), 49 * np.sin(t)], 1), 1.5)) as sim:\n"
              "    sim.run(0.2)\n"
              "print(re.search(r'VmHWM:\\s+(\\d+) kB', open('/proc/self/status').read()).group(1))\n")
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    peak_mb = int(proc.stdout.split()[-1]) / 1024
    assert peak_mb < 700, f"{peak_mb:.0f} MB"


# --- waypoint lines the race cannot follow, and races that end short --------------------------------

@pytest.mark.parametrize("make, fragment", [
    (lambda cl: cl[::-1], "against the track's direction"),
    (lambda cl: cl + np.array([0.0, 5.0]), "outside the track"),
])
def test_race_refuses_a_line_it_cannot_follow_in_one_line(tmp_path, capsys, make, fragment):
    from roar.autopilot import save_waypoints

    path = tmp_path / "line.txt"
    save_waypoints(path, make(get("oval").centerline))
    assert run_command("roar race", race.main, ["--laps", "1", "--waypoints", str(path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0]


def test_three_identical_waypoints_are_refused_instead_of_hanging(tmp_path, capsys):
    path = tmp_path / "line.txt"
    path.write_text("0,-1.5,0\n0,-1.5,0\n0,-1.5,0\n")
    assert run_command("roar race", race.main, ["--waypoints", str(path)]) == 1
    assert "at least 3 distinct waypoints" in capsys.readouterr().err


def test_a_race_that_ends_short_says_why_in_one_line_and_exits_2(capsys):
    assert race.main(["--laps", "2", "--seconds", "3"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("race incomplete:")]
    assert len(err) == 1 and "0 of 2 laps within the 3 s time limit (too slow)" in err[0]


def test_a_race_stopped_by_a_tunnels_cone_says_so_and_what_to_do():
    """The reason names the cone (not only the walls it was pushed into) and the two ways on."""
    from roar_sim.runs.race_result import RaceResult

    track = get("tunnel:1")
    result = RaceResult(track, np.ones(len(track.centerline)), cone_contacts=1242, wall_contacts=4217, travelled_m=6.0)
    why = result.shortfall(1, 140.0)
    assert why.index("ran into a cone in 1242") < why.index("touched a wall")
    assert "tunnel:1,cones=0,people=0" in why and "roar challenge tunnel:1" in why


def figure_eight_from_its_crossing(tmp_path):
    """x = 6 sin t, y = 6 sin t cos t, 0.6 m each side: a CSV track that starts where it crosses itself."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    path = tmp_path / "eight_centerline.csv"
    path.write_text("".join(f"{x:.4f}, {y:.4f}, 0.6, 0.6\n" for x, y in zip(6 * np.sin(t), 6 * np.sin(t) * np.cos(t))))
    return get(str(path))


def test_where_a_track_crosses_itself_the_cars_heading_says_which_leg(tmp_path):
    track = figure_eight_from_its_crossing(tmp_path)
    x, y, yaw = track.start_pose
    s_start = track.project((x + 1e-4, y - 1e-4), heading=yaw)[1]
    assert min(s_start, track.length_m - s_start) < 0.05  # at the start of the lap (just before it, or after)
    assert track.project((x, y), heading=yaw + np.pi / 2)[1] == pytest.approx(track.length_m / 2, abs=0.1)


def test_a_line_through_a_crossing_is_followed_on_the_leg_it_drives(tmp_path):
    """Track.follow keeps to the leg driven: along a figure eight's centre line from its crossing,
    every point is on the line (0 cross-track) and progress only grows, through the crossing too."""
    track = figure_eight_from_its_crossing(tmp_path)
    line = track.centerline[::3]
    _, along, cte = track.follow(line)
    steps = track.arc_delta(along[:-1], along[1:])  # the first point may read as the lap's end
    assert np.abs(cte).max() < 1e-6 and np.all(steps > 0) and steps.sum() > 0.95 * track.length_m, (along, cte)
    assert along[len(along) // 2] == pytest.approx(track.arc_start[3 * (len(along) // 2)])


def test_a_figure_eight_that_starts_at_its_crossing_is_timed_and_measured_on_the_leg_driven(tmp_path):
    """Progress is tracked continuously from the start: lap 1 is timed as lap 2 is (it was twice
    as long), the cross-track error is the car's from its own leg (it was 5.4 m on a 1.2 m track),
    and the racing line `roar track --line` draws is accepted by the race's line check."""
    track = figure_eight_from_its_crossing(tmp_path)
    result = race.race(track, 2)
    first, second = result.lap_times_s
    assert first < 1.2 * second and result.max_cross_track_m < 0.6 and result.wall_contacts == 0, race.report(result)
    race.check_line(track, race.optimal_line(track).points)  # raises WaypointError when a point is off the track


def test_a_race_plot_draws_the_line_followed_with_its_limit_and_no_stray_points_at_the_start():
    track = get("oval")
    line = race.optimal_line(track).points
    result = race.race(track, 1, waypoints=line)
    into_lap = np.array([p[3] for p in result.path])
    assert result.line is not None and into_lap.min() >= 0 and into_lap.max() < track.length_m
    assert into_lap[0] < 0.1  # the standing start is at the start of the lap, not at its end
    fig = race.plot(result)
    labels = [text.get_text() for ax in fig.axes if ax.get_legend() for text in ax.get_legend().get_texts()]
    assert "the line followed" in labels and "physical limit (the line followed)" in labels


def test_a_race_with_no_lap_says_how_long_it_drove():
    result = race.race(get("oval"), 2, timeout_s=3.0)
    assert not result.lap_times_s and "laps completed: 0 (0.00 s), in 3.0" in race.report(result)


def stadium(tmp_path, radius_m: float, name: str = "stadium", width_m: float = 1.2):
    """4 m straights joined by half circles of radius_m, width_m wide, as a centre-line CSV."""
    t = np.linspace(-np.pi / 2, np.pi / 2, 30, endpoint=False)
    straight = np.linspace(0, 4, 40, endpoint=False)
    points = np.vstack([np.column_stack([straight, np.full(40, -radius_m)]),
                        np.column_stack([4 + radius_m * np.cos(t), radius_m * np.sin(t)]),
                        np.column_stack([4 - straight, np.full(40, radius_m)]),
                        np.column_stack([-radius_m * np.cos(t), -radius_m * np.sin(t)])])
    path = tmp_path / f"{name}_centerline.csv"
    path.write_text("".join(f"{x:.6f}, {y:.6f}, {width_m / 2}, {width_m / 2}\n" for x, y in points))
    return get(str(path))


@pytest.mark.parametrize("radius_m", [0.31, 0.68])
def test_a_bend_no_car_can_take_is_refused_for_the_cars_and_taken_by_the_junior(tmp_path, radius_m):
    """The ESC and IARRC cars turn no tighter than 0.77 m: a tighter bend is refused in one line
    (how tight, where, what the car can do), in a race and in the Gym environment; the Junior
    turns on the spot and races it."""
    from roar_sim import robots
    from roar_sim.gym_env import RaceEnv

    track = stadium(tmp_path, radius_m)
    for robot in ("esc", "iarrc"):
        with pytest.raises(TrackError) as refused:
            race.race(track, 1, robot=robot)
        why = str(refused.value)
        said = float(why.split("radius of ")[1].split(" m")[0])
        assert said == pytest.approx(radius_m, abs=0.02) and "m along its centre line, at (" in why and "\n" not in why
        assert f"turns no tighter than {robots.get(robot).min_turn_radius_m():.2f} m" in why
        with pytest.raises(TrackError):
            RaceEnv(track, robot=robot)
    assert robots.get("esc").min_turn_radius_m() == pytest.approx(0.77, abs=0.01)
    result = race.race(track, 1, robot="junior")
    assert len(result.lap_times_s) == 1, race.report(result)


@pytest.mark.parametrize("radius_m, width_m", [(0.68, 2.2), (0.74, 1.2)])
def test_a_hairpin_tighter_than_the_car_turns_is_raced_where_the_track_is_wide_enough_to_run_wide(
        tmp_path, radius_m, width_m):
    """The ESC car turns no tighter than 0.77 m, but runs wide of a 0.68 m hairpin on a 2.2 m
    track (the F1TENTH circuits' width) and of a 0.74 m one on a 1.2 m track: both are raced, two
    laps without a wall, where the same 0.68 m hairpin 1.2 m wide is refused (above)."""
    track = stadium(tmp_path, radius_m, width_m=width_m)
    result = race.race(track, 2)
    assert len(result.lap_times_s) == 2 and result.wall_contacts == 0, race.report(result)


def test_a_bend_is_measured_over_at_least_the_files_point_spacing():
    """A 1 m circle of 16 points 0.39 m apart (the F1TENTH circuits' files have them ~0.4 m
    apart): the corners between points are no tighter bends (over the 0.25 m chord alone, the
    F1TENTH Monza's 0.72 m hairpin measured 0.54 m)."""
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    track = Track("sparse", np.column_stack([np.cos(angles), np.sin(angles)]) * 1.0 + (3, 3), 1.2)
    assert track.tightest_bend()[0] == pytest.approx(1.0, rel=0.05)


def test_a_kink_in_a_file_is_no_bend_and_a_wide_bend_is_raced(tmp_path):
    """Bends are measured over a chord: a 10 degree kink at one point does not refuse a track a
    car can drive, and a 0.9 m bend is raced."""
    track = stadium(tmp_path, 0.9)
    assert track.tightest_bend()[0] == pytest.approx(0.9, rel=0.05)
    race.race(track, 1)  # accepted: the car turns 0.77 m
    kinked = track.centerline.copy()
    kinked[20] += (0.0, 0.0045)  # a 10 degree kink on the straight (5 cm on each side)
    k = Track("kinked", kinked, 1.2)
    assert k.tightest_bend()[0] == pytest.approx(track.tightest_bend()[0], rel=0.01)  # the kink is not the tightest
