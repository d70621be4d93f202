"""Every run on the record: roar.recorder's MCAP files read back by the mcap library (and their
Foxglove messages decoded from the file's own schemas), Vehicle(record=...) on the simulator and
over a pty serial link, `roar record` stopped mid-run by Ctrl-C and SIGTERM leaving a file every
reader opens, and `roar replay`'s summary and its one-line refusals."""

import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import ROOT, free_port, served

pytest.importorskip("foxglove", reason="pip install foxglove-sdk (the project's record extra)")
pytest.importorskip("mcap", reason="pip install mcap (the project's record extra)")

from mcap.reader import make_reader  # noqa: E402

from roar.protocol import encode  # noqa: E402
from roar.recorder import Recorder  # noqa: E402
from roar.replay import ReplayError, messages, read_log, summary  # noqa: E402
from roar.telemetry import VehicleState  # noqa: E402

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)


def counts(path) -> dict[str, int]:
    with open(path, "rb") as f:
        s = make_reader(f).get_summary()
        return {c.topic: s.statistics.channel_message_counts[i] for i, c in s.channels.items()}


def test_each_kind_of_message_reads_back_in_foxglove_types(tmp_path):
    path = tmp_path / "run.mcap"
    rgb = np.zeros((120, 160, 3), np.uint8)
    rgb[:, :80] = (255, 120, 0)  # orange left half
    with Recorder(path, {"car": "test://", "track": "oval"}, simulated=True) as rec:
        rec.control(encode(1600, 1400), 1_000)
        rec.control(b"[1200,1500]\n", 2_000)  # a speed setpoint
        rec.control(b"?\n", 3_000)  # not one: kept as text
        rec.line("READY 2", 4_000)
        rec.line("ERR range", 5_000)
        rec.line("TEL autonomous none 7400 0 1234 800 1000 1580 1500 -200 500 100 0 300 0", 6_000)
        rec.state(VehicleState(time_s=0.5, x_m=1.0, y_m=2.0, yaw_rad=math.pi / 2, speed_m_s=0.7), 7_000)
        rec.scan([1.0, 2.0, float("inf"), 10.0], -1.0, 1.0, 8_000)
        rec.image(rgb, 9_000)
        rec.image(rgb, 10_000)
    got = {}
    for topic, t, m in messages(path):
        got.setdefault(topic, []).append((t, m))
    control = [m for _, m in got["/control"]]
    assert control[0] == {"text": "(1600,1400)", "result": "ok", "throttle_us": 1600, "steering_us": 1400}
    assert control[1]["result"] == "setpoint" and control[1]["speed_mm_s"] == 1200
    assert control[2]["text"] == "?" and "throttle_us" not in control[2]
    lines = [m for _, m in got["/car/lines"]]
    assert [m.message for m in lines] == ["READY 2", "ERR range", "TEL autonomous none 7400 0 1234 800 1000 1580 1500 -200 500 100 0 300 0"]
    (_, telemetry), = got["/car/telemetry"]
    assert telemetry["mode"] == "autonomous" and telemetry["battery_v"] == 7.4 and telemetry["pid_gains_pm"] == [500, 100, 0, 300]
    assert lines[1].level == 4 and lines[0].level == 2  # foxglove.LogLevel ERROR, INFO
    (_, pose), = got["/car/pose"]
    assert pose.frame_id == "world" and (pose.pose.position.x, pose.pose.position.y) == (1.0, 2.0)
    assert 2 * math.atan2(pose.pose.orientation.z, pose.pose.orientation.w) == pytest.approx(math.pi / 2)
    (_, tf), = got["/tf"]
    assert (tf.parent_frame_id, tf.child_frame_id) == ("world", "base_link")
    (_, state), = got["/car/state"]
    assert state == {"time_s": 0.5, "x_m": 1.0, "y_m": 2.0, "yaw_rad": pytest.approx(math.pi / 2), "speed_m_s": 0.7}
    (t, scan), = got["/lidar"]
    assert t == 8_000 and list(scan.ranges) == [1.0, 2.0, float("inf"), 10.0]  # as the sensor gave them
    assert len(got["/camera/image"]) == 2 and len(got["/camera/calibration"]) == 1  # calibration once per size
    import cv2

    jpeg = got["/camera/image"][0][1]
    assert jpeg.format == "jpeg"
    back = cv2.imdecode(np.frombuffer(jpeg.data, np.uint8), cv2.IMREAD_COLOR)[:, :, ::-1]
    assert np.abs(back.astype(int) - rgb).mean() < 4
    log = read_log(path)
    assert log.metadata["run"]["car"] == "test://" and log.metadata["run"]["clock"] == "simulated"
    assert log.messages == 14 and log.duration_s == pytest.approx(9e-6)


