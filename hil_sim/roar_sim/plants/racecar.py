"""The physical car: PyBullet's 1/10-scale racecar (pybullet_data/racecar/racecar.urdf) in the
world of roar_sim.world.scene. Rear-wheel drive through a motor with a speed and torque limit,
Ackermann steering on the two hinges, and the sensors a real car would have: a wheel encoder, a
gyro, a lidar on the Hokuyo link and the camera on the ZED link (roar.vision's preset of it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.vision.geometry import SIMULATED_CAR_CAMERA as CAMERA
from roar_sim.plants import car_profile
from roar_sim.plants.car_profile import URDF_MASS_KG, URDF_WHEELBASE_M, CarProfile
from roar_sim.sensors import lidar
from roar_sim.world.bullet import pb
from roar_sim.world.scene import World
from roar.tracks.track import Track

TRACK_WIDTH_M = 0.2  # [m] between the steering hinges (racecar.urdf)
WHEEL_RADIUS_M = 0.05  # [m]
REAR_WHEELS = (2, 3)  # joint indices in racecar.urdf
FRONT_WHEELS = (5, 7)
LEFT_HINGE, RIGHT_HINGE = 4, 6
LIDAR_LINK = 8  # hokuyo_joint
CAMERA_LINK = 9  # zed_camera_joint
FOOTPRINT_M = (-0.052, 0.4065, 0.147)  # [m] rear and front from the base along the car, half width (racecar.urdf's box)
LANE_CAMERA = (320, 240)  # [px] the frames the camera drivers see (lanes, the drag race, the leader's marker)


HINGE_TORQUE_NM = 10.0  # [N m] the most the steering servo turns each front hinge with
ENCODER_COUNTS_PER_REV = 1024  # [counts]
JOINT_SPEED_CAP_RAD_S = 100.0  # [rad/s] PyBullet's cap on every joint's speed unless told otherwise


@dataclass(frozen=True)
class CarState:
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad] anticlockwise from +x
    speed: float  # [m/s] along the car's heading, negative when reversing
    yaw_rate: float  # [rad/s] (IMU gyro z)
    encoder_counts: int  # rear-left wheel encoder, signed


def ackermann_angles(steer_rad: float, scale: float = 1.0) -> tuple[float, float]:
    """(left, right) hinge angles for a virtual centre angle: the inner wheel turns more, so both
    wheel axes meet on the rear axle line (of the car drawn `scale` times racecar.urdf's size)."""
    if abs(steer_rad) < 1e-6:
        return 0.0, 0.0
    wheelbase, track = URDF_WHEELBASE_M * scale, TRACK_WIDTH_M * scale
    radius = wheelbase / math.tan(steer_rad)  # signed: positive = turning left
    left = math.atan(wheelbase / (radius - track / 2))
    right = math.atan(wheelbase / (radius + track / 2))
    return left, right


class Racecar:
    """The racecar in a World (DIRECT, or GUI when gui=True) with an optional track; or, given
    `world`, one more car in that world (which then steps it: see step() and tick()), at `pose`.
    profile: the car's own numbers (roar_sim.plants.car_profile; default the ROAR car's): its size,
    mass, motor and tyres."""

    def __init__(self, track: Track | None, dt_s: float = 0.005, gui: bool = False,
                 world: World | None = None,
                 pose: tuple[float, float, float] | None = None, profile: CarProfile | None = None) -> None:
        self.dt_s = dt_s
        self.profile = profile = profile or car_profile.load()
        self.motor = motor = profile.motor
        self._owns_world = world is None
        self.world = World(track, dt_s, gui) if world is None else world
        self.client = c = self.world.client
        x, y, yaw = pose if pose is not None else self.world.start_pose()
        self.car = pb.loadURDF("racecar/racecar.urdf", [x, y, 0.05 * profile.scale],
                               pb.getQuaternionFromEuler([0, 0, yaw]), physicsClientId=c,
                               **({"globalScaling": profile.scale} if profile.scale != 1.0 else {}))
        if profile.mass_kg != URDF_MASS_KG:
            for link in range(-1, pb.getNumJoints(self.car, physicsClientId=c)):
                mass, _, inertia = pb.getDynamicsInfo(self.car, link, physicsClientId=c)[:3]
                k = profile.mass_kg / URDF_MASS_KG  # every link lighter (or heavier) alike, inertia with it
                pb.changeDynamics(self.car, link, mass=mass * k, localInertiaDiagonal=[v * k for v in inertia],
                                  physicsClientId=c)
        self._motors: dict[int, tuple] = {}  # joint -> its motor's settings, as last given to PyBullet
        for w in REAR_WHEELS + FRONT_WHEELS:
            self._motor(w, pb.VELOCITY_CONTROL, 0.0, 0.0)
            pb.changeDynamics(self.car, w, lateralFriction=motor.tyre_friction, physicsClientId=c)
            if motor.max_speed_rad_s > JOINT_SPEED_CAP_RAD_S:
                # a motor faster than PyBullet's cap: its wheels may spin beyond it (in a call of its own: given
                # with lateralFriction, PyBullet 3.2.7 drops that)
                pb.changeDynamics(self.car, w, maxJointVelocity=2 * motor.max_speed_rad_s, physicsClientId=c)
        self.walls = self.world.walls
        self.time_s = 0.0
        self.props: list = []  # things in the world that change with time: update(time_s) each step

    def close(self) -> None:
        if self._owns_world:
            self.world.close()

    def camera(self, width: int = 160, height: int = 120, far_m: float = 10.0,
               shake_rad: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
        """(RGB uint8 HxWx3, depth float32 HxW in metres) from the ZED camera link, looking ahead
        and slightly down; shake_rad turns it by (yaw, pitch) more, as a shaking mount would."""
        pos, orn = pb.getLinkState(self.car, CAMERA_LINK, physicsClientId=self.client)[:2]
        yaw = pb.getEulerFromQuaternion(orn)[2] + shake_rad[0]
        return self.world.render(pos, yaw, CAMERA.pitch_rad + shake_rad[1], width, height, CAMERA.fov_deg, far_m,
                                 body=self.car)

    def apply(self, drive: float, brake: float, steer_rad: float) -> None:
        """drive -1..1 of the motor limit, brake 0..1, steer_rad the virtual centre angle."""
        brake_nm, drag_nm = self.profile.brake_torque_nm, self.profile.rolling_drag_nm
        spins = ([state[1] for state in pb.getJointStates(self.car, REAR_WHEELS, physicsClientId=self.client)]
                 if brake <= 0 and drive != 0 else [0.0] * len(REAR_WHEELS))
        for w, spin in zip(REAR_WHEELS, spins):
            if brake > 0:
                self._motor(w, pb.VELOCITY_CONTROL, 0.0, brake_nm * brake)
            elif drive != 0:
                # The motor drives the wheel towards its speed for this throttle but never holds it
                # back: a wheel already turning faster in that direction coasts (no drag brake).
                target = drive * self.motor.max_speed_rad_s
                coasting = spin * target > 0 and abs(spin) > abs(target)
                torque = drag_nm if coasting else self.motor.max_torque_nm * abs(drive) + drag_nm
                self._motor(w, pb.VELOCITY_CONTROL, target, torque)
            else:
                self._motor(w, pb.VELOCITY_CONTROL, 0.0, drag_nm)
        left, right = ackermann_angles(steer_rad, self.profile.scale)
        for hinge, angle in ((LEFT_HINGE, left), (RIGHT_HINGE, right)):
            self._motor(hinge, pb.POSITION_CONTROL, angle, HINGE_TORQUE_NM)

    def _motor(self, joint: int, mode: int, target: float, force: float) -> None:
        """A joint's motor set to a target (a velocity, or a position) and its most force. PyBullet
        keeps a motor's settings from step to step, so unchanged ones are not given again (a third
        of the car's calls into PyBullet per physics step, the same physics)."""
        settings = (mode, target, force)
        if self._motors.get(joint) != settings:
            self._motors[joint] = settings
            key = "targetPosition" if mode == pb.POSITION_CONTROL else "targetVelocity"
            pb.setJointMotorControl2(self.car, joint, mode, force=force, physicsClientId=self.client, **{key: target})

    def step(self) -> None:
        self.world.step()
        self.tick()

    def tick(self) -> None:
        """Time moves on after a physics step of the world (in a shared world, whoever steps it)."""
        self.time_s += self.dt_s
        for prop in self.props:
            prop.update(self.time_s)

    def state(self) -> CarState:
        counts = int(self.wheel_angle() / (2 * math.pi) * ENCODER_COUNTS_PER_REV)
        return CarState(*self.world.planar_motion(self.car), counts)

    def wheel_angle(self) -> float:
        """[rad] the rear-left wheel's angle since the start (where the encoder sits)."""
        return pb.getJointState(self.car, REAR_WHEELS[0], physicsClientId=self.client)[0]

    def front_axle(self) -> tuple[float, float, float]:
        """(x [m], y [m], heading [rad]): the middle of the front wheels and the way they roll (the
        car's yaw and the mean of the steering hinges' angles); wheel odometry's encoders."""
        c = self.client
        xs, ys = zip(*(pb.getLinkState(self.car, w, physicsClientId=c)[4][:2] for w in FRONT_WHEELS))
        steer = sum(pb.getJointState(self.car, h, physicsClientId=c)[0] for h in (LEFT_HINGE, RIGHT_HINGE)) / 2
        yaw = pb.getEulerFromQuaternion(pb.getBasePositionAndOrientation(self.car, physicsClientId=c)[1])[2]
        return sum(xs) / 2, sum(ys) / 2, yaw + steer

    def wall_contacts(self, of: list[int] | None = None) -> int:
        """How many wall bodies (or bodies of `of`) the car touches right now."""
        return self.world.contacts(self.car, of)

    def lidar_mount(self) -> tuple[float, float, float]:
        """(x ahead [m], y left [m], yaw [rad]) of the lidar in the car's frame (its base's pose)."""
        c = self.client
        pos, orn = pb.getLinkState(self.car, LIDAR_LINK, physicsClientId=c)[:2]
        base, base_orn = pb.getBasePositionAndOrientation(self.car, physicsClientId=c)
        yaw = pb.getEulerFromQuaternion(base_orn)[2]
        dx, dy = pos[0] - base[0], pos[1] - base[1]
        return (math.cos(yaw) * dx + math.sin(yaw) * dy, -math.sin(yaw) * dx + math.cos(yaw) * dy,
                math.remainder(pb.getEulerFromQuaternion(orn)[2] - yaw, math.tau))

    def lidar_pose(self) -> tuple[float, float, float]:
        """(x [m], y [m], yaw [rad]) of the Hokuyo link in the world: where a scan starts."""
        pos, orn = pb.getLinkState(self.car, LIDAR_LINK, physicsClientId=self.client)[:2]
        return pos[0], pos[1], pb.getEulerFromQuaternion(orn)[2]

    def lidar(self, beams: int = lidar.BEAMS, fov_rad: float = lidar.FOV_RAD, range_m: float = lidar.RANGE_M,
              boxes=(), turn_rad: float = 0.0) -> np.ndarray:
        """A scan from the Hokuyo link: distances [m] from right to left; range_m where nothing is
        hit. boxes: other cars' footprints (footprint()) the beams meet. turn_rad: the lidar's
        mount turned by this much (left +), as a badly mounted one is."""
        pos, orn = pb.getLinkState(self.car, LIDAR_LINK, physicsClientId=self.client)[:2]
        yaw = pb.getEulerFromQuaternion(orn)[2] + turn_rad
        return lidar.scan(self.world, pos, yaw, beams, fov_rad, range_m, boxes, self.car)

    def footprint(self) -> tuple[float, float, float, float, float]:
        """(centre x [m], centre y [m], yaw [rad], half length [m], half width [m]) of the car's body
        as another car's lidar meets it (its bounding box, scaled with its profile)."""
        (x, y, _), orn = pb.getBasePositionAndOrientation(self.car, physicsClientId=self.client)
        yaw = pb.getEulerFromQuaternion(orn)[2]
        rear, front, half_width = (v * self.profile.scale for v in FOOTPRINT_M)
        middle = (rear + front) / 2
        return (x + middle * math.cos(yaw), y + middle * math.sin(yaw), yaw, (front - rear) / 2, half_width)
