"""`roar web`: drive and watch a car from a browser. One port serves the page (roar/web/static,
nothing fetched from elsewhere) and its WebSocket (/ws); every command reaches the car through a
roar.Vehicle, which re-sends it at the car's rate, so every guarantee of the library holds.

    with Vehicle("sim://oval") as car:
        server = WebServer(car)            # 127.0.0.1:8887
        server.start()                     # in a thread; or server.run() until Ctrl-C
        ...
        server.stop()                      # neutral, pages told

Safety: one driver at a time (roar.web.controls); the car goes to neutral when the driver's page
is hidden, closed, loses its socket or sends nothing for DEAD_MAN_S. Access: bound to loopback by
default (and then only loopback Host names are served: no DNS rebinding); bound beyond it, a
token is required (in the printed URL's query, then a cookie) for the page and its socket; the
socket takes only pages of this server's own origin.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import hmac
import http
import importlib.resources
import importlib.util
import ipaddress
import itertools
import json
import logging
import secrets
import threading
import time
from http.cookies import CookieError, SimpleCookie
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from roar.errors import RoarError, WebError
from roar.protocol import spec
from roar.transports.base import Transport
from roar.web.controls import AUTOPILOT_NONE, DEAD_MAN_S, DRIVE_PERIOD_S, MAX_MESSAGE_CHARS, Controls

log = logging.getLogger("roar.web")

WEB_PORT = 8887  # DonkeyCar's port: users of both find it where they expect
LOOPBACK = "127.0.0.1"
TOKEN_COOKIE = "roar_token"
STATE_PERIOD_S = 0.05  # [s] each page hears the car's state this often
CHECK_PERIOD_S = 0.01  # [s] the dead man and the autopilot are looked at this often
CAMERA_SIZE = (320, 240)  # [px] frames asked of a car that renders to order (the simulator)
CAMERA_FPS = 10.0  # [1/s]
JPEG_QUALITY = 80
MAX_SPEED_M_S = 2.0  # [m/s] the stick's full throttle on a car driven by speed (the IARRC car)
STATIC = {"/": ("index.html", "text/html; charset=utf-8"), "/app.js": ("app.js", "text/javascript; charset=utf-8"),
          "/style.css": ("style.css", "text/css; charset=utf-8")}
HEADERS = {"Cache-Control": "no-store", "X-Frame-Options": "DENY", "X-Content-Type-Options": "nosniff",
           "Content-Security-Policy": "default-src 'self'; img-src 'self' blob:; connect-src 'self'"}


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


MAX_REQUEST_LINE_BYTES = 8192  # [bytes] websockets' own limit for a request line
STREAM_RETRY_S = 0.5  # [s] before a camera stream that ended (or failed) is opened again


class WebServer:
    """The page and its socket for one Vehicle. host: where to listen (loopback by default; any
    other address needs the token, made here unless given); record_dir: where "record" writes
    its MCAP files; max_speed_m_s: full stick on a car driven by speed."""

    def __init__(self, vehicle, host: str = LOOPBACK, port: int = WEB_PORT, token: str | None = None,
                 record_dir: str | Path = "out/web", camera_fps: float = CAMERA_FPS,
                 max_speed_m_s: float = MAX_SPEED_M_S) -> None:
        self.vehicle, self.host, self.port = vehicle, host, port
        self.loopback = is_loopback(host)
        self.token = None if self.loopback else (token or secrets.token_urlsafe(16))
        self.record_dir = Path(record_dir)
        self.camera_fps, self.max_speed_m_s = camera_fps, max_speed_m_s
        link = vehicle.transport.link
        self.autopilot_names: tuple[str, ...] = tuple(link.autopilots)
        self.controls = Controls(self.autopilot_names, can_record=importlib.util.find_spec("foxglove") is not None)
        self.has_camera = type(link).camera is not Transport.camera or type(link).camera_stream is not Transport.camera_stream
        self.refused: dict[str, int] = {}  # HTTP/socket requests refused, by reason
        self.sent_commands = 0  # commands handed to the Vehicle
        self.applied = (0.0, 0.0)  # (throttle, steering) the Vehicle is sending now
        self._submitted = (0.0, 0.0)  # the last stick handed to the car's thread
        self.problem = ""  # the last thing that went wrong driving, recording or seeing (shown on the page)
        self.record_path: Path | None = None
        self.pages_served = 0  # sockets opened by pages
        self.camera_frames = 0
        self.camera_fps_now = 0.0
        self._frame: bytes | None = None
        self._ids = itertools.count(1)
        self._sockets: dict[str, object] = {}
        self._car = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="roar-web-car")  # in order
        self._autopilot = None
        self._autopilot_name = AUTOPILOT_NONE
        self._autopilot_busy = False
        self._autopilot_due = 0.0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stopping: asyncio.Event | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._start_error: BaseException | None = None
        self._camera_stop = threading.Event()
        self._tick: asyncio.Condition | None = None

    # --- URLs --------------------------------------------------------------------------------------

    @property
    def url(self) -> str:
        """The page's address (with the token where one is needed)."""
        host = LOOPBACK if self.host in ("0.0.0.0", "::", "") else self.host
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{self.port}/" + (f"?token={self.token}" if self.token else "")

    @property
    def lan_url(self) -> str | None:
        """The page's address for other machines, when listening on every interface (None when
        this machine has no route out, or listens on one address only)."""
        if self.host not in ("0.0.0.0", "::"):
            return None
        import socket

        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                s.connect(("10.255.255.255", 1))  # picks the outgoing interface; sends nothing
                address = s.getsockname()[0]
        except OSError:
            return None
        if is_loopback(address):
            return None
        return f"http://{address}:{self.port}/?token={self.token}"

    # --- running -----------------------------------------------------------------------------------

    def run(self) -> None:
        """Serve until stop() or Ctrl-C (KeyboardInterrupt); the car is at neutral after. WebError
        if it cannot listen."""
        asyncio.run(self._main())
        if self._start_error is not None:
            raise self._start_error

    def start(self) -> None:
        """Serve in a thread; returns once listening (WebError if it cannot)."""
        self._thread = threading.Thread(target=asyncio.run, args=(self._main(),), name="roar-web", daemon=True)
        self._thread.start()
        self._ready.wait(10.0)
        if self._start_error is not None:
            raise self._start_error

    @property
    def serving(self) -> bool:
        return self._ready.is_set() and self._start_error is None and self._thread is not None and self._thread.is_alive()

    def ignored_total(self) -> int:
        """Messages from pages ignored (malformed, out of range, not the driver's...)."""
        return sum(self.controls.ignored.values())

    def stop(self) -> None:
        if self._loop is not None and self._stopping is not None:
            self._loop.call_soon_threadsafe(self._stopping.set)
        if self._thread is not None:
            self._thread.join(10.0)
            self._thread = None

    async def _main(self) -> None:
        from websockets.asyncio.server import serve

        self._loop = asyncio.get_running_loop()
        self._stopping, self._tick = asyncio.Event(), asyncio.Condition()
        try:
            server = await serve(self._client, self.host, self.port, process_request=self._http,
                                 create_connection=_methods_checked(self),
                                 max_size=MAX_MESSAGE_CHARS * 4, ping_interval=5, ping_timeout=5, close_timeout=1,
                                 server_header=None, logger=_QUIET)
        except OSError as e:
            self._start_error = WebError(f"cannot serve on {self.host}:{self.port}: "
                                         f"{'the port is in use (--port)' if e.errno == 98 else e.strerror or e}")
            self._ready.set()
            return
        if self.port == 0:
            self.port = server.sockets[0].getsockname()[1]
        camera = threading.Thread(target=self._camera_loop, name="roar-web-camera", daemon=True)
        if self.has_camera:
            camera.start()
        self._ready.set()
        tasks = [asyncio.create_task(self._check_loop()), asyncio.create_task(self._state_loop())]
        try:
            await self._stopping.wait()
        finally:
            for task in tasks:
                task.cancel()
            self.controls.driver = None
            self._apply()
            server.close()
            await server.wait_closed()
            self._camera_stop.set()
            self._car.submit(self._finish).result(5.0)
            self._car.shutdown()
            if camera.is_alive():
                camera.join(2.0)

    def _finish(self) -> None:
        """On the car's thread, last: the autopilot shut down, the recording finished."""
        self._set_autopilot(AUTOPILOT_NONE)
        if self.record_path is not None:
            self._record(False)

    # --- HTTP ---------------------------------------------------------------------------------------

    def _http(self, connection, request):
        """Everything but the socket's upgrade: the page's files; and who may open the socket."""
        path = urlsplit(request.path)
        host = request.headers.get("Host", "")
        if self.loopback and not _host_is_loopback(host):
            return self._refuse(connection, http.HTTPStatus.FORBIDDEN, "Host is not a loopback name",
                                "this server answers only to 127.0.0.1 or localhost")
        if path.path == "/ws":
            origin = request.headers.get("Origin")
            if origin != f"http://{host}":
                return self._refuse(connection, http.HTTPStatus.FORBIDDEN, "Origin not this server",
                                    "the socket takes pages of this server only")
            if self.token and not self._cookie_ok(request):
                return self._refuse(connection, http.HTTPStatus.UNAUTHORIZED, "no token",
                                    "no token: open the URL `roar web` printed")
            return None  # the WebSocket handshake goes on
        if path.path == "/favicon.ico":  # browsers ask; the page has none
            return connection.respond(http.HTTPStatus.NO_CONTENT, "")
        if path.path not in STATIC:
            return self._refuse(connection, http.HTTPStatus.NOT_FOUND, "not found", "not found")
        if path.path == "/" and self.token:
            given = parse_qs(path.query).get("token", [""])[0]
            if given and hmac.compare_digest(given, self.token):
                response = connection.respond(http.HTTPStatus.SEE_OTHER, "")
                response.headers["Location"] = "/"
                response.headers["Set-Cookie"] = f"{TOKEN_COOKIE}={self.token}; HttpOnly; SameSite=Strict; Path=/"
                return response
            if not self._cookie_ok(request):
                return self._refuse(connection, http.HTTPStatus.UNAUTHORIZED, "no token",
                                    "no token: open the URL `roar web` printed (it ends in ?token=...)")
        name, kind = STATIC[path.path]
        response = connection.respond(http.HTTPStatus.OK, "")
        response.body = _static(name)
        del response.headers["Content-Type"]
        del response.headers["Content-Length"]
        response.headers["Content-Type"] = kind
        response.headers["Content-Length"] = str(len(response.body))
        for k, v in HEADERS.items():
            response.headers[k] = v
        return response

    def _cookie_ok(self, request) -> bool:
        try:
            cookie = SimpleCookie(request.headers.get("Cookie", ""))
        except CookieError:
            return False
        given = cookie[TOKEN_COOKIE].value if TOKEN_COOKIE in cookie else ""
        return bool(given) and hmac.compare_digest(given, self.token or "")

    def count_refusal(self, reason: str) -> None:
        self.refused[reason] = self.refused.get(reason, 0) + 1

    def _refuse(self, connection, status, reason: str, text: str):
        self.count_refusal(reason)
        response = connection.respond(status, text + "\n")
        for k, v in HEADERS.items():
            response.headers[k] = v
        return response

    # --- pages -------------------------------------------------------------------------------------

    async def _client(self, ws) -> None:
        cid = f"page{next(self._ids)}"
        self.pages_served += 1
        controls = self.controls
        self._sockets[cid] = ws
        role = controls.join(cid, time.monotonic())
        log.info("%s joined as %s", cid, role)
        writer = asyncio.create_task(self._writer(ws, cid))
        try:
            await ws.send(json.dumps(self._hello(cid)))
            async for message in ws:
                change = controls.handle(cid, message, time.monotonic())
                if change == "record":
                    self._car.submit(self._record, controls.recording)
                self._apply()
        except Exception as e:  # a socket cut or broken: the page is gone
            if not _closed(e):
                log.warning("%s: %s", cid, e)
        finally:
            writer.cancel()
            self._sockets.pop(cid, None)
            controls.leave(cid)
            self._apply()
            log.info("%s left", cid)

    def _hello(self, cid: str) -> dict:
        return {"t": "hello", "id": cid, "car": self.vehicle.url, "autopilots": list(self.controls.autopilots),
                "camera": self.has_camera, "can_record": self.controls.can_record,
                "dead_man_s": DEAD_MAN_S, "drive_period_s": DRIVE_PERIOD_S,
                "by_speed": self._by_speed(), "max_speed_m_s": self.max_speed_m_s}

    async def _writer(self, ws, cid: str) -> None:
        """This page's state every STATE_PERIOD_S, and each new camera frame (a stalled page holds
        up only itself)."""
        sent_frame = 0
        try:
            while True:
                async with self._tick:
                    await self._tick.wait()
                await ws.send(json.dumps(self._state(cid)))
                frame, number = self._frame, self.camera_frames
                if frame is not None and number != sent_frame:
                    sent_frame = number
                    await ws.send(frame)
        except Exception as e:
            if not _closed(e) and not isinstance(e, asyncio.CancelledError):
                log.warning("%s: %s", cid, e)

    async def _state_loop(self) -> None:
        while True:
            await asyncio.sleep(STATE_PERIOD_S)
            async with self._tick:
                self._tick.notify_all()

    def _state(self, cid: str) -> dict:
        v, c = self.vehicle, self.controls
        s = v.state()
        return {
            "t": "state", "role": c.role(cid), "driver": c.driver is not None, "pages": len(c.clients),
            "speed_m_s": s.speed_m_s, "x_m": s.x_m, "y_m": s.y_m, "time_s": s.time_s,
            "throttle": self.applied[0], "steering": self.applied[1], "by_speed": self._by_speed(),
            "pulses_us": list(v.pulses_us()), "latched": v.latched, "failsafe": s.failsafe, "mode": s.mode,
            "battery_v": s.battery_v, "battery_low": s.battery_low, "range_m": _finite(s.range_m),
            "throttle_out_us": s.throttle_out_us, "setpoint_m_s": s.setpoint_m_s,
            "link": {"connected": v.connected, "error": str(v.link_error or ""), "sent": v.messages_sent,
                     "car_errors": v.errors, "protocol": v.protocol_version},
            "max_throttle": c.max_throttle, "autopilot": c.autopilot, "recording": str(self.record_path or ""),
            "dead_man_trips": c.dead_man_trips, "ignored": sum(c.ignored.values()),
            "ignored_by_reason": dict(c.ignored), "camera_fps": round(self.camera_fps_now, 1),
            "problem": self.problem,
        }

    # --- the car -------------------------------------------------------------------------------------

    def _by_speed(self) -> bool:
        return self.vehicle.protocol_version == spec.META_SPEED_VERSION

    async def _check_loop(self) -> None:
        """The dead man (neutral once the driver is quiet) and the autopilot's steps."""
        while True:
            await asyncio.sleep(CHECK_PERIOD_S)
            self._apply()

    def _apply(self) -> None:
        """Hand the car what it should be sent now, when that changed (the Vehicle re-sends it)."""
        now = time.monotonic()
        command = self.controls.command(now)  # trips the dead man when the driver is quiet
        wanted = self.controls.autopilot if self.controls.driver is not None else AUTOPILOT_NONE
        if wanted != self._autopilot_name:
            self._autopilot_name = wanted
            self._car.submit(self._set_autopilot, wanted)
        if wanted != AUTOPILOT_NONE:
            if not self._autopilot_busy and now >= self._autopilot_due:
                self._autopilot_busy = True
                self._car.submit(self._autopilot_step)
            return
        if command != self._submitted:
            self._submitted = command
            self._car.submit(self._drive, *command)

    def _drive(self, throttle: float, steering: float) -> None:
        """On the car's thread: the stick to the Vehicle (speed on a car driven by speed)."""
        try:
            if self._by_speed():
                self.vehicle.drive(speed=throttle * self.max_speed_m_s, steering=steering)
            else:
                self.vehicle.drive(throttle=throttle, steering=steering)
            self.applied = (throttle, steering)
            self.sent_commands += 1
        except (RoarError, ValueError) as e:
            self.problem = str(e)

    def _set_autopilot(self, name: str) -> None:
        if self._autopilot is not None:
            self._autopilot.shutdown()
            self._autopilot = None
        if name != AUTOPILOT_NONE:
            try:
                self._autopilot = self.vehicle.transport.link.autopilot(name)
            except (RoarError, ValueError) as e:
                self.problem = f"autopilot {name}: {e}"
        if name == AUTOPILOT_NONE or self._autopilot is None:
            self._drive(0.0, 0.0)  # whatever the autopilot left the car doing

    def _autopilot_step(self) -> None:
        """On the car's thread: one step of the autopilot, limited as the stick is."""
        try:
            pilot = self._autopilot
            if pilot is None or self._autopilot_name == AUTOPILOT_NONE:
                return
            drive = pilot.step(self.vehicle.state())
            limit = self.controls.max_throttle
            if "speed" in drive:
                drive["speed"] = max(-limit * self.max_speed_m_s, min(limit * self.max_speed_m_s, drive["speed"]))
            else:
                drive["throttle"] = max(-limit, min(limit, drive["throttle"]))
            if self._autopilot_name != AUTOPILOT_NONE:  # not switched off meanwhile
                self.vehicle.drive(**drive)
                self.applied = (drive.get("throttle", drive.get("speed", 0.0)), drive["steering"])
        except (RoarError, ValueError) as e:
            self.problem = f"autopilot: {e}"
        finally:
            self._autopilot_due = time.monotonic() + (pilot.period_s if pilot is not None else 0.0)
            self._autopilot_busy = False

    def _record(self, on: bool) -> None:
        try:
            if on:
                self.record_dir.mkdir(parents=True, exist_ok=True)
                path = self.record_dir / time.strftime("web-%Y%m%d-%H%M%S.mcap")
                self.vehicle.record(path)
                self.record_path = path
            else:
                self.vehicle.record(None)
                self.record_path = None
        except (RoarError, OSError) as e:
            self.problem = f"record: {e}"
            self.record_path = None

    # --- the camera ----------------------------------------------------------------------------------

    def _camera_loop(self) -> None:
        """Frames as JPEG for the pages: a car's stream as it comes, else asked for camera_fps times a second."""
        from roar.camera import encode_jpeg

        stream = self.vehicle.camera_stream()
        streaming = stream is not None
        frames = iter(stream) if streaming else None
        period = 1.0 / self.camera_fps
        times: list[float] = []
        seeing = None  # the camera's own problem, shown until frames come again
        while not self._camera_stop.is_set():
            started = time.monotonic()
            try:
                if streaming and frames is None:  # the stream ended: open it again, as a browser would
                    reopened = self.vehicle.camera_stream()
                    frames = iter(reopened) if reopened is not None else None
                    rgb = None
                elif frames is not None:
                    rgb = next(frames)
                else:
                    got = self.vehicle.camera(*CAMERA_SIZE)
                    rgb = None if got is None else got[0]
            except StopIteration:
                self.problem = seeing = "the camera's stream ended: opening it again"
                frames, rgb = None, None
                self._camera_stop.wait(STREAM_RETRY_S)
            except Exception as e:  # a camera that fails is shown, and the car drives on
                self.problem = seeing = f"camera: {e}"
                rgb = None
                if streaming:
                    frames = None
                    self._camera_stop.wait(STREAM_RETRY_S)
            if rgb is not None and seeing is not None:
                if self.problem == seeing:
                    self.problem = ""
                seeing = None
            if rgb is not None:
                self._frame = encode_jpeg(rgb, JPEG_QUALITY)
                self.camera_frames += 1
                times = [t for t in times if started - t < 2.0] + [started]
                self.camera_fps_now = (len(times) - 1) / max(1e-6, times[-1] - times[0]) if len(times) > 1 else 0.0
            if frames is None:
                self._camera_stop.wait(max(0.0, period - (time.monotonic() - started)))


