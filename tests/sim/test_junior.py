"""The ROAR Junior end to end: the firmware's own HTTP reader, JuniorControl and L298N driver
drive a PyBullet differential-drive robot through an L298N/motor model; its HTTP ports on
loopback answer byte for byte as the robot; the host drives it through http:// and reads its
range and camera."""

import io
import math
import re
import socket
import threading
import time

import numpy as np
import pytest

from conftest import ROOT, wait_for
from roar.cli.sdk import run_command
from roar import Vehicle
from roar.junior import original_mix, query_for, smooth_mix
from roar.protocol import spec
from roar_sim.core.junior import SidePins
from roar_sim.plants.junior import ULTRASONIC_POS_M
from roar_sim.plants.l298n_motors import motor_torque
from roar_sim.robots.junior import Junior
from roar_sim.world.bullet import pb

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

IDLE_WAIT_S = 0.7  # [s] longer than the camera keeps capturing after its last request
OTHER_CLIENT = "127.0.0.2"  # a second client's address on loopback

FORWARD = SidePins(True, False, 1000)
TIMEOUT_S = spec.JUNIOR_FAILSAFE_TIMEOUT_US / 1e6


@pytest.fixture
def sim():
    with Junior() as s:
        s.run(0.2)  # settle on its wheels
        yield s


# --- the L298N and motor model ---------------------------------------------------------------

def test_the_bridge_drives_brakes_and_coasts():
    assert motor_torque(FORWARD, 0.0) > 0.05 and motor_torque(SidePins(False, True, 1000), 0.0) < -0.05
    assert motor_torque(FORWARD, 25.0) < 0  # faster than the motor's no-load speed: back-EMF wins
    assert motor_torque(SidePins(True, True, 1000), 10.0) < 0 < motor_torque(SidePins(False, False, 800), -10.0)
    assert motor_torque(SidePins(True, True, 0), 10.0) == 0 == motor_torque(SidePins(True, False, 0), 10.0)
    assert motor_torque(SidePins(True, False, 500), 0.0) == pytest.approx(motor_torque(FORWARD, 0.0) / 2)
    assert motor_torque(SidePins(True, False, 500), 9.8) == pytest.approx(0.0, abs=1e-3)  # half speed, half duty


def test_full_duty_tops_out_at_a_tt_motor_speed_and_it_drives_straight(sim):
    for _ in range(40):
        sim.get("forward=True&left_spd=1&right_spd=1")
        sim.run(0.05)
    s = sim.state()
    assert 0.45 < s.speed < 0.7 and abs(s.y) < 0.1 and abs(s.yaw) < 0.1
    assert s.left_wheel_rad_s == pytest.approx(s.right_wheel_rad_s, rel=0.05)


def test_spin_in_place_turns_without_going_anywhere(sim):
    x0 = sim.state().x
    for _ in range(20):
        sim.get("turnLeft=True&left_spd=0.6&right_spd=0.6")
        sim.run(0.05)
    s = sim.state()
    assert s.yaw_rate > 2 and math.hypot(s.x - x0, s.y) < 0.1


# --- the firmware's HTTP semantics, in the loop ----------------------------------------------

# What the ROAR Junior client sends (requests.get(url, params=...) of its ackermann_to_diff).
ORIGINAL_REQUESTS = [
    ("forward=True&left_spd=1&right_spd=1", (1000, 1000)),
    ("backward=True&left_spd=1&right_spd=1", (-1000, -1000)),
    ("forward=True&left_spd=0.8500000000000001&right_spd=0", (850, 0)),
    ("forward=True&left_spd=0&right_spd=0.9400000000000001", (0, 940)),
    ("stop=True", (0, 0)),
    ("forward=False&backward=True&left_spd=1&right_spd=1", (-1000, -1000)),
]


def duties(sim) -> tuple[int, int]:
    def signed(p: SidePins) -> int:
        return p.duty if p.in1 else -p.duty if p.in2 else 0
    sim.run(0.02)  # past any dead time
    left, right = sim.pins
    return signed(left), signed(right)


@pytest.mark.parametrize("query, expected", ORIGINAL_REQUESTS)
def test_the_original_clients_requests_are_accepted(sim, query, expected):
    status, body = sim.get(query)
    assert status == 200 and body.isdigit()
    assert duties(sim) == expected


