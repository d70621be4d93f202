"""roar ros2: the car as a ROS 2 node, driven by plain rclpy nodes in other processes (the
examples a user would write), with the real rclpy from the ROS 2 wheels."""

import itertools
import json
import math
import os
import textwrap
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy", reason="the ROS 2 wheels: pip install 'roar-platform[ros2]'")

from roar.ros2 import interfaces  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ROAR = [sys.executable, "-m", "roar.cli"]
_domains = itertools.count(os.getpid() % 50 * 4 + 10)  # this worker's own ROS domains: no two tests share one


def ros_env() -> dict[str, str]:
    """A fresh ROS domain, discovery on this machine only."""
    return {**os.environ, "ROS_DOMAIN_ID": str(next(_domains)), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}


def needs_types():
    missing = [p for p in interfaces.PACKAGES if not interfaces.available(p)]
    if missing:
        pytest.skip(f"{', '.join(missing)} not built: python -m roar.ros2.interfaces (needs cmake and g++)")


def test_the_built_types_are_the_upstream_types():
    """ackermann_msgs and tf2_msgs as built here hash as the upstream packages' own types: a node
    built against those talks to ours (ROS 2 compares the hashes on discovery)."""
    needs_types()
    for name, expected in interfaces.TYPE_HASHES.items():
        package, _, message = name.split("/")
        described = json.loads((interfaces.prefix() / "share" / package / "msg" / f"{message}.json").read_text())
        assert described["type_hashes"][0] == {"type_name": name, "hash_string": expected}
        assert interfaces.current(package)


UP_S = 60.0  # [s] a bridge that has not said it is up by then has hung: killed, and the test fails


def serve(url: str, *options: str, env: dict[str, str]) -> subprocess.Popen:
    import selectors

    # unbuffered bytes: each readline takes one line off the pipe, so select sees the next one
    bridge = subprocess.Popen([*ROAR, "ros2", url, *options], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, bufsize=0)
    said, end = [], time.monotonic() + UP_S
    with selectors.DefaultSelector() as waiting:  # a hung start fails the test, never the whole suite
        waiting.register(bridge.stdout, selectors.EVENT_READ)
        # lines before it are allowed (a car whose failsafe tripped before the first /drive says so)
        while not (said and "is node /roar" in said[-1]):
            if bridge.poll() is not None or not waiting.select(max(0.0, end - time.monotonic())):
                bridge.kill()
                pytest.fail(f"roar ros2 {url} did not say it is up in {UP_S:g} s: "
                            + "".join(said) + bridge.communicate()[0].decode()[-2000:])
            said.append(bridge.stdout.readline().decode())
    return bridge


EXIT_S = 3.0  # [s] from Ctrl-C to the process's end, its teardown included


def stop(bridge: subprocess.Popen) -> str:
    """Ctrl-C: within a second the car is at neutral and the bridge says what it did; the process
    then ends (the interpreter's own teardown -- rclpy's context, Numba, the simulator -- takes
    ~0.45 s more here, over a second under the suite's load: EXIT_S)."""
    import selectors

    bridge.send_signal(signal.SIGINT)
    start = time.monotonic()
    said = b""
    with selectors.DefaultSelector() as waiting:
        waiting.register(bridge.stdout, selectors.EVENT_READ)
        while b"the car was left at neutral" not in said and time.monotonic() - start < 10:
            if waiting.select(max(0.0, start + 10 - time.monotonic())):
                chunk = bridge.stdout.read(4096)
                if not chunk:
                    break
                said += chunk
    neutral_s = time.monotonic() - start
    try:
        out = said.decode() + bridge.communicate(timeout=10)[0].decode()
    except subprocess.TimeoutExpired:  # killed, not left running through the rest of the suite
        bridge.kill()
        pytest.fail("roar ros2 did not end within 10 s of Ctrl-C: " + bridge.communicate()[0].decode()[-2000:])
    assert neutral_s < 1.0 and time.monotonic() - start < EXIT_S, (neutral_s, time.monotonic() - start, out)
    assert bridge.returncode == 130, out
    assert "the car was left at neutral" in out, out
    return out


def laps_in(trace: Path, track: str = "oval") -> tuple[float, float]:
    """(laps driven along the centre line, the largest distance from it [m]) of a sim:// trace."""
    from roar.tracks import get

    rows = np.loadtxt(trace, delimiter=",", skiprows=1)[:, 1:3]
    moved = np.r_[True, np.any(np.diff(rows, axis=0) != 0, axis=1)]
    t = get(track)
    _, s, cte = t.follow(rows[moved])
    ds = np.diff(s)
    length = t.length_m
    ds = np.where(ds < -length / 2, ds + length, np.where(ds > length / 2, ds - length, ds))
    return float(ds.sum() / length), float(np.abs(cte).max())


def within_walls(cte_m: float) -> bool:
    from roar_sim import robots

    return cte_m < 0.6 - robots.get("esc").half_width_m  # the oval: 0.6 m each side of its centre line