ALLOWED_METHODS = ("GET", "HEAD")


def _methods_checked(server: WebServer):
    """websockets' connections, but a request whose method is not GET or HEAD is answered 405 at
    its first line: websockets reads no request body, and closed a POST with one without a word."""
    from websockets.asyncio.server import ServerConnection

    class MethodsChecked(ServerConnection):
        _first = b""

        def data_received(self, data: bytes) -> None:
            if self._first is None:
                return super().data_received(data)
            self._first += data
            line, found, _ = self._first.partition(b"\r\n")
            if not found and len(self._first) < MAX_REQUEST_LINE_BYTES:
                return None  # the request line is not all here yet
            buffered, self._first = self._first, None
            method = line.split(b" ", 1)[0].decode("ascii", "replace")
            if method in ALLOWED_METHODS:
                return super().data_received(buffered)
            server.count_refusal("method not allowed")
            text = f"{method} is not allowed here: the page takes GET\n".encode("ascii", "replace")
            self.transport.write(b"HTTP/1.1 405 Method Not Allowed\r\nAllow: %s\r\nConnection: close\r\n"
                                 b"Content-Type: text/plain\r\nContent-Length: %d\r\n\r\n%s"
                                 % (", ".join(ALLOWED_METHODS).encode(), len(text), text))
            self.transport.close()
            return None

    return MethodsChecked


def _host_is_loopback(host_header: str) -> bool:
    host = host_header.rsplit(":", 1)[0] if not host_header.endswith("]") else host_header
    return is_loopback(host.strip("[]"))


def _finite(x):
    return x if x is None or x == x and abs(x) != float("inf") else None


def _closed(e: BaseException) -> bool:
    from websockets.exceptions import ConnectionClosed

    return isinstance(e, (ConnectionClosed, ConnectionError, asyncio.CancelledError))


def _static(name: str) -> bytes:
    return importlib.resources.files("roar.web").joinpath("static", name).read_bytes()


# websockets' own log: a refused or broken request is counted (WebServer.refused), not printed
_QUIET = logging.getLogger("roar.web.websockets")
_QUIET.propagate = False
_QUIET.addHandler(logging.NullHandler())
