"""Inputs a new user gives, each either working or failing in one line (no traceback, non-zero
exit, the car left at neutral), and no success reported that did not happen."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from conftest import ROOT
from roar import TransportError, Vehicle
from roar.calibration import Calibration, CalibrationError
from roar.cli import main
from roar.protocol import encode

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)


def one_line_error(capsys, *argv) -> str:
    code = main(list(argv))
    err = capsys.readouterr().err.strip()
    assert code == 1 and "\n" not in err and "Traceback" not in err, err
    return err


def test_global_options_work_before_a_simulator_command(capsys):
    with pytest.raises(SystemExit) as e:
        main(["-v", "race", "--help"])
    assert e.value.code == 0 and "usage: roar race" in capsys.readouterr().out


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.startswith("roar 0.1.0")


@pytest.mark.parametrize("name, text, kind", [("cal.toml", "a = " + "[" * 100_000, "TOML"),
                                                ("track.json", "[" * 100_000, "JSON")])
def test_deeply_nested_files_fail_in_one_line(tmp_path, name, text, kind):
    from roar.tracks import TrackError
    from roar.tracks.track_files import load_json

    path = tmp_path / name
    path.write_text(text)
    load, error = (Calibration.load, CalibrationError) if kind == "TOML" else (load_json, TrackError)
    with pytest.raises(error) as e:
        load(path)
    assert f"not valid {kind}" in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("option", ["trace=/proc/roar/drive.csv", "plot=/proc/roar/drive.png", "plot=/tmp"])
def test_sim_outputs_that_cannot_be_written_fail_before_driving(capsys, option):
    err = one_line_error(capsys, "send", f"sim://?{option}", "--for", "0.1")
    assert "cannot write" in err or "must name a .png" in err


def test_a_serial_port_with_no_car_on_it_is_not_reported_as_success(capsys):
    master, slave = os.openpty()  # a port that takes bytes and never answers
    try:
        err = one_line_error(capsys, "send", f"serial://{os.ttyname(slave)}", "--for", "0.1")
        assert "no reply from a car" in err
        assert b"(1500,1500)" in os.read(master, 4096)  # it did send, then neutral
    finally:
        os.close(master)
        os.close(slave)


def test_gui_without_a_display_is_one_line_and_the_program_lives_on(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(TransportError) as e:
        Vehicle("sim://?gui=1")
    assert "needs a display" in str(e.value) and "\n" not in str(e.value)
    err = subprocess.run([sys.executable, "-m", "roar.cli", "race", "--gui"], capture_output=True, text=True,
                         cwd=ROOT, env={k: v for k, v in os.environ.items() if k != "DISPLAY"}, timeout=60)
    assert err.returncode == 1 and err.stderr.strip().splitlines()[-1].startswith("roar race: error: --gui needs a display")


def test_sim_serial_exits_130_on_ctrl_c():
    proc = subprocess.Popen([sys.executable, "-m", "roar.cli", "sim", "--serial"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert "/dev/pts/" in proc.stdout.readline()
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 130
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()


def test_the_simulated_port_never_tears_reply_lines_for_a_slow_reader(pty_car):
    """Hundreds of error replies while nobody reads; then every line read is whole."""
    import serial

    with serial.Serial(pty_car.path, timeout=0) as port:
        for _ in range(60):
            port.write(b"x\n" * 10)
            time.sleep(0.01)
        time.sleep(0.5)
        data = b""
        while chunk := port.read(65536):
            data += chunk
            time.sleep(0.05)
    lines = data.decode().splitlines()
    assert len(lines) > 50
    assert set(lines) <= {"READY 1", "ERR garbage", "FAILSAFE", "ARMED"}, sorted(set(lines))[:5]


@pytest.mark.parametrize("value", [10**400, -(10**400)])
def test_huge_integers_are_a_value_error(value):
    words = "throttle must be a finite number -1..1, got an integer of 401 digits"
    with Vehicle("loop://") as car, pytest.raises(ValueError, match=words):
        car.drive(throttle=value)


def test_numpy_integers_encode():
    np = pytest.importorskip("numpy")
    assert encode(np.int64(1600), np.uint16(1400)) == b"(1600,1400)"


def test_drive_from_a_thread_after_the_main_thread_ended_raises_instead_of_doing_nothing():
    """The vehicle stops sending when the main thread ends (the car's failsafe then stops it);
    a worker that drives after that gets an error, and `connected` says False."""
    script = textwrap.dedent("""
        import threading, time
        from roar import TransportError, Vehicle
        car = Vehicle("loop://")
        def worker():
            time.sleep(0.5)  # the main thread has returned by now
            try:
                car.drive(0.3)
                print("no error", car.connected, flush=True)
            except TransportError as e:
                print("raised:", e, "| connected:", car.connected, flush=True)
        threading.Thread(target=worker).start()
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=30, cwd=ROOT).stdout
    assert out.startswith("raised:") and "main thread has ended" in out and "connected: False" in out, out


