"""Reading a recording back (roar.recorder's MCAP files): what it holds, per channel the count,
rate and longest gap, with the mcap library's reader. A file that is not one ends in one line
(ReplayError): missing, empty, not MCAP, cut off, or another program's recording.

    log = read_log("run.mcap")       # .metadata, .channels {topic: ChannelStats}, .duration_s
    print(summary("run.mcap"))
    plot("run.mcap", "run.png")      # the path, the speed, the commands
    with Vehicle("sim://") as car:
        play("run.mcap", car)        # the recorded commands again, at their times
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

from roar.errors import ReplayError, RoarError

MAGIC = b"\x89MCAP0\r\n"  # the first bytes of every MCAP file (mcap.dev's specification)


@dataclass
class ChannelStats:
    topic: str
    schema: str
    count: int = 0
    first_ns: int = 0
    last_ns: int = 0
    longest_gap_ns: int = 0

    @property
    def rate_hz(self) -> float:
        """[Hz] while the channel ran: from its first message to its last."""
        span = (self.last_ns - self.first_ns) / 1e9
        return (self.count - 1) / span if self.count > 1 and span > 0 else 0.0

    def rate_in(self, log: Log) -> float:
        """[Hz] over the whole recording: what a channel that spoke twice in 12 s really gave."""
        return self.count / log.duration_s if log.duration_s > 0 else 0.0

    def quiet_ns(self, log: Log) -> int:
        """[ns] the channel's longest silence in the recording, its start and end included."""
        return max(self.longest_gap_ns, self.first_ns - log.start_ns, log.end_ns - self.last_ns)


@dataclass
class Log:
    path: Path
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)  # record name -> fields
    channels: dict[str, ChannelStats] = field(default_factory=dict)
    start_ns: int = 0
    end_ns: int = 0

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    @property
    def messages(self) -> int:
        return sum(c.count for c in self.channels.values())


def open_reader(path: str | Path):
    """(file, mcap reader) of a roar recording, or ReplayError in one line."""
    from mcap.reader import make_reader

    path = Path(path)
    try:
        f = open(path, "rb")
    except FileNotFoundError:
        raise ReplayError(f"{path}: no such file") from None
    except OSError as e:
        raise ReplayError(f"{path}: cannot be read ({e.strerror})") from None
    head = f.read(len(MAGIC))
    if not head:
        f.close()
        raise ReplayError(f"{path}: the file is empty (a recording that never started?)")
    if head != MAGIC:
        f.close()
        raise ReplayError(f"{path}: not an MCAP file (it does not start as one)")
    f.seek(0)
    return f, make_reader(f)


def metadata(path: str | Path) -> dict[str, dict[str, str]]:
    """A roar recording's metadata records (name -> fields) without reading its messages."""
    from mcap.exceptions import McapError

    f, reader = open_reader(path)
    try:
        with f:
            found = {record.name: dict(record.metadata) for record in reader.iter_metadata()}
    except (McapError, EOFError, ValueError, struct.error) as e:
        raise ReplayError(f"{path}: cut off or damaged ({e}): a recording that was not finished") from None
    if found.get("run", {}).get("recorder") != "roar":
        raise ReplayError(f"{path}: not a roar recording (no run metadata from roar)")
    return found


def read_log(path: str | Path) -> Log:
    """Everything but the messages' contents: metadata, and per channel its statistics."""
    from mcap.exceptions import McapError

    log = Log(Path(path), metadata(path))
    f, reader = open_reader(path)
    try:
        with f:
            last: dict[str, int] = {}
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                stats = log.channels.get(channel.topic)
                t = message.log_time
                if stats is None:
                    stats = log.channels[channel.topic] = ChannelStats(channel.topic, schema.name if schema else "",
                                                                       first_ns=t, last_ns=t)
                else:
                    stats.longest_gap_ns = max(stats.longest_gap_ns, t - last[channel.topic])
                    stats.first_ns, stats.last_ns = min(stats.first_ns, t), max(stats.last_ns, t)
                last[channel.topic] = t
                stats.count += 1
    except (McapError, EOFError, ValueError, struct.error) as e:
        raise ReplayError(f"{path}: cut off or damaged ({e}): a recording that was not finished") from None
    if log.channels:
        log.start_ns = min(c.first_ns for c in log.channels.values())
        log.end_ns = max(c.last_ns for c in log.channels.values())
    return log


def messages(path: str | Path, topics: list[str] | None = None, as_written: bool = False):
    """(topic, log time [ns], message) of a recording in time order (as_written: in the order they
    were written, which settles messages of the same time), JSON channels as dicts, protobuf ones
    (Foxglove's types) as protobuf messages built from the file's own schemas."""
    import json

    from mcap.exceptions import McapError

    f, reader = open_reader(path)
    decoders: dict[int, object] = {}
    with f:
        try:
            for schema, channel, message in reader.iter_messages(topics=topics, log_time_order=not as_written):
                decode = decoders.get(channel.id)
                if decode is None:
                    decode = decoders[channel.id] = json.loads if channel.message_encoding == "json" else \
                        _protobuf_decoder(schema)
                yield channel.topic, message.log_time, decode(message.data)
        except (McapError, EOFError, ValueError, struct.error) as e:
            raise ReplayError(f"{path}: cut off or damaged ({e}): a recording that was not finished") from None


