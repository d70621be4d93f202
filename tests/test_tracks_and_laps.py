"""Tracks (built-in and from files) and the built-in controller driving laps through the firmware."""

import json

import numpy as np
import pytest

from roar_sim import lap
from roar_sim.track import BUILTIN, Track, TrackError, get, oval


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_builtin_tracks_are_valid_closed_loops(name):
    tr = get(name)
    assert tr.length_m > 10 and len(tr.centerline) >= 100
    left, right = tr.edges()
    assert np.allclose(np.linalg.norm(left - right, axis=1), tr.width_m)


def test_file_round_trip(tmp_path):
    path = tmp_path / "t.json"
    path.write_text(oval().to_json())
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
        Track.load(path)
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
def test_controller_completes_a_lap_without_touching_a_wall(name):
    result = lap.drive_laps(get(name), laps=1, speed=1.5)
    assert len(result.lap_times_s) == 1
    assert result.wall_contacts == 0 and result.max_cross_track_m < 0.3
    assert result.lap_times_s[0] < 1.5 * get(name).length_m / 1.5


def test_lap_cli_prints_report_and_plot(tmp_path, capsys):
    png = tmp_path / "lap.png"
    assert lap.main(["--laps", "1", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "lap 1:" in out and "wall contacts: 0" in out
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args, fragment", [(["--laps", "0"], "--laps"), (["--speed", "9"], "--speed"),
                                            (["--plot", "x.jpg"], ".png")])
def test_lap_cli_rejects_bad_arguments(args, fragment, capsys):
    with pytest.raises(SystemExit) as e:
        lap.main(args)
    assert e.value.code == 2 and fragment in capsys.readouterr().err


def test_lap_cli_bad_track_is_one_line(capsys):
    assert lap.main(["--track", "nowhere.json"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err
