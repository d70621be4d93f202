"""roar web: the driving rules (one driver, the dead man, bad input), the server's access rules
over real sockets, and the page itself in a real Chromium (Debian's, through Playwright) driving
the simulated car."""

from __future__ import annotations

import contextlib
import json
import math
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from conftest import ROOT, free_port, served, wait_for

pytest.importorskip("websockets", reason="roar web needs websockets: pip install 'roar-platform[web]'")

from roar import Vehicle  # noqa: E402
from roar.calibration import Calibration  # noqa: E402
from roar.protocol import decode  # noqa: E402
from roar.web.controls import DEAD_MAN_S, Controls  # noqa: E402
from roar.web.server import WebServer  # noqa: E402

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

NEUTRAL = (1500, 1500)  # [us] with the default calibration
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run"]
# [s] beyond the dead man, for the car's thread and a busy machine: the suite runs CPU-bound tests beside
# this one on two cores, and the server, the simulator, Chromium and the sender (threads of one process,
# sharing its GIL with the simulator's) then took up to 71 ms, and once 152 ms (CI, 2026-12-06)
SLACK_S = 0.2
# [s] for Chromium itself to tear a closed tab down and cut its socket on a busy machine (up to 0.42 s
# seen beside a CPU-bound test): not our code's latency, which counts from the socket's end
BROWSER_CLOSE_S = 1.0


# --- the rules, on their own ------------------------------------------------------------------------


def drive(throttle, steering=0.0) -> str:
    return json.dumps({"t": "drive", "throttle": throttle, "steering": steering})


def test_first_page_drives_the_next_watches_until_it_takes_over():
    c = Controls()
    assert c.join("a", 0.0) == "driver" and c.join("b", 0.0) == "viewer"
    c.handle("b", drive(1.0), 0.0)
    assert c.command(0.01) == (0.0, 0.0) and c.ignored["not the driver"] == 1
    c.handle("a", drive(1.0, -0.5), 0.0)
    assert c.command(0.01) == (0.5, -0.5)  # the default limit halves the throttle
    assert c.handle("b", '{"t": "take"}', 0.02) == "role"
    assert c.role("a") == "viewer" and c.role("b") == "driver"
    assert c.command(0.03) == (0.0, 0.0)  # the new driver starts at neutral
    c.handle("a", drive(1.0), 0.04)
    assert c.command(0.05) == (0.0, 0.0)
    c.leave("b")
    assert c.driver is None and c.command(0.06) == (0.0, 0.0)


def test_dead_man_neutral_after_250_ms_of_silence_and_again_on_the_next_message():
    c = Controls()
    c.join("a", 0.0)
    c.handle("a", json.dumps({"t": "limit", "max_throttle": 1.0}), 0.0)
    c.handle("a", drive(0.8), 1.0)
    assert c.command(1.0 + DEAD_MAN_S - 0.001) == (0.8, 0.0)
    assert c.command(1.0 + DEAD_MAN_S + 0.001) == (0.0, 0.0) and c.dead_man_trips == 1
    assert c.command(1.0 + DEAD_MAN_S + 0.002) == (0.0, 0.0) and c.dead_man_trips == 1  # one trip per silence
    c.handle("a", drive(0.3), 5.0)
    assert c.command(5.01) == (0.3, 0.0)
    c.handle("a", '{"t": "release"}', 5.02)  # the page was hidden
    assert c.command(5.03) == (0.0, 0.0)


def test_autopilot_drives_only_while_the_driver_holds_the_dead_man():
    c = Controls(autopilots=("pose",))
    c.join("a", 0.0)
    assert c.handle("a", '{"t": "autopilot", "name": "pose"}', 0.0) == "settings" and c.autopilot == "pose"
    c.handle("a", drive(0.0), 0.2)
    assert c.command(0.3) == (0.0, 0.0) and c.autopilot == "pose"
    c.command(0.2 + DEAD_MAN_S + 0.01)
    assert c.autopilot == "none"
    c.handle("a", '{"t": "autopilot", "name": "warp"}', 1.0)
    assert c.ignored["unknown autopilot"] == 1 and c.autopilot == "none"


