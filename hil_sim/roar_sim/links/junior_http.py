"""The simulated ROAR Junior on HTTP, as the robot serves it:

    control  http://HOST:PORT/?forward=True&left_spd=0.5&right_spd=0.5   (the robot's port 81)
    camera   http://HOST:PORT-1/cam-lo.jpg  /cam-hi.jpg  /cam.bmp  /cam.jpg  /cam.mjpeg   (port 80)

The control port runs the firmware's own HTTP reader and responses (roar_sim.robots.junior), so
its replies are the robot's byte for byte; the camera port reads requests with the same reader
and refuses what the control port refuses, with the same replies (malformed or over 2048 bytes:
400; not GET: 405; a GET that declares a body: 400, its body never read as a request). Each
connection is its own task, so a slow client holds up no one; a connection quiet for the
robot's idle time (2 s) is closed, as the robot closes it, and a client holds at most
MAX_CONNECTIONS_PER_CLIENT at once (more are closed at once). The camera frames come from
roar_sim.links.junior_camera: renderer processes beside the simulation, capturing while asked for.

    roar sim --robot junior --http [127.0.0.1:8081] [--track oval] [--seconds 0]
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import threading
from dataclasses import dataclass

from roar.tracks.names import FORMS
from roar.cli.sdk import ArgumentParser, ExitStatus, UserError, add_foxglove_option, run_command, seconds_option
from roar.protocol import spec
from roar.transports.junior_http import host_port
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_sim.core.junior import HttpRequestReader
from roar_sim.core.library import HttpRead
from roar_sim.links.junior_camera import RENDER_WORKERS, Camera, CameraOff
from roar_sim.robots.junior import Junior
from roar.tracks.track import Track

CHUNK_S = 0.002  # [s] simulated time per step of the real-time loop
IDLE_CLOSE_S = spec.JUNIOR_IDLE_CLOSE_US / 1e6  # [s] a connection quiet this long is closed
MAX_CONNECTIONS_PER_CLIENT = 16  # connections one client address holds at once, per port
CAMERA_TIMEOUT_S = 5.0  # [s] a frame not rendered by then gets 503
STOP_WAIT_S = 1.0  # [s] stop() cancels and aborts again any connection still open after this
SIZES = {"low": (spec.JUNIOR_CAMERA_LOW_WIDTH, spec.JUNIOR_CAMERA_LOW_HEIGHT),
         "high": (spec.JUNIOR_CAMERA_HIGH_WIDTH, spec.JUNIOR_CAMERA_HIGH_HEIGHT)}
ROUTES = {spec.JUNIOR_ROUTE_CAMERA_LOW: ("low", "JPEG"), spec.JUNIOR_ROUTE_CAMERA_HIGH: ("high", "JPEG"),
          spec.JUNIOR_ROUTE_CAMERA_BMP: ("low", "BMP")}
CAMERA_OFF = b"camera off: no renderer is running\n"
CONTENT_TYPES = {"JPEG": "image/jpeg", "BMP": "image/bmp"}
MJPEG_BOUNDARY = "frame"


@dataclass
class Endpoints:
    control_url: str  # http://HOST:PORT
    camera_url: str  # http://HOST:PORT

    @property
    def vehicle_url(self) -> str:
        """The URL a Vehicle takes: the control URL, naming the camera port unless it is the
        control port minus one (the robot's 81/80 layout, which http:// assumes)."""
        control, camera = (int(u.rsplit(":", 1)[1]) for u in (self.control_url, self.camera_url))
        return self.control_url if camera == control - 1 else f"{self.control_url}?camera={camera}"


class JuniorServer:
    """The simulated Junior with its two HTTP ports, in real time on its own thread."""

    def __init__(self, track: Track | None = None, host: str = "127.0.0.1", port: int = 8081,
                 camera_port: int | None = None, gui: bool = False, render_workers: int = RENDER_WORKERS,
                 log=None) -> None:
        """log: a roar_sim.links.sim_log.SimLog maker (robot -> SimLog) to record or serve the run live."""
        self.host, self.port = host, port
        self.camera_port = port - 1 if camera_port is None and port else (camera_port or 0)
        self.sim = Junior(track, realtime=True, gui=gui)
        self.log = log(self.sim) if log is not None else None
        self.camera = Camera(track, lambda: self.sim.pose, render_workers)
        self._served: dict[str, int] = {}  # route -> the latest frame it served
        self._running = threading.Event()
        self._thread: threading.Thread | None = None
        self._servers: list[asyncio.AbstractServer] = []
        self._tasks: dict[asyncio.Task, asyncio.StreamWriter] = {}  # open connections
        self._held: dict[tuple[str, int], int] = {}  # (client address, our port) -> connections open

    # --- the simulation ------------------------------------------------------------------------

    def _simulate(self) -> None:
        next_log_s = 0.0
        while self._running.is_set():
            self.sim.run(CHUNK_S)
            if self.log is not None and self.sim.time_s + 1e-9 >= next_log_s:
                self.log.step()
                next_log_s = self.sim.time_s + CONTROL_PERIOD_S

    # --- control port: the firmware's own HTTP ---------------------------------------------------

    async def _control(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        connection = self.sim.connect()
        try:
            while connection.open:
                data = await _read(reader)
                if not data:
                    break
                if self.log is not None:
                    self.log.link_bytes(data)
                for reply in connection.feed(data):
                    writer.write(reply)
                await writer.drain()
        except (ConnectionError, OSError):
            pass
        finally:
            writer.close()

    # --- camera port -------------------------------------------------------------------------

    async def _camera(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        request, state = HttpRequestReader(), HttpRead.INCOMPLETE  # the control port's reader and rules
        try:
            while state == HttpRead.INCOMPLETE and (data := await _read(reader)):
                state = request.feed(data)[1]
        except (ConnectionError, OSError):
            state = HttpRead.INCOMPLETE
        if state == HttpRead.INCOMPLETE:  # the client went quiet or away mid-request
            writer.close()
            return
        refused = request.refusal()
        path = "" if refused else request.path
        try:
            if refused:
                writer.write(refused)
            elif (path in ROUTES or path == spec.JUNIOR_ROUTE_CAMERA_STREAM) and not self.camera.workers:
                writer.write(_response("503 Service Unavailable", "text/plain", CAMERA_OFF))
            elif path in ROUTES:
                size, fmt = ROUTES[path]
                async with asyncio.timeout(CAMERA_TIMEOUT_S):
                    seq, image = await self.camera.frame(SIZES[size], fmt, self._served.get(path, 0))
                self._served[path] = max(seq, self._served.get(path, 0))
                writer.write(_response("200 OK", CONTENT_TYPES[fmt], image))
            elif path == spec.JUNIOR_ROUTE_CAMERA_REDIRECT:
                writer.write(_response("302 Found", "text/plain", b"", [f"Location: {spec.JUNIOR_ROUTE_CAMERA_HIGH}"]))
            elif path == spec.JUNIOR_ROUTE_CAMERA_STREAM:
                await self._stream(writer)
            else:
                writer.write(_response("404 Not Found", "text/plain", b"no such route\n"))
            await writer.drain()
        except TimeoutError:
            writer.write(_response("503 Service Unavailable", "text/plain", b"camera timed out\n"))
        except CameraOff as e:
            writer.write(_response("503 Service Unavailable", "text/plain", f"{e}\n".encode()))
        except (ConnectionError, OSError):
            pass
        finally:
            writer.close()

    async def _stream(self, writer: asyncio.StreamWriter) -> None:
        writer.write(b"HTTP/1.1 200 OK\r\nContent-Type: multipart/x-mixed-replace; boundary=" +
                     MJPEG_BOUNDARY.encode() + b"\r\nConnection: close\r\n\r\n")
        seq = 0
        while self._running.is_set():
            try:
                async with asyncio.timeout(CAMERA_TIMEOUT_S):
                    seq, image = await self.camera.frame(SIZES["high"], "JPEG", seq)
            except TimeoutError:  # a slow frame (a busy machine) does not end a stream: wait on
                continue
            writer.write(f"--{MJPEG_BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(image)}\r\n\r\n"
                         .encode() + image + b"\r\n")
            await writer.drain()

    # --- running -----------------------------------------------------------------------------

    async def start(self) -> Endpoints:
        self._running.set()
        self._thread = threading.Thread(target=self._simulate, name="junior-sim", daemon=True)
        self._thread.start()
        control = await asyncio.start_server(self._tracked(self._control), self.host, self.port)
        camera = await asyncio.start_server(self._tracked(self._camera), self.host, self.camera_port)
        self._servers = [control, camera]
        port = control.sockets[0].getsockname()[1]
        camera_port = camera.sockets[0].getsockname()[1]
        return Endpoints(f"http://{self.host}:{port}", f"http://{self.host}:{camera_port}")

    def _tracked(self, handler):
        """handler, its task remembered while it runs, so that stop() can end open connections."""
        async def run(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            peer, ours = writer.get_extra_info("peername"), writer.get_extra_info("sockname")
            key = (peer[0] if peer else "", ours[1] if ours else 0)
            if self._held.get(key, 0) >= MAX_CONNECTIONS_PER_CLIENT:
                writer.close()  # this client holds enough: the others are not kept waiting for it
                return
            self._held[key] = self._held.get(key, 0) + 1
            task = asyncio.current_task()
            self._tasks[task] = writer
            try:
                await handler(reader, writer)
            except asyncio.CancelledError:
                pass  # stop() ended the connection (the handler has closed it)
            finally:
                self._tasks.pop(task, None)
                self._held[key] -= 1
                if not self._held[key]:
                    del self._held[key]
        return run

    async def stop(self) -> None:
        """Ends every connection and the simulation. A connection's task is cancelled and its
        socket aborted too: a cancel alone can be lost when it meets a read that completes at the
        same moment (a client sending at 50 Hz), and the handler would then serve on."""
        self._running.clear()
        for server in self._servers:
            server.close()
        while self._tasks:
            for task, writer in list(self._tasks.items()):
                writer.transport.abort()
                task.cancel()
            await asyncio.wait(list(self._tasks), timeout=STOP_WAIT_S)
        await self.camera.stop()
        for server in self._servers:
            await server.wait_closed()
        if self._thread is not None:
            self._thread.join()
        self.camera.close()
        if self.log is not None:
            self.log.close()
        self.sim.close()


async def _read(reader: asyncio.StreamReader) -> bytes:
    """What the client sent next; b"" when it closed or stayed quiet for IDLE_CLOSE_S."""
    try:
        async with asyncio.timeout(IDLE_CLOSE_S):  # unlike 3.11's wait_for, never swallows a cancel
            return await reader.read(4096)
    except TimeoutError:
        return b""


def _response(status: str, content_type: str, body: bytes, extra: list[str] | None = None) -> bytes:
    headers = [f"HTTP/1.1 {status}", f"Content-Type: {content_type}", f"Content-Length: {len(body)}",
               "Connection: close", *(extra or [])]
    return ("\r\n".join(headers) + "\r\n\r\n").encode("ascii") + body


def parse_address(text: str) -> tuple[str, int]:
    address = host_port(text)
    if address is None:
        raise UserError(f"--http takes HOST:PORT, e.g. 127.0.0.1:8081, got {text!r}")
    return address


async def serve(track: Track | None, host: str, port: int, seconds: float, gui: bool,
                camera_port: int | None = None, on_ready=print, log=None) -> None:
    server = JuniorServer(track, host, port, camera_port, gui, log=log)
    try:
        urls = await server.start()
        others = ", ".join(r for r in (*ROUTES, spec.JUNIOR_ROUTE_CAMERA_STREAM) if r != spec.JUNIOR_ROUTE_CAMERA_LOW)
        on_ready(f"simulated Junior: control {urls.control_url}/?forward=True&left_spd=0.5&right_spd=0.5\n"
                 f"                  camera  {urls.camera_url}{spec.JUNIOR_ROUTE_CAMERA_LOW} (also {others})\n"
                 f"drive it: python examples/circle.py '{urls.vehicle_url}'   (Ctrl-C stops)")
        if seconds > 0:
            await asyncio.sleep(seconds)
        else:
            await asyncio.Event().wait()
    finally:
        await server.stop()


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar sim --robot junior --http", description=__doc__)
    p.add_argument("--http", default="127.0.0.1:8081", metavar="HOST:PORT",
                   help="where to serve the control route (default 127.0.0.1:8081; port 0 picks free ports); "
                        "the camera is on the port below it")
    p.add_argument("--track", default=None, help=f"{FORMS} (default: open floor)")
    p.add_argument("--seconds", type=seconds_option, default=0.0, metavar="S", help="stop after this long (default: Ctrl-C)")
    p.add_argument("--gui", action="store_true", help="open the PyBullet window (needs a display)")
    add_foxglove_option(p, "the Junior's channels")
    return p


def main(argv: list[str] | None = None) -> int:
    from roar.tracks import get

    args = parser().parse_args(argv)
    host, port = parse_address(args.http)
    track = get(args.track) if args.track is not None else None
    log = None
    if args.foxglove is not None:
        from roar_sim.links.sim_log import SimLog

        log = lambda robot: SimLog(robot, None, None, args.foxglove,  # noqa: E731
                                   drain_lines=False)
        print(f"its channels live: Foxglove, Open connection, ws://127.0.0.1:{args.foxglove}", flush=True)
    try:
        asyncio.run(serve(track, host, port, args.seconds, args.gui, camera_port=0 if port == 0 else None,
                          on_ready=lambda text: print(text, flush=True), log=log))
    except OSError as e:
        raise UserError(f"cannot serve on {args.http}: {e.strerror or e}") from None
    return ExitStatus.OK


class InBackground:
    """A JuniorServer on its own asyncio loop in a background thread, for tests, benchmarks and
    programs that drive it from the same process:

        with InBackground(track, port=0) as junior:     # port 0: free ports
            Vehicle(junior.urls.control_url) ...
            junior.server.sim.state()
    """

    def __init__(self, track: Track | None = None, host: str = "127.0.0.1", port: int = 0,
                 camera_port: int | None = None, render_workers: int = RENDER_WORKERS, **options) -> None:
        """camera_port: default free when port is 0, else port - 1; options: JuniorServer's (gui)."""
        if camera_port is None and port == 0:
            camera_port = 0
        self.server = JuniorServer(track, host, port, camera_port, render_workers=render_workers, **options)
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="junior-http", daemon=True)
        self.urls: Endpoints | None = None

    def __enter__(self) -> InBackground:
        self._thread.start()
        self.urls = asyncio.run_coroutine_threadsafe(self.server.start(), self._loop).result(timeout=30)
        return self

    def __exit__(self, *exc) -> None:
        asyncio.run_coroutine_threadsafe(self.server.stop(), self._loop).result(timeout=30)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=10)
        self._loop.close()


if __name__ == "__main__":
    sys.exit(run_command("roar sim --robot junior --http", main))