@pytest.mark.realtime
def test_an_f1tenth_pure_pursuit_node_laps_the_oval(tmp_path):
    """A plain rclpy node written for f1tenth_gym_ros (/ego_racecar/odom in, /drive out at 40 Hz)
    drives our simulated car a whole lap, unchanged, against `roar ros2 --f1tenth`."""
    needs_types()
    env, trace, line = ros_env(), tmp_path / "drive.csv", tmp_path / "oval.csv"
    subprocess.run([*ROAR, "track", "oval", "--save", str(line)], check=True, capture_output=True)
    bridge = serve(f"sim://oval?speedup=3&trace={trace}", "--f1tenth", env=env)  # the failsafe: 83 ms of ours
    try:
        node = subprocess.run([sys.executable, str(ROOT / "examples/ros2/pure_pursuit.py"), str(line), "--f1tenth",
                               "--laps", "1", "--speed", "1.2", "--timeout", "40"],
                              env=env, capture_output=True, text=True, timeout=60)
    finally:
        out = stop(bridge)
    assert node.returncode == 0, node.stdout + node.stderr
    assert "lap 1:" in node.stdout
    laps, cte = laps_in(trace)
    assert laps >= 1.0 and within_walls(cte), (laps, cte)
    driven = int(out.split(" command(s) driven")[0].split()[-1])
    assert driven > 40 * 14 / 2 / 2, out  # 40 Hz over a lap of ~14 s driven at twice real time, halved for slack


@pytest.mark.realtime
def test_a_wall_follower_laps_the_oval_by_its_scan_alone_and_the_bridge_localizes_it(tmp_path, monkeypatch):
    """A plain rclpy node laps the oval by /scan alone; meanwhile `--localize` runs our particle
    filter on the bridge, and its /pose (in the map frame, on the simulator's clock) follows the
    simulator's own trace of the car."""
    needs_types()
    from geometry_msgs.msg import PoseWithCovarianceStamped

    env, trace = ros_env(), tmp_path / "drive.csv"
    for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(key, env[key])
    # twice real time: the car's firmware fails safe after 250 ms of its own time, 125 ms of ours
    bridge = serve(f"sim://oval?speedup=2&trace={trace}", "--localize", env=env)
    poses = []
    rclpy.init()
    probe = rclpy.create_node("probe")
    probe.create_subscription(PoseWithCovarianceStamped, "/pose", lambda m: poses.append(
        (m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.pose.pose.position.x, m.pose.pose.position.y,
         m.header.frame_id)), 10)
    try:
        node = subprocess.Popen([sys.executable, str(ROOT / "examples/ros2/wall_follow.py"), "--for", "18",
                                 "--speed", "1.0"],
                                env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        while node.poll() is None:
            rclpy.spin_once(probe, timeout_sec=0.02)
        out = node.stdout.read()
        node.stdout.close()
    finally:
        probe.destroy_node()
        rclpy.try_shutdown()
        said = stop(bridge)
    assert node.returncode == 0, out
    laps, cte = laps_in(trace)
    assert laps >= 1.0 and within_walls(cte), (laps, cte, said)
    truth = np.loadtxt(trace, delimiter=",", skiprows=1)
    t, x, y = (np.array([p[i] for p in poses]) for i in range(3))
    assert len(t) > 100 and {p[3] for p in poses} == {"map"}
    error = np.hypot(x - np.interp(t, truth[:, 0], truth[:, 1]), y - np.interp(t, truth[:, 0], truth[:, 2]))
    assert np.sqrt(np.mean(error ** 2)) < 0.1 and error.max() < 0.25, (np.sqrt(np.mean(error ** 2)), error.max())


# a user's node that publishes /drive at 40 Hz: 1 s of a real command, then 0.5 s of NaN (refused:
# no command a car could mean, so it must not keep the car going), then it dies
DRIVES_THEN_DIES = textwrap.dedent("""
    import time, rclpy
    from ackermann_msgs.msg import AckermannDriveStamped
    rclpy.init()
    node = rclpy.create_node("user")
    pub = node.create_publisher(AckermannDriveStamped, "/drive", 10)
    time.sleep(1.0)  # discovery
    for i in range(60):
        msg = AckermannDriveStamped()
        msg.drive.speed, msg.drive.steering_angle = (1.0, 0.1) if i < 40 else (float("nan"), 0.0)
        pub.publish(msg)
        time.sleep(1 / 40)
""")


@pytest.mark.realtime
def test_silence_and_a_dead_node_put_the_car_to_neutral_within_the_timeout(monkeypatch):
    """The Vehicle re-sends its last command forever; the bridge's timeout is what stops a car
    whose ROS node went silent or died: neutral on the wire within 250 ms and one tick of the last
    command it drove. Messages no car could mean (NaN) are counted, not driven, and keep nothing
    alive."""
    needs_types()
    from roar import Vehicle
    from roar.autopilot import CarLimits, CarModel
    from roar.protocol import encode
    from roar.ros2.bridge import PERIOD_S, TIMEOUT_S, Bridge

    env = ros_env()
    for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(key, env[key])
    model = CarModel(0.325, 0.4, CarLimits(max_speed_m_s=3.0, max_accel_m_s2=1.8, max_brake_m_s2=2.5,
                                           max_lateral_m_s2=3.4))
    neutral = encode(1500, 1500)
    rclpy.init()
    node = rclpy.create_node("roar")
    with Vehicle("loop://", calibration=None) as car:
        bridge = Bridge(car, node, model)
        last_driven = []
        take = bridge._take

        def taking(topic, make):
            before = bridge.counts.commands
            take(topic, make)
            if bridge.counts.commands > before:
                last_driven.append(time.monotonic())

        bridge._take = taking
        user = subprocess.Popen([sys.executable, "-c", DRIVES_THEN_DIES], env=env)
        try:
            end = time.monotonic() + 6.0  # at most; half a second after the user's node died
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.01)
                if user.poll() is not None:
                    end = min(end, time.monotonic() + 0.5)
        finally:
            user.kill()
            node.destroy_node()
            rclpy.try_shutdown()
        writes = list(car.transport.link.writes)
    assert user.returncode == 0
    assert bridge.counts.commands >= 30 and bridge.counts.refused >= 10, bridge.counts
    assert bridge.counts.last_refusal == "/drive: not a finite number"
    driving = [t for t, m in writes if t <= last_driven[-1] and m != neutral]
    assert driving, "the commands never reached the wire"
    first_neutral = next(t for t, m in writes if t > last_driven[-1] and m == neutral)
    assert first_neutral - last_driven[-1] <= TIMEOUT_S + PERIOD_S + 0.02, first_neutral - last_driven[-1]
    assert first_neutral - last_driven[-1] >= TIMEOUT_S - PERIOD_S  # not before the timeout either
    assert bridge.counts.timeouts == 1


