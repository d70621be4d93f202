"""The phone's role on the simulated car (ROAR's iOS app): the car's camera (JPEG + intrinsics),
metric depth (float32 + intrinsics) and state (CSV) streamed over UDP in ROAR's chunked format,
and control datagrams "throttle,steering" taken on the control port into the firmware, as the
phone forwards them to the car over BLE at 100 Hz. Unlike the phone, it stops forwarding when
the control datagrams stop, so the car's failsafe acts.

Pull mode (ROAR's): a receiver sends "ack" to a stream's port and gets the latest frame back.
Push mode: every new frame goes to `push_to` (host) on the stream's port, as fast as it renders.

    python -m roar_sim.links.phone_udp --size 320x240 --rate 20     (or: roar sim --stream)
"""

from __future__ import annotations

import argparse
import asyncio
import io
import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from roar.tracks.names import FORMS
from roar.protocol import encode, spec
from roar.cli.sdk import (ArgumentParser, ExitStatus, UserError, add_foxglove_option, run_command, seconds_option,
                             stopped_status)
from roar.vision.geometry import SIMULATED_CAR_CAMERA
from roar.stream import UnknownHost, peer
from roar_sim.core.lockstep import CONTROL_PERIOD_S
from roar_wire import control as ctl
from roar_wire import signing
from roar_wire import stream as wire

PORTS = {"rgb": spec.UDP_PORT_RGB, "depth": spec.UDP_PORT_DEPTH, "state": spec.UDP_PORT_VEHICLE_STATE}
FORWARD_PERIOD_S = 0.01  # [s] the phone's BLE writes (100 Hz)
CONTROL_SILENCE_S = spec.TIMING_FAILSAFE_TIMEOUT_US / 1e6  # [s] stop forwarding after this
HALF_RANGE_US = (spec.CONTROL_MAX_US - spec.CONTROL_MIN_US) // 2  # [us]
SIM_STEP_S = 0.002  # [s] simulated time per loop turn


@dataclass
class StreamConfig:
    width: int = 320
    height: int = 240
    rate_hz: float = 20.0  # frames rendered per second of simulated time
    jpeg_quality: int = 50
    host: str = "127.0.0.1"  # where the ports are bound
    ports: dict | None = None  # {"rgb": 8001, "depth": 8002, "state": 8003, "control": 8004}; None: the spec's
    push_to: str | None = None  # push mode: the receiver's host; None: pull mode (answer acks)
    depth: bool = True
    camera: bool = True  # False: the state stream alone (no frames rendered)
    pose_noise_m: float = 0.0  # [m] the state's position noise (and [rad] its heading's): the phone's tracking
    seed: int = 0  # of that noise


def jpeg(rgb: np.ndarray, quality: int) -> bytes:
    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(rgb).save(out, format="JPEG", quality=quality)
    return out.getvalue()


def payloads(rgb: np.ndarray, depth: np.ndarray | None, state: dict, quality: int) -> dict[str, bytes]:
    """The three streams' payloads of one rendered frame."""
    h, w = rgb.shape[:2]
    cam = SIMULATED_CAR_CAMERA.model(w, h)
    # the wire counts the principal point from the image's corner (the centre of a W x H image at
    # W/2, H/2: the depth map is 2 cx wide), OpenCV from pixel (0, 0)'s centre: half a pixel more
    k = cam.fx, cam.fy, cam.cx + 0.5, cam.cy + 0.5
    out = {"rgb": wire.with_intrinsics(*k, jpeg(rgb, quality)), "state": wire.state_line(state)}
    if depth is not None:
        out["depth"] = wire.with_intrinsics(*k, np.ascontiguousarray(depth, dtype="<f4").tobytes())
    return out


def control_to_pulses(throttle: float, steering: float) -> tuple[int, int]:
    """The phone's mapping of [-1, 1] to pulse widths [us] (no calibration: the phone has none)."""
    return (spec.CONTROL_NEUTRAL_US + round(throttle * HALF_RANGE_US),
            spec.CONTROL_NEUTRAL_US + round(steering * HALF_RANGE_US))