def test_parameters_apply_in_order(sim):
    sim.get("left_spd=0.5&right_spd=0.5")
    sim.get("stop=True&forward=True")
    assert duties(sim) == (500, 500)
    sim.get("forward=True&stop=True")
    assert duties(sim) == (0, 0)


@pytest.mark.parametrize("query, words", [
    ("left_spd=abc", "a speed takes a number 0..1: 'left_spd=abc'"),
    ("left_spd=nan&forward=True", "'left_spd=nan'"),
    ("forward=True&right_spd=1.01", "'right_spd=1.01'"),
    ("forward=True&right_spd=-0.5", "'right_spd=-0.5'"),
    ("forward=True&speed=1", "unknown parameter: 'speed=1'"),
    ("forward=yes", "a flag takes True or False: 'forward=yes'"),
    ("forward=True&left_spd=" + "1" * 10_000, "request too long"),
])
def test_bad_queries_get_400_with_a_reason_and_change_nothing(sim, query, words):
    sim.get("backward=True&left_spd=0.3&right_spd=0.3")
    before = duties(sim)
    status, body = sim.get(query)
    assert status == 400 and words in body and body.count("\n") == 1
    assert duties(sim) == before == (-300, -300)


def test_the_failsafe_stops_the_motors_500_ms_after_the_last_request(sim):
    sim.get("forward=True&left_spd=1&right_spd=1")
    t0 = sim.t_us
    stopped_at = None
    while sim.t_us < t0 + 700_000:
        sim.run(0.001)
        left, right = sim.pins
        if stopped_at is None and left.duty == 0 and right.duty == 0:
            stopped_at = sim.t_us
    assert stopped_at is not None
    assert TIMEOUT_S * 1e6 < stopped_at - t0 <= TIMEOUT_S * 1e6 + 2_000  # within one loop (and the step taken)


def test_a_reversal_shows_the_dead_time_on_the_pins(sim):
    sim.pin_log = []
    sim.get("forward=True&left_spd=1&right_spd=1")
    sim.run(0.1)
    sim.get("backward=True&left_spd=1&right_spd=1")
    sim.run(0.1)
    left = [(t, p) for t, _, p, _ in sim.pin_log]  # each change of the left side's pins
    states = [(p.in1, p.in2, p.duty) for _, p in left]
    assert states == [(True, False, 1000), (False, False, 0), (False, True, 1000)]  # forward, coast, back
    (coast_from, _), (back_from, _) = left[1:]
    assert back_from - coast_from >= spec.L298N_DEAD_TIME_US


@pytest.mark.parametrize("distance_m", [0.15, 0.6, 1.5, 3.0])
def test_the_ultrasonic_reads_a_placed_wall_within_2_cm(distance_m):
    with Junior(pose=(0.0, 0.0, 0.0)) as sim:
        c = sim.plant.client
        wall = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.05, 1.0, 0.3], physicsClientId=c)
        sensor_x = ULTRASONIC_POS_M[0]
        pb.createMultiBody(0, wall, -1, [sensor_x + distance_m + 0.05, 0, 0.3], physicsClientId=c)
        sim.run(0.2)
        sensor_now = sim.state().x + sensor_x  # the robot settles a little
        status, body = sim.get("stop=True")
        wall_face = sensor_x + distance_m
        assert status == 200 and abs(int(body) - (wall_face - sensor_now) * 100) <= 2


def test_nothing_within_4_m_reads_0_no_echo(sim):
    assert sim.get("stop=True") == (200, "0")


# --- the HTTP ports on loopback --------------------------------------------------------------

@pytest.fixture(scope="module")
def junior():
    from roar_sim.links.junior_http import InBackground
    from roar.tracks.track import oval

    with InBackground(oval(), port=0) as server:
        yield server


def http_get(url: str, path: str, timeout: float = 5.0):
    import http.client
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=timeout)
    conn.request("GET", path)
    response = conn.getresponse()
    body = response.read()
    conn.close()
    return response.status, dict(response.getheaders()), body