BAD_MESSAGES = [
    ('{"t": "drive", "throttle": NaN, "steering": 0}', "not JSON"),
    ('{"t": "drive", "throttle": Infinity, "steering": 0}', "not JSON"),
    ('{"t": "drive", "throttle": 1e999, "steering": 0}', "axis not a finite number"),
    ('{"t": "drive", "throttle": ' + "9" * 400 + ', "steering": 0}', "axis not a finite number"),
    ('{"t": "drive", "throttle": 1.5, "steering": 0}', "axis outside -1..1"),
    ('{"t": "drive", "throttle": 0.5, "steering": -1.01}', "axis outside -1..1"),
    ('{"t": "drive", "throttle": true, "steering": 0}', "axis not a finite number"),
    ('{"t": "drive", "throttle": "0.5", "steering": 0}', "axis not a finite number"),
    ('{"t": "drive", "throttle": 0.5}', "axis not a finite number"),
    ('{"t": "drive", "throttle', "not JSON"),
    ("[1, 2]", "not a message"),
    ('{"throttle": 1}', "not a message"),
    ('{"t": "fly"}', "unknown message"),
    ('{"t": "limit", "max_throttle": 2}', "max_throttle not in 0..1"),
    ('{"t": "record", "on": "yes"}', "record needs on: true|false and roar-platform[record]"),
    ("[" * 5000, "too long"),
    (b"\x00\xff", "not text"),
]


@pytest.mark.parametrize("text, reason", BAD_MESSAGES)
def test_a_bad_message_is_counted_and_moves_nothing(text, reason):
    c = Controls()
    c.join("a", 0.0)
    c.handle("a", drive(0.2), 0.0)
    assert c.handle("a", text, 0.01) is None
    assert c.ignored == {reason: 1}
    assert c.command(0.02) == (0.1, 0.0) and c.max_throttle == 0.5


# --- the server over real sockets (loop://: every write on the wire, timed) ------------------------------


@pytest.fixture
def loop_server():
    car = Vehicle("loop://", calibration=Calibration())
    server = WebServer(car, port=0)
    server.start()
    yield car, server
    server.stop()
    car.close()


def ws_connect(server, origin: str | None = "same", path="/ws", **kwargs):
    from websockets.sync.client import connect

    host = f"127.0.0.1:{server.port}"
    origin = f"http://{host}" if origin == "same" else origin
    return connect(f"ws://{host}{path}", origin=origin, open_timeout=5, **kwargs)


def wire(car) -> list[tuple[float, tuple[int, int]]]:
    """(time, (throttle, steering) [us]) of every control message written so far."""
    out = []
    for t, data in list(car.transport.writes):
        cmd = decode(data)
        out.append((t, (cmd.throttle_us, cmd.steering_us)))
    return out


def neutral_on_the_wire_after(car, t: float) -> float:
    """When neutral was first written after t (waiting up to 2 s for it); fails if never."""
    at = wait_for(lambda: next((w for w, p in wire(car) if w > t and p == NEUTRAL), None), 2.0)
    assert at is not None, f"no neutral on the wire after {t}: {wire(car)[-5:]}"
    return at


def test_socket_drives_the_car_and_silence_brings_neutral_within_250_ms(loop_server):
    car, server = loop_server
    with ws_connect(server) as ws:
        hello = json.loads(ws.recv(timeout=5))
        assert hello["t"] == "hello" and hello["car"] == "loop://" and hello["dead_man_s"] == DEAD_MAN_S
        ws.send(json.dumps({"t": "limit", "max_throttle": 1.0}))
        ws.send(drive(0.5, 1.0))
        assert wait_for(lambda: car.pulses_us() == (1750, 2000), 2.0)
        last = time.monotonic()  # nothing more from the page: its script stalled
        assert neutral_on_the_wire_after(car, last) - last <= DEAD_MAN_S + SLACK_S
        assert server.controls.dead_man_trips == 1


def test_closing_the_socket_brings_neutral_at_once(loop_server):
    car, server = loop_server
    with ws_connect(server) as ws:
        ws.recv(timeout=5)
        ws.send(drive(1.0))
        assert wait_for(lambda: car.pulses_us() == (1750, 1500), 2.0)
        closed = time.monotonic()
        ws.close()
    assert neutral_on_the_wire_after(car, closed) - closed < DEAD_MAN_S
    assert server.controls.dead_man_trips == 0  # it was the close, not the silence


def test_bad_messages_over_the_socket_never_move_the_car(loop_server):
    car, server = loop_server
    with ws_connect(server) as ws:
        ws.recv(timeout=5)
        for text, _ in BAD_MESSAGES:
            if len(text) < 4000:
                ws.send(text)
        ws.send(json.dumps({"t": "ping"}))
        assert wait_for(lambda: server.ignored_total() == len(BAD_MESSAGES), 2.0)  # the long one left out, a "ping" added
    assert all(p == NEUTRAL for _, p in wire(car))
    assert not server.problem


def test_a_message_beyond_the_socket_limit_closes_only_that_page(loop_server):
    car, server = loop_server
    from websockets.exceptions import ConnectionClosed

    with ws_connect(server) as ws:
        ws.recv(timeout=5)
        ws.send("x" * 100_000)
        with pytest.raises(ConnectionClosed):
            for _ in range(100):
                ws.recv(timeout=2)
    assert all(p == NEUTRAL for _, p in wire(car))
    with ws_connect(server) as ws:  # the server goes on
        assert json.loads(ws.recv(timeout=5))["t"] == "hello"


