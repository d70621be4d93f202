"""The simulator's side of a recording (roar.recorder): besides what a host sees of the car (every
control message as it reached the firmware, every line it sent, its state), what only the
simulator knows, each control period: the firmware's outputs (pulses, where the command came
from, the brake phase, latched), contacts with walls, cones and people, and -- where those pieces
run -- the particle filter's pose and particles. Times are the simulator's.

    log = SimLog(robot, "run.mcap", {"driver": "racer"})  # beside the car, track and command line
    ... each control period: log.step()   (and log.localization(filter) where one runs)
    log.close()
"""

from __future__ import annotations

import json
import sys

import numpy as np

from roar.recorder import Recorder
from roar.tracks.tunnel import CONE_HEIGHT_M, CONE_RADIUS_M, MARKER_SIZE_M

FIRMWARE = "/sim/firmware"
CONTACTS = "/sim/contacts"
TRUE_POSE = "/sim/true_pose"
FILTER_POSE = "/localization/pose"
PARTICLES = "/localization/particles"
STEPS = "/localization/steps"
LANES = "/perception/lanes"
PATH = "/planning/path"
TREE = "/planning/tree"
CONES = "/perception/cones"
MARKERS = "/perception/markers"
SCENE = "/perception/scene"
LOCAL_GRID = "/localization/local_grid"
GRID_EVERY_S = 0.5  # [s] between recorded trees and local grids
DRIVER_STATE = "/autopilot/state"
RACE = "/race"  # a race against other cars: /race/car_N/... each opponent, /race/standings, /race/contacts
TRACKED = "/racing/tracked"  # the cars the ego's lidar tracks (x, y, heading of travel)
PARTICLES_EVERY_S = 0.2  # [s] between recorded particle clouds (a cloud is ~40 bytes a particle)
MAX_PARTICLES = 300  # recorded of a cloud, evenly picked