@pytest.mark.parametrize("route, fmt, size", [
    (spec.JUNIOR_ROUTE_CAMERA_LOW, "JPEG", (320, 240)), (spec.JUNIOR_ROUTE_CAMERA_HIGH, "JPEG", (800, 600)),
    (spec.JUNIOR_ROUTE_CAMERA_BMP, "BMP", (320, 240))])
def test_each_camera_route_returns_an_image_of_its_size(junior, route, fmt, size):
    from PIL import Image

    status, headers, body = http_get(junior.urls.camera_url, route)
    assert status == 200 and headers["Content-Type"] == f"image/{fmt.lower()}"
    image = Image.open(io.BytesIO(body))
    assert image.format == fmt and image.size == size
    assert np.asarray(image).std() > 5  # a picture, not a blank


def test_cam_jpg_redirects_to_the_high_resolution_route(junior):
    status, headers, _ = http_get(junior.urls.camera_url, spec.JUNIOR_ROUTE_CAMERA_REDIRECT)
    assert status == 302 and headers["Location"] == spec.JUNIOR_ROUTE_CAMERA_HIGH


def test_the_mjpeg_stream_gives_whole_frames(junior):
    from roar.camera import MjpegStream

    with MjpegStream(junior.urls.camera_url + spec.JUNIOR_ROUTE_CAMERA_STREAM) as stream:
        frames = [f for f, _ in zip(stream, range(3))]
    assert [f.shape for f in frames] == [(600, 800, 3)] * 3


def test_the_control_port_answers_as_the_firmware(junior):
    status, headers, body = http_get(junior.urls.control_url, "/?stop=True")
    assert status == 200 and headers["Connection"] == "keep-alive" and body.decode().isdigit()
    status, headers, body = http_get(junior.urls.control_url, "/?left_spd=2")
    assert status == 400 and headers["Connection"] == "close" and b"'left_spd=2'" in body
    assert http_get(junior.urls.control_url, "/steer")[0] == 404


def test_idle_connections_do_not_stop_a_driver_and_two_drivers_are_served(junior):
    """200 connections opened by another client and never used, then two clients drive at 50 Hz
    for a second: every request answered, the robot never stopped by its failsafe."""
    from urllib.parse import urlsplit

    parts = urlsplit(junior.urls.control_url)
    idle = [socket.create_connection((parts.hostname, parts.port), source_address=(OTHER_CLIENT, 0))
            for _ in range(200)]
    try:
        answered, stops = [], []

        def driver(query):
            import http.client
            conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=2)
            for _ in range(50):
                conn.request("GET", f"/?{query}")
                response = conn.getresponse()
                answered.append(response.status)
                response.read()
                stops.append(junior.server.sim.pins[0].duty == 0 and junior.server.sim.time_s > 0.6)
                time.sleep(0.02)
            conn.close()

        threads = [threading.Thread(target=driver, args=(q,)) for q in
                   ("forward=True&left_spd=0.4&right_spd=0.4", "forward=True&left_spd=0.4&right_spd=0.4")]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert answered == [200] * 100 and not any(stops[10:])
    finally:
        for s in idle:
            s.close()


def address(url: str) -> tuple[str, int]:
    host, port = url.removeprefix("http://").rsplit(":", 1)
    return host, int(port)


def exchange(url: str, data: bytes, timeout: float = 5.0) -> bytes:
    """Everything the server sends back to `data` until it closes the connection."""
    with socket.create_connection(address(url), timeout=timeout) as s:
        s.sendall(data)
        out = b""
        while chunk := s.recv(65536):
            out += chunk
    return out


SMUGGLED = b"GET /?forward=True&left_spd=1&right_spd=1 HTTP/1.1\r\nHost: junior\r\n\r\n"