@pytest.mark.parametrize("origin", [None, "http://evil.example", "null"])
def test_the_socket_refuses_other_origins(loop_server, origin):
    from websockets.exceptions import InvalidStatus

    car, server = loop_server
    with pytest.raises(InvalidStatus) as e:
        ws_connect(server, origin=origin)
    assert e.value.response.status_code == 403
    assert server.refused == {"Origin not this server": 1}


def http_get(url: str, headers: dict | None = None):
    import urllib.error
    import urllib.request

    class NoRedirect(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, *a, **k):
            return None

    opener = urllib.request.build_opener(NoRedirect)
    try:
        with opener.open(urllib.request.Request(url, headers=headers or {}), timeout=5) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def test_loopback_server_serves_its_page_and_refuses_other_host_names(loop_server):
    car, server = loop_server
    status, headers, body = http_get(f"http://127.0.0.1:{server.port}/")
    assert status == 200 and b"app.js" in body and headers["Content-Type"].startswith("text/html")
    assert "default-src 'self'" in headers["Content-Security-Policy"]
    for path in ("/app.js", "/style.css"):
        assert http_get(f"http://127.0.0.1:{server.port}{path}")[0] == 200
    assert http_get(f"http://127.0.0.1:{server.port}/../etc/passwd")[0] == 404
    # a DNS name pointing at 127.0.0.1 (a rebinding attack) is not served
    assert http_get(f"http://127.0.0.1:{server.port}/", {"Host": f"evil.example:{server.port}"})[0] == 403


@pytest.mark.parametrize("method, body", [("POST", b"a=1"), ("POST", b""), ("PUT", b"x"), ("DELETE", None),
                                          ("OPTIONS", None), ("PATCH", b"{}")])
def test_other_methods_are_answered_405_with_the_ones_allowed(loop_server, method, body):
    """Only GET and HEAD: the rest, with a body or not, get 405 and an Allow header, and the car
    never moves."""
    import http.client

    car, server = loop_server
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=5)
    connection.request(method, "/", body=body)
    response = connection.getresponse()
    assert response.status == 405 and response.getheader("Allow") == "GET, HEAD", response.status
    assert b"not allowed" in response.read()
    assert server.refused.get("method not allowed", 0) >= 1
    connection.close()
    for method in ("GET", "HEAD"):
        connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=5)
        connection.request(method, "/")
        assert connection.getresponse().status == 200
        connection.close()


def test_beyond_loopback_the_token_is_needed_for_page_and_socket():
    from websockets.exceptions import InvalidStatus

    with Vehicle("loop://", calibration=Calibration()) as car:
        server = WebServer(car, host="0.0.0.0", port=0)
        server.start()
        try:
            base = f"http://127.0.0.1:{server.port}/"
            assert server.token and server.url == base + f"?token={server.token}"
            assert http_get(base)[0] == 401
            assert http_get(base + "?token=wrong")[0] == 401
            status, headers, _ = http_get(server.url)
            assert status == 303 and headers["Location"] == "/"
            cookie = headers["Set-Cookie"].split(";")[0]
            assert "HttpOnly" in headers["Set-Cookie"] and "SameSite=Strict" in headers["Set-Cookie"]
            assert http_get(base, {"Cookie": cookie})[0] == 200
            with pytest.raises(InvalidStatus) as e:
                ws_connect(server)
            assert e.value.response.status_code == 401
            with pytest.raises(InvalidStatus):
                ws_connect(server, additional_headers={"Cookie": "roar_token=wrong"})
            assert all(p == NEUTRAL for _, p in wire(car))
            with ws_connect(server, additional_headers={"Cookie": cookie}) as ws:
                ws.recv(timeout=5)
                ws.send(drive(1.0))
                assert wait_for(lambda: car.pulses_us() == (1750, 1500), 2.0)
            assert server.refused["no token"] == 4
        finally:
            server.stop()


def test_a_car_driven_by_speed_gets_speed_setpoints():
    with Vehicle("sim://?robot=iarrc", calibration=Calibration()) as car:
        server = WebServer(car, port=0, max_speed_m_s=1.0)
        server.start()
        try:
            assert wait_for(lambda: car.protocol_version == 2, 3.0)
            with ws_connect(server) as ws:
                assert json.loads(ws.recv(timeout=5))["by_speed"]
                ws.send(json.dumps({"t": "limit", "max_throttle": 1.0}))

                def speed():
                    ws.send(drive(1.0))
                    time.sleep(0.05)
                    return car.state().speed_m_s > 0.5
                assert wait_for(speed, 8.0)
                assert car._speed == 1.0
        finally:
            server.stop()
        assert car._speed == 0.0


