"""A car at any URL as a ROS 2 node (rclpy), through roar.Vehicle: ROS commands in, what the car
measures out. `roar ros2 URL` runs one (roar.cli.ros2); docs/ros2.md has the topic and QoS table.

In:  /drive (ackermann_msgs/AckermannDriveStamped) and /cmd_vel (geometry_msgs/Twist), mapped by
     roar.ros2.commands. No command for `timeout_s` (250 ms by default, never off) -> neutral:
     the Vehicle re-sends its last command at 50 Hz, so without this a silent ROS node would
     never reach the car's own failsafe.
Out: /odom (nav_msgs/Odometry) and the odom -> base_link transform, dead-reckoned from what the car
     measures (speed and gyro: roar.localization.odometry), starting at the pose the link first
     reports (the simulator's start on its track: odom then coincides with map); /imu (the gyro);
     /scan (sensor_msgs/LaserScan) where the car has a lidar; /clock from the simulator's clock;
     /map (nav_msgs/OccupancyGrid, transient local) for the track; /diagnostics (the link and the
     bridge's counts). A car that reports neither speed nor pose gets no /odom.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from roar.localization.odometry import Odometry
from roar.errors import CameraError, RefusedCommand, RoarError
from roar.ros2.commands import Ask, Driver, ackermann, twist

PERIOD_S = 0.02  # [s] the bridge's tick: odometry, clock, scan, the command timeout
TIMEOUT_S = 0.25  # [s] no command for this long -> neutral (the firmware's own failsafe is 250 ms too)
CAMERA_SIZE = (320, 240)  # [px] the simulator's frames (a real car's camera gives its own size)
DIAGNOSTICS_PERIOD_S = 1.0  # [s]
STOP_WAIT_S = 0.5  # [s] for a sensor's thread to finish its read at the end
RETRY_S = 1.0  # [s] between tries of a sensor whose read failed (a camera's stream that ended)
# [s] the particle filter weighs a scan this often (on the scans' clock): enough to follow a car, and
# its CPU (and the GIL it holds) leaves the threads that feed the car's failsafe their time
LOCALIZE_PERIOD_S = 0.1
# [m^2, rad^2] what /odom's covariances say: dead reckoning's spread (a 2D car: z, roll and pitch
# unknown, said by a huge variance, as 2D drivers do)
POSE_VARIANCE = (0.01, 0.01, 1e6, 1e6, 1e6, 0.01)
TWIST_VARIANCE = (0.0025, 0.0025, 1e6, 1e6, 1e6, 0.0004)


@dataclass(frozen=True)
class Names:
    """Topic and frame names; F1TENTH gives f1tenth_gym_ros's, so its nodes drive ours unchanged."""

    drive: str = "/drive"
    cmd_vel: str = "/cmd_vel"
    odom: str = "/odom"
    scan: str = "/scan"
    imu: str = "/imu"
    map: str = "/map"
    pose: str = "/pose"  # with --localize: the car on the map, as a particle filter says (amcl's amcl_pose)
    map_frame: str = "map"
    odom_frame: str = "odom"
    base_frame: str = "base_link"
    laser_frame: str = "laser"
    camera_frame: str = "camera_optical"  # z ahead, x right, y down (REP 103's optical frame)
    image: str = "/camera/image_raw"
    camera_info: str = "/camera/camera_info"
    depth: str = "/camera/depth/image_raw"


STANDARD = Names()
# f1tenth_gym_ros: odometry in the map frame (its car's pose is the simulator's truth there)
F1TENTH = Names(odom="/ego_racecar/odom", odom_frame="map", base_frame="ego_racecar/base_link",
                laser_frame="ego_racecar/laser", camera_frame="ego_racecar/camera_optical")


@dataclass
class Counts:
    commands: int = 0  # /drive and /cmd_vel messages driven
    refused: int = 0  # ... not driven: no number a car could mean
    timeouts: int = 0  # times the car was put to neutral for silence
    scans: int = 0
    odoms: int = 0
    last_refusal: str = ""
    by_topic: dict = field(default_factory=dict)