class SimLog:
    def __init__(self, robot, path, metadata: dict | None = None, serve_port: int | None = None,
                 drain_lines: bool = True) -> None:
        """path: the MCAP file (None: none); serve_port: also serve the channels live (Foxglove
        WebSocket on 127.0.0.1); drain_lines: step() reads the robot's lines (set False where a
        link reads them: they are recorded as it does)."""
        self.robot, self.drain_lines = robot, drain_lines
        track = getattr(robot, "track", None)
        info = {"car": f"sim://?robot={type(robot).__module__.rsplit('.', 1)[-1]}",
                "track": getattr(track, "name", "") if track is not None else "open floor",
                "command": " ".join(sys.argv)}
        info.update(metadata or {})
        self.rec = Recorder(path, info, simulated=True, serve_port=serve_port)
        write, read = robot.write, robot.read

        def logged_write(data: bytes) -> None:  # the bytes as they reach the firmware
            write(data)
            self.rec.control(data, self.t_ns())

        def logged_read() -> list[str]:
            lines = read()
            t = self.t_ns()
            for line in lines:
                self.rec.line(line, t)
            return lines

        robot.write, robot.read = logged_write, logged_read  # this robot's only: the class is untouched
        if hasattr(robot, "host"):  # the IARRC car: its drive() writes through host()
            robot.host = logged_write
        elif "http" in type(robot).links:
            drive = robot.drive  # the Junior: its drive() is an HTTP request of duties, no control message

            def logged_drive(throttle: float, steering: float) -> None:
                drive(throttle, steering)
                self.rec.command(throttle, steering, self.t_ns(), "http")

            robot.drive = logged_drive
        self._next_cloud_s = 0.0
        self._set_up = False
        self._paths, self._objects, self._next_grid_s = 0, {}, 0.0

    def t_ns(self) -> int:
        return int(round(self.robot.time_s * 1e9))

    def step(self) -> None:
        """One control period: the car's state and pose, the firmware's outputs, contacts, and
        the lines it sent (read here: nobody else reads a simulated race's lines)."""
        robot, t = self.robot, self.t_ns()
        if self.drain_lines:
            robot.read()
        self.rec.state(robot.vehicle_state(), t)
        self.rec.fields(FIRMWARE, firmware(robot), t, "roar_sim.Firmware")
        self.rec.fields(CONTACTS, contacts(robot), t, "roar_sim.Contacts")

    def other(self, name: str, robot) -> None:
        """Another robot in the same world now (a race's opponent): its true pose, its state,
        its firmware's outputs and its contacts on /race/NAME/..."""
        t, s = self.t_ns(), robot.state()
        self.rec.pose(f"{RACE}/{name}/pose", (s.x, s.y, s.yaw), t)
        self.rec.fields(f"{RACE}/{name}/state", {"speed_m_s": s.speed, "yaw_rate_rad_s": s.yaw_rate}, t,
                        "roar_sim.CarState")
        self.rec.fields(f"{RACE}/{name}/firmware", firmware(robot), t, "roar_sim.Firmware")
        self.rec.fields(f"{RACE}/{name}/contacts", contacts(robot), t, "roar_sim.Contacts")

    def fields(self, topic: str, fields: dict, title: str) -> None:
        """A record of named values now (JSON), under a schema title."""
        self.rec.fields(topic, fields, self.t_ns(), title)

    def poses(self, topic: str, poses) -> None:
        """Poses (x, y, yaw) [m, m, rad] seen now: the cars a driver tracks, say."""
        self.rec.poses(topic, np.asarray(poses, float).reshape(-1, 3), self.t_ns())

    def scan(self, scan) -> None:
        """A lidar scan (roar.localization.scan.LaserScan) the driver was given now."""
        self.rec.scan(scan.ranges, float(scan.angles[0]), float(scan.angles[-1]), int(round(scan.time_s * 1e9)))

    def localization(self, car) -> None:
        """A LocalizedCar's period: the filter's pose (with the true pose beside it), its particles
        every PARTICLES_EVERY_S (MAX_PARTICLES of them), the scan it weighed, and on STEPS exactly
        what it was given (odometry, the scan's time) and its pose, so that roar.replay.localize
        runs the same filter again, bit for bit; its set-up in the file's "localization" record."""
        t = self.t_ns()
        f = car.filter
        if not self._set_up:
            self.rec.note("localization", {k: json.dumps(v) for k, v in car.setup.items()})
            self._set_up = True
        scan = car.scan if car.scanned else None
        if scan is not None:
            self.scan(scan)
        step = {"odometry": list(car.odo), "pose": list(f.pose), "scan": None}
        if scan is not None:  # which /lidar message, and what its ranges mean
            step["scan"] = {"time_s": scan.time_s, "log_ns": int(round(scan.time_s * 1e9)),
                            "range_min_m": scan.range_min_m, "range_max_m": scan.range_max_m}
        self.rec.fields(STEPS, step, t, "roar_sim.FilterStep")
        s = self.robot.state()
        self.rec.pose(FILTER_POSE, f.pose, t)
        self.rec.pose(TRUE_POSE, (s.x, s.y, s.yaw), t)
        if self.robot.time_s + 1e-9 >= self._next_cloud_s and len(f.poses):
            pick = np.linspace(0, len(f.poses) - 1, min(MAX_PARTICLES, len(f.poses))).astype(int)
            self.rec.poses(PARTICLES, np.asarray(f.poses)[pick], t)
            self._next_cloud_s = self.robot.time_s + PARTICLES_EVERY_S

    def link_bytes(self, data: bytes) -> None:
        """Bytes that reached the robot on a link the wrappers do not see (the Junior's HTTP
        port, served), as they came."""
        self.rec.control(data, self.t_ns())

    def pose(self, topic: str, pose) -> None:
        """Another pose (x, y, yaw) [m, m, rad] now: another car's, say."""
        self.rec.pose(topic, pose, self.t_ns())

    def image(self, rgb, lossless: bool = False) -> None:
        """A frame the driver's camera took now (lossless: as PNG, for a replay of the detector)."""
        self.rec.image(rgb, self.t_ns(), lossless=lossless)

    def lanes(self, lanes) -> None:
        """What the lane detector made of the frame (roar.vision.lanes.Lanes)."""
        centre = lanes.centre is not None
        self.rec.fields(LANES, {"lines": lanes.source, "offset_m": lanes.offset_m if centre else None,
                                "heading_rad": lanes.heading_rad if centre else None}, self.t_ns(), "roar.Lanes")

    def driver_state(self, state: str) -> None:
        """The driver's state this period (the lane driver's following, stopped, ...; the drag
        racer's)."""
        self.rec.fields(DRIVER_STATE, {"state": state}, self.t_ns(), "roar.DriverState")

    def planning(self, driver, local=None) -> None:
        """The challenge's driver (roar.planning.course_driver.CourseDriver) this period: each new
        path as it reached the follower, the last plan's tree every GRID_EVERY_S, the confirmed
        cones and markers when they change, the local grid every GRID_EVERY_S."""
        t = self.t_ns()
        for poses in driver.paths[self._paths:]:
            self.rec.poses(PATH, poses[:: max(1, len(poses) // 200)], t)
        self._paths = len(driver.paths)
        changed = False
        for kind, topic in (("cone", CONES), ("marker", MARKERS)):
            found = driver.objects(kind)
            if found != self._objects.get(kind):
                self._objects[kind], changed = found, True
                self.rec.poses(topic, [(x, y, 0.0) for x, y in found] or np.zeros((0, 3)), t)
        if changed:  # the same for Foxglove's 3D panel: cones and floor markers drawn as what they are
            self.rec.objects(SCENE, self._objects["cone"], self._objects["marker"], t, CONE_RADIUS_M, CONE_HEIGHT_M,
                             MARKER_SIZE_M)
        if self.robot.time_s + 1e-9 < self._next_grid_s:
            return
        self._next_grid_s = self.robot.time_s + GRID_EVERY_S
        tree = driver.planner.tree
        if tree is not None and len(tree) > 1:
            nodes = tree.poses()
            self.rec.poses(TREE, nodes[:: max(1, len(nodes) // 500)], t)
        if local is not None and local.time_s is not None:
            r = local.resolution_m
            occupied = np.where(local.occupied(), 100, np.where(local.free(), 0, 50))
            self.rec.grid(LOCAL_GRID, occupied, (local.origin[0] * r, local.origin[1] * r), r, t)

    def close(self) -> None:
        self.rec.close()


def firmware(robot) -> dict:
    """What a simulated robot's firmware outputs now: its info, the pulses and where the command
    came from, the brake phase, latched, and the simulated ESC's mode (where there are such)."""
    fields = {**robot.info(), "braking": robot.braking()}
    outputs = getattr(robot, "outputs", None)
    if outputs is not None:
        fields.update(throttle_us=outputs.throttle_us, steering_us=outputs.steering_us,
                      source=outputs.source.name.lower(), brake_phase=outputs.brake_phase.name.lower(),
                      latched=outputs.latched)
    esc = getattr(robot, "esc", None)  # the simulated ESC behind the firmware's pulse
    if esc is not None:
        fields["esc_mode"] = esc.mode.name.lower()
    return fields


def contacts(robot) -> dict:
    """Whether the robot touches a wall, a cone, a person now."""
    world = robot.plant.world
    return {"wall": robot.touching_wall(), "cone": robot.touching(world.cones), "person": robot.touching(world.people)}