# --- the command line ------------------------------------------------------------------------------------


def roar(*args, timeout=60):
    return subprocess.run([sys.executable, "-m", "roar.cli", *args], capture_output=True, text=True, timeout=timeout)


def test_cli_one_line_errors_for_a_port_in_use_and_an_unknown_car():
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        r = roar("web", "loop://", "--port", str(port))
    assert r.returncode == 1 and r.stderr.count("\n") == 1, r.stderr
    assert "port is in use" in r.stderr
    r = roar("web", "warp://car")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "warp" in r.stderr, r.stderr
    r = roar("web", "loop://", "--port", "70000")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "must be a port" in r.stderr, r.stderr


def test_cli_serves_for_a_while_and_leaves_the_car_at_neutral():
    r = roar("web", "loop://", "--port", str(free_port()), "--for", "0.5")
    assert r.returncode == 0, r.stderr
    assert "roar web: open http://127.0.0.1:" in r.stdout and "left at neutral" in r.stdout
    r = roar("web", "loop://", "--port", str(free_port()), "--host", "0.0.0.0", "--for", "0.3")
    assert r.returncode == 0 and "?token=" in r.stdout and "its token is the key" in r.stdout


def test_ctrl_c_ends_at_once_with_a_page_connected():
    import signal

    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "roar.cli", "web", "loop://", "--port", str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "roar web: open" in proc.stdout.readline()
        from websockets.sync.client import connect

        with connect(f"ws://127.0.0.1:{port}/ws", origin=f"http://127.0.0.1:{port}") as ws:
            ws.recv(timeout=5)
            ws.send(drive(0.5))
            time.sleep(0.2)
            began = time.monotonic()
            proc.send_signal(signal.SIGINT)
            out, err = proc.communicate(timeout=10)
            assert time.monotonic() - began < 3.0
    finally:
        proc.kill()
    assert proc.returncode == 130 and "Traceback" not in err, err


# --- the page in a real browser --------------------------------------------------------------------------


def _playwright():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("the browser tests need Playwright: pip install playwright (roar-platform[dev])")
    if not Path(CHROMIUM).exists():
        pytest.skip("the browser tests need Chromium: apt install chromium")
    return sync_playwright


class WireLog:
    """Every control message the Vehicle hands the simulated car's link, timed; and when each of
    the pages' messages reached the server (watch(server))."""

    def __init__(self, car) -> None:
        self.writes: list[tuple[float, tuple[int, int]]] = []
        self.received: list[float] = []
        self.left: list[float] = []  # when the server saw a page's socket end
        link = car.transport
        inner = link.write

        def write(data: bytes) -> None:
            inner(data)
            cmd = decode(data)
            self.writes.append((time.monotonic(), (cmd.throttle_us, cmd.steering_us)))

        link.write = write

    def first(self, after: float, pulses) -> float | None:
        return next((t for t, p in list(self.writes) if t >= after and p == pulses), None)

    def watch(self, server) -> None:
        handle = server.controls.handle

        def handled(client_id, text, now_s):
            self.received.append(now_s)
            return handle(client_id, text, now_s)

        server.controls.handle = handled
        leave = server.controls.leave

        def left(client_id):
            self.left.append(time.monotonic())
            return leave(client_id)

        server.controls.leave = left

    def quiet_to_neutral(self, after: float) -> float:
        """[s] from the pages' last message to the car's neutral, the first after `after`: the
        dead man's promise (a page's last message may arrive a moment after it was told to stop)."""
        neutral = self.first(after, NEUTRAL)
        return neutral - max(t for t in list(self.received) if t < neutral)


@pytest.fixture(scope="module")
def browser():
    sync_playwright = _playwright()
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def sim_web():
    """The simulated ESC car on an open floor, served by roar web; its wire logged."""
    car = Vehicle("sim://", calibration=Calibration())
    log = WireLog(car)
    server = WebServer(car, port=0, record_dir=ROOT / "out" / "test_web")
    log.watch(server)
    server.start()
    yield car, server, log
    server.stop()
    car.close()


@pytest.fixture
def page_on(browser, sim_web):
    """Open pages on the served simulator; every page is closed (and the car neutral) after."""
    car, server, log = sim_web
    context = browser.new_context(viewport={"width": 1280, "height": 900}, has_touch=True, bypass_csp=True)
    errors: list[str] = []

    def open_page():
        page = context.new_page()
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server.url)
        page.wait_for_function("window.roar && roar.state !== null", timeout=10_000)
        return page

    yield open_page
    context.close()
    assert wait_for(lambda: not server.controls.clients and car.pulses_us() == NEUTRAL, 3.0)
    assert not errors, errors