@pytest.mark.parametrize("headers, body", [
    (b"Content-Length: %d\r\n" % len(SMUGGLED), SMUGGLED),
    (b"Transfer-Encoding: chunked\r\n", b"%x\r\n%s\r\n0\r\n\r\n" % (len(SMUGGLED), SMUGGLED)),
])
def test_a_get_with_a_body_is_refused_and_its_body_never_runs(junior, headers, body):
    """The body of a GET is not a second request: the GET is refused with 400, the connection
    closes, and the robot does not drive -- on the control port and, by the same rules, the camera's."""
    for url in (junior.urls.control_url, junior.urls.camera_url):
        assert http_get(junior.urls.control_url, "/?stop=True")[0] == 200
        request = b"GET /?stop=True HTTP/1.1\r\nHost: junior\r\n" + headers + b"\r\n" + body
        reply = exchange(url, request)
        assert reply.count(b"HTTP/1.1 ") == 1 and reply.startswith(b"HTTP/1.1 400 Bad Request\r\n"), reply
        assert reply.endswith(b"\r\n\r\na GET takes no body\n") and b"Connection: close" in reply
        time.sleep(0.1)
        assert junior.server.sim.pins[0].duty == 0


@pytest.mark.parametrize("request_bytes", [
    b"POST /cam-lo.jpg HTTP/1.1\r\nHost: junior\r\n\r\n",
    b"GET /cam-lo.jpg HTTP/1.1\r\nX-Padding: " + b"a" * 5000 + b"\r\n\r\n",
    b"GET /cam-lo.jpg HTTP/1.1\r\nContent-Length: 3\r\n\r\nabc",
    b"hello\r\n\r\n",
], ids=["post", "long-header", "body", "garbage"])
def test_both_ports_refuse_alike(junior, request_bytes):
    """One set of rules for both ports: the camera's refusal is the control port's, byte for byte."""
    control = exchange(junior.urls.control_url, request_bytes.replace(b"/cam-lo.jpg", b"/?stop=True"))
    camera = exchange(junior.urls.camera_url, request_bytes)
    assert camera == control and camera.split(b" ", 2)[1] in (b"400", b"405"), (camera, control)


def test_quiet_connections_are_closed_and_a_client_holds_a_few(junior):
    """A connection that sends nothing, or half a request and then nothing (slow loris), is
    closed after the robot's idle time; a client's connections beyond the cap are closed at once,
    while another client is served."""
    from roar_sim.links.junior_http import IDLE_CLOSE_S, MAX_CONNECTIONS_PER_CLIENT

    for url in (junior.urls.control_url, junior.urls.camera_url):
        held = [socket.create_connection(address(url), source_address=(OTHER_CLIENT, 0), timeout=10)
                for _ in range(MAX_CONNECTIONS_PER_CLIENT + 4)]
        held[0].sendall(b"GET /?sto")  # half a request, then silence
        t0 = time.monotonic()
        try:
            # the ones over the cap: closed at once (EOF, or reset)
            for s in held[MAX_CONNECTIONS_PER_CLIENT:]:
                try:
                    assert s.recv(100) == b""
                except ConnectionResetError:
                    pass
            assert time.monotonic() - t0 < 1.0
            # another client meanwhile: served
            assert exchange(url, b"GET /nowhere HTTP/1.1\r\n\r\n").startswith(b"HTTP/1.1 404")
            # the rest: closed once quiet for the idle time, not before
            for s in held[:MAX_CONNECTIONS_PER_CLIENT]:
                assert s.recv(100) == b""
            assert IDLE_CLOSE_S - 0.1 < time.monotonic() - t0 < IDLE_CLOSE_S + 3.0
        finally:
            for s in held:
                s.close()


# --- the host: http:// and the camera -----------------------------------------------------------

def test_the_transport_reconnects_after_the_robot_closed_its_quiet_connection(junior):
    from roar.protocol import encode, spec
    from roar.transports.junior_http import HttpTransport
    from roar_sim.links.junior_http import IDLE_CLOSE_S

    transport = HttpTransport(*address(junior.urls.control_url), camera_port=address(junior.urls.camera_url)[1])
    transport.open()
    try:
        transport.write(encode(spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US))
        time.sleep(IDLE_CLOSE_S + 0.5)  # the robot closes the connection meanwhile
        transport.write(encode(spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US))
        assert transport.requests == 3
    finally:
        transport.close()

@pytest.mark.parametrize("throttle, steering, expected", [
    (0, 0.7, (0, 0)), (0.2, 0, (1, 1)), (-0.9, 0, (-1, -1)), (0.5, 1.0, (1.0, 0)), (0.5, -0.5, (0, 0.9))])