def _protobuf_decoder(schema):
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    if schema is None or schema.encoding != "protobuf":
        raise ReplayError(f"a channel whose schema is {getattr(schema, 'encoding', 'missing')}: not roar's")
    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(schema.data).file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name)).FromString


def summary(path: str | Path) -> str:
    log = read_log(path)
    run = log.metadata.get("run", {})
    clock = run.get("clock", "?")
    lines = [f"{log.path}: {log.duration_s:.2f} s of {clock} time, {log.messages:,} messages; car "
             f"{run.get('car', '?')}" + (f", protocol {log.metadata['car']['protocol_version']}"
                                          if "protocol_version" in log.metadata.get("car", {}) else "")]
    if run.get("command"):
        lines.append(f"  recorded by: {run['command']}")
    width = max([len(t) for t in log.channels] + [7])
    lines.append(f"  {'channel':<{width}}  {'schema':<26} {'messages':>8} {'rate':>9} {'longest silence':>16}")
    for topic in sorted(log.channels):
        c = log.channels[topic]
        lines.append(f"  {topic:<{width}}  {c.schema:<26} {c.count:>8,} {c.rate_in(log):>6.1f} Hz "
                     f"{c.quiet_ns(log) / 1e9:>14.3f} s")
    lines.append("  (rates over the whole recording; a silence counts from its start and to its end too)")
    return "\n".join(lines)


def commands(path: str | Path) -> list[tuple[float, dict]]:
    """([s] from the first, control message) of every control message that changed what the car
    was told (the sender's re-sends dropped)."""
    out, last, t0 = [], None, None
    for _, t, msg in messages(path, ["/control"]):
        t0 = t if t0 is None else t0
        said = {k: msg.get(k) for k in ("throttle_us", "steering_us", "speed_mm_s", "throttle", "steering")}
        if msg.get("result") in ("ok", "setpoint", "fractions") and said != last:
            out.append(((t - t0) / 1e9, msg))
            last = said
    return out


def play(path: str | Path, car, on_command=None) -> int:
    """Send a recording's commands to a car (a roar.Vehicle) at their recorded times: the
    Vehicle re-sends each at its rate and sends neutral when it closes, so every failsafe rule
    holds as when a program drives. Returns how many were played."""
    import time

    todo = commands(path)
    if not todo:
        raise ReplayError(f"{path}: no control messages to play")
    start = time.monotonic()
    for k, (at_s, msg) in enumerate(todo):
        time.sleep(max(0.0, at_s - (time.monotonic() - start)))
        if msg.get("result") == "setpoint":
            car.drive(speed=msg["speed_mm_s"] / 1000, steering=(msg["steering_us"] - 1500) / 500)
        elif msg.get("result") == "fractions":  # a link that carried fractions (the Junior's duties)
            car.drive(msg["throttle"], msg["steering"])
        else:
            car.send_pulses(msg["throttle_us"], msg["steering_us"])
        if on_command is not None:
            on_command(k, at_s, msg)
    return len(todo)