def test_keys_drive_the_simulated_car(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    assert page.evaluate("roar.role") == "driver"
    page.keyboard.down("ArrowUp")
    assert wait_for(lambda: car.state().speed_m_s > 0.3, 5.0)
    assert car.pulses_us() == (1750, 1500)  # the default limit: half throttle
    page.keyboard.down("d")
    assert wait_for(lambda: car.pulses_us() == (1750, 2000), 2.0)
    assert wait_for(lambda: car.state().yaw_rate_rad_s < -0.2, 3.0)  # right: clockwise
    page.keyboard.up("d")
    page.keyboard.up("ArrowUp")
    assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)
    page.keyboard.down("ArrowDown")
    assert wait_for(lambda: car.pulses_us()[0] == 1250, 2.0)
    page.keyboard.press(" ")  # space: neutral even while a key is held
    assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)
    page.keyboard.up("ArrowDown")


def _pad_point(page, x: float, y: float) -> tuple[float, float]:
    box = page.locator("#pad").bounding_box()
    return box["x"] + box["width"] / 2 * (1 + x), box["y"] + box["height"] / 2 * (1 + y)


def test_on_screen_joystick_by_mouse_and_by_touch(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    page.mouse.move(*_pad_point(page, 0, 0))
    page.mouse.down()
    page.mouse.move(*_pad_point(page, 0.5, -0.8), steps=5)  # up and right: forward, steering right
    # the Vehicle has it (server.applied is set a moment before the car's thread hands it over)
    assert wait_for(lambda: 1650 < car.pulses_us()[0] <= 1750 and 1700 < car.pulses_us()[1] < 1800, 2.0), \
        car.pulses_us()
    page.mouse.up()
    assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)

    cdp = page.context.new_cdp_session(page)
    x0, y0 = _pad_point(page, 0, 0)
    x1, y1 = _pad_point(page, -0.9, 0)  # a finger to the left: full left, no throttle
    cdp.send("Input.dispatchTouchEvent", {"type": "touchStart", "touchPoints": [{"x": x0, "y": y0}]})
    cdp.send("Input.dispatchTouchEvent", {"type": "touchMove", "touchPoints": [{"x": x1, "y": y1}]})
    assert wait_for(lambda: car.pulses_us()[1] < 1100 and car.pulses_us()[0] == 1500, 2.0), car.pulses_us()
    cdp.send("Input.dispatchTouchEvent", {"type": "touchEnd", "touchPoints": []})
    assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)


def test_gamepad_axes_drive_the_car(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    page.evaluate("""() => {
        window.fakePad = {axes: [0.6, -1.0, 0, 0], buttons: Array.from({length: 16}, () => ({value: 0}))};
        navigator.getGamepads = () => [window.fakePad];
    }""")
    assert wait_for(lambda: car.pulses_us() == (1750, 1800), 2.0), car.pulses_us()
    page.evaluate("window.fakePad.axes = [0.05, 0.05, 0, 0]")  # inside the dead zone
    assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)