def test_the_original_mapping_is_the_roar_junior_clients(throttle, steering, expected):
    assert original_mix(throttle, steering) == pytest.approx(expected)


def test_smooth_mixing_and_the_query_for_wheel_duties():
    assert smooth_mix(0.5, 0.0) == (0.5, 0.5) and smooth_mix(0.5, 1.0) == (1.0, 0.0)
    assert smooth_mix(0.0, 0.5) == (0.5, -0.5)
    assert query_for(0.0, 0.0) == "stop=True"
    assert query_for(0.5, 0.25) == "forward=True&left_spd=0.500&right_spd=0.250"
    assert query_for(-0.5, -1.0) == "backward=True&left_spd=0.500&right_spd=1.000"
    assert query_for(-0.5, 0.5) == "turnLeft=True&left_spd=0.500&right_spd=0.500"


def test_a_vehicle_drives_the_simulated_junior_over_http_and_reads_its_range(junior):
    sim = junior.server.sim
    with Vehicle(junior.urls.vehicle_url + "&mixing=smooth") as car:
        yaw0 = sim.state().yaw
        car.drive(throttle=0.6, steering=0.5)
        assert wait_for(lambda: sim.state().speed > 0.15, timeout_s=3)
        assert wait_for(lambda: sim.state().yaw - yaw0 < -0.3, timeout_s=5)  # steering right turns clockwise
        state = car.state()
        assert state.range_m is not None and (state.range_m == math.inf or 0.02 <= state.range_m <= 4.0)
        assert car.transport.requests > 10
    assert wait_for(lambda: abs(sim.state().speed) < 0.05, timeout_s=3)  # neutral on exit, then it stops


def test_the_vehicle_camera_and_stream_give_frames(junior):
    with Vehicle(junior.urls.vehicle_url) as car:
        rgb, depth = car.camera(320, 240)
        assert rgb.shape == (240, 320, 3) and depth is None
        assert next(iter(car.camera_stream())).shape == (600, 800, 3)


def test_the_circle_example_drives_the_simulated_junior(junior):
    import subprocess
    import sys

    sim = junior.server.sim
    proc = subprocess.Popen([sys.executable, str(ROOT / "examples" / "circle.py"), junior.urls.vehicle_url])
    try:
        yaw0 = sim.state().yaw
        assert wait_for(lambda: abs(sim.state().yaw_rate) > 1.0, timeout_s=10)
        assert wait_for(lambda: abs(sim.state().yaw - yaw0) > 2.0, timeout_s=10)
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_bad_http_urls_and_no_junior_are_one_line():
    from roar import TransportError

    for url, words in (("http://127.0.0.1", "needs HOST:PORT"), ("http://127.0.0.1:81?mixing=tank", "mixing must be"),
                       ("http://127.0.0.1:1", "Junior at 127.0.0.1:1")):
        with pytest.raises(TransportError) as e:
            Vehicle(url)
        assert words in str(e.value) and "\n" not in str(e.value)