def test_ros_commands_become_the_cars_commands():
    """No ROS graph: what /drive and /cmd_vel ask, as steering and throttle (or a speed)."""
    from roar.autopilot import CarLimits, CarModel, DiffDriveModel
    from roar.errors import RefusedCommand
    from roar.ros2.commands import Driver, ackermann, twist

    limits = CarLimits(max_speed_m_s=3.0, max_accel_m_s2=1.8, max_brake_m_s2=2.5, max_lateral_m_s2=3.4)
    car = Driver(CarModel(0.325, 0.4, limits))
    left = ackermann(1.0, 0.2, 0.325)
    assert car.steering(left) == pytest.approx(-0.5)  # left is a negative command, half of a 0.4 rad lock
    assert car.steering(ackermann(1.0, 1.2, 0.325)) == -1.0  # past the lock: full lock
    assert car.steering(twist(1.0, 1.0)) == pytest.approx(-math.atan(0.325) / 0.4)  # 1 rad/s at 1 m/s
    assert twist(0.0, 1.0).curvature_per_m == 0.0  # an Ackermann car cannot turn in place
    assert car.command(ackermann(-1.5, 0.0, 0.325), None, 0.02) == {"throttle": -0.5, "steering": 0.0}
    assert car.command(ackermann(9.0, 0.0, 0.325), None, 0.02)["throttle"] == 1.0  # beyond its top speed: top speed
    # from standstill: more than the feed-forward (1.5 / 3)
    assert car.command(ackermann(1.5, 0.0, 0.325), 0.0, 0.02)["throttle"] > 0.5
    speed_car = Driver(CarModel(0.325, 0.4, limits), by_speed=True)
    assert speed_car.command(ackermann(1.5, 0.0, 0.325), 0.0, 0.02) == {"speed": 1.5, "steering": 0.0}
    assert speed_car.neutral() == {"speed": 0.0, "steering": 0.0}
    junior = Driver(DiffDriveModel(0.2, limits))
    assert junior.steering(twist(1.0, 1.0)) == pytest.approx(-0.1)  # the wheels' speeds differ by 1 x 0.2 / 2
    for bad in ((math.nan, 0.0), (1.0, math.inf), (60.0, 0.0), (1.0, math.pi / 2)):
        with pytest.raises(RefusedCommand):
            ackermann(*bad, 0.325)
    with pytest.raises(RefusedCommand):
        twist(math.nan, 0.0)


def test_without_the_extra_it_names_the_extra(tmp_path):
    (tmp_path / "rclpy.py").write_text("raise ImportError('no ROS here', name='rclpy')\n")
    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    run = subprocess.run([*ROAR, "ros2", "loop://", "--for", "0.1"], env=env, capture_output=True, text=True,
                         timeout=30)
    assert run.returncode == 1
    assert run.stderr.strip() == ("roar ros2: error: roar ros2 needs rclpy: pip install 'roar-platform[ros2]' "
                                  "(the ROS 2 wheels, for Python 3.11)")


