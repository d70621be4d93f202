"""A roar recording (roar.recorder's MCAP, Foxglove's types) as a rosbag2 (ROS 2 types, CDR, MCAP
storage), so ROS users' tools read our runs: `ros2 bag`, rosbags, Foxglove as ROS messages.

    roar ros2 --bag run.mcap --out run_bag/

Written with rosbags (its Kilted type store): no ROS graph is needed. Topics:

    /car/state       -> /odom              nav_msgs/Odometry (where the state has a pose)
    /lidar           -> /scan              sensor_msgs/LaserScan (frame laser)
    /camera/image    -> /camera/image_raw/compressed   sensor_msgs/CompressedImage
    /camera/calibration -> /camera/camera_info         sensor_msgs/CameraInfo
    /camera/depth    -> /camera/depth/image_raw        sensor_msgs/Image (32FC1)
    /tf              -> /tf                tf2_msgs/TFMessage (world -> base_link as map -> base_link)
    /car/lines       -> /rosout            rcl_interfaces/Log (name "car")
    /control, /wire/control, /car/telemetry -> /roar/control, /roar/wire/control, /roar/car/telemetry
                                           std_msgs/String (the JSON each record holds)

Every other topic is left out, and counted: /car/pose (what /odom and /tf carry), a planner's, a
filter's."""

from __future__ import annotations

import json
import math
from pathlib import Path

from roar.errors import Ros2Error
from roar.localization.odometry import Pose
from roar.recorder import CALIBRATION, CONTROL, DEPTH, IMAGE, LINES, SCAN, STATE, TELEMETRY, TF, WIRE_CONTROL

ODOM_FRAME, BASE_FRAME, LASER_FRAME, CAMERA_FRAME, MAP_FRAME = "odom", "base_link", "laser", "camera_optical", "map"
TYPES = {  # our topic -> (the bag's topic, its type)
    STATE: ("/odom", "nav_msgs/msg/Odometry"),
    SCAN: ("/scan", "sensor_msgs/msg/LaserScan"),
    IMAGE: ("/camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage"),
    CALIBRATION: ("/camera/camera_info", "sensor_msgs/msg/CameraInfo"),
    DEPTH: ("/camera/depth/image_raw", "sensor_msgs/msg/Image"),
    TF: ("/tf", "tf2_msgs/msg/TFMessage"),
    LINES: ("/rosout", "rcl_interfaces/msg/Log"),
    CONTROL: ("/roar/control", "std_msgs/msg/String"),
    WIRE_CONTROL: ("/roar/wire/control", "std_msgs/msg/String"),
    TELEMETRY: ("/roar/car/telemetry", "std_msgs/msg/String"),
}
LOG_LEVELS = {1: 10, 2: 20, 3: 30, 4: 40, 5: 50}  # foxglove.LogLevel -> rcl_interfaces Log's levels


