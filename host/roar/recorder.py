"""Every run on the record: an MCAP log (mcap.dev), written with foxglove-sdk in Foxglove's own
message types where one fits, so Foxglove (or any MCAP reader) shows a run with no setup.

    with Recorder("run.mcap", metadata={"car": "sim://oval"}) as rec:
        rec.control(b"C1500,1500\\n", t_ns)       # every control message as sent
        rec.line("READY 2", t_ns)                  # every line the car sent
        rec.state(vehicle_state, t_ns)
        rec.scan(ranges, -2.36, 2.36, t_ns)        # a lidar scan
        rec.image(rgb, t_ns)                       # a camera frame (JPEG)

    Vehicle("sim://oval", record="run.mcap")     # the same, for everything a Vehicle sends and reads

Times are nanoseconds: of the simulator's clock for sim:// (metadata clock=simulated), else of
the host's monotonic clock (clock=monotonic, and wall_clock_offset_ns = wall - monotonic at the
start). Chunks are zstd-compressed, ~1 MiB each; the file is finished on close(), at the
program's exit and on Ctrl-C or SIGTERM (roar's commands turn both into a clean exit), so every
reader opens it.

Topics (TOPICS below): control messages as JSON (the text and its decoded pulses or speed), twice
(roar.transports.recording): as the script asked for them (/control), and as they went on the link
(/wire/control: signed where a key signs, with the signing layer's own messages);
the car's lines as foxglove.Log, telemetry fields and the car's state as JSON, the pose as
foxglove.PoseInFrame and a world -> base_link foxglove.FrameTransform, lidar as
foxglove.LaserScan, camera frames as foxglove.CompressedImage with a foxglove.CameraCalibration.
"""

from __future__ import annotations

import atexit
import math
import threading
import time
import weakref
from dataclasses import asdict
from pathlib import Path

from roar.errors import RecordError
from roar.transports.recording import RecordingTransport  # noqa: F401 (importable from here too)

CONTROL = "/control"  # every control message as the script asked for it
WIRE_CONTROL = "/wire/control"  # the same as it went on the link: signed, with the signing layer's own
LINES = "/car/lines"
TELEMETRY = "/car/telemetry"
STATE = "/car/state"
POSE = "/car/pose"
TF = "/tf"
SCAN = "/lidar"
IMAGE = "/camera/image"
DEPTH = "/camera/depth"
CALIBRATION = "/camera/calibration"
TOPICS = (CONTROL, WIRE_CONTROL, LINES, TELEMETRY, STATE, POSE, TF, SCAN, IMAGE, DEPTH, CALIBRATION)
WORLD_FRAME, CAR_FRAME, LIDAR_FRAME, CAMERA_FRAME = "world", "base_link", "lidar", "camera"
SERVE_HOST = "127.0.0.1"  # live channels are served on loopback only
FOXGLOVE_PORT = 8765  # Foxglove's own default
CHUNK_BYTES = 1 << 20  # [B] of messages before a chunk is compressed and written
JPEG_QUALITY = 85

CONTROL_SCHEMA = {"type": "object", "title": "roar.Control", "properties": {
    "text": {"type": "string", "description": "the message as sent, as text"},
    "throttle_us": {"type": "integer"}, "steering_us": {"type": "integer"},
    "speed_mm_s": {"type": "integer", "description": "a speed setpoint's"},
    "result": {"type": "string", "description": "what the car's parser makes of it (ok, setpoint, or why not)"},
    "throttle": {"type": "number", "description": "-1..1, on a link that carries fractions (the Junior's duties)"},
    "steering": {"type": "number", "description": "-1..1 (+1 full right), on a link that carries fractions"}}}
STATE_SCHEMA = {"type": "object", "title": "roar.VehicleState",
                "description": "roar.telemetry.VehicleState's fields; absent where the link cannot tell"}
TELEMETRY_SCHEMA = {"type": "object", "title": "roar.Telemetry", "description": "a telemetry line's fields"}


