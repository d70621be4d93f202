"""The physical car: PyBullet's 1/10-scale racecar (pybullet_data/racecar/racecar.urdf) on a
plane with the track's walls. Rear-wheel drive through a motor with a speed and torque limit,
Ackermann steering on the two hinges, and the sensors a real car would have.
"""

from __future__ import annotations

import ctypes
import math
import os
from dataclasses import dataclass

import numpy as np
from roar_sim.quiet_pybullet import pb
import pybullet_data

from roar_sim.floor import add_floor
from roar_sim.track import Track

WHEELBASE_M = 0.325  # [m] hinge axis to rear axle (racecar.urdf)
TRACK_WIDTH_M = 0.2  # [m] between the steering hinges (racecar.urdf)
WHEEL_RADIUS_M = 0.05  # [m]
REAR_WHEELS = (2, 3)  # joint indices in racecar.urdf
FRONT_WHEELS = (5, 7)
LEFT_HINGE, RIGHT_HINGE = 4, 6
LIDAR_LINK = 8  # hokuyo_joint
CAMERA_LINK = 9  # zed_camera_joint
MOTOR_MAX_SPEED_RAD_S = 60.0  # [rad/s] wheel speed at full throttle (3 m/s)
MOTOR_MAX_TORQUE_NM = 1.5  # [N m] per rear wheel
BRAKE_MAX_TORQUE_NM = 2.0  # [N m] per rear wheel at full brake
ROLLING_DRAG_NM = 0.02  # [N m] coasting resistance per wheel
ENCODER_COUNTS_PER_REV = 1024  # [counts]
WALL_HEIGHT_M, WALL_THICKNESS_M = 0.3, 0.05  # [m] higher than the lidar (0.17 m)
GROUND_HALF_M = 25.0  # [m] asphalt shown beyond the track (or around the origin without one)
SOLVER_ITERATIONS = 10  # contact solver iterations per step (PyBullet default 50): a car on a plane settles in few


@dataclass(frozen=True)
class CarState:
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad] anticlockwise from +x
    speed: float  # [m/s] along the car's heading, negative when reversing
    yaw_rate: float  # [rad/s] (IMU gyro z)
    encoder_counts: int  # rear-left wheel encoder, signed


def _add_box(vertices: list, indices: list, a: np.ndarray, b: np.ndarray) -> None:
    """Append a wall box from a to b (WALL_THICKNESS_M thick, WALL_HEIGHT_M high) as 12 triangles."""
    direction = (b - a) / max(1e-9, float(np.linalg.norm(b - a)))
    a, b = a - direction * WALL_THICKNESS_M / 2, b + direction * WALL_THICKNESS_M / 2
    normal = np.array([-direction[1], direction[0]]) * WALL_THICKNESS_M / 2
    base = len(vertices)
    for z in (0.0, WALL_HEIGHT_M):
        for p in (a - normal, b - normal, b + normal, a + normal):
            vertices.append([float(p[0]), float(p[1]), z])
    faces = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4),
             (1, 2, 6), (1, 6, 5), (2, 3, 7), (2, 7, 6), (3, 0, 4), (3, 4, 7)]
    for f in faces:
        indices.extend(base + k for k in f)


def ackermann_angles(steer_rad: float) -> tuple[float, float]:
    """(left, right) hinge angles for a virtual centre angle: the inner wheel turns more, so both
    wheel axes meet on the rear axle line."""
    if abs(steer_rad) < 1e-6:
        return 0.0, 0.0
    radius = WHEELBASE_M / math.tan(steer_rad)  # signed: positive = turning left
    left = math.atan(WHEELBASE_M / (radius - TRACK_WIDTH_M / 2))
    right = math.atan(WHEELBASE_M / (radius + TRACK_WIDTH_M / 2))
    return left, right


class SimError(RuntimeError):
    """The simulator cannot start as asked; str() is one line."""


def display_problem() -> str | None:
    """Why PyBullet's window cannot open here (one line), or None. PyBullet itself would end the
    whole Python process without a word."""
    display = os.environ.get("DISPLAY")
    if not display:
        return "--gui needs a display: DISPLAY is not set (run without --gui, or under xvfb-run)"
    try:
        x11 = ctypes.CDLL("libX11.so.6")
    except OSError:
        return "--gui needs X11, and libX11 is not installed"
    x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    connection = x11.XOpenDisplay(None)
    if not connection:
        return f"--gui needs a display: cannot open DISPLAY={display}"
    x11.XCloseDisplay(connection)
    return None