def test_a_vehicle_records_what_it_sends_and_hears_in_simulated_time(tmp_path):
    from roar import Vehicle

    path = tmp_path / "run.mcap"
    with Vehicle("sim://oval?speedup=2", record=path) as car:
        car.drive(0.3, -0.5)
        time.sleep(0.6)
        car.lidar()
        car.camera(160, 120)
        pulses = car.pulses_us()
        car.drive(0.0, 0.0)
        time.sleep(0.2)
    control = [m for _, _, m in messages(path, ["/control"])]
    assert {"throttle_us": pulses[0], "steering_us": pulses[1]}.items() <= control[len(control) // 2].items() or \
        any(m.get("throttle_us") == pulses[0] and m.get("steering_us") == pulses[1] for m in control)
    assert control[-1]["throttle_us"] == 1500  # the neutral sent at close
    assert len(control) >= 20  # re-sent at 50 Hz, every one recorded
    states = [m for _, _, m in messages(path, ["/car/state"])]
    times = [t for _, t, _ in messages(path, ["/car/state"])]
    assert times == sorted(times) and all(t == round(s["time_s"] * 1e9) for t, s in zip(times, states))
    assert max(s["x_m"] for s in states) != min(s["x_m"] for s in states)  # it drove
    c = counts(path)
    assert c["/lidar"] == 1 and c["/camera/image"] == 1 and c["/car/lines"] >= 1
    assert any(m.message.startswith("READY") for _, _, m in messages(path, ["/car/lines"]))
    log = read_log(path)
    assert log.metadata["run"]["clock"] == "simulated" and log.metadata["car"]["protocol_version"] == "1"


def test_a_simulated_links_messages_before_its_first_step_are_not_stamped_on_another_clock(tmp_path):
    """A sim:// link whose simulator has not stepped yet: what is written then is at simulated
    time 0, not on the host's clock, which (the simulator slipping behind a busy host) sorted it
    among later messages and made a neutral appear between two commands in replay."""
    from roar.transports.recording import RecordingTransport, RunClock

    class NotYetStepped:
        scheme = "sim"
        state_now = None

        def write(self, data):
            pass

        def state(self):
            return self.state_now

    inner, path = NotYetStepped(), tmp_path / "run.mcap"
    link = RecordingTransport(inner, Recorder(path, simulated=True), RunClock(inner))
    link.write(encode(1500, 1500))
    time.sleep(0.05)  # the host's clock runs on; the simulator has not started
    inner.state_now = VehicleState(time_s=0.002, x_m=0.0, y_m=0.0, yaw_rad=0.0)
    link.write(encode(1600, 1500))
    link.recorder.close()
    stamped = [(t, m["throttle_us"]) for _, t, m in messages(path, ["/control"])]
    assert stamped == [(0, 1500), (2_000_000, 1600)]


def test_recording_starts_and_stops_mid_run_into_finished_files(tmp_path):
    from roar import Vehicle

    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    with Vehicle("loop://") as car:
        car.drive(0.2, 0.0)
        assert car.flush()
        before = len(car.transport.writes)
        assert car.record(first) is car.recorder
        car.drive(0.4, 0.0)
        time.sleep(0.2)
        car.record(second)  # the first is finished, the second begins
        car.drive(-0.4, 0.0)
        time.sleep(0.2)
        assert car.record(None) is None and car.recorder is None
        car.drive(0.0, 0.0)
        time.sleep(0.1)
        after = len(car.transport.link.writes)
    got = {p: [m["throttle_us"] for _, _, m in messages(p, ["/control"])] for p in (first, second)}
    assert got[first] and set(got[first]) == {1700}  # nothing from before it started
    assert got[second] and set(got[second]) == {1300}  # nothing after it stopped
    assert before > 0 and after > before + len(got[first]) + len(got[second])  # the link saw every message


def test_a_car_over_a_serial_link_is_recorded_on_the_hosts_clock(pty_car, tmp_path):
    from roar import Vehicle

    path = tmp_path / "run.mcap"
    start = time.monotonic_ns()
    with Vehicle(f"serial://{pty_car.path}", record=path) as car:
        car.drive(0.2, 0.0)
        assert car.wait_for(timeout_s=3.0, since=0.0) is not None  # whenever it said it (maybe before now)
        time.sleep(0.3)
    heard = list(car.replies)
    took = time.monotonic_ns() - start
    log = read_log(path)
    run = log.metadata["run"]
    assert run["clock"] == "monotonic" and abs(int(run["wall_clock_offset_ns"]) - (time.time_ns() - time.monotonic_ns())) < 5e9
    assert 0 < log.duration_s <= took / 1e9
    lines = [m.message for _, _, m in messages(path, ["/car/lines"])]
    assert lines and lines == heard  # every line the car sent, in order
    control = [m for _, _, m in messages(path, ["/control"])]
    assert any(m.get("throttle_us", 1500) > 1500 for m in control) and control[-1]["throttle_us"] == 1500


def roar(*args, **kwargs):
    return subprocess.Popen([sys.executable, "-m", "roar.cli", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **kwargs)


@pytest.mark.parametrize("how", [signal.SIGINT, signal.SIGTERM])
def test_a_recording_stopped_mid_run_is_a_finished_file(tmp_path, how):
    path = tmp_path / "run.mcap"
    proc = roar("record", "sim://oval", "--out", str(path), "--for", "60")
    deadline = time.monotonic() + 60
    while "recording" not in (line := proc.stdout.readline()) and time.monotonic() < deadline:
        assert line, proc.stderr.read()
    time.sleep(1.0)
    proc.send_signal(how)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + how, err
    assert "Traceback" not in err
    with open(path, "rb") as f:  # the summary and index are there: a seeking reader opens it
        reader = make_reader(f)
        assert reader.get_summary() is not None and reader.get_summary().statistics.message_count > 20
    log = read_log(path)
    assert log.channels["/control"].count > 20 and log.metadata["run"]["command"].startswith(sys.executable) is False
    assert "record sim://oval" in log.metadata["run"]["command"]


def test_a_channel_that_spoke_twice_in_a_long_run_shows_a_low_rate_and_a_long_silence(tmp_path):
    """Two lines 20 ms apart in a 12.6 s recording are 0.2 Hz with a 12.6 s silence, not 50 Hz."""
    path = tmp_path / "run.mcap"
    with Recorder(path) as rec:
        for k in range(631):  # 12.6 s of control messages at 50 Hz
            rec.control(encode(1500, 1500), k * 20_000_000)
        rec.line("READY 1", 0)
        rec.line("ARMED", 20_000_000)
    row = next(line for line in summary(path).splitlines() if line.strip().startswith("/car/lines"))
    rate, silence = float(row.split("Hz")[0].split()[-1]), float(row.split("Hz")[1].split()[0])
    assert rate == pytest.approx(2 / 12.6, abs=0.05) and silence == pytest.approx(12.58, abs=0.01), row


def test_roar_record_and_replay_summarise_a_run(tmp_path):
    path = tmp_path / "run.mcap"
    done = subprocess.run([sys.executable, "-m", "roar.cli", "record", "sim://oval", "--out", str(path), "--for", "1"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "recorded" in done.stdout and str(path) in done.stdout
    out = summary(path)
    assert "simulated time" in out and "sim://oval" in out
    row = next(line for line in out.splitlines() if line.strip().startswith("/control"))
    rate = float(row.split("Hz")[0].split()[-1])
    assert 40 <= rate <= 60  # re-sent at 50 Hz of the car's time
    shown = subprocess.run([sys.executable, "-m", "roar.cli", "replay", str(path)], capture_output=True, text=True,
                           timeout=60)
    assert shown.returncode == 0 and shown.stdout.strip() == out


def foreign(path):
    from mcap.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        schema = w.register_schema("pose", "jsonschema", b"{}")
        channel = w.register_channel("/odom", "json", schema)
        w.add_message(channel, 1, json.dumps({"x": 1}).encode(), 1)
        w.finish()


@pytest.mark.parametrize("make, says", [
    (lambda p: None, "no such file"),
    (lambda p: p.write_bytes(b""), "empty"),
    (lambda p: p.write_text("hello"), "not an MCAP file"),
    (foreign, "not a roar recording"),
    ("cut", "cut off"),
])
def test_replay_refuses_what_is_not_a_recording_in_one_line(tmp_path, make, says):
    path = tmp_path / "bad.mcap"
    if make == "cut":
        good = tmp_path / "good.mcap"
        with Recorder(good) as rec:
            for k in range(3000):
                rec.scan(np.random.default_rng(k).uniform(0, 10, 540), -2.0, 2.0, k * 1000)
        path.write_bytes(good.read_bytes()[: os.path.getsize(good) // 2])
    else:
        make(path)
    with pytest.raises(ReplayError, match=says):
        read_log(path)
    shown = subprocess.run([sys.executable, "-m", "roar.cli", "replay", str(path)], capture_output=True, text=True,
                           timeout=60)
    assert shown.returncode == 1 and says in shown.stderr and len(shown.stderr.strip().splitlines()) == 1


def test_a_recording_that_cannot_be_made_is_one_line_and_drives_nothing(tmp_path):
    (tmp_path / "a_file").write_text("not a folder")
    done = subprocess.run([sys.executable, "-m", "roar.cli", "record", "sim://oval", "--out",
                           str(tmp_path / "a_file" / "run.mcap"), "--for", "1"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_a_race_on_the_filters_pose_records_what_only_the_simulator_knows(tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.tracks import get
    from roar_sim.runs.localize import Localize
    from roar_sim.runs.race import race

    path = tmp_path / "race.mcap"
    track = get("tunnel:5,cones=0")
    race(track, laps=1, timeout_s=3.0, localize=Localize(track, particles=500), log=path)
    log = read_log(path)
    assert log.metadata["run"]["clock"] == "simulated" and log.metadata["run"]["car"] == "sim://?robot=esc"
    c = log.channels
    periods = c["/sim/firmware"].count
    assert 140 <= periods <= 152 and c["/sim/firmware"].rate_hz == pytest.approx(50, abs=0.5)  # 3 s at 50 Hz
    assert c["/control"].count >= periods and c["/lidar"].rate_hz == pytest.approx(25, abs=0.5)
    assert c["/localization/particles"].rate_hz == pytest.approx(5, abs=0.3)
    for name in ("/sim/true_pose", "/localization/pose", "/sim/contacts", "/car/state", "/tf"):
        assert c[name].count == periods, name
    firmware = [m for _, _, m in messages(path, ["/sim/firmware"])]
    sent = [m for _, _, m in messages(path, ["/control"])]
    assert firmware[-1]["throttle_us"] in {m["throttle_us"] for m in sent[-3:]}  # what it was sent, it outputs
    assert {"brake_phase", "source", "latched", "braking"} <= firmware[-1].keys() and firmware[-1]["source"] == "host"
    truth = [(m.pose.position.x, m.pose.position.y) for _, _, m in messages(path, ["/sim/true_pose"])]
    estimate = [(m.pose.position.x, m.pose.position.y) for _, _, m in messages(path, ["/localization/pose"])]
    assert max(math.dist(a, b) for a, b in zip(truth, estimate)) < 0.3
    assert math.dist(truth[0], truth[-1]) > 1.0  # it drove
    clouds = [m for _, _, m in messages(path, ["/localization/particles"])]
    assert all(len(m.poses) == 300 for m in clouds)
    scan = next(m for _, _, m in messages(path, ["/lidar"]))
    assert scan.end_angle - scan.start_angle == pytest.approx(math.radians(270), abs=0.01)
    assert not any(m["cone"] or m["person"] for _, _, m in messages(path, ["/sim/contacts"]))


CLIENT = ROOT / "tests" / "foxglove_client"


def foxglove_client(port: int, topics: list[str], count: int, seconds: float = 30.0) -> tuple[dict, dict]:
    """What the npm @foxglove/ws-protocol client (tests/foxglove_client/client.mjs) saw:
    (advertised channels by topic, the messages it received by topic)."""
    import shutil

    if shutil.which("node") is None or not (CLIENT / "node_modules" / "@foxglove" / "ws-protocol").exists():
        pytest.skip("the Foxglove client needs Node.js and `npm ci` in tests/foxglove_client (make test does both)")
    done = subprocess.run(["node", str(CLIENT / "client.mjs"), f"ws://127.0.0.1:{port}", ",".join(topics), str(count),
                           str(seconds)], capture_output=True, text=True, timeout=seconds + 30)
    events = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    assert done.returncode == 0, (done.stdout[-2000:], done.stderr[-2000:])
    advertised, got = {}, {}  # (a server may advertise its channels in several messages, as they begin)
    for e in events:
        if "advertised" in e:
            advertised.update({c["topic"]: c for c in e["advertised"]})
        else:
            got.setdefault(e["topic"], []).append(e)
    return advertised, got


def test_a_served_car_is_live_in_an_independent_foxglove_client(tmp_path):
    from roar import Vehicle

    port = free_port()
    with served("--serial", "--foxglove", str(port), "--seconds", "60", lines=2) as said:
        path = said[0].split(" on ")[1].split(" ")[0]
        assert "ws://127.0.0.1" in said[1]
        with Vehicle(f"serial://{path}") as car:
            car.send_pulses(1600, 1300)
            assert car.flush(2.0)
            time.sleep(0.1)  # the simulator has it (its pty pumped)
            advertised, got = foxglove_client(port, ["/control", "/sim/firmware", "/car/state", "/car/pose"], 25)
    assert advertised["/car/pose"]["schemaName"] == "foxglove.PoseInFrame"
    assert advertised["/sim/firmware"]["encoding"] == "json"
    assert all(len(got[t]) == 25 for t in ("/control", "/sim/firmware", "/car/state", "/car/pose"))
    said = [(e["json"].get("throttle_us"), e["json"].get("steering_us")) for e in got["/control"]]
    assert said[-10:] == [(1600, 1300)] * 10, [(e["logTime"], e["json"]["text"]) for e in got["/control"]]  # as the firmware got it
    assert [int(e["logTime"]) for e in got["/control"]] == sorted(int(e["logTime"]) for e in got["/control"])
    assert got["/sim/firmware"][-1]["json"]["source"] == "host"
    assert all(e["json"]["time_s"] > 0 for e in got["/car/state"]) and all(e["bytes"] > 0 for e in got["/car/pose"])


def test_a_race_against_other_cars_is_live_in_foxglove_and_ends_at_ctrl_c():
    """roar race --opponents 1 --foxglove PORT: the opponent's own channels and the cars the ego
    tracks, served while it races in real time; Ctrl-C ends it within 2 s."""
    import socket

    port = free_port()
    race = subprocess.Popen([sys.executable, "-m", "roar.cli", "race", "--opponents", "1", "--track", "oval",
                             "--laps", "1", "--foxglove", str(port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # the server starts once the racing line is computed
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                assert race.poll() is None, race.communicate()
                time.sleep(0.2)
        time.sleep(1.0)  # the race's first periods: every channel advertised
        topics = ["/race/car_1/pose", "/race/car_1/firmware", "/racing/tracked", "/race/standings"]
        advertised, got = foxglove_client(port, topics, 10)
    finally:
        race.send_signal(signal.SIGINT)
        start = time.monotonic()
        out, err = race.communicate(timeout=30)
    assert time.monotonic() - start < 2.0 and "Traceback" not in err, err
    assert f"ws://127.0.0.1:{port}" in out
    assert advertised["/racing/tracked"]["schemaName"] == "foxglove.PosesInFrame"
    assert all(len(got[t]) == 10 for t in topics)
    assert got["/race/car_1/firmware"][-1]["json"]["source"] == "host"
    assert len(got["/race/standings"][-1]["json"]["positions"]) == 2


@pytest.mark.parametrize("metadata, track", [({"car": "sim://oval"}, "oval"), ({"car": "sim://?track=random:3"}, "random:3"),
                                             ({"car": "sim://", "track": "figure-eight"}, "figure-eight"),
                                             ({"car": "sim://"}, None), ({"car": "serial:///dev/ttyUSB0"}, None),
                                             ({"car": "sim:///nowhere/gone.json"}, None)])
def test_a_recordings_plot_draws_the_track_the_file_names(tmp_path, metadata, track):
    from roar.replay import _track_of, plot, read_log

    path = tmp_path / "run.mcap"
    with Recorder(path, metadata, simulated=True) as rec:
        rec.control(encode(1500, 1500), 0)
    found = _track_of(read_log(path))
    assert (found.name if found is not None else None) == track
    plot(path, tmp_path / "run.png")  # drawn, with or without a track
    assert (tmp_path / "run.png").stat().st_size > 5_000


def test_replay_plots_a_run_and_plays_its_commands_to_a_car(tmp_path):
    from roar import Vehicle
    from roar.replay import commands

    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    with Vehicle("sim://oval", record=first) as car:
        assert car.wait_for(timeout_s=10.0, since=0.0) is not None  # up (until then the library holds neutral)
        for throttle_us, steering_us in ((1600, 1500), (1650, 1300), (1500, 1700)):
            car.send_pulses(throttle_us, steering_us)
            time.sleep(0.4)
    recorded = commands(first)
    said = [(m["throttle_us"], m["steering_us"]) for _, m in recorded]
    assert said[-4:] == [(1600, 1500), (1650, 1300), (1500, 1700), (1500, 1500)] and len(said) <= 5  # (neutral first?)
    done = subprocess.run([sys.executable, "-m", "roar.cli", "replay", str(first), "--plot", str(tmp_path / "p.png"),
                           "--to", "sim://oval"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert f"played {len(said)} commands" in done.stdout and (tmp_path / "p.png").stat().st_size > 10_000
    # played again into a recording of its own: the same commands, at the same moments
    from roar.replay import play

    with Vehicle("sim://oval", record=second) as car:
        play(first, car)
    again = commands(second)
    assert [m["throttle_us"] for _, m in again] == [m["throttle_us"] for _, m in recorded]
    assert all(abs(a - b) < 0.15 for (a, _), (b, _) in zip(again, recorded))


def test_a_signed_run_records_the_wire_and_what_the_script_asked_and_replays_re_signed(tmp_path):
    """With signing on, /wire/control holds what went on the link (signed, with the signing
    layer's own neutral) and /control what the script asked; replay plays the asked commands,
    re-signed by the replaying Vehicle, and the keyed car takes them (the recorded signatures
    would be refused as replays)."""
    from roar import Vehicle
    from roar.replay import commands, play

    key = bytes(range(16))
    url = f"sim://?eeprom={tmp_path / 'car.eeprom'}"
    with Vehicle(url, key=False) as car:  # put the key in the simulated car over its serial link
        car.transport.link.write(f"\nKEY {key.hex()}\n".encode())
        assert car.wait_for(timeout_s=5.0, since=0.0) is not None
        time.sleep(0.3)
    path = tmp_path / "signed.mcap"
    with Vehicle(url, key=key, record=path) as car:
        time.sleep(0.3)
        car.send_pulses(1600, 1500)
        time.sleep(0.4)
        assert car.signer.session and car.errors == 0
    asked = [m for _, _, m in messages(path, ["/control"])]
    on_wire = [m for _, _, m in messages(path, ["/wire/control"])]
    assert asked and all(m["text"].count(",") == 1 for m in asked)  # (T,S): as the script asked
    signed = [m for m in on_wire if m["text"].count(",") == 3]  # (T,S,COUNTER,MAC), as the car took them
    assert signed and {m["text"].split(",")[0] for m in signed} >= {"(1600", "(1500"}
    assert len(on_wire) > len(asked)  # the unsigned probe before the session was known, and the signer's neutral
    lines = [m.message for _, _, m in messages(path, ["/car/lines"])]
    assert any(line.startswith("SESSION ") for line in lines)  # the handshake is on the record
    recorded = commands(path)
    assert [(m["throttle_us"], m["steering_us"]) for _, m in recorded][-2:] == [(1600, 1500), (1500, 1500)]
    with Vehicle(url, key=key) as car:
        assert play(path, car) == len(recorded)
        assert car.errors == 0 and car.signer.refused == 0  # re-signed: taken


def test_replay_to_a_real_car_asks_first(tmp_path):
    path = tmp_path / "run.mcap"
    with Recorder(path) as rec:
        rec.control(encode(1600, 1500), 0)
    done = subprocess.run([sys.executable, "-m", "roar.cli", "replay", str(path), "--to", "serial:///dev/roar-none"],
                          capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert done.returncode == 1 and "--yes" in done.stderr and len(done.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("url, words", [("nonsense://x", "unknown URL scheme 'nonsense://'"),
                                         ("serial://", "needs a port"), ("sim://?speedup=9", "speedup")])
def test_replay_refuses_a_url_that_names_no_car_before_asking_anything(tmp_path, url, words):
    path = tmp_path / "run.mcap"
    with Recorder(path) as rec:
        rec.control(encode(1600, 1500), 0)
    done = subprocess.run([sys.executable, "-m", "roar.cli", "replay", str(path), "--to", url],
                          capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert done.returncode == 1 and words in done.stderr and "real car" not in done.stderr, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


@pytest.fixture(scope="module")
def with_frames(tmp_path_factory):
    """A recorded drive of the simulated car with 160x120 camera frames, the steering swept."""
    from roar import Vehicle

    path = tmp_path_factory.mktemp("frames") / "run.mcap"
    with Vehicle("sim://oval", record=path) as car:
        assert car.wait_for(timeout_s=10.0, since=0.0) is not None  # the car is up (whenever it said so)
        for k in range(12):
            car.send_pulses(1600, 1300 + 40 * k)
            assert car.flush(1.0)
            car.camera(160, 120)
    return path


def test_a_recording_becomes_a_donkeycar_tub_its_own_reader_loads(with_frames, tmp_path):
    import shutil

    from roar.dataset import frames

    expected = [(round(a, 6), round(th, 6)) for _, _, a, th in frames(with_frames)]
    assert len(expected) == 12 and expected[-1] == (round((1300 + 440 - 1500) / 500, 6), 0.2)
    tub = tmp_path / "tub"
    done = subprocess.run([sys.executable, "-m", "roar.cli", "dataset", str(with_frames), "--out", str(tub)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "12 frames" in done.stdout, done.stderr
    donkey = ROOT / ".venv-donkey" / "bin" / "python"
    if not donkey.exists() or shutil.which("python3.11") is None:
        pytest.skip("DonkeyCar's reader needs .venv-donkey (make test makes it with python3.11: pip install "
                    "donkeycar==5.3.0 'numpy<2')")
    read = subprocess.run([str(donkey), str(ROOT / "tests" / "donkey" / "read_tub.py"), str(tub)],
                          capture_output=True, text=True, timeout=120)
    line = next((x for x in read.stdout.splitlines() if x.startswith("TUB ")), None)
    assert read.returncode == 0 and line, read.stderr[-2000:]
    got = json.loads(line[4:])
    assert got["len"] == 12 and got["inputs"] == ["cam/image_array", "user/angle", "user/throttle", "user/mode"]
    assert [(round(r["user/angle"], 6), round(r["user/throttle"], 6)) for r in got["records"]] == expected
    assert all(r["image_size"] == [160, 120] and r["user/mode"] == "user" for r in got["records"])
    assert [r["_index"] for r in got["records"]] == list(range(12))
    stamps = [r["_timestamp_ms"] for r in got["records"]]
    assert stamps == sorted(stamps) and stamps[-1] - stamps[0] < 60_000  # the run's own times


def test_a_recording_becomes_arrays_for_pytorch(with_frames, tmp_path):
    out = tmp_path / "run.npz"
    done = subprocess.run([sys.executable, "-m", "roar.cli", "dataset", str(with_frames), "--format", "npz", "--out",
                           str(out)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    data = np.load(out)
    assert data["images"].shape == (12, 120, 160, 3) and data["images"].dtype == np.uint8
    assert data["angle"].tolist() == pytest.approx([(1300 + 40 * k - 1500) / 500 for k in range(12)])
    assert np.all(np.diff(data["t_s"]) > 0)
    example = subprocess.run([sys.executable, str(ROOT / "examples" / "dataset_npz.py"),
                              str(out)], capture_output=True, text=True, timeout=120)
    assert example.returncode == 0 and "12 frames" in example.stdout, example.stderr


def test_a_recording_without_frames_is_no_dataset(tmp_path):
    path = tmp_path / "run.mcap"
    with Recorder(path) as rec:
        rec.control(encode(1600, 1500), 0)
    done = subprocess.run([sys.executable, "-m", "roar.cli", "dataset", str(path), "--out", str(tmp_path / "tub")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and "no camera frames" in done.stderr and len(done.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("robot, firmware_keys", [("esc", {"throttle_us", "brake_phase", "source", "esc_mode"}),
                                                   ("iarrc", {"throttle_us", "setpoint_mm_s", "esc_mode"}),
                                                   ("junior", {"duty_permille"})])
def test_every_robots_race_is_recorded_with_its_own_firmware(robot, firmware_keys, tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.tracks import get
    from roar_sim.runs.race import race

    path = tmp_path / "race.mcap"
    race(get("oval"), laps=1, robot=robot, timeout_s=2.0, log=path)
    log = read_log(path)
    assert log.metadata["run"]["car"] == f"sim://?robot={robot}"
    assert log.channels["/sim/firmware"].rate_hz == pytest.approx(50, abs=0.5)
    firmware = [m for _, _, m in messages(path, ["/sim/firmware"])]
    assert firmware_keys <= firmware[-1].keys()
    control = [m for _, _, m in messages(path, ["/control"])]
    assert control and {m["result"] for m in control} == {"esc": {"ok"}, "iarrc": {"setpoint"},
                                                          "junior": {"fractions"}}[robot]
    states = [m for _, _, m in messages(path, ["/car/state"])]
    assert math.dist((states[0]["x_m"], states[0]["y_m"]), (states[-1]["x_m"], states[-1]["y_m"])) > 0.5  # it drove


def test_a_speed_car_is_recorded_with_its_setpoints_and_telemetry(tmp_path):
    from roar import Vehicle

    path = tmp_path / "run.mcap"
    with Vehicle("sim://?robot=iarrc", record=path) as car:
        car.drive(speed=1.0, steering=0.2)
        time.sleep(1.0)
    setpoints = [m for _, _, m in messages(path, ["/control"]) if m.get("result") == "setpoint"]
    assert {m["speed_mm_s"] for m in setpoints} >= {0, 1000} and setpoints[-1]["speed_mm_s"] == 0  # zero at close
    telemetry = [m for _, _, m in messages(path, ["/car/telemetry"])]
    assert telemetry and {"mode", "battery_v", "speed_m_s", "pid_gains_pm"} <= telemetry[-1].keys()
    assert read_log(path).metadata["car"]["protocol_version"] == "2"


def test_a_recorded_filter_replays_open_loop_bit_for_bit(tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.replay import localize
    from roar.tracks import get
    from roar_sim.runs.localize import Localize
    from roar_sim.runs.race import race
    from roar_sim.world.scene import world_map

    path = tmp_path / "race.mcap"
    track = get("tunnel:2,cones=0,people=4")
    race(track, laps=1, timeout_s=4.0, localize=Localize(track, particles=400), log=path)
    pairs = localize(path, world_map(track))  # the map the race localized on
    assert len(pairs) >= 195
    assert all(recorded == replayed for recorded, replayed in pairs)  # the same floats, not nearly
    assert len({p for p, _ in pairs}) > 100  # it moved: not a pose compared with itself


def test_roar_vision_reads_a_recordings_camera_frames(with_frames, tmp_path):
    done = subprocess.run([sys.executable, "-m", "roar.cli", "vision", str(with_frames), "--out", str(tmp_path / "v")],
                          capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if " at " in line and ": lines " in line]
    assert len(rows) == 12 and "12 frames" in done.stdout
    assert sum("lines none" not in row for row in rows) >= 10  # the oval's lines, seen from the recording
    assert len(list((tmp_path / "v").glob("*_lanes.png"))) == 12


def test_a_lane_driver_race_records_its_frames_and_what_it_saw_in_them(tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.tracks import get
    from roar_sim.runs.race import race

    path = tmp_path / "lane.mcap"
    race(get("oval"), laps=1, lateral="lane", timeout_s=1.0, log=path)
    c = read_log(path).channels
    frames = c["/camera/image"].count
    assert frames >= 45 and c["/perception/lanes"].count == frames and c["/autopilot/state"].count >= frames
    seen = [m for _, _, m in messages(path, ["/perception/lanes"])]
    assert sum(m["lines"] != "none" for m in seen) >= frames - 2 and all("offset_m" in m for m in seen)
    from roar.autopilot.lane_agent import LaneState

    states = [m["state"] for _, _, m in messages(path, ["/autopilot/state"])]
    assert set(states) <= {s.value for s in LaneState} and states[-1] == LaneState.FOLLOWING.value


@pytest.mark.parametrize("robot", ["iarrc", "junior"])
def test_every_robots_drive_becomes_a_dataset(robot, tmp_path):
    from roar import Vehicle
    from roar.dataset import frames
    from roar.protocol import spec

    path = tmp_path / "run.mcap"
    with Vehicle(f"sim://?robot={robot}", record=path) as car:
        for k in range(4):
            if robot == "iarrc":
                car.drive(speed=0.5 * (k + 1), steering=0.25)
            else:
                car.drive(0.2 * (k + 1), 0.25)
            assert car.flush(1.0)
            car.camera(160, 120)
    rows = list(frames(path))
    assert len(rows) == 4 and all(rgb.shape == (120, 160, 3) for _, rgb, _, _ in rows)
    assert all(a == pytest.approx(0.25, abs=0.01) for _, _, a, _ in rows)
    want = [500 * (k + 1) / spec.SETPOINT_MAX_SPEED_MM_S for k in range(4)] if robot == "iarrc" else \
        [0.2 * (k + 1) for k in range(4)]
    assert [th for _, _, _, th in rows] == pytest.approx(want, abs=0.01)


def test_the_drag_race_is_recorded_too(tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.tracks import get
    from roar_sim.runs.drag import drag_race

    path = tmp_path / "drag.mcap"
    drag_race(get("drag:20"), top_speed_m_s=3.0, timeout_s=2.0, log=path)
    c = read_log(path).channels
    assert c["/camera/image"].count == c["/autopilot/state"].count == c["/sim/firmware"].count >= 90
    assert {m["result"] for _, _, m in messages(path, ["/control"])} == {"setpoint"}
    assert c["/car/telemetry"].rate_hz == pytest.approx(10, abs=1.0)  # the IARRC car's TEL lines, 10 Hz


def test_the_iarrc_car_over_a_serial_link_is_recorded_with_setpoints_and_telemetry(tmp_path):
    from roar import Vehicle

    sim = subprocess.Popen([sys.executable, "-m", "roar.cli", "sim", "--serial", "--robot", "iarrc", "--seconds", "60"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    path = tmp_path / "run.mcap"
    try:
        port = sim.stdout.readline().split(" on ")[1].split(" ")[0]
        with Vehicle(f"serial://{port}", record=path) as car:
            car.drive(speed=0.8, steering=0.1)
            time.sleep(1.0)
    finally:
        sim.send_signal(signal.SIGINT)
        sim.communicate(timeout=30)
    log = read_log(path)
    assert log.metadata["run"]["clock"] == "monotonic" and log.metadata["car"]["protocol_version"] == "2"
    setpoints = [m for _, _, m in messages(path, ["/control"]) if m.get("result") == "setpoint"]
    assert 800 in {m["speed_mm_s"] for m in setpoints} and setpoints[-1]["speed_mm_s"] == 0
    telemetry = [m for _, _, m in messages(path, ["/car/telemetry"])]
    assert len(telemetry) >= 5 and telemetry[-1]["mode"] in ("autonomous", "disarmed", "manual", "boot")


def test_the_combined_driver_behind_its_leader_is_recorded(tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.tracks import get
    from roar_sim.runs.combined import combined_race

    path = tmp_path / "combined.mcap"
    combined_race(get("course"), distance_m=3.0, log=path)
    c = read_log(path).channels
    periods = c["/sim/firmware"].count
    assert periods >= 20 and c["/camera/image"].count == c["/autopilot/state"].count == c["/sim/leader"].count == periods
    assert 0 < c["/v2v/leader"].count <= periods
    heard = [(m.pose.position.x, m.pose.position.y) for _, _, m in messages(path, ["/v2v/leader"])]
    truth = [(m.pose.position.x, m.pose.position.y) for _, _, m in messages(path, ["/sim/leader"])]
    assert math.dist(heard[-1], truth[-1]) < 0.5  # what it heard is where the leader was, a few periods ago


def test_a_served_junior_is_live_too(tmp_path):
    from roar import Vehicle

    port, http = free_port(), free_port()
    with served("--robot", "junior", "--http", f"127.0.0.1:{http}", "--foxglove", str(port), "--seconds", "60",
                lines=4) as lines:
        assert any(f"ws://127.0.0.1:{port}" in line for line in lines), lines
        with Vehicle(f"http://127.0.0.1:{http}") as car:
            car.drive(0.5, 0.0)
            time.sleep(0.3)
            _, got = foxglove_client(port, ["/control", "/sim/firmware", "/car/state"], 10)
    assert all(e["json"]["result"] == "http" and e["json"]["text"].startswith("GET /") for e in got["/control"])
    assert any(max(e["json"]["duty_permille"]) > 0 for e in got["/sim/firmware"])  # it drives its motors


def test_the_phone_streaming_car_is_live_too(tmp_path):
    port = free_port()
    ports = [free_port() for _ in range(4)]
    with served("--stream", "--ports", ",".join(map(str, ports)), "--foxglove", str(port), "--seconds", "60",
                "--rate", "10", lines=2) as lines:
        assert any(f"ws://127.0.0.1:{port}" in line for line in lines), lines
        _, got = foxglove_client(port, ["/camera/image", "/sim/firmware", "/car/state"], 5)
    assert all(e["bytes"] > 1000 for e in got["/camera/image"]) and len(got["/car/state"]) == 5



def test_a_recorded_lane_detector_replays_open_loop_bit_for_bit(tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar.replay import lanes
    from roar.tracks import get
    from roar_sim.runs.race import race

    path = tmp_path / "lane.mcap"
    race(get("oval"), laps=1, lateral="lane", timeout_s=2.0, log=path)
    pairs = lanes(path)
    assert len(pairs) >= 95
    assert all(recorded == replayed for recorded, replayed in pairs)  # the same floats, frame by frame
    assert len({r["offset_m"] for r, _ in pairs}) > 20  # it steered: not one frame compared with itself


@pytest.mark.parametrize("robot", ["iarrc", "junior"])
def test_every_robots_recording_plays_back_to_it(robot, tmp_path):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar import Vehicle
    from roar.replay import commands, play
    from roar.tracks import get
    from roar_sim.runs.race import race

    first, second = tmp_path / "race.mcap", tmp_path / "again.mcap"
    # (the Junior, at 0.55 m/s down the oval's straight, steers by a pulse or two in its first second)
    race(get("oval"), laps=1, robot=robot, timeout_s=1.0 if robot == "iarrc" else 3.0, log=first)
    recorded = commands(first)
    assert len(recorded) >= 10
    with Vehicle(f"sim://oval?robot={robot}", record=second) as car:
        if robot == "iarrc":
            assert car.wait_for(timeout_s=10.0, since=0.0) is not None  # it says READY 2: driven by speed
        assert play(first, car) == len(recorded)
    def wire(m):  # what the car is told, as the replaying Vehicle puts it on the wire
        if m["result"] == "setpoint":
            return ("speed", m["speed_mm_s"], m["steering_us"])
        if m["result"] == "fractions":
            return ("pulses", round(1500 + 500 * m["throttle"]), round(1500 + 500 * m["steering"]))
        return ("pulses", m["throttle_us"], m["steering_us"])

    def changes(messages_):  # what the car was told, each change once (neutral and zero speed, the
        out = []  # library's own bookends, left out)
        for w in (wire(m) for m in messages_):
            if w[1:] not in ((1500, 1500), (0, 1500)) and (not out or w != out[-1]):
                out.append(w)
        return out

    def in_order(part, whole):  # part is whole with some left out, nothing added or reordered
        rest = iter(whole)
        return all(any(x == y for y in rest) for x in part)

    want = changes(m for _, m in recorded)
    got = changes(m for _, m in commands(second))
    # the same commands in order, as the car's own link carries them; a command set while the sender
    # was still busy with the one before may be overtaken (the library never queues stale commands)
    assert len(want) >= 5 and in_order(got, want) and len(got) >= len(want) - 2, (got, want)