def foxglove_sdk():
    try:
        import foxglove
        import foxglove.channels  # noqa: F401
    except ImportError:
        raise RecordError("recording needs foxglove-sdk: pip install 'roar-platform[record]'") from None
    return foxglove


class Recorder:
    def __init__(self, path: str | Path | None, metadata: dict[str, str] | None = None, simulated: bool = False,
                 serve_port: int | None = None) -> None:
        """An MCAP file at path (replaced if there; None: none); metadata: strings for the file's
        "run" record (the car, the track, the command line...); simulated: times are the
        simulator's; serve_port: also serve every channel live over the Foxglove WebSocket
        protocol on 127.0.0.1 at this port (Foxglove: "Open connection", ws://127.0.0.1:PORT)."""
        from roar.user_files import unwritable

        fox = foxglove_sdk()
        from foxglove.mcap import MCAPWriteOptions

        self.path = None if path is None else Path(path)
        problem = self.path is not None and unwritable(self.path)
        if problem:
            raise RecordError(f"{self.path}: {problem}")
        self._fox = fox
        self._ctx = fox.Context()
        self._server = None
        if serve_port is not None:
            if not (isinstance(serve_port, int) and 1 <= serve_port <= 65535):
                raise RecordError(f"the Foxglove port must be 1..65535, got {serve_port!r}")
            try:
                self._server = fox.start_server(name="roar", host=SERVE_HOST, port=serve_port, context=self._ctx)
            except Exception as e:  # the SDK's own error type: a port in use, mostly
                raise RecordError(f"cannot serve Foxglove on {SERVE_HOST}:{serve_port}: {e}") from None
        self._writer = None if self.path is None else fox.open_mcap(
            self.path, allow_overwrite=True, context=self._ctx, writer_options=MCAPWriteOptions(chunk_size=CHUNK_BYTES))
        self._channels: dict[str, object] = {}
        self._lock = threading.Lock()
        self.closed = False
        self.messages = 0  # recorded
        self._calibrated: tuple[int, int] | None = None  # the image size a calibration was written for
        info = {"clock": "simulated" if simulated else "monotonic", "recorder": "roar"}
        if not simulated:
            info["wall_clock_offset_ns"] = str(time.time_ns() - time.monotonic_ns())
        info.update({k: str(v) for k, v in (metadata or {}).items()})
        if self._writer is not None:
            self._writer.write_metadata("run", info)
        atexit.register(_close_at_exit, weakref.ref(self))  # a program ending any way finishes the file

    # -- channels -------------------------------------------------------------------------------

    def _channel(self, topic: str, kind: str | None = None, schema: dict | None = None):
        ch = self._channels.get(topic)
        if ch is None:
            fox = self._fox
            if kind is None:
                ch = fox.Channel(topic, schema=schema, context=self._ctx)
            else:
                ch = getattr(fox.channels, f"{kind}Channel")(topic, context=self._ctx)
            self._channels[topic] = ch
        return ch

    def _log(self, topic: str, msg, t_ns: int, kind: str | None = None, schema: dict | None = None) -> None:
        with self._lock:
            if self.closed:
                return
            self._channel(topic, kind, schema).log(msg, log_time=int(t_ns))
            self.messages += 1

    @staticmethod
    def _stamp(t_ns: int):
        from foxglove.messages import Timestamp

        return Timestamp(sec=int(t_ns) // 1_000_000_000, nsec=int(t_ns) % 1_000_000_000)

    # -- what is recorded -------------------------------------------------------------------------

    def control(self, data: bytes, t_ns: int) -> None:
        """A control message as the script asked for it: its text and what it says."""
        self._log(CONTROL, _control_message(data), t_ns, schema=CONTROL_SCHEMA)

    def wire_control(self, data: bytes, t_ns: int) -> None:
        """A control message as it went on the link to the car (signed, where a key signs)."""
        self._log(WIRE_CONTROL, _control_message(data), t_ns, schema=CONTROL_SCHEMA)

    def command(self, throttle: float, steering: float, t_ns: int, text: str = "") -> None:
        """A command on a link that carries fractions rather than a control message (the
        Junior's HTTP duties): throttle and steering in -1..1."""
        self._log(CONTROL, {"text": text, "result": "fractions", "throttle": float(throttle),
                            "steering": float(steering)}, t_ns, schema=CONTROL_SCHEMA)

    def line(self, text: str, t_ns: int) -> None:
        """A line the car sent; a telemetry line's fields on TELEMETRY too."""
        from foxglove.messages import Log, LogLevel

        from roar.protocol import spec
        from roar.telemetry import parse_telemetry

        level = LogLevel.Error if text.startswith(spec.SERIAL_REPLY_ERROR) else LogLevel.Info
        self._log(LINES, Log(timestamp=self._stamp(t_ns), level=level, message=text, name="car", file="", line=0),
                  t_ns, "Log")
        fields = parse_telemetry(text) if text.startswith(spec.TELEMETRY_REPLY) else None
        if fields:
            self._log(TELEMETRY, _jsonable(fields), t_ns, schema=TELEMETRY_SCHEMA)

    def state(self, state, t_ns: int) -> None:
        """The car's state (roar.telemetry.VehicleState); with a position, its pose and transform."""
        from foxglove.messages import FrameTransform

        fields = {k: v for k, v in _jsonable(asdict(state)).items() if v is not None}
        self._log(STATE, fields, t_ns, schema=STATE_SCHEMA)
        if state.x_m is None or state.y_m is None:
            return
        from foxglove.messages import Quaternion, Vector3

        x, y, yaw = float(state.x_m), float(state.y_m), state.yaw_rad or 0.0
        self.pose(POSE, (x, y, yaw), t_ns)  # the foxglove messages are built anew each time: they cannot be read back
        self._log(TF, FrameTransform(timestamp=self._stamp(t_ns), parent_frame_id=WORLD_FRAME, child_frame_id=CAR_FRAME,
                                     translation=Vector3(x=x, y=y, z=0.0),
                                     rotation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))),
                  t_ns, "FrameTransform")

    def fields(self, topic: str, fields: dict, t_ns: int, title: str = "") -> None:
        """Any record of named values (JSON, one schema per topic titled `title`): what a
        simulator or an autopilot adds (the firmware's outputs, contacts, a planner's state)."""
        self._log(topic, _jsonable(fields), t_ns, schema={"type": "object", "title": title or topic})

    def poses(self, topic: str, poses, t_ns: int) -> None:
        """Poses (N, 3) [m, m, rad] in the world as foxglove.PosesInFrame (a filter's particles, a
        path, a tree's nodes, objects found)."""
        from foxglove.messages import PosesInFrame

        import numpy as np

        made = [_pose(x, y, th) for x, y, th in np.asarray(poses, dtype=float).reshape(-1, 3)]
        self._log(topic, PosesInFrame(timestamp=self._stamp(t_ns), frame_id=WORLD_FRAME, poses=made), t_ns,
                  "PosesInFrame")

    def pose(self, topic: str, pose, t_ns: int) -> None:
        """One pose (x, y, yaw) [m, m, rad] in the world as foxglove.PoseInFrame."""
        from foxglove.messages import PoseInFrame

        self._log(topic, PoseInFrame(timestamp=self._stamp(t_ns), frame_id=WORLD_FRAME, pose=_pose(*pose)), t_ns,
                  "PoseInFrame")

    def objects(self, topic: str, cones, markers, t_ns: int, cone_radius_m: float = 0.1,
                cone_height_m: float = 0.3, marker_size_m: tuple[float, float] = (0.5, 0.3)) -> None:
        """Cones (orange cones) and floor markers (green tiles), (x, y) [m] each, as one
        foxglove.SceneUpdate entity that replaces the last: what the camera has found so far."""
        from foxglove.messages import Color, CubePrimitive, CylinderPrimitive, SceneEntity, SceneUpdate, Vector3

        orange, green = Color(r=1.0, g=0.45, b=0.0, a=1.0), Color(r=0.1, g=0.8, b=0.2, a=0.8)
        cylinders = [CylinderPrimitive(pose=_pose(x, y, 0.0, z=cone_height_m / 2), bottom_scale=1.0, top_scale=0.2,
                                       size=Vector3(x=2 * cone_radius_m, y=2 * cone_radius_m, z=cone_height_m),
                                       color=orange) for x, y in cones]
        cubes = [CubePrimitive(pose=_pose(x, y, 0.0, z=0.005), color=green,
                               size=Vector3(x=marker_size_m[0], y=marker_size_m[1], z=0.01)) for x, y in markers]
        entity = SceneEntity(timestamp=self._stamp(t_ns), frame_id=WORLD_FRAME, id="found", frame_locked=False,
                             cylinders=cylinders, cubes=cubes)
        self._log(topic, SceneUpdate(entities=[entity]), t_ns, "SceneUpdate")

    def grid(self, topic: str, cells, corner_xy: tuple[float, float], resolution_m: float, t_ns: int) -> None:
        """An occupancy grid as foxglove.Grid (field "occupancy", 0..100 as ROS maps have it):
        cells (nx, ny), [i, j] the cell i along x and j along y from the world corner corner_xy [m]."""
        from foxglove.messages import Grid, PackedElementField, PackedElementFieldNumericType, Pose, Quaternion
        from foxglove.messages import Vector2, Vector3

        import numpy as np

        rows = np.ascontiguousarray(np.asarray(cells, dtype=np.uint8).T)  # row j (y), column i (x)
        pose = Pose(position=Vector3(x=float(corner_xy[0]), y=float(corner_xy[1]), z=0.0),
                    orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0))
        field = PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Uint8)
        self._log(topic, Grid(timestamp=self._stamp(t_ns), frame_id=WORLD_FRAME, pose=pose, column_count=rows.shape[1],
                              cell_size=Vector2(x=resolution_m, y=resolution_m), row_stride=rows.shape[1],
                              cell_stride=1, fields=[field], data=rows.tobytes()), t_ns, "Grid")

    def scan(self, ranges, start_rad: float, end_rad: float, t_ns: int) -> None:
        """A lidar scan: ranges [m] at equal steps from start_rad to end_rad (the car's frame),
        kept exactly as the sensor gave them (what it read at or beyond its range too), so a
        replay feeds a filter the same numbers."""
        from foxglove.messages import LaserScan, Pose, Quaternion, Vector3

        import numpy as np

        r = np.asarray(ranges, dtype=np.float64).ravel()
        pose = Pose(position=Vector3(x=0.0, y=0.0, z=0.0), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0))
        self._log(SCAN, LaserScan(timestamp=self._stamp(t_ns), frame_id=CAR_FRAME, pose=pose,
                                  start_angle=float(start_rad), end_angle=float(end_rad), ranges=r.tolist(),
                                  intensities=[]), t_ns, "LaserScan")

    def image(self, rgb, t_ns: int, fx_px: float | None = None, lossless: bool = False) -> None:
        """A camera frame (RGB, H x W x 3, uint8) as JPEG (lossless: PNG, the exact pixels, for a
        replay that must see what the driver saw); its calibration (a pinhole of focal length
        fx_px, or 70 degrees vertical) once per size."""
        from foxglove.messages import CameraCalibration, CompressedImage

        import numpy as np

        from roar.vision.geometry import cv2

        bgr = np.ascontiguousarray(rgb[:, :, ::-1])
        ok, jpeg = (cv2().imencode(".png", bgr, [cv2().IMWRITE_PNG_COMPRESSION, 1]) if lossless else
                    cv2().imencode(".jpg", bgr, [cv2().IMWRITE_JPEG_QUALITY, JPEG_QUALITY]))
        if not ok:
            raise RecordError("a camera frame could not be encoded as JPEG")
        h, w = rgb.shape[:2]
        stamp = self._stamp(t_ns)
        if self._calibrated != (w, h):
            f = fx_px if fx_px is not None else (h / 2) / math.tan(math.radians(35.0))
            cx, cy = (w - 1) / 2, (h - 1) / 2
            self._log(CALIBRATION, CameraCalibration(
                timestamp=stamp, frame_id=CAMERA_FRAME, width=w, height=h, distortion_model="", D=[],
                K=[f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0], R=[1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0],
                P=[f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0]), t_ns, "CameraCalibration")
            self._calibrated = (w, h)
        self._log(IMAGE, CompressedImage(timestamp=stamp, frame_id=CAMERA_FRAME, data=jpeg.tobytes(),
                                         format="png" if lossless else "jpeg"), t_ns, "CompressedImage")

    def note(self, name: str, fields: dict[str, str]) -> None:
        """A metadata record (strings) learnt during the run: the car's protocol version..."""
        with self._lock:
            if not self.closed and self._writer is not None:
                self._writer.write_metadata(name, {k: str(v) for k, v in fields.items()})

    def depth(self, depth, t_ns: int) -> None:
        """A depth image (H x W, metres) as foxglove.RawImage, 32FC1 (4 bytes a pixel: recorded
        only where a link carries depth and it is asked for)."""
        from foxglove.messages import RawImage

        import numpy as np

        d = np.ascontiguousarray(np.asarray(depth, dtype="<f4"))
        self._log(DEPTH, RawImage(timestamp=self._stamp(t_ns), frame_id=CAMERA_FRAME, width=d.shape[1],
                                  height=d.shape[0], encoding="32FC1", step=d.shape[1] * 4, data=d.tobytes()),
                  t_ns, "RawImage")

    # -- the end ----------------------------------------------------------------------------------

    def close(self) -> None:
        """Finish the file (its summary and index): every reader opens it."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            if self._writer is not None:
                self._writer.close()
            if self._server is not None:
                self._server.stop()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _control_message(data: bytes) -> dict:
    """A control message's record: its text and what the car's parser makes of it."""
    from roar.protocol.control import StreamDecoder

    msg: dict = {"text": bytes(data).decode("ascii", "replace").strip()}
    events = StreamDecoder().feed(bytes(data))
    if bytes(data).startswith(b"GET "):  # the Junior's HTTP request: its first line says it
        msg = {"text": msg["text"].splitlines()[0], "result": "http"}
    elif events:  # what the car's own parser makes of it (the twin of the firmware's)
        e = events[-1]
        msg["result"] = str(e.result)
        if e.command is not None:
            msg.update(throttle_us=e.command.throttle_us, steering_us=e.command.steering_us)
        if e.setpoint is not None:
            msg.update(speed_mm_s=e.setpoint.speed_mm_s, steering_us=e.setpoint.steering_us)
    return msg


def _pose(x: float, y: float, yaw: float, z: float = 0.0):
    from foxglove.messages import Pose, Quaternion, Vector3

    return Pose(position=Vector3(x=float(x), y=float(y), z=float(z)),
                orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)))


def _close_at_exit(ref) -> None:
    recorder = ref()
    if recorder is not None:
        recorder.close()


def _jsonable(fields: dict) -> dict:
    """Fields as JSON takes them: enums as their words, tuples as lists, infinities and NaN as
    None, nested records and lists alike."""
    return {k: _json_value(v) for k, v in fields.items()}


def _json_value(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return _jsonable(v)
    if isinstance(v, (tuple, list)):
        return [_json_value(x) for x in v]
    if v is not None and not isinstance(v, (bool, int, float, str)):
        return str(v)
    return v