def test_the_issue_calibration_fails_in_one_line_with_roar_send(capsys, tmp_path):
    path = tmp_path / "t.toml"
    path.write_text("[throttle]\ntrim_us = 1530\n")
    assert "would never arm" in one_line_error(capsys, "send", "sim://", "--throttle", "0.5", "--for", "0.2",
                                                "--calibration", str(path))


def test_send_to_the_simulated_car_still_succeeds(capsys):
    code = main(["send", "sim://", "--throttle", "0.2", "--for", "0.2"])
    out = capsys.readouterr().out
    assert code == 0 and "link ok" in out and "ARMED" in out


@pytest.mark.parametrize("argv", [["--help"], ["race", "--help"], ["sim", "--help"]])
def test_no_pybullet_banner_in_any_output(argv):
    proc = subprocess.run([sys.executable, "-m", "roar.cli", *argv], capture_output=True, text=True, cwd=ROOT,
                          timeout=60)
    assert proc.returncode == 0 and "build time" not in proc.stdout + proc.stderr


def test_pybullet_itself_still_prints_its_banner_so_the_test_above_can_fail():
    proc = subprocess.run([sys.executable, "-c", "import pybullet"], capture_output=True, text=True, timeout=60)
    assert "build time" in proc.stdout + proc.stderr


# --- round 3: data from files and the network, and what the messages say ------------------------

def test_send_over_a_dropped_link_does_not_claim_it_sent_neutral(capsys):
    code = main(["send", "loop://?fail_after=3", "--for", "0.3"])
    out = capsys.readouterr().out
    assert code == 1 and "neutral sent" not in out
    assert "link down: loop:// link cut (fail_after); neutral could not be sent" in out


@pytest.mark.parametrize("value, shown", [(1.0000001, "got 1.0000001"), (float("nan"), "got nan"), ("1", "got '1'")])
def test_a_bad_value_is_shown_as_given(value, shown):
    words = f"throttle must be a finite number -1..1, {shown}$"
    with Vehicle("loop://") as car, pytest.raises(ValueError, match=words):
        car.drive(throttle=value)


@pytest.mark.parametrize("argv, words", [
    (["scan", "--timeout", "0"], "argument --timeout: must be a finite number more than 0 and at most 60 s, got '0'"),
    (["race", "--track", ""], "the track name is empty"),
])
def test_messages_say_what_is_wrong(capsys, argv, words):
    assert words in one_line_error(capsys, *argv)


def test_a_zero_timeout_in_a_url_says_the_range_excludes_zero():
    with pytest.raises(TransportError, match="timeout must be a finite number more than 0 and at most 30 s, got 0.0"):
        Vehicle("http://127.0.0.1:8081?timeout=0")