@pytest.mark.realtime
def test_topics_frames_stamps_and_qos_as_documented(monkeypatch):
    """What a ROS user's tools see of `roar ros2 sim://oval`: /scan to best-effort and reliable
    subscribers alike, /odom and /imu with covariances, the TF tree, stamps on the simulator's
    /clock, and /map to a subscriber that joins late (transient local)."""
    needs_types()
    from diagnostic_msgs.msg import DiagnosticArray
    from nav_msgs.msg import OccupancyGrid, Odometry
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import CameraInfo, Image, Imu, LaserScan
    from tf2_msgs.msg import TFMessage

    env = ros_env()
    for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(key, env[key])
    bridge = serve("sim://oval?speedup=2", "--camera", "10", env=env)
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    got: dict[str, list] = {}
    rclpy.init()
    node = rclpy.create_node("probe")
    try:
        def keep(name):
            return lambda msg: got.setdefault(name, []).append(msg)

        for name, kind, topic, qos in (("scan best effort", LaserScan, "/scan", qos_profile_sensor_data),
                                       ("scan reliable", LaserScan, "/scan", 10), ("odom", Odometry, "/odom", 10),
                                       ("imu", Imu, "/imu", qos_profile_sensor_data), ("clock", Clock, "/clock", 10),
                                       ("tf", TFMessage, "/tf", 10), ("tf_static", TFMessage, "/tf_static", latched),
                                       ("diagnostics", DiagnosticArray, "/diagnostics", 10),
                                       ("image", Image, "/camera/image_raw", qos_profile_sensor_data),
                                       ("camera_info", CameraInfo, "/camera/camera_info", 10)):
            node.create_subscription(kind, topic, keep(name), qos)
        # 3 s at least, and on a busy machine until every topic came and five frames (at most 20 s: a busy
        # machine's first camera frames come late; the rate is checked below against the time listened)
        began = time.monotonic()
        names = ("scan best effort", "scan reliable", "odom", "imu", "clock", "tf", "tf_static", "diagnostics",
                 "image", "camera_info")

        def enough() -> bool:
            return (time.monotonic() - began >= 3.0 and all(got.get(n) for n in names)
                    and min(len(got["scan best effort"]), len(got["scan reliable"])) > 20 and len(got["image"]) >= 5
                    and max(c.clock.sec + c.clock.nanosec * 1e-9 for c in got["clock"]) > 4.0)

        while not enough() and time.monotonic() - began < 20.0:
            rclpy.spin_once(node, timeout_sec=0.01)
        listened_s = time.monotonic() - began
        node.create_subscription(OccupancyGrid, "/map", keep("map"), latched)  # late: transient local
        end = time.monotonic() + 1.0
        while time.monotonic() < end and "map" not in got:
            rclpy.spin_once(node, timeout_sec=0.01)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        stop(bridge)
    assert len(got.get("scan best effort", [])) > 20 and len(got.get("scan reliable", [])) > 20, got.keys()
    scan = got["scan reliable"][-1]
    assert scan.header.frame_id == "laser" and len(scan.ranges) == 1080
    assert scan.angle_min == pytest.approx(-math.radians(135)) and scan.angle_max == pytest.approx(math.radians(135))
    assert scan.angle_min + scan.angle_increment * (len(scan.ranges) - 1) == pytest.approx(scan.angle_max)
    odom = got["odom"][-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    assert (odom.pose.pose.position.x, odom.pose.pose.position.y) == pytest.approx((0.0, -1.5), abs=0.05)  # the start
    assert odom.pose.covariance[0] > 0 and odom.twist.covariance[35] > 0
    assert got["imu"][-1].orientation_covariance[0] == -1  # no orientation, as REP 145 says
    clocks = {(c.clock.sec, c.clock.nanosec) for c in got["clock"]}
    assert all((m.header.stamp.sec, m.header.stamp.nanosec) in clocks for m in got["odom"][-10:])
    sim_s = max(s + ns * 1e-9 for s, ns in clocks)
    assert sim_s > 4.0  # 3 s and more of wall time at twice real time (or as fast as a busy machine ran it)
    edges = {(t.header.frame_id, t.child_frame_id) for m in got["tf"] + got["tf_static"] for t in m.transforms}
    assert edges == {("odom", "base_link"), ("base_link", "laser"), ("base_link", "camera_optical"), ("map", "odom")}
    laser = next(t for m in got["tf_static"] for t in m.transforms if t.child_frame_id == "laser")
    assert laser.transform.translation.x == pytest.approx(0.265, abs=0.01)  # the racecar's hokuyo, ahead of the axle
    image, info = got["image"][-1], got["camera_info"][-1]
    assert (image.width, image.height, image.encoding, image.header.frame_id) == (320, 240, "rgb8", "camera_optical")
    pixels = np.frombuffer(bytes(image.data), dtype=np.uint8).reshape(240, 320, 3)
    assert pixels.std() > 10  # a picture, not a blank
    focal = 120 / math.tan(math.radians(70) / 2)  # the simulated car's camera: 70 degrees vertically
    assert info.k[0] == pytest.approx(focal) and info.k[4] == pytest.approx(focal) and info.k[2] == 159.5
    assert 5 <= len(got["image"]) <= listened_s * 10 + 2  # at 10 frames a second of wall time
    mount = next(t for m in got["tf_static"] for t in m.transforms if t.child_frame_id == "camera_optical")
    q = mount.transform.rotation
    # the optical axis (the rotation's third column) in the car's frame: ahead, pitched down a quarter
    axis = (2 * (q.x * q.z + q.w * q.y), 2 * (q.y * q.z - q.w * q.x), 1 - 2 * (q.x ** 2 + q.y ** 2))
    pitch = math.atan(0.25)
    assert axis == pytest.approx((math.cos(pitch), 0.0, -math.sin(pitch)), abs=1e-6)
    grid = got["map"][0]
    assert grid.header.frame_id == "map" and grid.info.resolution == pytest.approx(0.05)
    cells = np.asarray(grid.data).reshape(grid.info.height, grid.info.width)
    assert {0, 100} <= set(np.unique(cells))

    def cell(x, y):  # ROS's grid: row-major from the origin, rows along +y
        return cells[int((y - grid.info.origin.position.y) / 0.05), int((x - grid.info.origin.position.x) / 0.05)]

    assert cell(0.0, -1.5) == 0  # the start, and its walls 0.6 m to each side
    assert 100 in [cell(0.0, y) for y in (-0.95, -0.9, -0.85)] and 100 in [cell(0.0, y) for y in (-2.15, -2.1, -2.05)]
    status = got["diagnostics"][-1].status[0]
    assert status.name == "roar: sim://oval?speedup=2" and status.message == "ok"


JAZZY = ROOT / ".venv-ros2-jazzy"
JAZZY_NODE = textwrap.dedent("""
    import time, rclpy
    from ackermann_msgs.msg import AckermannDriveStamped
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import LaserScan
    rclpy.init()
    node = rclpy.create_node("jazzy_user")
    scans = []
    node.create_subscription(LaserScan, "/scan", lambda m: scans.append(len(m.ranges)), qos_profile_sensor_data)
    pub = node.create_publisher(AckermannDriveStamped, "/drive", 10)
    found = time.monotonic() + 10.0  # discovery (slower on a busy machine), then 2 s of driving
    while not scans and time.monotonic() < found:
        rclpy.spin_once(node, timeout_sec=0.05)
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        msg = AckermannDriveStamped()
        msg.drive.speed = 1.0
        pub.publish(msg)
        rclpy.spin_once(node, timeout_sec=0.025)
    print(len(scans), scans[-1] if scans else 0)
""")


@pytest.mark.realtime
def test_a_node_on_an_older_distribution_drives_ours():
    """Users' stacks run older distributions: a node on ROS 2 Jazzy (rclpy 7, another environment)
    finds our Kilted node, hears its /scan and drives it on /drive."""
    if not (JAZZY / ".installed").is_file():
        pytest.skip("no .venv-ros2-jazzy: scripts/setup.sh test makes it "
                    "(pip install -r tests/ros2/jazzy-requirements.txt)")
    env = ros_env()
    bridge = serve("sim://oval", env=env)
    try:
        # its own libraries: not the ones this environment's start-up hook put on the path
        own = {k: v for k, v in env.items() if k not in ("LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE",
                                                         "AMENT_PREFIX_PATH", "PYTHONPATH")}
        node = subprocess.run([str(JAZZY / "bin/python"), "-c", JAZZY_NODE], env=own, capture_output=True, text=True,
                              timeout=30)
    finally:
        out = stop(bridge)
    assert node.returncode == 0, node.stderr
    scans, beams = map(int, node.stdout.split())
    assert scans > 30 and beams == 1080, node.stdout
    assert int(out.split(" command(s) driven")[0].split()[-1]) > 30, out


def test_a_recording_becomes_a_rosbag2_that_rosbags_reads(tmp_path):
    """roar ros2 --bag: a roar recording as a rosbag2 (ROS 2 types, CDR, MCAP) that rosbags,
    the reference reader, opens and decodes, field for field."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    from roar.recorder import Recorder
    from roar.telemetry import VehicleState

    run, bag = tmp_path / "run.mcap", tmp_path / "bag"
    with Recorder(run, {"car": "sim://oval"}, simulated=True) as rec:
        rec.control(b"(1600,1400)\n", 1_000_000)
        rec.state(VehicleState(time_s=0.02, x_m=1.0, y_m=-1.5, yaw_rad=math.pi / 2, speed_m_s=0.8,
                               yaw_rate_rad_s=0.3), 20_000_000)
        rec.scan(np.linspace(1.0, 2.0, 1080), -math.radians(135), math.radians(135), 20_000_000)
        rec.image(np.full((24, 32, 3), 128, np.uint8), 40_000_000)
        rec.depth(np.full((24, 32), 2.5, np.float32), 40_000_000)
        rec.line("READY 2", 50_000_000)
        rec.pose("/planner/goal", (3.0, 0.0, 0.0), 60_000_000)  # no ROS counterpart: left out
    result = subprocess.run([*ROAR, "ros2", "--bag", str(run), "--out", str(bag)], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0, result.stderr
    # the planner's goal, and /car/pose (what /odom and /tf carry)
    assert "2 message(s) of other topics left out" in result.stdout
    assert (bag / "metadata.yaml").is_file()  # rosbag2's MCAP storage, in ROS 2's own encodings (Foxglove's cue)
    from mcap.reader import make_reader

    with open(next(bag.glob("*.mcap")), "rb") as f:
        summary = make_reader(f).get_summary()
    assert {(c.message_encoding, summary.schemas[c.schema_id].encoding) for c in summary.channels.values()} == \
        {("cdr", "ros2msg")}
    store = get_typestore(Stores.ROS2_KILTED)
    got = {}
    with Reader(bag) as reader:
        assert reader.message_count == 8
        for connection, t_ns, raw in reader.messages():
            got.setdefault(connection.topic, []).append((t_ns, store.deserialize_cdr(raw, connection.msgtype)))
    assert set(got) == {"/roar/control", "/odom", "/tf", "/scan", "/camera/camera_info",
                        "/camera/image_raw/compressed", "/camera/depth/image_raw", "/rosout"}
    t_ns, odom = got["/odom"][0]
    assert t_ns == 20_000_000 and (odom.header.stamp.sec, odom.header.stamp.nanosec) == (0, 20_000_000)
    assert (odom.pose.pose.position.x, odom.pose.pose.position.y) == (1.0, -1.5)
    assert 2 * math.atan2(odom.pose.pose.orientation.z, odom.pose.pose.orientation.w) == pytest.approx(math.pi / 2)
    assert odom.twist.twist.linear.x == pytest.approx(0.8) and odom.twist.twist.angular.z == pytest.approx(0.3)
    scan = got["/scan"][0][1]
    assert len(scan.ranges) == 1080 and scan.ranges[-1] == pytest.approx(2.0)
    assert scan.angle_min + scan.angle_increment * 1079 == pytest.approx(scan.angle_max)
    assert got["/camera/image_raw/compressed"][0][1].format == "jpeg"
    depth = got["/camera/depth/image_raw"][0][1]
    assert np.frombuffer(depth.data.tobytes(), "<f4").reshape(24, 32).mean() == pytest.approx(2.5)
    assert got["/rosout"][0][1].msg == "READY 2"
    assert json.loads(got["/roar/control"][0][1].data)["throttle_us"] == 1600
    tf = got["/tf"][0][1].transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("map", "base_link")
    again = subprocess.run([*ROAR, "ros2", "--bag", str(run), "--out", str(bag)], capture_output=True, text=True,
                           timeout=60)
    assert again.returncode == 1 and "exists" in again.stderr and len(again.stderr.strip().splitlines()) == 1


LIDAR_AHEAD_M = 0.3  # [m] where the foreign bag's lidar sits ahead of its base_link (its /tf_static says)


def write_foreign_bag(path: Path, name: str, laps: float = 1.0) -> np.ndarray:
    """A rosbag2 as another team's car would write it, made with rosbags: /scan (1,080 beams cast
    on the track's map from a lidar LIDAR_AHEAD_M ahead, as /tf_static says) at 10 Hz and /odom at
    50 Hz, dead reckoning that drifts (each step 2 % long and turned 0.01 rad/m off), driving track
    `name`'s centre line at 1 m/s. Returns the true poses (of base_link) at the scans."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from roar.localization.odometry import relative
    from roar.localization.raycast import RayMarcher
    from roar.tracks import get
    from roar.tracks.occupancy_map import track_map

    track = get(name)
    caster = RayMarcher(track_map(track))
    store = get_typestore(Stores.ROS2_KILTED)
    t = store.types
    angles = np.linspace(-math.radians(135), math.radians(135), 1080)
    truth = []

    def stamp(ns, frame="odom"):
        return t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                       frame_id=frame)

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        statics = writer.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=store)
        scans = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=store)
        odoms = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        mount = t["geometry_msgs/msg/TransformStamped"](  # their lidar, LIDAR_AHEAD_M ahead of base_link
            header=stamp(0, "base_link"), child_frame_id="laser", transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=LIDAR_AHEAD_M, y=0.0, z=0.1),
                rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
        writer.write(statics, 0, store.serialize_cdr(t["tf2_msgs/msg/TFMessage"](transforms=[mount]),
                                                     "tf2_msgs/msg/TFMessage"))
        steps = int(track.length_m * laps / 0.02)  # 1 m/s, 50 Hz
        o, last = track.pose_at(0.0), track.pose_at(0.0)
        for k in range(steps):
            s, ns = k * 0.02, k * 20_000_000
            x, y, yaw = track.pose_at(s)
            dx, dy, dyaw = relative(last, (x, y, yaw))
            last = (x, y, yaw)
            ahead, left, turn = 1.02 * dx, 1.02 * dy, dyaw + 0.01 * math.hypot(dx, dy)
            o = (o[0] + ahead * math.cos(o[2]) - left * math.sin(o[2]), o[1] + ahead * math.sin(o[2]) +
                 left * math.cos(o[2]), o[2] + turn)
            odom = t["nav_msgs/msg/Odometry"](
                header=stamp(ns), child_frame_id="base_link",
                pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=t["geometry_msgs/msg/Pose"](
                    position=t["geometry_msgs/msg/Point"](x=o[0], y=o[1], z=0.0),
                    orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(o[2] / 2),
                                                                   w=math.cos(o[2] / 2))), covariance=np.zeros(36)),
                twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=t["geometry_msgs/msg/Twist"](
                    linear=t["geometry_msgs/msg/Vector3"](x=1.0, y=0.0, z=0.0),
                    angular=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)), covariance=np.zeros(36)))
            writer.write(odoms, ns, store.serialize_cdr(odom, "nav_msgs/msg/Odometry"))
            if k % 5 == 0:
                lidar = [x + LIDAR_AHEAD_M * math.cos(yaw), y + LIDAR_AHEAD_M * math.sin(yaw), yaw]
                ranges = caster.cast(np.array([lidar]), angles)[0].astype(np.float32)
                scan = t["sensor_msgs/msg/LaserScan"](
                    header=stamp(ns, "laser"), angle_min=float(angles[0]), angle_max=float(angles[-1]),
                    angle_increment=float(angles[1] - angles[0]), time_increment=0.0, scan_time=0.1, range_min=0.06,
                    range_max=10.0, ranges=ranges, intensities=np.zeros(0, np.float32))
                writer.write(scans, ns, store.serialize_cdr(scan, "sensor_msgs/msg/LaserScan"))
                truth.append((x, y, yaw))
    return np.asarray(truth)