def convert(recording: str | Path, out: str | Path) -> dict[str, int]:
    """Write `recording` as a rosbag2 folder `out` (which must not exist yet); the messages
    written per bag topic, and "left out": those of topics with no ROS counterpart."""
    import numpy as np
    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin
    from rosbags.typesys import Stores, get_typestore

    from roar.replay import messages, metadata

    recording, out = Path(recording), Path(out)
    metadata(recording)  # a roar recording, readable: or ReplayError in one line, before anything is written
    if out.exists():
        raise Ros2Error(f"{out} exists: a rosbag2 is a new folder (give another --out or remove it)")
    if not out.parent.is_dir():
        raise Ros2Error(f"{out.parent} does not exist: make it first")
    store = get_typestore(Stores.ROS2_KILTED)
    t = store.types
    counts: dict[str, int] = {"left out": 0}

    def header(ns: int, frame: str):
        return t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                       frame_id=frame)

    def vector(x=0.0, y=0.0, z=0.0):
        return t["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def quaternion(x=0.0, y=0.0, z=0.0, w=1.0):
        return t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def odometry(ns, s):
        if s.get("x_m") is None or s.get("y_m") is None:
            return None
        yaw = s.get("yaw_rad") or 0.0
        pose = t["geometry_msgs/msg/Pose"](position=t["geometry_msgs/msg/Point"](x=s["x_m"], y=s["y_m"], z=0.0),
                                           orientation=quaternion(z=math.sin(yaw / 2), w=math.cos(yaw / 2)))
        twist = t["geometry_msgs/msg/Twist"](linear=vector(x=s.get("speed_m_s") or 0.0),
                                             angular=vector(z=s.get("yaw_rate_rad_s") or 0.0))
        return t["nav_msgs/msg/Odometry"](
            header=header(ns, ODOM_FRAME), child_frame_id=BASE_FRAME,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)))

    def scan(ns, m):
        n = len(m.ranges)
        step = (m.end_angle - m.start_angle) / (n - 1) if n > 1 else 0.0
        return t["sensor_msgs/msg/LaserScan"](
            header=header(ns, LASER_FRAME), angle_min=m.start_angle, angle_max=m.end_angle, angle_increment=step,
            time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=float(max(m.ranges, default=0.0)),
            ranges=np.asarray(m.ranges, dtype=np.float32), intensities=np.zeros(0, dtype=np.float32))

    def image(ns, m):
        return t["sensor_msgs/msg/CompressedImage"](header=header(ns, CAMERA_FRAME), format=m.format,
                                                    data=np.frombuffer(m.data, dtype=np.uint8))

    def calibration(ns, m):
        roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        return t["sensor_msgs/msg/CameraInfo"](
            header=header(ns, CAMERA_FRAME), height=m.height, width=m.width, distortion_model="plumb_bob",
            d=np.zeros(5), k=np.asarray(m.K, dtype=float), r=np.asarray(m.R, dtype=float),
            p=np.asarray(m.P, dtype=float), binning_x=0, binning_y=0, roi=roi)

    def depth(ns, m):
        return t["sensor_msgs/msg/Image"](header=header(ns, CAMERA_FRAME), height=m.height, width=m.width,
                                          encoding=m.encoding, is_bigendian=0, step=m.step,
                                          data=np.frombuffer(m.data, dtype=np.uint8))

    def transform(ns, m):
        parent = MAP_FRAME if m.parent_frame_id == "world" else m.parent_frame_id
        r, v = m.rotation, m.translation
        stamped = t["geometry_msgs/msg/TransformStamped"](
            header=header(ns, parent), child_frame_id=m.child_frame_id,
            transform=t["geometry_msgs/msg/Transform"](translation=vector(v.x, v.y, v.z),
                                                       rotation=quaternion(r.x, r.y, r.z, r.w)))
        return t["tf2_msgs/msg/TFMessage"](transforms=[stamped])

    def log_line(ns, m):
        return t["rcl_interfaces/msg/Log"](stamp=header(ns, "").stamp, level=LOG_LEVELS.get(int(m.level), 20),
                                           name=m.name or "car", msg=m.message, file=m.file, function="", line=m.line)

    def text(ns, m):
        return t["std_msgs/msg/String"](data=json.dumps(m))

    build = {STATE: odometry, SCAN: scan, IMAGE: image, CALIBRATION: calibration, DEPTH: depth, TF: transform,
             LINES: log_line, CONTROL: text, WIRE_CONTROL: text, TELEMETRY: text}
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for topic, ns, message in messages(recording):
            if topic not in build:
                counts["left out"] += 1
                continue
            made = build[topic](ns, message)
            if made is None:
                continue
            name, kind = TYPES[topic]
            if topic not in connections:
                connections[topic] = writer.add_connection(name, kind, typestore=store)
            writer.write(connections[topic], ns, store.serialize_cdr(made, kind))
            counts[name] = counts.get(name, 0) + 1
    return counts


# --- a foreign bag: what it holds, and our particle filter over it --------------------------------

def is_bag(path: str | Path) -> bool:
    """A rosbag2 folder (its metadata.yaml beside its storage)."""
    return Path(path).is_dir() and (Path(path) / "metadata.yaml").is_file()


def open_bag(path: str | Path):
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError

    try:
        reader = Reader(Path(path))
        reader.open()
    except (ReaderError, OSError, ValueError) as e:
        raise Ros2Error(f"{path}: not a readable rosbag2 ({e})") from None
    return reader