def test_terminal_escapes_in_a_track_file_are_shown_escaped(tmp_path, capsys):
    """A track's name reaches the terminal: its control characters (colours, cursor moves, a
    right-to-left override) are printed escaped, never raw."""
    import json

    from roar_sim.runs import race
    from roar.tracks.track import oval

    path = tmp_path / "evil.json"
    path.write_text(json.dumps({"name": "\x1b[2J\x1b[31mred\x1b[0m\u202eevil\r", "width_m": oval().width_m,
                                "centerline": oval().centerline.tolist()}))
    assert race.main(["--track", str(path), "--laps", "1"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\u202e" not in out and "\r" not in out
    assert "on track \\x1b[2J\\x1b[31mred\\x1b[0m\\u202eevil\\r:" in out


def test_what_a_junior_replies_is_shown_escaped():
    """A body from the network in an error message: escaped too."""
    from roar.checks import printable

    assert printable("bad\x1b[31m\x07\n") == "bad\\x1b[31m\\x07\\n"
    assert printable("é ok ✓") == "é ok ✓"  # printable text is left alone
    assert printable("x" * 100, 10) == "xxxxxxx..."


def test_files_with_a_utf8_byte_order_mark_are_read(tmp_path):
    import json

    from roar.autopilot import load_waypoints, save_waypoints
    from roar.tracks.track import oval
    from roar.tracks.track_files import load_json

    save_waypoints(tmp_path / "plain.txt", oval().centerline)
    bom = tmp_path / "bom.txt"
    bom.write_bytes(b"\xef\xbb\xbf" + (tmp_path / "plain.txt").read_bytes())
    assert (load_waypoints(bom) == load_waypoints(tmp_path / "plain.txt")).all()
    track = json.dumps({"width_m": oval().width_m, "centerline": oval().centerline.tolist()})
    (tmp_path / "bom.json").write_bytes(b"\xef\xbb\xbf" + track.encode())
    assert load_json(tmp_path / "bom.json").length_m == pytest.approx(oval().length_m)
    (tmp_path / "calibration.toml").write_bytes(b"\xef\xbb\xbf" + b"[steering]\ntrim_us = 1510\n")
    assert Calibration.load(tmp_path / "calibration.toml").steering.trim_us == 1510


@pytest.mark.parametrize("shift, words", [((5.0, 0.0), "outside the track"),
                                          (None, "run against the track's direction")])
def test_waypoints_off_the_track_or_reversed_name_their_file(tmp_path, capsys, shift, words):
    import numpy as np

    from roar.autopilot import save_waypoints
    from roar.tracks.track import oval

    line = oval().centerline
    line = line + np.array(shift) if shift else line[::-1]
    path = tmp_path / "line.txt"
    save_waypoints(path, line)
    err = one_line_error(capsys, "race", "--waypoints", str(path), "--laps", "1")
    assert f"roar race: error: {path}: " in err and words in err


def _library_calls():
    """(what, a call taking one value) for every timeout, period and rate a user hands the library."""
    import asyncio

    from roar import camera
    from roar.aio import run_sync
    from roar.stream import Reassembler, StreamReceiver

    def on_vehicle(method):
        def call(value):
            with Vehicle("loop://") as car:
                return getattr(car, method)(timeout_s=value)
        return call

    def next_frame(value):
        async def run():
            async with StreamReceiver("state", port=0) as receiver:
                return await receiver.next_frame(value)
        return asyncio.run(run())

    async def nothing():
        return None

    return {
        "Vehicle.wait_for": ("timeout_s", on_vehicle("wait_for")),
        "Vehicle.wait_armed": ("timeout_s", on_vehicle("wait_armed")),
        "Vehicle.flush": ("timeout_s", on_vehicle("flush")),
        "Vehicle(rate_hz=)": ("rate_hz", lambda v: Vehicle("loop://", rate_hz=v).close()),
        "camera.fetch": ("timeout_s", lambda v: camera.fetch("http://127.0.0.1:1/cam-lo.jpg", v)),
        "camera.MjpegStream": ("timeout_s", lambda v: camera.MjpegStream("http://127.0.0.1:1/cam.mjpeg", v)),
        "aio.run_sync": ("timeout_s", lambda v: run_sync(nothing(), v)),
        "Reassembler": ("timeout_s", lambda v: Reassembler(timeout_s=v)),
        "StreamReceiver.next_frame": ("timeout_s", next_frame),
    }


@pytest.mark.parametrize("call", sorted(_library_calls()))
@pytest.mark.parametrize("value", [float("nan"), float("inf"), -1, 1e308, 10**400, "1", None, True])
def test_every_timeout_period_and_rate_is_checked(call, value):
    """A NaN no longer hangs, an infinity is no OverflowError, a string no TypeError: a
    ValueError naming the argument, at once."""
    import time

    name, fn = _library_calls()[call]
    t0 = time.monotonic()
    if value is None and call in ("Vehicle(rate_hz=)", "aio.run_sync"):
        fn(value)  # None: the default rate, no timeout
    else:
        with pytest.raises(ValueError, match=f"^{name} must be a finite number"):
            fn(value)
    assert time.monotonic() - t0 < 2.0


@pytest.mark.parametrize("argv, words", [
    (["stream", "udp://127.0.0.1", "--out", "{file}"], "--out cannot write into {file}: {file} is a file, not a folder"),
    (["stream", "udp://127.0.0.1", "--out", "/proc/roar"], "--out cannot make the folder /proc/roar"),
    (["vision", "{frames}", "--out", "{file}"], "--out cannot write into {file}: {file} is a file, not a folder"),
    (["vision", "{frames}", "--video", "{file}/v.mp4"], "--video cannot write {file}/v.mp4: {file} is a file"),
    (["race", "--plot", "{file}/x.png"], "--plot cannot write {file}/x.png: {file} is a file, not a folder"),
    (["send", "sim://?trace={file}/x.csv"], "trace: cannot write {file}/x.csv: {file} is a file, not a folder"),
    (["sweep", "--out", "{file}"], "--out cannot write into {file}: {file} is a file, not a folder"),
    (["calibrate", "loop://", "--file", "{file}/x.toml"], "--file cannot write {file}/x.toml: {file} is a file"),
])
def test_output_paths_are_checked_before_any_work_with_the_real_problem(tmp_path, capsys, monkeypatch, argv, words):
    """A parent that is a file (as /etc/passwd/x), a folder that cannot be made (/proc): named in
    one line before the command does anything -- calibrate before its walk-through."""
    import io

    import numpy as np

    monkeypatch.setattr("sys.stdin", io.StringIO("1500\n" * 20))  # calibrate would take these
    blocker = tmp_path / "file"
    blocker.write_text("")
    (tmp_path / "frames").mkdir()
    np.save(tmp_path / "frames" / "a.npy", np.full((240, 320, 3), 90, np.uint8))
    paths = {"file": blocker, "frames": tmp_path / "frames"}
    argv = [a.format(**paths) for a in argv]
    t0 = time.monotonic()
    assert main(argv) == 1
    out, err = capsys.readouterr()
    assert err.strip() == f"roar {argv[0]}: error: {words.format(**paths)}" or words.format(**paths) in err, err
    assert "\n" not in err.strip() and out == "" and time.monotonic() - t0 < 5


@pytest.mark.parametrize("argv, words", [
    (["track", "drag:nan"], "length must be a finite number 10..100 m, got nan"),
    (["track", "drag:1e3"], "length must be a finite number 10..100 m, got 1000"),
    (["track", "random:1000000000000000001"], "a whole number 0..10^18"),
    (["track", "random:3,width=1,width=2.2"], "parameter 'width' given twice"),
    (["track", "tunnel:3,cones=1,cones=2"], "parameter 'cones' given twice"),
    (["send", "loop://", "--throttle", "-inf"], "throttle must be a finite number -1..1, got -inf"),
    (["send", "loop://", "--steering", "-1e308"], "steering must be a finite number -1..1"),
    (["race", "--start-lights", "-1"], "--start-lights: must be a whole number 0..10^18"),
    (["race", "--shaky-camera", "-3"], "--shaky-camera: must be a whole number 0..10^18"),
])
def test_each_message_names_the_range_that_holds(capsys, argv, words):
    assert words in one_line_error(capsys, *argv)


def test_the_largest_seed_a_message_allows_is_taken(capsys):
    assert main(["track", "random:1000000000000000000"]) == 0


def test_a_map_number_written_without_a_dot_is_a_number_as_ros_reads_it(tmp_path, capsys):
    """YAML 1.1 reads `1e9` as text; ROS's map_server reads a number, and so does roar."""
    from PIL import Image

    Image.new("L", (20, 20), 255).save(tmp_path / "m.png")
    (tmp_path / "far.yaml").write_text("image: m.png\nresolution: 5e-2\norigin: [1e9, 0.0, 0.0]\n")
    assert "puts the map 1000000000 m from the world's origin" in one_line_error(capsys, "track", str(tmp_path / "far.yaml"))


def test_a_race_served_to_foxglove_runs_in_real_time_and_says_where(tmp_path):
    """--foxglove without --realtime: the race is paced to the wall clock (else it is over before a
    viewer connects) and says where to connect."""
    from conftest import free_port

    port = free_port()
    start = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "roar.cli", "race", "--laps", "1", "--seconds", "2",
                           "--foxglove", str(port)], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 2, done.stderr  # one lap in 2 s is not driven: the race ran short, as it should
    assert f"ws://127.0.0.1:{port}" in done.stdout and "real time" in done.stdout
    assert time.monotonic() - start >= 2.0


@pytest.mark.parametrize("argv, started", [(["race", "--laps", "1", "--seconds", "3"], "racing oval ..."),
                                           (["challenge", "tunnel:3", "--to", "2", "--oracle"], "challenge tunnel:3 ..."),
                                           (["platoon", "--seconds", "1"], "platoon ...")])
def test_progress_in_a_log_is_one_plain_line_not_carriage_return_frames(argv, started):
    """stderr a file, not a terminal: the run says once that it started, and no bar's frames follow."""
    done = subprocess.run([sys.executable, "-m", "roar.cli", *argv], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode in (0, 2), done.stderr[-2000:]
    assert "\r" not in done.stderr and started in done.stderr.splitlines(), done.stderr[-2000:]


def test_a_missing_folder_is_refused_not_made_except_under_out(tmp_path, capsys, monkeypatch):
    """A typo in a path makes no folder: an output whose folder does not exist is refused in one
    line; under out/ (where the defaults write) the folders are made."""
    typo = tmp_path / "nonexistent" / "dir"
    err = one_line_error(capsys, "track", "oval", "--save", str(typo / "oval.json"))
    assert "its folder" in err and "does not exist" in err and not (tmp_path / "nonexistent").exists()
    err = one_line_error(capsys, "dataset", str(tmp_path / "none.mcap"), "--out", str(typo / "tub"))
    assert "its parent folder" in err and "does not exist" in err and not (tmp_path / "nonexistent").exists()
    assert "does not exist" in one_line_error(capsys, "vision", str(tmp_path / "nonexistent"))
    monkeypatch.chdir(tmp_path)
    assert main(["track", "oval", "--save", "out/tracks/oval.json"]) == 0
    assert (tmp_path / "out" / "tracks" / "oval.json").is_file()


def test_recording_into_a_name_that_is_not_mcap_says_so(tmp_path, capsys):
    code = main(["record", "loop://", "--out", str(tmp_path / "run.png"), "--for", "0.1"])
    err = capsys.readouterr().err
    assert code == 0 and "does not end in .mcap" in err