def quaternion(yaw: float):
    from geometry_msgs.msg import Quaternion

    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


class Bridge:
    """The node's publishers, subscriptions and tick over one Vehicle (left at neutral by close)."""

    def __init__(self, vehicle, node, model, names: Names = STANDARD, timeout_s: float = TIMEOUT_S,
                 track: str | None = None, camera_hz: float = 0.0, localize: bool = False, log=print) -> None:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import OccupancyGrid, Odometry as OdometryMsg
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import Imu, LaserScan

        from roar.ros2.interfaces import available

        self.vehicle, self.node, self.names, self.timeout_s = vehicle, node, names, timeout_s
        self.link = vehicle.transport.link
        self.simulated = self.link.scheme == "sim"
        self.driver = Driver(model)
        self.model = model
        self.counts = Counts()
        self.log = log
        self._ask: Ask | None = None
        self._last_command = -math.inf  # [s] monotonic
        self._neutral = True
        self._odometry: Odometry | None = None
        self._travelled_m = 0.0
        self._last_state_t: float | None = None
        self._last_diagnostics = -math.inf
        self._has_tf = available("tf2_msgs")

        # Sensors: reliable, depth 5: a best-effort subscriber (qos_profile_sensor_data) and a
        # reliable one (rclpy's default) both match a reliable publisher; a best-effort one would
        # leave a reliable subscriber silent.
        sensors = QoSProfile(depth=5, reliability=ReliabilityPolicy.RELIABLE)
        # Commands: best-effort, depth 10: hears reliable publishers (F1TENTH's, Nav2's) and
        # best-effort ones alike, where a reliable subscription would not hear the latter.
        commands = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.qos = {"sensors": sensors, "commands": commands, "latched": latched}

        self.odom_pub = node.create_publisher(OdometryMsg, names.odom, sensors)
        self.imu_pub = node.create_publisher(Imu, names.imu, sensors)
        self.scan_pub = node.create_publisher(LaserScan, names.scan, sensors) if vehicle.lidar() is not None else None
        self.clock_pub = node.create_publisher(Clock, "/clock", QoSProfile(depth=1)) if self.simulated else None
        self.diagnostics_pub = node.create_publisher(DiagnosticArray, "/diagnostics", QoSProfile(depth=10))
        self.map_pub = node.create_publisher(OccupancyGrid, names.map, latched)
        node.create_subscription(Twist, names.cmd_vel, self._on_twist, commands)
        if available("ackermann_msgs"):
            from ackermann_msgs.msg import AckermannDriveStamped

            node.create_subscription(AckermannDriveStamped, names.drive, self._on_drive, commands)
        else:
            log(f"no ackermann_msgs here: {names.drive} is not offered ({names.cmd_vel} is); "
                "python -m roar.ros2.interfaces builds it")
        if self._has_tf:
            from tf2_msgs.msg import TFMessage

            self.tf_pub = node.create_publisher(TFMessage, "/tf", QoSProfile(depth=100))
            self.tf_static_pub = node.create_publisher(TFMessage, "/tf_static", latched)
        else:
            log("no tf2_msgs here: /tf is not offered; python -m roar.ros2.interfaces builds it")
        self.lidar_mount = self.link.lidar_mount() or (0.0, 0.0, 0.0)  # where base_link -> laser goes
        self.known = None  # the map of `track` (roar.tracks.OccupancyMap): /map, and --localize's
        if track:
            from roar.tracks.names import map_of

            self.known = map_of(track)
        self.localizer = None  # a MapLocalizer from the first scan with odometry, with --localize
        self._next_localize_s = -math.inf  # [s] on the scans' clock
        self._odom_pose = None  # the latest odometry pose (x, y, yaw), for the localizer's thread
        self.pose_pub = None
        if localize:
            from geometry_msgs.msg import PoseWithCovarianceStamped

            from roar.errors import Ros2Error

            if names.odom_frame == names.map_frame:
                raise Ros2Error("--localize publishes map -> odom: not with --f1tenth, whose odometry is in the "
                                "map frame")
            if self.scan_pub is None or self.known is None:
                raise Ros2Error("--localize needs a lidar and a map (a sim:// track, or --map): "
                                f"{'no lidar' if self.scan_pub is None else 'no map'} here")
            self.pose_pub = node.create_publisher(PoseWithCovarianceStamped, names.pose, sensors)
        self.timer = node.create_timer(PERIOD_S, self.tick)
        self.camera = Camera(self) if camera_hz > 0 and vehicle.camera(*CAMERA_SIZE) is not None else None
        self._publish_static()
        # sensors that take the simulator's thread (a scan's rays, a render) or a link's round trip
        # are read on threads of their own: the executor's thread stays free for the commands
        self.pollers = [Poller("scan", PERIOD_S, lambda: self._publish_scan(self.stamp(self.vehicle.state())),
                               log)] if self.scan_pub is not None else []
        if self.camera is not None:
            self.pollers.append(self.camera.poller(camera_hz, log))
        for poller in self.pollers:
            poller.start()

    # --- what the car is ----------------------------------------------------------------------

    def _drives_by_speed(self) -> bool:
        from roar.protocol import spec

        return self.vehicle.protocol_version == spec.META_SPEED_VERSION

    # --- commands in --------------------------------------------------------------------------

    def _on_drive(self, msg) -> None:
        self._take(self.names.drive, lambda: ackermann(msg.drive.speed, msg.drive.steering_angle,
                                                      getattr(self.model, "wheelbase_m", 1.0)))

    def _on_twist(self, msg) -> None:
        self._take(self.names.cmd_vel, lambda: twist(msg.linear.x, msg.angular.z))

    def _take(self, topic: str, make) -> None:
        try:
            ask = make()
        except RefusedCommand as e:
            self.counts.refused += 1
            self.counts.last_refusal = f"{topic}: {e}"
            return
        self.counts.commands += 1
        self.counts.by_topic[topic] = self.counts.by_topic.get(topic, 0) + 1
        self._ask, self._last_command = ask, time.monotonic()
        self._drive(self.vehicle.state())

    def _drive(self, state) -> None:
        silent = time.monotonic() - self._last_command > self.timeout_s
        if silent or self._ask is None:
            if not self._neutral:
                self.counts.timeouts += 1
                self.vehicle.drive(**self._neutral_command())
                self._neutral = True
            return
        speed = state.speed_m_s if state is not None else None
        self.driver.by_speed = self._drives_by_speed()
        self.vehicle.drive(**self.driver.command(self._ask, speed, PERIOD_S))
        self._neutral = False

    # --- what the car measures, out -------------------------------------------------------------

    def stamp(self, state):
        """The message time: the simulator's clock on sim:// (so use_sim_time nodes agree), else now."""
        from builtin_interfaces.msg import Time

        if self.simulated and state is not None and state.time_s is not None:
            ns = int(state.time_s * 1e9)
            return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return self.node.get_clock().now().to_msg()

    def tick(self) -> None:
        state = self.vehicle.state()
        self._drive(state)
        stamp = self.stamp(state)
        if self.clock_pub is not None:
            from rosgraph_msgs.msg import Clock

            self.clock_pub.publish(Clock(clock=stamp))
        pose = self._odometry_pose(state)
        if pose is not None:
            self._odom_pose = pose
            self._publish_odometry(state, pose, stamp)
        if state is not None and state.yaw_rate_rad_s is not None:
            self._publish_imu(state, stamp)
        if time.monotonic() - self._last_diagnostics >= DIAGNOSTICS_PERIOD_S:
            self._last_diagnostics = time.monotonic()
            self._publish_diagnostics(state, stamp)

    def _odometry_pose(self, state):
        """(x, y, yaw): the pose a real link measures (a phone's, by its visual-inertial odometry);
        else speed and gyro integrated from the first reported pose (the simulator's pose is its
        truth, which no car has: it gives only the start); None where the link reports neither."""
        if state is None:
            return None
        has_pose = None not in (state.x_m, state.y_m, state.yaw_rad)
        if has_pose and not self.simulated:
            return state.x_m, state.y_m, state.yaw_rad
        if state.speed_m_s is None or state.yaw_rate_rad_s is None or state.time_s is None:
            return (state.x_m, state.y_m, state.yaw_rad) if has_pose else None
        if self._odometry is None:
            start = (state.x_m or 0.0, state.y_m or 0.0, state.yaw_rad or 0.0)
            self._odometry = Odometry(start)
        if self._last_state_t is not None and state.time_s > self._last_state_t:
            self._travelled_m += state.speed_m_s * (state.time_s - self._last_state_t)
        self._last_state_t = state.time_s
        return self._odometry.update(state.time_s, self._travelled_m, state.yaw_rate_rad_s)

    def _publish_odometry(self, state, pose, stamp) -> None:
        from geometry_msgs.msg import TransformStamped
        from nav_msgs.msg import Odometry as OdometryMsg

        msg = OdometryMsg()
        msg.header.stamp, msg.header.frame_id = stamp, self.names.odom_frame
        msg.child_frame_id = self.names.base_frame
        msg.pose.pose.position.x, msg.pose.pose.position.y = float(pose[0]), float(pose[1])
        msg.pose.pose.orientation = quaternion(pose[2])
        msg.twist.twist.linear.x = float(state.speed_m_s or 0.0)
        msg.twist.twist.angular.z = float(state.yaw_rate_rad_s or 0.0)
        msg.pose.covariance = diagonal(POSE_VARIANCE)
        msg.twist.covariance = diagonal(TWIST_VARIANCE)
        self.odom_pub.publish(msg)
        self.counts.odoms += 1
        if self._has_tf:
            from tf2_msgs.msg import TFMessage

            t = TransformStamped()
            t.header = msg.header
            t.child_frame_id = self.names.base_frame
            t.transform.translation.x, t.transform.translation.y = msg.pose.pose.position.x, msg.pose.pose.position.y
            t.transform.rotation = msg.pose.pose.orientation
            self.tf_pub.publish(TFMessage(transforms=[t]))

    def _publish_imu(self, state, stamp) -> None:
        from sensor_msgs.msg import Imu

        msg = Imu()
        msg.header.stamp, msg.header.frame_id = stamp, self.names.base_frame
        msg.orientation_covariance[0] = -1.0  # no orientation (REP 145)
        msg.linear_acceleration_covariance[0] = -1.0  # no accelerometer
        msg.angular_velocity.z = float(state.yaw_rate_rad_s)
        msg.angular_velocity_covariance = diagonal((1e6, 1e6, 0.0004))
        self.imu_pub.publish(msg)

    def _publish_scan(self, stamp) -> None:
        from sensor_msgs.msg import LaserScan

        ranges = self.vehicle.lidar()
        if ranges is None or len(ranges) < 2:
            return
        fov = math.radians(270)  # right to left, as Vehicle.lidar gives it
        msg = LaserScan()
        msg.header.stamp, msg.header.frame_id = stamp, self.names.laser_frame
        msg.angle_min, msg.angle_max = -fov / 2, fov / 2
        msg.angle_increment = fov / (len(ranges) - 1)
        msg.scan_time = PERIOD_S
        msg.range_min, msg.range_max = 0.06, 10.0  # [m] a UST-10LX's, as the simulator's lidar
        msg.ranges = [float(r) for r in ranges]
        self.scan_pub.publish(msg)
        self.counts.scans += 1
        t = stamp.sec + stamp.nanosec * 1e-9
        if self.pose_pub is not None and self._odom_pose is not None and t >= self._next_localize_s:
            self._next_localize_s = t + LOCALIZE_PERIOD_S
            self._localize(self._odom_pose, msg, stamp)

    def _localize(self, odometry, scan, stamp) -> None:
        """The particle filter on this scan: the car's pose on /pose, map -> odom on /tf."""
        import numpy as np
        from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped

        from roar.ros2.localizing import MapLocalizer

        if self.localizer is None:  # the simulator's odometry starts at the car's start on its track
            self.localizer = MapLocalizer(self.known, odometry if self.simulated else None, self.lidar_mount)
        angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
        t = stamp.sec + stamp.nanosec * 1e-9
        (x, y, yaw), (ox, oy, oyaw) = self.localizer.step(odometry, angles, np.asarray(scan.ranges), t,
                                                          scan.range_min, scan.range_max)
        msg = PoseWithCovarianceStamped()
        msg.header.stamp, msg.header.frame_id = stamp, self.names.map_frame
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        msg.pose.pose.orientation = quaternion(yaw)
        c = self.localizer.covariance  # (x, y, yaw)
        cov = [0.0] * 36
        for i, a in enumerate((0, 1, 5)):
            for j, b in enumerate((0, 1, 5)):
                cov[a * 6 + b] = float(c[i, j])
        msg.pose.covariance = cov
        self.pose_pub.publish(msg)
        if self._has_tf:
            from tf2_msgs.msg import TFMessage

            tf = TransformStamped()
            tf.header.stamp, tf.header.frame_id = stamp, self.names.map_frame
            tf.child_frame_id = self.names.odom_frame
            tf.transform.translation.x, tf.transform.translation.y = ox, oy
            tf.transform.rotation = quaternion(oyaw)
            self.tf_pub.publish(TFMessage(transforms=[tf]))

    def _publish_diagnostics(self, state, stamp) -> None:
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        latched = self.vehicle.latched
        error = self.vehicle.link_error
        values = {
            "url": self.vehicle.url, "connected": self.vehicle.connected, "failsafe latched": latched,
            "messages sent": self.vehicle.messages_sent, "car errors": self.vehicle.errors,
            "commands driven": self.counts.commands, "commands refused": self.counts.refused,
            "last refusal": self.counts.last_refusal, "command timeouts": self.counts.timeouts,
            "battery [V]": None if state is None else state.battery_v,
            "car refusals": dict(self.vehicle.refusals) or None,
        }
        level = DiagnosticStatus.ERROR if error else DiagnosticStatus.WARN if latched else DiagnosticStatus.OK
        status = DiagnosticStatus(level=level, name=f"roar: {self.vehicle.url}", hardware_id=self.vehicle.url,
                                  message=str(error) if error else "failsafe latched" if latched else "ok",
                                  values=[KeyValue(key=k, value="" if v is None else str(v))
                                          for k, v in values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = stamp
        self.diagnostics_pub.publish(msg)

    def _publish_static(self) -> None:
        from geometry_msgs.msg import TransformStamped

        stamp = self.stamp(self.vehicle.state())
        if self._has_tf:
            from tf2_msgs.msg import TFMessage

            transforms = []
            laser = TransformStamped()
            laser.header.stamp, laser.header.frame_id = stamp, self.names.base_frame
            laser.child_frame_id = self.names.laser_frame
            laser.transform.translation.x, laser.transform.translation.y = self.lidar_mount[:2]
            laser.transform.rotation = quaternion(self.lidar_mount[2])
            transforms.append(laser)
            if self.camera is not None and self.camera.preset is not None:
                transforms.append(self.camera.mount(stamp))
            if self.names.odom_frame != self.names.map_frame and self.pose_pub is None:
                # odom starts where the car starts on the map (with --localize the filter says where)
                odom = TransformStamped()
                odom.header.stamp, odom.header.frame_id = stamp, self.names.map_frame
                odom.child_frame_id = self.names.odom_frame
                odom.transform.rotation.w = 1.0
                transforms.append(odom)
            self.tf_static_pub.publish(TFMessage(transforms=transforms))
        if self.known is not None:
            self.map_pub.publish(occupancy_grid(self.known, self.names.map_frame, stamp))

    def close(self) -> None:
        stop_pollers(self.pollers)
        self.vehicle.drive(**self._neutral_command())

    def _neutral_command(self) -> dict[str, float]:
        """Neutral as this car takes it: zero speed for a car that drives by speed (said before any
        command was driven: a bridge stopped before its first /drive put a throttle to the IARRC car)."""
        self.driver.by_speed = self._drives_by_speed()
        return self.driver.neutral()


class Poller:
    """Calls `read` every period_s [s] on a thread of its own until stopped (a late call is not
    made up for: the next comes a period after it). A read that fails (a link's or camera's
    error) is said in one line, once until it changes or reads again, and tried again a period later."""

    def __init__(self, name: str, period_s: float, read, log=print) -> None:
        import threading

        self.name, self.period_s, self.read, self.log = name, period_s, read, log
        self.failure: str | None = None  # the last read's error, None once one reads again
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"roar-ros2-{name}", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        stop_pollers([self])

    def _run(self) -> None:
        next_at = time.monotonic()
        while not self._stop.is_set():
            try:
                self.read()
                if self.failure is not None:
                    self.log(f"{self.name}: reads again")
                self.failure = None
            except RoarError as e:
                retry_s = max(self.period_s, RETRY_S)
                if str(e) != self.failure:
                    self.log(f"{self.name}: {e} (trying again every {retry_s:g} s)")
                self.failure = str(e)
                next_at = time.monotonic() + retry_s - self.period_s
            next_at = max(next_at + self.period_s, time.monotonic())
            self._stop.wait(next_at - time.monotonic())


def stop_pollers(pollers) -> None:
    """Ends every poller's thread after its read in hand (a scan, a render, a stream's next frame):
    all asked at once, then waited for together, STOP_WAIT_S at most in all (one after the other, a
    scan's and a camera's waits added up to Ctrl-C's whole second); one that hangs on a dead link
    is left to end with the process, not waited for (Ctrl-C ends in 1 s)."""
    for poller in pollers:
        poller._stop.set()
    deadline = time.monotonic() + STOP_WAIT_S
    for poller in pollers:
        poller._thread.join(timeout=max(0.0, deadline - time.monotonic()))


class Camera:
    """The car's camera on /camera/image_raw (rgb8), /camera/camera_info and, where it gives depth,
    /camera/depth/image_raw (32FC1, metres), on a Poller's thread (a frame takes a render in the
    simulator or a read of a Junior's stream, longer than the bridge's 20 ms tick)."""

    def __init__(self, bridge: Bridge) -> None:
        from sensor_msgs.msg import CameraInfo, Image

        self.bridge = bridge
        self.preset = bridge.link.camera_preset()
        names, sensors = bridge.names, bridge.qos["sensors"]
        self.image_pub = bridge.node.create_publisher(Image, names.image, sensors)
        self.info_pub = bridge.node.create_publisher(CameraInfo, names.camera_info, sensors)
        self.depth_pub = bridge.node.create_publisher(Image, names.depth, sensors)
        self.frames = 0

    def poller(self, hz: float, log=print) -> Poller:
        """A frame every 1/hz [s]: from the car's stream where it has one (a Junior's MJPEG: every
        frame read as it comes, the newest published each period, never a backlog), else fetched."""
        if self.bridge.vehicle.camera_stream() is None:
            return Poller("camera", 1.0 / hz, self.step, log)
        frames = {"stream": None, "due": 0.0}  # the open stream; [s] monotonic, when the next is published

        def read() -> None:
            if frames["stream"] is None:
                frames["stream"] = iter(self.bridge.vehicle.camera_stream())
            try:
                rgb = next(frames["stream"])
            except StopIteration:
                frames["stream"] = None  # opened again on the next read
                raise CameraError("the camera's stream ended") from None
            except RoarError:
                frames["stream"] = None
                raise
            if time.monotonic() >= frames["due"]:
                frames["due"] = time.monotonic() + 1.0 / hz
                self.publish(rgb, None, self.bridge.stamp(self.bridge.vehicle.state()))

        return Poller("camera", 0.0, read, log)

    def step(self) -> None:
        frame = self.bridge.vehicle.camera(*CAMERA_SIZE)
        if frame is not None:
            self.publish(*frame, self.bridge.stamp(self.bridge.vehicle.state()))

    def publish(self, rgb, depth, stamp) -> None:
        import numpy as np
        from sensor_msgs.msg import CameraInfo, Image

        frame = self.bridge.names.camera_frame
        height, width = rgb.shape[:2]
        image = Image(height=height, width=width, encoding="rgb8", step=width * 3)
        image.header.stamp, image.header.frame_id = stamp, frame
        image.data = np.ascontiguousarray(rgb, dtype=np.uint8).tobytes()
        self.image_pub.publish(image)
        info = CameraInfo(height=height, width=width, distortion_model="plumb_bob")
        info.header = image.header
        info.d = [0.0] * 5
        if self.preset is not None:  # a pinhole without distortion; else K all zero: uncalibrated
            m = self.preset.model(width, height)
            info.k = [m.fx, 0.0, m.cx, 0.0, m.fy, m.cy, 0.0, 0.0, 1.0]
            info.p = [m.fx, 0.0, m.cx, 0.0, 0.0, m.fy, m.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        self.info_pub.publish(info)
        if depth is not None:
            d = Image(height=height, width=width, encoding="32FC1", step=width * 4)
            d.header = image.header
            d.data = np.ascontiguousarray(depth, dtype=np.float32).tobytes()
            self.depth_pub.publish(d)
        self.frames += 1

    def mount(self, stamp):
        """base_link -> the camera's optical frame: its mount, pitched down, axes turned to z ahead,
        x right, y down."""
        from geometry_msgs.msg import TransformStamped

        p = self.preset
        c, s = math.cos(p.pitch_rad), math.sin(p.pitch_rad)
        # the optical axes in the car's frame (x ahead, y left, z up): the rotation's columns
        x_axis, y_axis, z_axis = (0.0, -1.0, 0.0), (-s, 0.0, -c), (c, 0.0, -s)
        t = TransformStamped()
        t.header.stamp, t.header.frame_id = stamp, self.bridge.names.base_frame
        t.child_frame_id = self.bridge.names.camera_frame
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = p.x_m, p.y_m, p.z_m
        t.transform.rotation = rotation_quaternion(x_axis, y_axis, z_axis)
        return t


def rotation_quaternion(x_axis, y_axis, z_axis):
    """The quaternion of the rotation whose matrix has these columns."""
    from geometry_msgs.msg import Quaternion

    (m00, m10, m20), (m01, m11, m21), (m02, m12, m22) = x_axis, y_axis, z_axis
    w = math.sqrt(max(0.0, 1 + m00 + m11 + m22)) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + m00 - m11 - m22)) / 2, m21 - m12)
    y = math.copysign(math.sqrt(max(0.0, 1 - m00 + m11 - m22)) / 2, m02 - m20)
    z = math.copysign(math.sqrt(max(0.0, 1 - m00 - m11 + m22)) / 2, m10 - m01)
    return Quaternion(x=x, y=y, z=z, w=w)


def diagonal(values) -> list[float]:
    n = len(values)
    out = [0.0] * n * n
    for i, v in enumerate(values):
        out[i * n + i] = float(v)
    return out


def occupancy_grid(grid, frame: str, stamp):
    """A map (roar.tracks.OccupancyMap) as a nav_msgs/OccupancyGrid (100 occupied, 0 free, -1
    unknown; row 0 at the origin, the bottom of roar's map image)."""
    import numpy as np
    from nav_msgs.msg import OccupancyGrid

    cells = np.full(grid.free.shape, -1, dtype=np.int8)
    cells[grid.free] = 0
    cells[grid.occupied] = 100
    msg = OccupancyGrid()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.info.map_load_time = stamp
    msg.info.resolution = float(grid.resolution_m)
    msg.info.height, msg.info.width = cells.shape
    msg.info.origin.position.x, msg.info.origin.position.y = float(grid.origin[0]), float(grid.origin[1])
    msg.info.origin.orientation = quaternion(grid.origin[2])
    msg.data = cells[::-1].ravel().tolist()
    return msg