def summary(path: str | Path) -> str:
    """What a rosbag2 holds: its span, and per topic its type, count and rate."""
    reader = open_bag(path)
    try:
        span_s = (reader.end_time - reader.start_time) / 1e9 if reader.message_count else 0.0
        lines = [f"{path}: rosbag2 ({reader.ros_distro or 'distribution not said'}), {reader.message_count} messages "
                 f"over {span_s:.1f} s"]
        for topic, info in sorted(reader.topics.items()):
            rate = info.msgcount / span_s if span_s > 0 else 0.0
            lines.append(f"  {topic:32} {info.msgtype:36} {info.msgcount:7}  {rate:6.1f} Hz")
    finally:
        reader.close()
    return "\n".join(lines)


def localize(path: str | Path, known, scan_topic: str = "/scan", odom_topic: str = "/odom",
             start: str = "global", particles: int = 2500, seed: int = 0) -> list[tuple]:
    """Our particle filter over a foreign rosbag2: each scan on `scan_topic` weighed on the map
    `known` (an OccupancyMap), the particles moved between scans as the poses on `odom_topic`
    (nav_msgs/Odometry) moved, the lidar where the bag's /tf_static puts the scan's frame on the
    odometry's child frame (else at its origin). start: "global" (anywhere on the map) or "odom" (at
    the first odometry pose: a bag whose odom frame is the map's, as f1tenth_gym_ros's). Returns per
    scan (t [s], the odometry's pose, the filter's pose, its spread [m])."""
    import numpy as np
    from rosbags.typesys import Stores, get_typestore

    from roar.localization import LaserScan, ParticleFilter

    if start not in ("global", "odom"):
        raise Ros2Error(f"start must be global or odom, got {start!r}")
    store = get_typestore(Stores.ROS2_KILTED)
    reader = open_bag(path)
    out, odom, base, f = [], None, None, None
    mounts: dict[tuple[str, str], Pose] = {}  # (parent, child) frames -> (x, y, yaw) from /tf_static
    try:
        wanted = [c for c in reader.connections if c.topic in (scan_topic, odom_topic)]
        kinds = {c.topic: c.msgtype for c in wanted}
        for topic, kind in ((scan_topic, "sensor_msgs/msg/LaserScan"), (odom_topic, "nav_msgs/msg/Odometry")):
            if kinds.get(topic) != kind:
                found = kinds.get(topic, "nothing")
                raise Ros2Error(f"{path}: {topic} holds {found}, not {kind} "
                                f"(topics: {', '.join(sorted(reader.topics))})")
        wanted += [c for c in reader.connections
                   if c.topic == "/tf_static" and c.msgtype == "tf2_msgs/msg/TFMessage"]
        for connection, t_ns, raw in reader.messages(connections=wanted):
            msg = store.deserialize_cdr(raw, connection.msgtype)
            if connection.topic == "/tf_static":
                for tf in msg.transforms:
                    r, v = tf.transform.rotation, tf.transform.translation
                    mounts[(tf.header.frame_id, tf.child_frame_id)] = (float(v.x), float(v.y),
                                                                        2 * math.atan2(r.z, r.w))
                continue
            if connection.topic == odom_topic:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                odom, base = (float(p.x), float(p.y), 2 * math.atan2(q.z, q.w)), msg.child_frame_id
                continue
            if odom is None:
                continue  # no motion known yet
            if f is None:
                f = ParticleFilter(known, particles, seed=seed,
                                   sensor=mounts.get((base, msg.header.frame_id), (0.0, 0.0, 0.0)))
                if start == "odom":
                    f.start_at(odom)
                else:
                    f.start_global()
            f.predict(odom)
            ranges = np.asarray(msg.ranges, dtype=np.float64)
            angles = msg.angle_min + msg.angle_increment * np.arange(len(ranges))
            f.correct(LaserScan(angles, ranges, t_ns / 1e9, float(msg.range_min), float(msg.range_max)))
            out.append((t_ns / 1e9, odom, tuple(float(v) for v in f.pose), f.spread_m))
    finally:
        reader.close()
    if not out:
        raise Ros2Error(f"{path}: no {scan_topic} after an {odom_topic} message: nothing to localize")
    return out