def test_frames_are_delivered_whole_or_not_at_all():
    """An MJPEG stream with a truncated JPEG, a part of garbage and bytes outside any part
    between good frames: only the good frames come out, each whole."""
    from PIL import Image

    from roar.camera import MjpegStream, decode_image

    def jpeg(colour):
        out = io.BytesIO()
        Image.new("RGB", (64, 48), colour).save(out, "JPEG")
        return out.getvalue()

    good = [jpeg((255, 0, 0)), jpeg((0, 255, 0)), jpeg((0, 0, 255))]
    parts = [good[0], good[1][: len(good[1]) // 2], b"\x00garbage\xff" * 50, good[1], good[2]]
    body = b"noise before the first part\r\n"
    for p in parts:
        body += b"--b\r\nContent-Type: image/jpeg\r\nContent-Length: %d\r\n\r\n" % len(p) + p + b"\r\n"
    body += b"--b--\r\n"
    assert decode_image(good[0][:-10]) is None and decode_image(b"") is None

    listener = socket.create_server(("127.0.0.1", 0))

    def serve():
        conn, _ = listener.accept()
        conn.recv(4096)
        conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: multipart/x-mixed-replace; boundary=b\r\n\r\n" + body)
        conn.close()

    threading.Thread(target=serve, daemon=True).start()
    with MjpegStream(f"http://127.0.0.1:{listener.getsockname()[1]}/cam.mjpeg") as stream:
        frames = list(stream)
    listener.close()
    colours = [tuple(int(v) for v in f[24, 32]) for f in frames]
    assert len(frames) == 3 and stream.skipped == 2
    assert [max(range(3), key=lambda i: c[i]) for c in colours] == [0, 1, 2]


def test_a_vehicle_reconnects_when_the_junior_comes_back():
    """The robot reboots (its server goes away and returns on the same port): the Vehicle's
    held command reaches the new one without the script doing anything."""
    from roar_sim.links.junior_http import InBackground

    with InBackground(render_workers=0) as first:
        port = int(first.urls.control_url.rsplit(":", 1)[1])
        car = Vehicle(first.urls.control_url, rate_hz=50)
        car.drive(throttle=0.5, steering=0.0)
        assert wait_for(lambda: first.server.sim.state().speed > 0.1, timeout_s=3)
    try:
        assert wait_for(lambda: not car.connected, timeout_s=3)
        with InBackground(port=port, camera_port=0, render_workers=0) as second:
            assert wait_for(lambda: second.server.sim.state().speed > 0.1, timeout_s=10)
            assert car.connected and car.link_error is None
    finally:
        car.close()


def test_stop_ends_a_connection_whose_handler_lost_its_cancel(monkeypatch):
    """Python 3.11's wait_for can swallow a cancel that meets a completing read, and a client
    sending at 50 Hz keeps such a handler serving: stop() must still end it, and soon."""
    from roar_sim.links import junior_http

    real = junior_http.JuniorServer._control

    async def deaf_once(self, reader, writer):  # the lost cancel, made certain
        import asyncio
        try:
            await real(self, reader, writer)
        except asyncio.CancelledError:
            await real(self, reader, writer)
    monkeypatch.setattr(junior_http.JuniorServer, "_control", deaf_once)
    junior = junior_http.InBackground(render_workers=0).__enter__()
    car = Vehicle(junior.urls.control_url, rate_hz=50)
    try:
        car.drive(throttle=0.5, steering=0.0)
        assert wait_for(lambda: junior.server._tasks, timeout_s=3)
        started = time.monotonic()
        junior.__exit__(None, None, None)
        assert time.monotonic() - started < 3 * junior_http.STOP_WAIT_S
    finally:
        car.close()


def test_roar_sim_junior_serves_both_ports_and_prints_them():
    import re
    import signal
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "roar.cli", "sim", "--robot", "junior", "--http", "127.0.0.1:0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        banner = "".join(proc.stdout.readline() for _ in range(3))
        control, camera = re.findall(r"(http://127\.0\.0\.1:\d+)/", banner)[:2]
        status, _, body = http_get(control, "/?forward=True&left_spd=0.5&right_spd=0.5")
        assert status == 200 and body.strip().isdigit()
        status, headers, image = http_get(camera, spec.JUNIOR_ROUTE_CAMERA_LOW)
        assert status == 200 and headers["Content-Type"] == "image/jpeg" and image[:2] == b"\xff\xd8"
        status, _, body = http_get(control, "/?forward=maybe")
        assert status == 400 and body.count(b"\n") <= 1
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:  # fail, but leave no server behind
            proc.kill()
            proc.communicate()
            raise
    assert proc.returncode == 130 and "Traceback" not in err


# --- the autopilot drives it ------------------------------------------------------------------------

def test_the_autopilot_laps_the_oval_with_the_junior_by_its_http_requests(tmp_path, capsys, monkeypatch):
    from roar_sim.robots import junior
    from roar_sim.runs import race

    requests = []
    real_request = junior.request
    monkeypatch.setattr(junior, "request", lambda query, keep_alive=True: (requests.append(query),
                                                                          real_request(query, keep_alive))[1])
    png = tmp_path / "junior.png"
    assert race.main(["--robot", "junior", "--laps", "1", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "ROAR Junior" in out and "lap 1:" in out and "wall contacts: 0" in out
    ratio = float(re.search(r"lap 1: .*?([\d.]+) x the centre line.s limit", out).group(1))
    assert 1.0 <= ratio < 1.2, out  # near its own measured limits, never faster than them
    assert png.stat().st_size > 10_000
    # every period went out as a GET of the control route, and the curvature reached the wheels
    assert len(requests) > 1000 and all(q.startswith("forward=True&") or q == "stop=True" for q in requests)
    assert sum(q.split("left_spd=")[1][:5] != q.split("right_spd=")[1][:5] for q in requests if "spd" in q) > 500


def test_the_junior_refuses_the_heading_pid(capsys):
    from roar_sim.runs import race

    assert run_command("roar race", race.main, ["--robot", "junior", "--steering", "pid"]) == 1
    assert "pure pursuit only" in capsys.readouterr().err


def test_a_dead_camera_renderer_gives_503_not_a_hang():
    from roar_sim.links.junior_http import InBackground

    with InBackground(render_workers=1) as junior:
        status, _, _ = http_get(junior.urls.camera_url, spec.JUNIOR_ROUTE_CAMERA_LOW, timeout=30)
        assert status == 200
        for process in junior.server.camera._processes:
            process.kill()
            process.join()
        time.sleep(IDLE_WAIT_S)  # the capture loop ends; the next request starts one on a dead renderer
        status, _, body = http_get(junior.urls.camera_url, spec.JUNIOR_ROUTE_CAMERA_LOW, timeout=10)
        assert status == 503 and b"camera off" in body
        status, _, body = http_get(junior.urls.control_url, "/?stop=True")
        assert status == 200  # control goes on


def test_a_stream_frame_is_handed_on_before_the_next_part_starts():
    """A whole frame with its Content-Length is delivered at once, not one frame period later
    when the next boundary arrives."""
    from PIL import Image

    from roar.camera import MjpegStream

    out = io.BytesIO()
    Image.new("RGB", (64, 48), (0, 200, 0)).save(out, "JPEG")
    frame = out.getvalue()
    listener = socket.create_server(("127.0.0.1", 0))
    done = threading.Event()

    def serve():
        conn, _ = listener.accept()
        conn.recv(4096)
        conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: multipart/x-mixed-replace; boundary=b\r\n\r\n"
                     b"--b\r\nContent-Type: image/jpeg\r\nContent-Length: %d\r\n\r\n" % len(frame) + frame + b"\r\n")
        done.wait(10)  # the next part never comes while the client waits
        conn.close()

    threading.Thread(target=serve, daemon=True).start()
    try:
        with MjpegStream(f"http://127.0.0.1:{listener.getsockname()[1]}/cam.mjpeg", timeout_s=3) as stream:
            first = next(iter(stream))
        assert first.shape == (48, 64, 3) and first[24, 32, 1] > 150
    finally:
        done.set()
        listener.close()


def test_signed_control_on_the_junior_over_http(junior):
    """A Junior with a key (set on its serial port) drives only for signed queries; a host
    without the key is refused 403 with the reason and the robot stays put; a second host with
    the key counts on past the first one's counter."""
    from roar_wire import signing

    sim, key = junior.server.sim, bytes(range(16))
    sim.write(b"KEY " + key.hex().encode() + b"\n")
    assert wait_for(lambda: (lines := sim.read()) and lines[0] == f"KEY {signing.fingerprint(key)}")
    try:
        for attempt, (k, moves) in enumerate([(key, True), (False, False), (bytes(16), False), (key, True)]):
            assert wait_for(lambda: abs(sim.state().speed) < 0.05, timeout_s=5)
            with Vehicle(junior.urls.vehicle_url, key=k) as car:
                car.drive(throttle=0.6)
                moved = wait_for(lambda: sim.state().speed > 0.15, timeout_s=1.5)
                assert moved == moves, (attempt, k)
                if k is not False:
                    assert car.signer.session == sim.board.session
                if attempt == 3:  # past the first host's counter after at most one refusal
                    assert car.signer.refused <= 1
        status, body = sim.get("forward=True")
        assert (status, body) == (403, f"unsigned {sim.board.session:08x}\n")
    finally:
        sim.write(b"KEY -\n")
        assert wait_for(lambda: "KEY none" in sim.read())