class _Port(asyncio.DatagramProtocol):
    def __init__(self, phone: Phone, kind: str) -> None:
        self.phone, self.kind = phone, kind
        self.transport: asyncio.DatagramTransport | None = None

    def connection_made(self, transport) -> None:
        self.transport = transport

    def datagram_received(self, data: bytes, addr) -> None:
        self.phone._received(self.kind, data, addr)

    def error_received(self, exc) -> None:  # a receiver that went away (ICMP unreachable)
        pass


class Phone:
    """The streams of one simulated ESC car (roar_sim.robots.esc), run by serve() in the caller's event loop."""

    def __init__(self, sim, config: StreamConfig | None = None, key: bytes | None = None, session: int = 1) -> None:
        """key: signed control (the app's own setting, never set over the network): with one, only
        signed control datagrams drive; others are answered with the car's ERR line."""
        self.sim, self.config = sim, config or StreamConfig()
        self.auth = signing.Authenticator()
        if key is not None:
            self.auth.set_key(key, session)
        self.ports = dict(PORTS, control=spec.UDP_PORT_CONTROL) | (self.config.ports or {})
        self._endpoints: dict[str, _Port] = {}
        self._latest: dict[str, list[bytes]] = {}  # kind -> datagrams of the newest frame
        self._served: dict[tuple[str, tuple], int] = {}  # (kind, receiver) -> the frame id it last got
        self._waiting: set[tuple[str, tuple]] = set()  # asked, and already has the newest: next frame
        self._frame_id = 0
        self._armed = False  # control forwarding began with neutral (the car arms on it)
        self._control: tuple[float, float] | None = None
        self._control_at = -math.inf
        self.frames_rendered = 0
        self.render_s = 0.0  # [s] wall time spent rendering and encoding
        self.bad_control = 0
        self.sent = 0
        self.log = None  # a roar_sim.links.sim_log.SimLog: the run recorded or served live
        self._noise = np.random.default_rng(self.config.seed)
        self._frame_s: float | None = None

    async def start(self) -> Phone:
        loop = asyncio.get_running_loop()
        for kind, port in self.ports.items():
            _, proto = await loop.create_datagram_endpoint(lambda k=kind: _Port(self, k),
                                                           local_addr=(self.config.host, port))
            self._endpoints[kind] = proto
        self.render()  # the first frame now: its renderer's first-frame cost (the rays' kernels loading, ~0.7 s)
        return self  # is paid before the stream is announced, not in its real-time loop where Ctrl-C waits on it

    def bound(self, kind: str) -> tuple[str, int]:
        """The address a stream (or the control port) is bound to."""
        return self._endpoints[kind].transport.get_extra_info("sockname")[:2]

    def close(self) -> None:
        for e in self._endpoints.values():
            if e.transport is not None:
                e.transport.close()

    def _received(self, kind: str, data: bytes, addr) -> None:
        if kind == "control":
            verdict, data = self.auth.check_datagram(data)
            if verdict != ctl.OK:  # refused: the sender hears why, nothing changes
                self.bad_control += 1
                reply = "%s %s" % (spec.SERIAL_REPLY_ERROR, signing.refusal(verdict, self.auth))
                self._endpoints[kind].transport.sendto(reply.encode(), addr)
                return
            control = wire.parse_control(data)
            if control is None:
                self.bad_control += 1
            else:
                self._control, self._control_at = control, time.monotonic()
        elif data == spec.UDP_REQUEST_PAYLOAD.encode() and kind in self._latest:  # pull mode
            if self._served.get((kind, addr)) == self._frame_id:
                self._waiting.add((kind, addr))  # it has this one: it gets the next
            else:
                self._send(kind, addr)

    def _send(self, kind: str, addr) -> None:
        transport = self._endpoints[kind].transport
        for d in self._latest[kind]:
            transport.sendto(d, addr)
            self.sent += 1
        self._served[(kind, addr)] = self._frame_id

    def render(self) -> None:
        """Render one frame, cut its payloads into datagrams, push them when pushing."""
        start = time.perf_counter()
        s = self.sim.state()
        dx, dy, dyaw = self._noise.normal(0.0, self.config.pose_noise_m, 3) if self.config.pose_noise_m else (0, 0, 0)
        state = {"x": s.x + dx, "y": s.y + dy, "yaw": math.degrees(s.yaw + dyaw), "vx": s.speed * math.cos(s.yaw),
                 "vy": s.speed * math.sin(s.yaw), "gz": s.yaw_rate, "hall_effect_sensor_velocity": s.speed,
                 "recv_time": self.sim.time_s}
        if self.config.camera:
            rgb, depth = self.sim.plant.camera(self.config.width, self.config.height)
            if self.log is not None:
                self.log.image(rgb)
            frame = payloads(rgb, depth if self.config.depth else None, state, self.config.jpeg_quality)
        else:
            frame = {"state": wire.state_line(state)}
        self._frame_id = (self._frame_id + 1) % wire.MODULUS
        self._frame_s = self.sim.time_s  # [s] the simulator's time of the latest frame
        self._latest = {kind: wire.chunks(p, self._frame_id) for kind, p in frame.items()}
        self.frames_rendered += 1
        self.render_s += time.perf_counter() - start
        if self.config.push_to is not None:
            for kind in self._latest:
                self._send(kind, (self.config.push_to, self.ports[kind]))
        waiting, self._waiting = self._waiting, set()
        for kind, addr in waiting:
            if kind in self._latest:
                self._send(kind, addr)

    def forward_control(self) -> None:
        """The phone's BLE write: the latest control, while it is fresh."""
        if self._control is None or time.monotonic() - self._control_at > CONTROL_SILENCE_S:
            self._armed = False  # silent: the car's failsafe stops it; neutral first when it resumes
            return
        if not self._armed:
            self.sim.write(encode(spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US))
            self._armed = True
            return
        self.sim.write(encode(*control_to_pulses(*self._control)))

    async def serve(self, seconds: float = 0.0, step=None) -> None:
        """Run the simulated car in real time, render at rate_hz and forward control at 100 Hz,
        for `seconds` (0: until cancelled). step(seconds): what runs the car a loop turn (default
        its run() and read(); a roar_sim.links.pty.PtyCar's pump() when a pty carries its control)."""
        next_frame = next_forward = next_log = self.sim.time_s
        if self._frame_s == self.sim.time_s:  # start() rendered this instant's frame
            next_frame += 1.0 / self.config.rate_hz
        wall0, sim0 = time.monotonic(), self.sim.time_s
        while seconds <= 0 or self.sim.time_s - sim0 < seconds:
            if self.sim.time_s >= next_forward:
                self.forward_control()
                next_forward += FORWARD_PERIOD_S
            if self.sim.time_s >= next_frame:
                self.render()
                next_frame += 1.0 / self.config.rate_hz
            if step is None:
                self.sim.run(SIM_STEP_S)
                self.sim.read()
            else:
                step(SIM_STEP_S)
            if self.log is not None and self.sim.time_s + 1e-9 >= next_log:
                self.log.step()
                next_log += CONTROL_PERIOD_S
            ahead = (self.sim.time_s - sim0) - (time.monotonic() - wall0)
            await asyncio.sleep(max(0.0, ahead))  # keeps real time, and lets the datagrams in


def parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"want WIDTHxHEIGHT, e.g. 320x240, got {text!r}") from None
    if not (16 <= w <= 1920 and 16 <= h <= 1080):
        raise argparse.ArgumentTypeError(f"size must be 16x16 .. 1920x1080, got {text}")
    return w, h


def parse_ports(text: str) -> dict[str, int]:
    try:
        ports = [int(v) for v in text.split(",")]
    except ValueError:
        ports = []
    if len(ports) != 4 or not all(1 <= p <= 65535 for p in ports) or len(set(ports)) != 4:
        raise argparse.ArgumentTypeError(f"want four different ports RGB,DEPTH,STATE,CONTROL, got {text!r}")
    return dict(zip(("rgb", "depth", "state", "control"), ports))


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar sim --stream", description=__doc__)
    p.add_argument("--robot", default="esc", choices=["esc"], help="the car whose phone it is: the ESC car")
    p.add_argument("--track", default="oval", help=f"{FORMS} (default oval)")
    p.add_argument("--size", type=parse_size, default=(320, 240), help="camera size WxH (default 320x240)")
    p.add_argument("--rate", type=float, default=20.0, help="frames per second (default 20)")
    p.add_argument("--push", metavar="HOST", help="push every frame to HOST instead of answering acks")
    p.add_argument("--host", default="127.0.0.1",
                   help="the address to bind the ports to (default 127.0.0.1; 0.0.0.0 for other machines)")
    p.add_argument("--ports", type=parse_ports, default=None, metavar="RGB,DEPTH,STATE,CONTROL",
                   help=f"the four ports (default ROAR's {','.join(str(v) for v in PORTS.values())},{spec.UDP_PORT_CONTROL})")
    p.add_argument("--seconds", type=seconds_option, default=0.0, metavar="S", help="stop after this long (default: Ctrl-C)")
    p.add_argument("--key", metavar="KEYFILE", default=None,
                   help="signed control, as the phone app's own setting: drive only for control signed with this "
                        "key (a key file, e.g. ~/.config/roar/key); others are answered with the car's ERR line")
    add_foxglove_option(p, "the car's channels")
    return p