def plot(path: str | Path, png: str | Path) -> None:
    """The driven path, the speed and the commands over time, into a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    log = read_log(path)
    states = [(t, m) for _, t, m in messages(path, ["/car/state"])]
    control = [(t, m) for _, t, m in messages(path, ["/control"]) if m.get("result") in ("ok", "setpoint")]
    t0 = log.start_ns
    fig, (ax_path, ax_speed, ax_cmd) = plt.subplots(3, 1, figsize=(8, 11), gridspec_kw={"height_ratios": [3, 1, 1]})
    xy = [(m["x_m"], m["y_m"]) for _, m in states if "x_m" in m and "y_m" in m]
    track = _track_of(log)
    if track is not None:
        from roar.tracks.drawing import draw_track

        draw_track(ax_path, track)
    if xy:
        ax_path.plot(*zip(*xy), lw=1.2, label="driven path")
        ax_path.plot(*xy[0], "go", label="start")
        ax_path.plot(*xy[-1], "rs", label="end")
        ax_path.legend(fontsize=8)
    else:
        ax_path.text(0.5, 0.5, "this link reported no position", ha="center", transform=ax_path.transAxes)
    ax_path.set_aspect("equal", adjustable="datalim")
    run = log.metadata.get("run", {})
    where = f", track {track.name}" if track is not None else ""
    ax_path.set(xlabel="x [m]", ylabel="y [m]", title=f"{log.path.name}: {run.get('car', '')}{where}")
    speed = [((t - t0) / 1e9, m["speed_m_s"]) for t, m in states if "speed_m_s" in m]
    if speed:
        ax_speed.plot(*zip(*speed), lw=1)
    ax_speed.set(xlabel="t [s]", ylabel="speed [m/s]")
    for key, label in (("throttle_us", "throttle"), ("steering_us", "steering")):
        points = [((t - t0) / 1e9, m[key]) for t, m in control if key in m]
        if points:
            ax_cmd.step(*zip(*points), where="post", lw=1, label=f"{label} [us]")
    ax_cmd.set(xlabel="t [s]", ylabel="pulse [us]")
    ax_cmd.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)


def _track_of(log: Log):
    """The track the recording names (its "track" record, or the sim:// URL's), where it loads
    here (a built-in or seeded name, a file that is still there); else None."""
    from roar.transports import TransportError, parse_url

    run = log.metadata.get("run", {})
    name = run.get("track", "")
    if not name and run.get("car", "").lower().startswith("sim://"):
        try:
            _, target, options = parse_url(run["car"])
        except TransportError:
            return None
        files = (".json", ".csv", ".yaml", ".yml")  # a path keeps its slashes, as sim:// reads it
        name = options.get("track") or (target if target.lower().endswith(files) else target.strip("/"))
    if not name or name == "open floor":
        return None
    try:
        from roar.tracks import get

        return get(name)
    except (ImportError, RoarError, ValueError):
        return None


def localize(path: str | Path, known) -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """Run a recorded race's particle filter again, open loop, from what the recording holds: the
    filter's set-up (the "localization" record), each period's odometry and the scans it weighed
    (/localization/steps, /lidar), on the map `known` (an OccupancyMap). Returns (recorded pose,
    replayed pose) per period: equal, bit for bit, when the filter is the one that ran."""
    import json

    import numpy as np

    from roar.localization import LaserScan, ParticleFilter

    setup = {k: json.loads(v) for k, v in metadata(path).get("localization", {}).items()}
    if not setup:
        raise ReplayError(f"{path}: no particle filter ran in this recording (roar race --localize --log)")
    scans = {t: m for _, t, m in messages(path, ["/lidar"])}
    f = ParticleFilter(known, setup["particles"], setup["beams"], sensor=tuple(setup["sensor"]), seed=setup["seed"])
    if setup["start"] is None:
        f.start_global()
    else:
        f.start_at(tuple(setup["start"]))
    out = []
    for _, _, step in messages(path, ["/localization/steps"]):
        f.predict(tuple(step["odometry"]))
        s = step["scan"]
        if s is not None:
            m = scans.get(s["log_ns"])
            if m is None:
                raise ReplayError(f"{path}: the scan at {s['time_s']:.3f} s is missing")
            ranges = np.array(m.ranges, dtype=np.float64)
            f.correct(LaserScan(np.linspace(m.start_angle, m.end_angle, len(ranges)), ranges, s["time_s"],
                                s["range_min_m"], s["range_max_m"]))
        out.append((tuple(step["pose"]), tuple(float(v) for v in f.pose)))
    return out


def lanes(path: str | Path, camera=None) -> list[tuple[dict, dict]]:
    """Run a recorded lane driver's detector again, open loop, over the frames it saw (recorded
    losslessly), with the simulated car's camera unless `camera` (a roar.vision.geometry
    CameraPreset) says otherwise. Returns (recorded, replayed) per frame, each {lines, offset_m,
    heading_rad}: equal, bit for bit, when the detector is the one that ran."""
    import numpy as np

    from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye, cv2
    from roar.vision.lanes import LaneDetector

    camera = camera or SIMULATED_CAR_CAMERA
    seen = [m for _, _, m in messages(path, ["/perception/lanes"], as_written=True)]
    if not seen:
        raise ReplayError(f"{path}: no lane detections in this recording (roar race --driver lane --log)")
    detector, out = None, []
    frames = [m for _, _, m in messages(path, ["/camera/image"], as_written=True)]
    if len(frames) != len(seen) or any(m.format != "png" for m in frames):
        raise ReplayError(f"{path}: the lane driver's frames are not all here losslessly ({len(frames)} frames, "
                          f"{len(seen)} detections)")
    for frame, recorded in zip(frames, seen):
        rgb = np.ascontiguousarray(cv2().imdecode(np.frombuffer(frame.data, np.uint8), cv2().IMREAD_COLOR)[:, :, ::-1])
        if detector is None:
            detector = LaneDetector(BirdsEye(camera.model(rgb.shape[1], rgb.shape[0])))
        found = detector.detect(rgb)
        centre = found.centre is not None
        out.append((recorded, {"lines": found.source, "offset_m": found.offset_m if centre else None,
                               "heading_rad": found.heading_rad if centre else None}))
    return out
