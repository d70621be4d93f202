"""udp:// -- a car driven through the phone on it (ROAR's iOS app), or the simulated one
(`roar sim --stream`): control as "throttle,steering" datagrams to the phone's control port,
which it forwards to the car over BLE; the phone's camera, depth and state streams read back.

    udp://192.168.1.20          the phone (ports 8001-8004, ROAR's)
    udp://127.0.0.1             the simulated car's phone
    ?push=1                     listen on 8001-8003 for frames the phone pushes, instead of asking
                                for each with "ack"
    ?ports=9001,9002,9003,9004  a phone on other ports: camera, depth, state, control (as
                                `roar sim --stream --ports` serves them)

car.camera() is the newest (RGB, metric depth) pair, car.state() position, heading, speed and
yaw rate from the state stream. The phone has no replies: no READY or ARMED events.

Signed control (roar.transports.signing): a signing Vehicle sets `signer`; each datagram then goes as
"throttle,steering,COUNTER,MAC". A phone with a key answers other datagrams to their sender
with the car's ERR line ("ERR unsigned SESSION", ...), which refusal() hands back.
"""

from __future__ import annotations

import asyncio
import math
import socket
import threading

from roar.protocol import spec
from roar.telemetry import VehicleState
from roar.transports.base import LinkLost, Transport, TransportError, pop_option, unit_command
from roar_wire import stream as wire

START_TIMEOUT_S = 5.0  # [s]


class UdpPhoneTransport(Transport):
    scheme = "udp"
    signs_itself = True  # the car takes datagrams: signed through signer.sign_datagram
    min_period_s = 0.01  # [s] the phone forwards at 100 Hz

    def __init__(self, host: str, push: bool = False, ports: dict[str, int] | None = None) -> None:
        from roar.stream import KINDS

        self.host, self.push = host, push
        self.ports = ports or {**KINDS, "control": spec.UDP_PORT_CONTROL}  # kind -> the phone's port
        self.receivers: dict = {}
        self._latest: dict = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._sock: socket.socket | None = None
        self._error: BaseException | None = None
        self._stop: asyncio.Event | None = None

    @classmethod
    def from_url(cls, target: str, options: dict[str, str]) -> UdpPhoneTransport:
        host = target.strip("/")
        if not host or ":" in host:
            raise TransportError(f"udp:// needs the phone's HOST only (its ports are ROAR's 8001-8004), got {target!r}")
        return cls(host, pop_option(options, "push", bool, False), _ports(pop_option(options, "ports", str, None)))

    def open(self) -> None:
        from roar.stream import StreamReceiver, UnknownHost, peer

        try:
            address, listen = peer(self.host)
            self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self._sock.connect((address, self.ports["control"]))
            self._sock.setblocking(False)  # (sends never wait; refusal() reads what the phone answered)
        except (OSError, UnknownHost) as e:
            raise TransportError(f"udp://{self.host}: {e.strerror if isinstance(e, OSError) else e}") from None
        started = threading.Event()

        async def run() -> None:
            self._stop = asyncio.Event()
            try:
                for kind, port in self.ports.items():
                    if kind == "control":
                        continue
                    rx = StreamReceiver(kind, host=listen, port=port if self.push else 0,
                                        sender=None if self.push else (address, port), ack=not self.push)
                    self.receivers[kind] = await rx.start()
            except BaseException as e:
                self._error = e
                started.set()
                return
            started.set()
            collectors = [asyncio.create_task(self._collect(kind, rx)) for kind, rx in self.receivers.items()]
            await self._stop.wait()
            for task in collectors:
                task.cancel()
            await asyncio.gather(*collectors, return_exceptions=True)
            for rx in self.receivers.values():
                rx.close()

        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_until_complete, args=(run(),), name="roar-udp",
                                        daemon=True)
        self._thread.start()
        started.wait(START_TIMEOUT_S)
        if self._error is not None:
            self.close()
            reason = self._error.strerror if isinstance(self._error, OSError) else self._error
            raise TransportError(f"udp://{self.host}: cannot listen for its streams: {reason}") from None

    async def _collect(self, kind: str, rx) -> None:
        async for frame in rx:
            self._latest[kind] = frame

    def write(self, data: bytes) -> None:
        throttle, steering = unit_command(data, self.scheme)
        line = wire.control_line(throttle, steering)
        if self.signer is not None:
            line = self.signer.sign_datagram(line)
        try:
            self._sock.send(line)
        except OSError as e:  # e.g. the phone's port is closed (ICMP unreachable)
            raise LinkLost(f"udp://{self.host}: {e.strerror or e}") from None

    def refusal(self) -> str | None:
        """The latest "ERR ..." the phone answered a refused control datagram with, once."""
        line = None
        while self._sock is not None:
            try:
                data = self._sock.recv(256)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:  # the phone's port is closed: write() says so
                break
            text = data.decode("ascii", "replace").strip()
            if text.startswith(spec.SERIAL_REPLY_ERROR + " "):
                line = text
        return line

    def state(self) -> VehicleState | None:
        frame = self._latest.get("state")
        if frame is None:
            return None
        s = frame.state
        return VehicleState(time_s=s["recv_time"], x_m=s["x"], y_m=s["y"], yaw_rad=math.radians(s["yaw"]),
                            speed_m_s=s["hall_effect_sensor_velocity"], yaw_rate_rad_s=s["gz"])

    def camera(self, width: int = 0, height: int = 0):
        """The newest (RGB HxWx3, depth HxW [m] or None) as the phone streams them (its size,
        whatever width and height ask), or None before the first frame."""
        rgb, depth = self._latest.get("rgb"), self._latest.get("depth")
        return None if rgb is None else (rgb.image, None if depth is None else depth.image)

    def close(self) -> None:
        loop = self._loop
        if loop is not None:
            if self._stop is not None:
                loop.call_soon_threadsafe(self._stop.set)
            if self._thread is not None:
                self._thread.join(timeout=2.0)
            if not loop.is_running():
                loop.close()
            self._loop = None
        if self._sock is not None:
            self._sock.close()
            self._sock = None


def _ports(text: str | None) -> dict[str, int] | None:
    """?ports=RGB,DEPTH,STATE,CONTROL -> {kind: port}; TransportError (one line) for anything else."""
    if text is None:
        return None
    parts = text.split(",")
    if len(parts) != 4 or not all(p.strip().isdigit() and 1 <= int(p) <= 65535 for p in parts):
        raise TransportError(f"udp://...?ports= takes four ports 1..65535 (camera, depth, state, control), got {text!r}")
    return dict(zip(("rgb", "depth", "state", "control"), (int(p) for p in parts)))