def main(argv: list[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    if not 0.5 <= args.rate <= 60:
        p.error(f"--rate must be 0.5..60 frames/s, got {args.rate:g}")
    push_to = None
    if args.push is not None:
        try:
            push_to = peer(args.push)[0]  # once, now: not a name lookup per datagram
        except UnknownHost as e:
            p.error(f"--push: {e}")
    from roar_sim.robots.esc import EscCar
    from roar.tracks import get

    key = None
    if args.key is not None:
        from roar.signing import SigningError, read_key_file

        try:
            key = read_key_file(args.key)
        except SigningError as e:
            p.error(f"--key: {e}")
    sim = EscCar(get(args.track))
    config = StreamConfig(width=args.size[0], height=args.size[1], rate_hz=args.rate, push_to=push_to,
                          host=args.host, ports=args.ports)
    phone = Phone(sim, config, key=key)
    if args.foxglove is not None:
        from roar_sim.links.sim_log import SimLog

        try:
            phone.log = SimLog(sim, None, None, args.foxglove, drain_lines=False)
        except BaseException:
            sim.close()
            raise
        print(f"its channels live: Foxglove, Open connection, ws://127.0.0.1:{args.foxglove}", flush=True)

    async def run() -> None:
        try:
            await phone.start()
        except OSError as e:
            raise UserError(f"cannot bind the stream ports on {config.host}: {e.strerror or e}") from None
        print(f"streaming the simulated car: camera {args.size[0]}x{args.size[1]} at {args.rate:g}/s; "
              + ", ".join(f"{k} {h}:{port}" for k, (h, port) in ((k, phone.bound(k)) for k in phone.ports))
              + ("" if args.push else " (send 'ack' to a stream's port for its latest frame)"), flush=True)
        try:
            await phone.serve(args.seconds)
        finally:
            phone.close()

    try:
        asyncio.run(run())
    except KeyboardInterrupt as e:
        return stopped_status(e)
    finally:
        if phone.log is not None:
            phone.log.close()
        sim.close()
    print(f"rendered {phone.frames_rendered} frames, {phone.render_s / max(1, phone.frames_rendered) * 1000:.1f} ms each")
    return ExitStatus.OK


if __name__ == "__main__":
    sys.exit(run_command("roar sim --stream", main))