class Plant:
    """One PyBullet world (DIRECT, or GUI when gui=True) with one car and a track."""

    def __init__(self, track: Track | None, dt_s: float = 0.005, gui: bool = False) -> None:
        self.dt_s = dt_s
        problem = display_problem() if gui else None
        if problem:
            raise SimError(problem)
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        c = self.client
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setTimeStep(dt_s, physicsClientId=c)
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=c)
        self.ground = self._add_ground(track)
        x, y, yaw = track.start_pose if track else (0.0, 0.0, 0.0)
        self.car = pb.loadURDF("racecar/racecar.urdf", [x, y, 0.05], pb.getQuaternionFromEuler([0, 0, yaw]),
                               physicsClientId=c)
        for w in REAR_WHEELS + FRONT_WHEELS:
            pb.setJointMotorControl2(self.car, w, pb.VELOCITY_CONTROL, targetVelocity=0, force=0, physicsClientId=c)
        self.walls = self._build_walls(track) if track else []
        self.floor = add_floor(track, c) if track else None
        self.time_s = 0.0
        if gui:
            self._frame_gui(track)

    def _add_ground(self, track: Track | None) -> int:
        """An endless flat ground (a collision plane, so no track can reach its edge) shown as dark
        asphalt (plain, so walls stand out for the camera) under the track and a margin around it."""
        c = self.client
        centre, half = np.zeros(2), GROUND_HALF_M
        if track is not None:
            lo, hi = track.centerline.min(axis=0), track.centerline.max(axis=0)
            centre, half = (lo + hi) / 2, float(max(hi - lo)) / 2 + track.width_m + GROUND_HALF_M
        shape = pb.createCollisionShape(pb.GEOM_PLANE, planeNormal=[0, 0, 1], physicsClientId=c)
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half, half, 0.0005], rgbaColor=[0.25, 0.25, 0.27, 1],
                                      visualFramePosition=[0, 0, -0.0005], physicsClientId=c)
        body = pb.createMultiBody(0, shape, visual, [float(centre[0]), float(centre[1]), 0], physicsClientId=c)
        pb.changeDynamics(body, -1, lateralFriction=1.0, physicsClientId=c)  # as PyBullet's plane.urdf
        return body

    def _frame_gui(self, track: Track | None) -> None:
        """Hide the debug panels and look down on the whole track."""
        c = self.client
        pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=c)
        centre, size = (0.0, 0.0), 2.0
        if track is not None:
            lo, hi = track.centerline.min(axis=0), track.centerline.max(axis=0)
            centre, size = tuple((lo + hi) / 2), float(max(hi - lo)) + track.width_m
        pb.resetDebugVisualizerCamera(size, 0, -60, [centre[0], centre[1], 0], physicsClientId=c)

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)

    def _build_walls(self, track: Track) -> list[int]:
        """One static triangle mesh of wall boxes along both edges (one body keeps the physics
        fast). A segment that would lie inside another part of the track (the crossing of a
        figure-eight) is left out."""
        cl = track.centerline
        n = len(cl)
        vertices: list[list[float]] = []
        indices: list[int] = []
        for edge in track.edges():
            for i in range(n):
                a, b = edge[i], edge[(i + 1) % n]
                mid = (a + b) / 2
                d = np.linalg.norm(cl - mid, axis=1)
                far = np.abs((np.arange(n) - i + n // 2) % n - n // 2) > 10
                if np.any(d[far] < track.width_m / 2 - 0.02):
                    continue
                _add_box(vertices, indices, a, b)
        c = self.client
        shape = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, indices=indices,
                                        flags=pb.GEOM_FORCE_CONCAVE_TRIMESH, physicsClientId=c)
        visual = pb.createVisualShape(pb.GEOM_MESH, vertices=vertices, indices=indices,
                                      rgbaColor=[0.8, 0.8, 0.8, 1], physicsClientId=c)
        return [pb.createMultiBody(0, shape, visual, [0, 0, 0], physicsClientId=c)]

    def camera(self, width: int = 160, height: int = 120, fov_deg: float = 70.0,
               far_m: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
        """(RGB uint8 HxWx3, depth float32 HxW in metres) from the ZED camera link, looking ahead
        and slightly down."""
        c, near = self.client, 0.05  # [m] the car's own body lies behind the camera
        pos, orn = pb.getLinkState(self.car, CAMERA_LINK, physicsClientId=c)[:2]
        yaw = pb.getEulerFromQuaternion(orn)[2]
        forward = np.array([math.cos(yaw), math.sin(yaw), -0.25])
        view = pb.computeViewMatrix(pos, (np.array(pos) + forward).tolist(), [0, 0, 1])
        proj = pb.computeProjectionMatrixFOV(fov_deg, width / height, near, far_m)
        _, _, rgba, depth_buf, _ = pb.getCameraImage(width, height, view, proj, renderer=pb.ER_TINY_RENDERER,
                                                     physicsClientId=c)
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
        d = np.asarray(depth_buf, dtype=np.float32).reshape(height, width)
        depth = far_m * near / (far_m - (far_m - near) * d)
        return rgb, depth

    def apply(self, drive: float, brake: float, steer_rad: float) -> None:
        """drive -1..1 of the motor limit, brake 0..1, steer_rad the virtual centre angle."""
        c = self.client
        for w in REAR_WHEELS:
            if brake > 0:
                pb.setJointMotorControl2(self.car, w, pb.VELOCITY_CONTROL, targetVelocity=0,
                                         force=BRAKE_MAX_TORQUE_NM * brake, physicsClientId=c)
            elif drive != 0:
                # The motor drives the wheel towards its speed for this throttle but never holds it
                # back: a wheel already turning faster in that direction coasts (no drag brake).
                target = drive * MOTOR_MAX_SPEED_RAD_S
                spin = pb.getJointState(self.car, w, physicsClientId=c)[1]
                coasting = spin * target > 0 and abs(spin) > abs(target)
                torque = ROLLING_DRAG_NM if coasting else MOTOR_MAX_TORQUE_NM * abs(drive) + ROLLING_DRAG_NM
                pb.setJointMotorControl2(self.car, w, pb.VELOCITY_CONTROL, targetVelocity=target, force=torque,
                                         physicsClientId=c)
            else:
                pb.setJointMotorControl2(self.car, w, pb.VELOCITY_CONTROL, targetVelocity=0, force=ROLLING_DRAG_NM,
                                         physicsClientId=c)
        left, right = ackermann_angles(steer_rad)
        for hinge, angle in ((LEFT_HINGE, left), (RIGHT_HINGE, right)):
            pb.setJointMotorControl2(self.car, hinge, pb.POSITION_CONTROL, targetPosition=angle, force=10,
                                     physicsClientId=c)

    def step(self) -> None:
        pb.stepSimulation(physicsClientId=self.client)
        self.time_s += self.dt_s

    def state(self) -> CarState:
        c = self.client
        (x, y, _), orn = pb.getBasePositionAndOrientation(self.car, physicsClientId=c)
        (vx, vy, _), (_, _, wz) = pb.getBaseVelocity(self.car, physicsClientId=c)
        yaw = pb.getEulerFromQuaternion(orn)[2]
        speed = vx * math.cos(yaw) + vy * math.sin(yaw)
        wheel_angle = pb.getJointState(self.car, REAR_WHEELS[0], physicsClientId=c)[0]
        counts = int(wheel_angle / (2 * math.pi) * ENCODER_COUNTS_PER_REV)
        return CarState(x, y, yaw, speed, wz, counts)

    def wall_contacts(self) -> int:
        """How many wall bodies the car touches right now."""
        touching = {pt[2] for pt in pb.getContactPoints(bodyA=self.car, physicsClientId=self.client)}
        return len(touching & set(self.walls))

    def lidar(self, beams: int = 1080, fov_rad: float = math.radians(270), range_m: float = 10.0) -> np.ndarray:
        """2D scan from the Hokuyo link: distances [m] from right to left; range_m where nothing is hit."""
        c = self.client
        pos, orn = pb.getLinkState(self.car, LIDAR_LINK, physicsClientId=c)[:2]
        yaw = pb.getEulerFromQuaternion(orn)[2]
        angles = yaw + np.linspace(-fov_rad / 2, fov_rad / 2, beams)
        start = np.tile(pos, (beams, 1))
        end = start + range_m * np.stack([np.cos(angles), np.sin(angles), np.zeros(beams)], axis=1)
        hits = pb.rayTestBatch(start.tolist(), end.tolist(), physicsClientId=c)
        return np.array([h[2] * range_m if h[0] >= 0 else range_m for h in hits])