def test_our_particle_filter_runs_over_a_foreign_bag(tmp_path):
    """A ROS user's bag (written with rosbags, no roar in it): roar replay summarises it, and
    roar ros2 --localize-bag follows the car over most of a lap on the map where the odometry alone
    drifts."""
    bag, out = tmp_path / "their_bag", tmp_path / "track.csv"
    truth = write_foreign_bag(bag, "course", laps=0.6)  # past the bends, down the long straight
    shown = subprocess.run([*ROAR, "replay", str(bag)], capture_output=True, text=True, timeout=60)
    assert shown.returncode == 0, shown.stderr
    scan_line = next(line for line in shown.stdout.splitlines() if line.split()[0] == "/scan")
    assert scan_line.split()[1:3] == ["sensor_msgs/msg/LaserScan", str(len(truth))]
    assert float(scan_line.split()[3]) == pytest.approx(10.0, abs=0.2)  # [Hz]
    run = subprocess.run([*ROAR, "ros2", "--localize-bag", str(bag), "--map", "course", "--start", "odom",
                          "--out", str(out)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    assert len(rows) == len(truth)
    error = np.hypot(rows[:, 4] - truth[:, 0], rows[:, 5] - truth[:, 1])
    assert np.sqrt(np.mean(error ** 2)) < 0.1 and error.max() < 0.3, (np.sqrt(np.mean(error ** 2)), error.max())
    odometry_error = np.hypot(rows[:, 1] - truth[:, 0], rows[:, 2] - truth[:, 1])
    assert odometry_error[-1] > 0.3  # the odometry alone drifted: the map did the work


# a user's node: /drive (or the topic given) at 40 Hz, speed [m/s] and steering [rad] as given, for
# the seconds given (inf: until killed), counted from when the bridge subscribes (discovery takes
# seconds on a busy machine; it exits 3 if the bridge has not subscribed within 30 s)
DRIVES = textwrap.dedent("""
    import sys, time, rclpy
    from ackermann_msgs.msg import AckermannDriveStamped
    topic, speed, steering, seconds = sys.argv[1], *map(float, sys.argv[2:5])
    rclpy.init()
    node = rclpy.create_node("user")
    pub = node.create_publisher(AckermannDriveStamped, topic, 10)
    found = time.monotonic() + 30
    while pub.get_subscription_count() == 0:
        if time.monotonic() > found:
            sys.exit(f"nobody subscribed to {topic} within 30 s")
        time.sleep(0.05)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        msg = AckermannDriveStamped()
        msg.drive.speed, msg.drive.steering_angle = speed, steering
        pub.publish(msg)
        time.sleep(1 / 40)
""")


@pytest.mark.realtime
def test_a_killed_bridge_leaves_the_car_to_its_own_failsafe(pty_car):
    """The bridge killed outright (SIGKILL: no neutral sent) while a ROS node drives a car on a
    serial port: nothing re-sends the last command, and the car's firmware stops it 250 ms after
    the last message it got."""
    needs_types()
    env = ros_env()
    bridge = serve(f"serial://{pty_car.path}", env=env)
    user = subprocess.Popen([sys.executable, "-c", DRIVES, "/drive", "1.0", "0.2", "inf"], env=env)
    try:
        from conftest import wait_for

        assert wait_for(lambda: pty_car.sim.outputs.throttle_us > 1500, timeout_s=10), "the ROS node never drove it"
        assert pty_car.sim.outputs.steering_us < 1500  # 0.2 rad to the left: a command below centre
        bridge.kill()
        killed_s = pty_car.sim.time_s
        assert wait_for(lambda: pty_car.sim.outputs.throttle_us == 1500, timeout_s=2.0, poll_s=0.002)
        stopped_after_s = pty_car.sim.time_s - killed_s
    finally:
        for process in (user, bridge):
            process.kill()
            process.wait(timeout=10)
        bridge.stdout.close()
    assert 0.25 - 0.05 <= stopped_after_s <= 0.25 + 0.05, stopped_after_s  # the last message came <= 20 ms before


def test_the_launch_files_command_lines_are_ones_roar_ros2_takes():
    """examples/ros2/bridge.launch.py (for a ROS install: launch is not on PyPI) makes command
    lines that roar ros2's own parser accepts, for each combination of its arguments."""
    import importlib.util

    from roar.cli.ros2 import parser

    spec = importlib.util.spec_from_file_location("launch_example", ROOT / "examples/ros2/bridge.launch.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    defaults = {name: default for name, (default, _) in example.ARGUMENTS.items()}
    for f1tenth, localize, url in itertools.product(("true", "false"), ("true", "false"),
                                                    ("sim://", "serial:///dev/ttyUSB0")):
        line = example.bridge_command(**{**defaults, "f1tenth": f1tenth, "localize": localize, "url": url})
        assert line[:2] == ["roar", "ros2"]
        args = parser().parse_args(line[2:])
        assert args.f1tenth == (f1tenth == "true") and args.localize == (f1tenth == "false" and localize == "true")
        assert args.url == ("sim://?track=oval" if url == "sim://" else url)


@pytest.mark.realtime
def test_a_bridge_stopped_before_any_drive_leaves_a_speed_car_at_zero_speed():
    """Ctrl-C before the first /drive: the IARRC car (it drives by speed) is put to zero speed, not
    to a throttle it refuses, and the bridge ends within a second (it raised and stayed up)."""
    needs_types()
    out = stop(serve("sim://?robot=iarrc", env=ros_env()))
    assert "0 command(s) driven" in out, out


def test_the_iarrc_car_takes_drive_speeds_as_setpoints_on_a_remapped_topic(tmp_path):
    """The IARRC car holds a speed itself: /drive's speed becomes its setpoint (its own PID, on its
    own encoder, brings it there); and --ros-args reach rclpy: /drive remapped to /ego/drive."""
    needs_types()
    env, trace = ros_env(), tmp_path / "drive.csv"
    bridge = serve(f"sim://?robot=iarrc&speedup=2&trace={trace}",  # its failsafe: 125 ms of ours
                   "--ros-args", "-r", "/drive:=/ego/drive", env=env)
    try:
        node = subprocess.run([sys.executable, "-c", DRIVES, "/ego/drive", "1.0", "0.0", "4"], env=env,
                              capture_output=True, text=True, timeout=60)
    finally:
        out = stop(bridge)
    assert node.returncode == 0, node.stderr
    assert int(out.split(" command(s) driven")[0].split()[-1]) > 50, out
    speeds = np.loadtxt(trace, delimiter=",", skiprows=1)[:, 4]
    assert 0.9 <= np.percentile(speeds, 95) <= 1.1, np.percentile(speeds, 95)  # held at the 1 m/s asked


@pytest.mark.realtime
def test_a_phone_on_the_car_gives_odom_from_its_own_pose_and_its_camera(monkeypatch):
    """udp://, ROAR's own set-up (a phone on the car streams its pose, camera and depth; roar sim
    --stream stands in for it): /drive drives the car through it, /odom follows the phone's pose,
    and /camera/image_raw and depth carry its frames."""
    needs_types()
    from ackermann_msgs.msg import AckermannDriveStamped
    from nav_msgs.msg import Odometry
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import Image

    env = ros_env()
    for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(key, env[key])
    phone = subprocess.Popen([*ROAR, "sim", "--stream", "--seconds", "20", "--size", "160x120"], cwd=ROOT,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    bridge = None
    got: dict[str, list] = {}
    rclpy.init()
    node = rclpy.create_node("user")
    try:
        assert "streaming the simulated car" in phone.stdout.readline()
        bridge = serve("udp://127.0.0.1", "--camera", "5", env=env)
        node.create_subscription(Odometry, "/odom", lambda m: got.setdefault("odom", []).append(m), 10)
        node.create_subscription(Image, "/camera/image_raw", lambda m: got.setdefault("image", []).append(m),
                                 qos_profile_sensor_data)
        node.create_subscription(Image, "/camera/depth/image_raw", lambda m: got.setdefault("depth", []).append(m),
                                 qos_profile_sensor_data)
        drive = node.create_publisher(AckermannDriveStamped, "/drive", 10)
        end = time.monotonic() + 4.0
        while time.monotonic() < end:
            msg = AckermannDriveStamped()
            msg.drive.speed = 0.8
            drive.publish(msg)
            rclpy.spin_once(node, timeout_sec=0.025)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        if bridge is not None:
            stop(bridge)
        phone.kill()
        phone.communicate()
    odom = got.get("odom", [])
    assert len(odom) > 50, got.keys()
    assert odom[-1].pose.pose.position.x - odom[0].pose.pose.position.x > 0.5  # it drove ahead, as the phone saw
    image, depth = got["image"][-1], got["depth"][-1]
    assert (image.width, image.height, image.encoding) == (160, 120, "rgb8")
    assert (depth.width, depth.height, depth.encoding) == (160, 120, "32FC1")


def test_a_junior_over_http_streams_its_camera_and_turns_by_its_wheels(monkeypatch):
    """http:// (the ROAR Junior, served by the simulator on loopback as the robot serves): /cmd_vel
    turns it by its wheels' speeds, and /camera/image_raw carries its MJPEG stream's frames at the
    rate asked (the stream gives more: the newest is published, none queued)."""
    needs_types()
    from geometry_msgs.msg import Twist
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import Image

    from roar_sim.links.junior_http import InBackground

    env = ros_env()
    for key in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE"):
        monkeypatch.setenv(key, env[key])
    images: list[tuple[float, Image]] = []
    turned_rad, yaw = 0.0, 0.0  # [rad] unwrapped, counterclockwise positive
    with InBackground() as junior:
        bridge = serve(junior.urls.vehicle_url, "--camera", "2", env=env)
        rclpy.init()
        node = rclpy.create_node("user")
        try:
            node.create_subscription(Image, "/camera/image_raw", lambda m: images.append((time.monotonic(), m)),
                                     qos_profile_sensor_data)
            turn = node.create_publisher(Twist, "/cmd_vel", 10)
            start = time.monotonic()  # 5 s, and on until 3 frames came (a loaded machine renders 800 x 600 slowly)
            while time.monotonic() - start < 5.0 or (len(images) < 3 and time.monotonic() - start < 30.0):
                msg = Twist()
                msg.linear.x, msg.angular.z = 0.2, 1.5
                turn.publish(msg)
                rclpy.spin_once(node, timeout_sec=0.05)
                now = junior.server.sim.state().yaw
                turned_rad, yaw = turned_rad + math.remainder(now - yaw, math.tau), now
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
            stop(bridge)
    assert turned_rad > 1.0  # left, by its wheels (1.5 rad/s asked: the wheels slip on the spot)
    assert len(images) >= 3, len(images)
    gaps = np.diff([t for t, _ in images])
    assert gaps.min() > 0.3  # 2 Hz asked: never the stream's backlog in a burst
    image = images[-1][1]
    assert (image.width, image.height, image.encoding) == (800, 600, "rgb8")
    assert len(image.data) == 800 * 600 * 3 and max(image.data[::997]) > 0


def test_a_sensor_that_fails_is_said_once_and_tried_again(monkeypatch):
    """A camera's stream that ends (a Junior rebooting) is one line, not a traceback per try nor a
    dead thread: the sensor is read again once it answers."""
    from roar.errors import CameraError
    from roar.ros2 import bridge

    monkeypatch.setattr(bridge, "RETRY_S", 0.01)
    said, tries = [], []

    def read():
        tries.append(1)
        if len(tries) <= 3:
            raise CameraError("the camera's stream ended")

    poller = bridge.Poller("camera", 0.0, read, said.append)
    poller.start()
    deadline = time.monotonic() + 5.0
    while len(tries) < 6 and time.monotonic() < deadline:
        time.sleep(0.01)
    poller.stop()
    assert said == ["camera: the camera's stream ended (trying again every 0.01 s)", "camera: reads again"]