def test_camera_frames_reach_the_page(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    first = page.evaluate("roar.frames")
    assert wait_for(lambda: page.evaluate("roar.frames") >= first + 5, 5.0)
    src = page.evaluate("document.getElementById('camera').src")
    assert wait_for(lambda: page.evaluate("document.getElementById('camera').src") != src, 2.0)
    size = page.evaluate("[document.getElementById('camera').naturalWidth, document.getElementById('camera').naturalHeight]")
    assert size == [320, 240]
    assert float(page.inner_text("#fps").split()[0]) > 3


def _drive_forward(page, car) -> None:
    page.keyboard.down("ArrowUp")
    assert wait_for(lambda: car.pulses_us()[0] == 1750, 2.0)


def test_closing_the_tab_brings_neutral_within_250_ms(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    _drive_forward(page, car)
    closed = time.monotonic()
    page.close()
    assert wait_for(lambda: log.first(closed, NEUTRAL), 2.0)
    neutral = log.first(closed, NEUTRAL)
    assert neutral - closed <= DEAD_MAN_S + BROWSER_CLOSE_S
    cut = min(t for t in log.left if t >= closed)  # the server saw the socket end
    assert neutral - cut <= DEAD_MAN_S, f"{neutral - cut:.3f} s from the socket's end to neutral"


def test_a_hidden_page_brings_neutral(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    _drive_forward(page, car)
    hidden = time.monotonic()
    hide(page)
    assert wait_for(lambda: log.first(hidden, NEUTRAL), 2.0)
    assert log.first(hidden, NEUTRAL) - hidden <= DEAD_MAN_S
    time.sleep(0.3)
    assert car.pulses_us() == NEUTRAL  # the key is still down, but a hidden page sends nothing
    page.keyboard.up("ArrowUp")


def test_a_stalled_page_brings_neutral_within_250_ms(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    _drive_forward(page, car)
    cdp = page.context.new_cdp_session(page)
    cdp.send("Debugger.enable")
    stalled = time.monotonic()
    cdp.send("Debugger.pause")  # the page's script stops: no more stick
    assert wait_for(lambda: log.first(stalled, NEUTRAL), 2.0)
    assert log.quiet_to_neutral(stalled) <= DEAD_MAN_S + SLACK_S
    cdp.send("Debugger.resume")
    page.keyboard.up("ArrowUp")


class StallingProxy:
    """A TCP relay between the browser and the server that can stop relaying without closing
    anything: a cut socket as a lost Wi-Fi link makes one."""

    def __init__(self, port: int) -> None:
        self.target, self.cut = port, threading.Event()
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen()
        self.port = self.sock.getsockname()[1]
        self.open: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                a, _ = self.sock.accept()
            except OSError:
                return
            b = socket.create_connection(("127.0.0.1", self.target))
            self.open += [a, b]
            for src, dst in ((a, b), (b, a)):
                threading.Thread(target=self._pipe, args=(src, dst), daemon=True).start()

    def _pipe(self, src, dst) -> None:
        try:
            while data := src.recv(65536):
                if self.cut.is_set():
                    continue  # swallowed: nothing arrives, nothing is closed
                dst.sendall(data.replace(f":{self.port}".encode(), f":{self.target}".encode()))
        except OSError:
            pass

    def close(self) -> None:
        for sock in [self.sock, *self.open]:
            sock.close()


def test_a_cut_socket_brings_neutral_within_250_ms(browser, sim_web):
    car, server, log = sim_web
    proxy = StallingProxy(server.port)
    context = browser.new_context(bypass_csp=True)
    try:
        page = context.new_page()
        page.goto(f"http://127.0.0.1:{proxy.port}/")
        page.wait_for_function("window.roar && roar.state !== null", timeout=10_000)
        _drive_forward(page, car)
        cut = time.monotonic()
        proxy.cut.set()
        assert wait_for(lambda: log.first(cut, NEUTRAL), 2.0)
        assert log.quiet_to_neutral(cut) <= DEAD_MAN_S + SLACK_S
    finally:
        proxy.close()
        context.close()
    assert wait_for(lambda: not server.controls.clients, 3.0)


def test_a_second_page_watches_until_it_takes_over(page_on, sim_web):
    car, server, log = sim_web
    first, second = page_on(), page_on()
    assert first.evaluate("roar.role") == "driver"
    assert wait_for(lambda: second.evaluate("roar.role") == "viewer", 2.0)
    assert second.is_visible("#take") and not first.is_visible("#take")
    ignored = server.ignored_total()
    second.keyboard.down("ArrowUp")
    time.sleep(0.3)
    assert car.pulses_us() == NEUTRAL and server.ignored_total() == ignored  # a viewer's page sends no stick
    second.keyboard.up("ArrowUp")
    second.evaluate("""() => document.querySelector('#take').hidden = false""")
    second.click("#take")
    assert wait_for(lambda: second.evaluate("roar.role") == "driver", 2.0)
    assert wait_for(lambda: first.is_visible("#banner"), 2.0)
    assert "took over" in first.inner_text("#banner")
    first.keyboard.down("ArrowUp")  # the old driver's keys do nothing now
    second.keyboard.down("ArrowLeft")
    assert wait_for(lambda: car.pulses_us() == (1500, 1000), 2.0)
    time.sleep(0.2)
    assert car.pulses_us() == (1500, 1000)
    first.keyboard.up("ArrowUp")
    second.keyboard.up("ArrowLeft")


def test_limit_and_stop_button(page_on, sim_web):
    car, server, log = sim_web
    page = page_on()
    page.locator("#limit").fill("0.2")
    assert wait_for(lambda: server.controls.max_throttle == 0.2, 2.0)
    page.keyboard.down("w")
    assert wait_for(lambda: car.pulses_us() == (1600, 1500), 2.0)
    page.click("#stop")
    assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)
    page.keyboard.up("w")
    page.locator("#limit").fill("0.5")
    assert wait_for(lambda: server.controls.max_throttle == 0.5, 2.0)


def test_record_button_writes_an_mcap_the_library_reads(page_on, sim_web):
    pytest.importorskip("foxglove", reason="recording needs roar-platform[record]")
    from roar.replay import summary

    car, server, log = sim_web
    page = page_on()
    page.click("#record")
    assert wait_for(lambda: server.record_path is not None, 3.0)
    path = server.record_path
    page.keyboard.down("ArrowUp")
    time.sleep(1.0)
    page.keyboard.up("ArrowUp")
    assert wait_for(lambda: page.inner_text("#record") == "stop recording", 2.0)
    page.click("#record")
    assert wait_for(lambda: server.record_path is None, 3.0)
    text = summary(path)
    assert "/control" in text and "/camera" in text, text
    assert not server.problem


@contextlib.contextmanager
def page_for(browser, car, wait: bool = True, host: str = "127.0.0.1", **context_options):
    """roar web serving `car`, and a new page on it (once it has heard the server, unless not
    `wait`): yields (server, page); the page closed and the server stopped after."""
    server = WebServer(car, host=host, port=0)
    server.start()
    context = browser.new_context(bypass_csp=True, **context_options)
    try:
        page = context.new_page()
        if wait:
            page.goto(server.url)
            page.wait_for_function("window.roar && roar.hello !== null && roar.state !== null", timeout=10_000)
        yield server, page
    finally:
        context.close()
        server.stop()


def hide(page) -> None:
    """The page as a browser hides it (another tab in front, the phone locked)."""
    page.evaluate("""() => {
        Object.defineProperty(document, 'hidden', {value: true, configurable: true});
        document.dispatchEvent(new Event('visibilitychange'));
    }""")


def test_screenshot_is_not_blank_and_the_plot_draws(browser):
    """The page as a user sees it, the autopilot lapping the oval: written to out/roar_web.png
    (the README's picture is one of these)."""
    import io

    import numpy as np
    from PIL import Image

    with Vehicle("sim://oval", calibration=Calibration()) as car, \
            page_for(browser, car, viewport={"width": 1280, "height": 800}) as (server, page):
        page.select_option("#autopilot", "pose")
        assert wait_for(lambda: page.evaluate("roar.plotted") > 60 and page.evaluate("roar.frames") > 20, 10.0)

        # read before the full-page screenshot, which on a busy machine holds the page's script as long
        assert wait_for(lambda: still_driving(page, "pose") and "m/s" in page.inner_text("#speed"), 10.0), \
            page.inner_text("#sent")
        out = ROOT / "out" / "roar_web.png"
        out.parent.mkdir(exist_ok=True)
        page.screenshot(path=str(out), full_page=True)
        shot = np.asarray(Image.open(out).convert("RGB")).astype(int)
        assert shot.std() > 20  # not one colour
        pixels = np.asarray(Image.open(io.BytesIO(page.locator("#plot").screenshot())).convert("RGB")).astype(int)
        for colour in ((0x4f, 0xc3, 0xf7), (0x81, 0xc7, 0x84), (0xff, 0xb7, 0x4d)):  # speed, throttle, steering
            # (a line, not a stray pixel: steering along the straight lies close to the others' lines)
            assert (np.abs(pixels - colour).sum(axis=2) < 40).sum() > 25, f"no line of colour {colour} in the plot"
        camera = np.asarray(Image.open(io.BytesIO(page.locator("#camera").screenshot())).convert("RGB"))
        assert camera.std() > 10


def test_page_beyond_loopback_needs_the_token(browser):
    with Vehicle("loop://", calibration=Calibration()) as car, \
            page_for(browser, car, wait=False, host="0.0.0.0") as (server, page):
        response = page.goto(f"http://127.0.0.1:{server.port}/")
        assert response.status == 401 and "token" in page.inner_text("body")
        page.goto(server.url)
        page.wait_for_function("window.roar && roar.state !== null", timeout=10_000)
        assert page.url == f"http://127.0.0.1:{server.port}/"  # the token is in a cookie now
        assert page.evaluate("roar.role") == "driver"
        page.keyboard.down("ArrowUp")
        assert wait_for(lambda: car.pulses_us() == (1750, 1500), 2.0)
        page.keyboard.up("ArrowUp")


def still_driving(page, autopilot: str) -> bool:
    """Whether `autopilot` drives the car; if not, it is chosen again. A busy machine can hold the
    page's script past the dead man, which rightly stops the autopilot (#sent says so, the list
    shows none): the user would choose it again."""
    if f"(autopilot {autopilot})" in page.inner_text("#sent"):
        return True
    page.select_option("#autopilot", autopilot)
    return False


def test_pose_autopilot_drives_the_track_while_the_page_holds_on(browser):
    with Vehicle("sim://oval", calibration=Calibration()) as car, page_for(browser, car) as (server, page):
        assert page.evaluate("roar.hello.autopilots") == ["none", "pose", "lane"]
        start = car.state()
        page.select_option("#autopilot", "pose")
        moved = wait_for(lambda: still_driving(page, "pose") and
                         math.hypot(car.state().x_m - start.x_m, car.state().y_m - start.y_m) > 2.0, 10.0)
        # (once, on a busy CI machine, it had not moved 2 m in 10 s: what the server then held says why)
        assert moved, (car.state(), server.controls.autopilot, server.controls.dead_man_trips, server.applied,
                       server.problem)
        # still choosing pose, unless the dead man has just stopped it again (seen in a suite on two busy cores)
        assert server.controls.autopilot == "pose" or server.controls.dead_man_trips, server.controls.autopilot
        assert not server.problem, server.problem
        assert abs(car.state().y_m - start.y_m) < 0.5  # along the straight, on the line
        hidden = time.monotonic()
        hide(page)
        assert wait_for(lambda: car.pulses_us() == NEUTRAL, 2.0)
        assert server.controls.autopilot == "none" and time.monotonic() - hidden < 1.0


def test_lane_autopilot_drives_by_camera_alone(browser):
    from roar.tracks import get

    line = get("oval").centerline
    with Vehicle("sim://oval", calibration=Calibration()) as car, page_for(browser, car) as (server, page):
        start = car.state()
        page.select_option("#autopilot", "lane")
        worst = 0.0

        def driven() -> bool:
            nonlocal worst
            if not still_driving(page, "lane"):
                return False
            s = car.state()
            worst = max(worst, float(min(math.hypot(x - s.x_m, y - s.y_m) for x, y in line)))
            return math.hypot(s.x_m - start.x_m, s.y_m - start.y_m) > 1.5
        moved = wait_for(driven, 15.0)
        s = car.state()
        assert moved and not server.problem, (server.problem, s, server.applied, server.controls.autopilot)
        assert worst < 0.4, worst  # on the road (0.6 m each side of the centre line)


def two_free_ports() -> int:
    """P with P and P - 1 free (a served Junior's control and camera ports)."""
    for _ in range(50):
        p = free_port()
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", p - 1))
            except OSError:
                continue
        return p
    raise RuntimeError("no two free ports in a row")


def frames_on_a_page(browser, car, count: int = 3) -> tuple[int, float]:
    """Serve car, open the page, wait for `count` camera frames: (frames, the fps it shows)."""
    with page_for(browser, car) as (server, page):
        wait_for(lambda: page.evaluate("roar.frames") >= count, 10.0)
        page.keyboard.down("ArrowUp")  # it drives too
        assert wait_for(lambda: server.applied[0] > 0 and server.sent_commands >= 1, 2.0)
        page.keyboard.up("ArrowUp")
        assert not server.problem, server.problem
        # the rate shown settles over the first second of frames (a loaded machine's first ones came at 1/s)
        wait_for(lambda: float(page.inner_text("#fps").split()[0]) > 1, 5.0)
        return page.evaluate("roar.frames"), float(page.inner_text("#fps").split()[0])


def test_a_camera_stream_that_ends_is_opened_again():
    """A car's stream that ends (a Wi-Fi drop, a camera restarting) is opened again: the page says
    so meanwhile, and the frames come on (it used to stop seeing for good)."""
    import numpy as np

    opened = []

    def camera_stream():
        opened.append(time.monotonic())
        count = 3 if len(opened) == 1 else 10**6  # the first stream ends after three frames

        def frames():
            for _ in range(count):
                time.sleep(0.02)
                yield np.zeros((48, 64, 3), np.uint8)
        return frames()

    with Vehicle("loop://", calibration=Calibration()) as car:
        car.camera_stream = camera_stream
        server = WebServer(car, port=0)
        server.has_camera = True  # (a loop:// link has none of its own)
        server.start()
        try:
            assert wait_for(lambda: "opening it again" in server.problem, 3.0)
            assert wait_for(lambda: len(opened) >= 2 and server.camera_frames > 10 and not server.problem, 5.0)
        finally:
            server.stop()


def test_a_juniors_mjpeg_stream_reaches_the_page(browser):
    port = two_free_ports()
    with served("--robot", "junior", "--http", f"127.0.0.1:{port}", "--seconds", "60", lines=2):
        with Vehicle(f"http://127.0.0.1:{port}", calibration=Calibration()) as car:
            frames, fps = frames_on_a_page(browser, car)
    assert frames >= 3 and fps > 1


def test_a_phones_udp_stream_reaches_the_page(browser):
    with served("--stream", "--seconds", "60", "--rate", "10", lines=1):
        with Vehicle("udp://127.0.0.1", calibration=Calibration()) as car:
            frames, fps = frames_on_a_page(browser, car)
    assert frames >= 3 and fps > 1
