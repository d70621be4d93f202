"""`roar sweep`: a grid of autopilot parameters x tracks raced on this machine's processes and as
Ray tasks -- a real local Ray, and a real cluster started with `ray start` -- with the table
equal to a serial run's, resumed without redoing finished runs, and failed runs (an exception, a
worker that dies) reported while the others are kept."""

import csv
import json
import os
import socket
import subprocess
import sys

import pytest

from roar_sim.runs import sweep as sweep_module
from roar_sim.runs import sweep_table, sweep_workers
from roar_sim.runs.sweep import COLUMNS, Run, SweepError, Table, grid, parse_values

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
pytest.importorskip("ray", reason="pip install ray (make setup installs it; roar-platform[sweep])")

ROAR = [sys.executable, "-m", "roar.cli"]
# a small grid: 4 one-lap races of the oval, one K_dd at the edge of the wall
SMALL = ["--track", "oval", "--k-dd", "0.3,0.8", "--margin", "0.85,1", "--laps", "1"]


def roar(*args, env=None, timeout=240):
    return subprocess.run([*ROAR, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "RAY_USAGE_STATS_ENABLED": "0", **(env or {})})


def rows(path):
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_grid_and_values():
    assert parse_values("0.2,0.4", "k-dd", 0.05, 2) == [0.2, 0.4]
    assert parse_values("0.85:1:4", "margin", 0.3, 1) == [0.85, 0.9, 0.95, 1.0]  # rounded: 0.9, not 0.8999...
    assert parse_values("0.5,0.5,0.6", "margin", 0.3, 1) == [0.5, 0.6]
    runs = grid(["oval", "figure-eight"], [0.2, 0.4], [0.9], laps=1)
    assert [(r.track, r.k_dd_s) for r in runs] == [("oval", 0.2), ("oval", 0.4), ("figure-eight", 0.2),
                                                   ("figure-eight", 0.4)]
    assert runs[0] == Run("oval", 0.2, 0.9, 1, "esc")
    for text, why in [("3", "outside 0.05..2"), ("a,b", "give numbers"), ("0.1:0.2:0", "must be 1..100"),
                      ("nan", "outside"), (",", "no values")]:
        with pytest.raises(SweepError, match=why):
            parse_values(text, "k-dd", 0.05, 2)


def test_ray_table_equals_serial_table_and_resumes(tmp_path):
    """The same grid on a 2-CPU local Ray and here, one race after another: the same CSV, byte
    for byte. The serial table is built in two sweeps: the second runs only what the first left."""
    ray_out, serial_out = tmp_path / "ray", tmp_path / "serial"
    first = roar("sweep", *SMALL[:3], "0.3", *SMALL[4:], "--serial", "--out", str(serial_out))
    assert first.returncode == 0, first.stderr
    assert "0 already in" in first.stderr and len(rows(serial_out / "results.csv")) == 2
    resumed = roar("sweep", *SMALL, "--serial", "--out", str(serial_out))
    assert resumed.returncode == 0, resumed.stderr
    assert "2 already in" in resumed.stderr and "2 to run" in resumed.stderr
    on_ray = roar("sweep", *SMALL, "--ray", "--workers", "2", "--out", str(ray_out))
    assert on_ray.returncode == 0, on_ray.stderr
    assert "on a local Ray" in on_ray.stderr
    local = roar("sweep", *SMALL, "--workers", "2", "--out", str(tmp_path / "local"))
    assert local.returncode == 0, local.stderr
    assert "on 2 local processes" in local.stderr
    assert (tmp_path / "local" / "results.csv").read_bytes() == (serial_out / "results.csv").read_bytes()

    table = (ray_out / "results.csv").read_bytes()
    assert table == (serial_out / "results.csv").read_bytes()
    got = rows(ray_out / "results.csv")
    assert [(r["k_dd_s"], r["margin"]) for r in got] == [("0.3", "0.85"), ("0.3", "1.0"), ("0.8", "0.85"),
                                                         ("0.8", "1.0")]
    assert all(r["status"] == "ok" and r["laps_done"] == "1" for r in got)
    assert len({r["best_lap_s"] for r in got}) == 4  # each parameter point drove its own race
    assert float(got[0]["best_lap_s"]) > float(got[1]["best_lap_s"])  # a larger margin laps faster
    assert "oval: best K_dd" in on_ray.stdout and "x the physical limit" in on_ray.stdout
    assert (ray_out / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    again = roar("sweep", *SMALL, "--ray", "--workers", "2", "--out", str(ray_out))  # nothing left: no race runs
    assert again.returncode == 0 and "4 already in" in again.stderr and "0 to run" in again.stderr
    assert (ray_out / "results.csv").read_bytes() == table


FLAKY_RUNS = """
import json, os, sys
from pathlib import Path
from roar_sim.runs.sweep import Table, grid, sweep

TABLE, MODE, CALLS = sys.argv[1:4]  # module globals: pickled with fn (a worker has its own argv)

def fn(run):
    if MODE == "faulty" and run.margin == 0.5:
        raise ValueError("no grip\\nat this margin")
    if MODE == "faulty" and run.margin == 0.6:
        os._exit(3)  # the worker process dies
    with open(CALLS, "a") as f:
        f.write(f"{run.margin}\\n")
    return {"track": run.track, "robot": run.robot, "k_dd_s": run.k_dd_s, "margin": run.margin,
            "laps": run.laps, "status": "ok", "laps_done": run.laps, "best_lap_s": 10 * run.margin,
            "limit_lap_s": 8.0, "best_ratio": 1.25 * run.margin, "wall_contacts": 0,
            "max_cross_track_m": 0.1, "error": ""}

runs = grid(["oval"], [0.3], [0.4, 0.5, 0.6, 0.7])
print(json.dumps(sweep(runs, Table(Path(TABLE)), fn, serial=MODE == "fixed", workers=2)))
"""


def test_failed_runs_are_reported_and_the_others_kept_then_rerun(tmp_path):
    script, table, calls = tmp_path / "flaky.py", tmp_path / "results.csv", tmp_path / "calls"
    script.write_text(FLAKY_RUNS)
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    faulty = subprocess.run([sys.executable, str(script), str(table), "faulty", str(calls)], capture_output=True,
                            text=True, timeout=240, env=env)
    assert faulty.returncode == 0, faulty.stderr
    got = {float(r["margin"]): r for r in json.loads(faulty.stdout.splitlines()[-1])}
    assert got[0.4]["status"] == got[0.7]["status"] == "ok"
    assert got[0.5]["status"] == "failed" and got[0.5]["error"] == "ValueError: no grip"
    assert got[0.6]["status"] == "failed" and "worker running it died" in got[0.6]["error"]
    # a run that finished beside the dying one may have lost its result with the broken pool and
    # run again alone: each good run ran, the failing ones never reached their end
    assert set(calls.read_text().split()) == {"0.4", "0.7"}
    calls.write_text("")

    fixed = subprocess.run([sys.executable, str(script), str(table), "fixed", str(calls)], capture_output=True,
                           text=True, timeout=120, env=env)
    assert fixed.returncode == 0, fixed.stderr
    assert sorted(calls.read_text().split()) == ["0.5", "0.6"]  # only the failed ones again
    final = rows(table)
    assert [r["margin"] for r in final] == ["0.4", "0.5", "0.6", "0.7"]
    assert all(r["status"] == "ok" for r in final)


def test_a_failed_row_is_run_again(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text(
        "track,robot,k_dd_s,margin,laps,status,laps_done,best_lap_s,limit_lap_s,best_ratio,wall_contacts,"
        "max_cross_track_m,error\n"
        "oval,car,0.3,0.9,1,failed,0,,,,,,SimError: earlier\n")
    done = roar("sweep", "--track", "oval", "--k-dd", "0.3", "--margin", "0.9", "--laps", "1", "--serial",
                "--out", str(out))
    assert done.returncode == 0, done.stderr
    assert "0 already in" in done.stderr and rows(out / "results.csv")[0]["status"] == "ok"


def test_the_cli_lists_failed_runs_and_exits_2(tmp_path, monkeypatch, capsys):
    from roar_sim.runs import sweep

    def race_run(run):
        if run.k_dd_s == 0.8:
            raise RuntimeError("the simulator stopped")
        return sweep.failed_row(run, "") | {"status": "ok", "laps_done": 1, "best_lap_s": 9.0, "limit_lap_s": 8.0,
                                            "best_ratio": 1.125, "wall_contacts": 0, "max_cross_track_m": 0.1}

    monkeypatch.setattr(sweep, "race_run", race_run)
    assert sweep.main(["--track", "oval", "--k-dd", "0.3,0.8", "--margin", "0.9", "--laps", "1", "--serial",
                       "--out", str(tmp_path)]) == 2
    out = capsys.readouterr().out
    assert "2 runs: 1 drove every lap, 0 incomplete, 1 failed" in out
    assert "failed: oval K_dd 0.8 margin 0.9: RuntimeError: the simulator stopped" in out
    assert "oval: best K_dd 0.3 s, margin 0.9: best lap 9.00 s = 1.125 x" in out
    assert (tmp_path / "sweep.png").exists()


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_a_ray_cluster_at_an_address(tmp_path):
    """`ray start --head` is a real cluster on this machine; the sweep connects to it by address
    (with Ray's token authentication) and gives the same table as here."""
    ray = os.path.join(os.path.dirname(sys.executable), "ray")
    port = _free_port()
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    started = subprocess.run([ray, "start", "--head", "--port", str(port), "--num-cpus", "2",
                              "--include-dashboard", "false", "--disable-usage-stats"],
                             capture_output=True, text=True, timeout=120, env=env)
    assert started.returncode == 0, started.stderr
    try:
        grid_args = ["--track", "oval", "--k-dd", "0.3,0.8", "--margin", "0.9", "--laps", "1"]
        cluster = roar("sweep", *grid_args, "--address", f"127.0.0.1:{port}", "--out", str(tmp_path / "c"),
                       env={"RAY_AUTH_MODE": "token"})
        assert cluster.returncode == 0, cluster.stderr
        assert f"on Ray at 127.0.0.1:{port}" in cluster.stderr
        serial = roar("sweep", *grid_args, "--serial", "--out", str(tmp_path / "s"))
        assert serial.returncode == 0, serial.stderr
        assert (tmp_path / "c" / "results.csv").read_bytes() == (tmp_path / "s" / "results.csv").read_bytes()
    finally:
        subprocess.run([ray, "stop", "--force"], capture_output=True, timeout=120, env=env)


@pytest.mark.parametrize("args, message", [
    (["--k-dd", "5"], "roar sweep: error: --k-dd 5 is outside 0.05..2"),
    (["--margin", "a,b"], "roar sweep: error: --margin 'a,b': give numbers"),
    (["--track", "nowhere"], "roar sweep: error: "),
    (["--address", "127.0.0.1:1"], "roar sweep: error: cannot reach the Ray cluster at 127.0.0.1:1"),
    (["--address", "nohost"], "roar sweep: error: --address nohost: give HOST:PORT"),
])
def test_bad_input_is_one_line(tmp_path, args, message):
    done = roar("sweep", "--out", str(tmp_path), *args, timeout=60)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1].startswith(message), done.stderr
    assert "Traceback" not in done.stderr


def test_a_table_of_something_else_is_not_overwritten(tmp_path):
    (tmp_path / "results.csv").write_text("name,score\nx,1\n")
    done = roar("sweep", "--out", str(tmp_path), "--serial", timeout=60)
    assert done.returncode == 1 and "is not a sweep results table" in done.stderr
    assert (tmp_path / "results.csv").read_text() == "name,score\nx,1\n"


@pytest.mark.parametrize("args", [["--laps", "0"], ["--workers", "2", "--serial"], ["--serial", "--address", "auto"],
                                  ["--ray", "--serial"], ["--track", "random:9-2"]])
def test_bad_options(tmp_path, args):
    done = roar("sweep", "--out", str(tmp_path), *args, timeout=60)
    assert done.returncode == 1 and "error:" in done.stderr and "Traceback" not in done.stderr


def fake_race(run):
    """A result row as race_run makes it, without racing (the table is what is under test)."""
    return {**sweep_table.run_columns(run), "status": "ok", "laps_done": run.laps, "best_lap_s": 10.0 + run.margin,
            "limit_lap_s": 9.0, "best_ratio": (10.0 + run.margin) / 9.0, "wall_contacts": 0,
            "max_cross_track_m": 0.1, "error": ""}


DAMAGED_ROWS = [
    "figure-eight,esc,0.3,0.9,1,ok",  # cut short (the row)
    "figure-eight,esc,0.3,0.95,1,ok,1,,,,,,",  # whole, but the numbers are gone
    "figure-eight,esc,0.3,1.0,1,great,1,10,9,1.1,0,0.1,",  # a status the tool does not write
    "figure-eight,esc,0.3,0.85,1,ok,1,10,9,nan,0,0.1,",  # a ratio that is not finite
]


@pytest.mark.parametrize("damaged", DAMAGED_ROWS)
def test_a_damaged_row_is_reported_set_aside_and_run_again(tmp_path, monkeypatch, capsys, damaged):
    """Each damaged row: one line naming it, the row kept in results.damaged.csv, its run raced
    again, and a table that reads back whole -- run after run."""
    monkeypatch.setattr(sweep_module, "race_run", fake_race)
    table = tmp_path / "results.csv"
    table.write_text(",".join(COLUMNS) + "\n" + damaged + "\n")
    argv = ["--out", str(tmp_path), "--serial", "--track", "figure-eight", "--k-dd", "0.3",
            "--margin", "0.85,0.9,0.95,1", "--laps", "1"]
    for attempt in range(2):
        capsys.readouterr()
        assert sweep_module.main(argv) == 0
        err = capsys.readouterr().err
        if attempt == 0:
            assert f"{table} line 2: " in err and "set aside in results.damaged.csv" in err, err
            assert "0 already in" in err and "4 to run" in err, err
        else:
            assert "line 2" not in err and "4 already in" in err, err
        written = rows(table)
        assert len(written) == 4 and all(r["status"] == "ok" and r["best_ratio"] for r in written), written
    assert (tmp_path / "results.damaged.csv").read_text().splitlines()[1].rstrip(",") == damaged.rstrip(",")


def test_an_interrupted_write_never_leaves_half_a_table(tmp_path, monkeypatch):
    """The table is replaced whole: a write that dies midway leaves the last whole table."""
    table = Table(tmp_path / "results.csv")
    runs = grid(["oval"], [0.3], [0.85, 0.9], laps=1)
    table.add(sweep_table.as_strings(fake_race(runs[0])))
    before = (tmp_path / "results.csv").read_bytes()

    def dies(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(sweep_table.os, "replace", dies)
    with pytest.raises(OSError):
        table.add(sweep_table.as_strings(fake_race(runs[1])))
    assert (tmp_path / "results.csv").read_bytes() == before
    assert Table(tmp_path / "results.csv").damaged == []


def test_a_malformed_result_becomes_a_failed_row():
    row = sweep_table.as_strings({**fake_race(Run("oval", 0.3, 0.9, 1)), "limit_lap_s": float("inf")})
    table = Table.__new__(Table)
    table.rows, table.damaged = {}, []
    table._write = lambda keys: None
    table.add(row)
    (kept,) = table.rows.values()
    assert kept["status"] == "failed" and "limit_lap_s 'inf' is not a finite number" in kept["error"]


class _Stuck:
    """A stand-in for the `ray` module whose shutdown, like the driver's goodbye on a busy machine,
    lasts until the local Ray's processes are gone (here: one process, `sleep`)."""

    def __init__(self):
        self.server = subprocess.Popen(["sleep", "60"])
        info = type("Info", (), {"process": self.server})
        node = type("Node", (), {"all_processes": {"raylet": [info]}})
        worker = type("Worker", (), {"_global_node": node})
        self._private = type("Private", (), {"worker": worker})
        self.ended = False

    def shutdown(self):
        self.server.wait()
        self.ended = True


def test_after_ctrl_c_a_slow_ray_goodbye_is_cut_short():
    import time

    ray = _Stuck()
    t0 = time.monotonic()
    sweep_workers.shutdown_at_once(ray)
    assert time.monotonic() - t0 < 3 * sweep_workers.RAY_GOODBYE_S
    assert ray.server.poll() == -9 and ray.ended  # killed, and so the goodbye ended


def test_the_kill_works_on_a_snapshot_of_rays_table_which_its_shutdown_changes_meanwhile():
    """Ray's shutdown, still running in its thread, takes each process out of the node's table as it
    stops it while the kill walks the table (seen once: "dictionary changed size during iteration",
    a traceback instead of status 130)."""
    ray = _Stuck()
    table = ray._private.worker._global_node.all_processes

    class Leaving:  # the table loses its raylet while the kill looks at this process
        @property
        def process(self):
            table.pop("raylet", None)
            return ray.server

    table["dashboard"] = [Leaving()]
    try:
        sweep_workers._kill_local_ray(ray)
        assert ray.server.wait(5) == -9
    finally:
        ray.server.kill()


def test_ctrl_c_ends_a_sweep_on_local_processes_at_once_and_keeps_what_finished(tmp_path):
    """Seeded random tracks as a range (random:1-3: three tracks), raced on this machine's
    processes; Ctrl-C ends the sweep and every process it started within seconds (status 130)."""
    import signal
    import time

    process = subprocess.Popen([*ROAR, "sweep", "--track", "random:1-3", "--k-dd", "0.4", "--margin", "0.8,0.9",
                                "--laps", "2", "--workers", "2", "--out", str(tmp_path)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and len(sweep_workers.descendants(process.pid)) < 2:
            time.sleep(0.1)  # its two processes are up
        children = sweep_workers.descendants(process.pid)
        assert len(children) >= 2
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        start = time.monotonic()
        _, err = process.communicate(timeout=20)
        assert time.monotonic() - start < 5.0
    finally:
        process.kill()
    assert process.returncode == 130, err
    assert "6 runs (3 tracks x 2 parameter points)" in err and "on 2 local processes" in err
    assert "interrupted: the finished runs are in" in err and "Traceback" not in err
    time.sleep(0.5)
    assert not [pid for pid in children if os.path.exists(f"/proc/{pid}") and
                open(f"/proc/{pid}/stat").read().split()[2] != "Z"]  # none left running
