"""The ROAR Junior as a physical robot in the simulator's world: an ESP32-CAM two-wheel chassis
(two driven wheels at the back, a skid ball at the front), each wheel driven by a TT gear motor
through one side of an L298N (roar_sim.plants.l298n_motors: it tops out at about 0.55 m/s), an
HC-SR04 ultrasonic ranger and the camera on the front.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar_sim.core.junior import SidePins
from roar_sim.plants import junior_profile
from roar_sim.plants.l298n_motors import motor_torque
from roar_sim.sensors import ultrasonic
from roar_sim.world.bullet import pb
from roar_sim.world.scene import World
from roar.tracks.track import Track

# Chassis, as an ESP32-CAM 2WD kit is built
CHASSIS_HALF_M = (0.10, 0.065, 0.02)  # [m] half length, width, height of the chassis box
CHASSIS_KG = 0.38  # [kg] with the battery pack
WHEEL_RADIUS_M = 0.0325  # [m]
WHEEL_WIDTH_M = 0.027  # [m]
WHEEL_KG = 0.03  # [kg]
WHEEL_TRACK_M = 0.15  # [m] between the wheels' centres
WHEEL_X_M = -0.03  # [m] axle behind the chassis centre
SKID_RADIUS_M = 0.0125  # [m] the ball under the front
SKID_X_M = 0.075  # [m]
ULTRASONIC_POS_M = (0.10, 0.0, 0.045)  # [m] in the chassis frame (from the axle-height origin)
CAMERA_POS_M = (0.06, 0.0, 0.075)  # [m]
CAMERA_PITCH_RAD = math.radians(12)  # looking slightly down
CAMERA_FOV_DEG = 62.0  # OV2640 with the stock lens (vertical field of view used by PyBullet)

LEFT, RIGHT = 0, 1  # wheel joint indices
SPIN_LIMIT_RAD_S = 1000.0  # [rad/s] a velocity target no wheel reaches: the force limit is the torque


@dataclass(frozen=True)
class JuniorState:
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad]
    speed: float  # [m/s] along the heading
    yaw_rate: float  # [rad/s]
    left_wheel_rad_s: float  # [rad/s] positive rolling forward
    right_wheel_rad_s: float  # [rad/s]


class JuniorPlant:
    """The Junior in a World with an optional track; profile: its motors (a JuniorProfile; None:
    a stock kit's)."""

    def __init__(self, track: Track | None, dt_s: float = 0.005, gui: bool = False,
                 pose: tuple[float, float, float] | None = None,
                 profile: junior_profile.JuniorProfile | None = None) -> None:
        self.dt_s = dt_s
        self.sides = (profile or junior_profile.load()).sides()  # (strength, gearbox friction [N m]) left, right
        self.world = World(track, dt_s, gui)
        self.client = self.world.client
        x, y, yaw = pose or self.world.start_pose()
        self.robot = self._build(x, y, yaw)
        self.time_s = 0.0

    def _build(self, x: float, y: float, yaw: float) -> int:
        c = self.client
        chassis = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=CHASSIS_HALF_M,
                                          collisionFramePosition=[0, 0, CHASSIS_HALF_M[2]], physicsClientId=c)
        chassis_v = pb.createVisualShape(pb.GEOM_BOX, halfExtents=CHASSIS_HALF_M, rgbaColor=[0.9, 0.55, 0.1, 1],
                                         visualFramePosition=[0, 0, CHASSIS_HALF_M[2]], physicsClientId=c)
        axis_y = pb.getQuaternionFromEuler([math.pi / 2, 0, 0])  # a cylinder's axis (z) along y
        wheel = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=WHEEL_RADIUS_M, height=WHEEL_WIDTH_M,
                                        physicsClientId=c)
        wheel_v = pb.createVisualShape(pb.GEOM_CYLINDER, radius=WHEEL_RADIUS_M, length=WHEEL_WIDTH_M,
                                       rgbaColor=[0.1, 0.1, 0.1, 1], physicsClientId=c)
        skid = pb.createCollisionShape(pb.GEOM_SPHERE, radius=SKID_RADIUS_M, physicsClientId=c)
        skid_v = pb.createVisualShape(pb.GEOM_SPHERE, radius=SKID_RADIUS_M, rgbaColor=[0.7, 0.7, 0.7, 1],
                                      physicsClientId=c)
        half_track = WHEEL_TRACK_M / 2
        body = pb.createMultiBody(
            CHASSIS_KG, chassis, chassis_v, [x, y, WHEEL_RADIUS_M], pb.getQuaternionFromEuler([0, 0, yaw]),
            linkMasses=[WHEEL_KG, WHEEL_KG, 0.005],
            linkCollisionShapeIndices=[wheel, wheel, skid],
            linkVisualShapeIndices=[wheel_v, wheel_v, skid_v],
            linkPositions=[[WHEEL_X_M, half_track, 0], [WHEEL_X_M, -half_track, 0],
                           [SKID_X_M, 0, SKID_RADIUS_M - WHEEL_RADIUS_M]],
            linkOrientations=[axis_y, axis_y, [0, 0, 0, 1]],
            linkInertialFramePositions=[[0, 0, 0]] * 3,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * 3,
            linkParentIndices=[0, 0, 0],
            linkJointTypes=[pb.JOINT_REVOLUTE, pb.JOINT_REVOLUTE, pb.JOINT_FIXED],
            linkJointAxis=[[0, 0, -1], [0, 0, -1], [0, 0, 1]],  # -z of the turned cylinder: forward roll positive
            physicsClientId=c)
        pb.changeDynamics(body, 2, lateralFriction=0.0, spinningFriction=0.0, rollingFriction=0.0,
                          physicsClientId=c)  # the skid ball slides
        for w in (LEFT, RIGHT):
            pb.changeDynamics(body, w, lateralFriction=1.0, physicsClientId=c)
            pb.setJointMotorControl2(body, w, pb.VELOCITY_CONTROL, targetVelocity=0, force=self.sides[w][1],
                                     physicsClientId=c)
        return body

    def apply(self, left: SidePins, right: SidePins) -> None:
        """The L298N inputs for the next physics step."""
        c = self.client
        for joint, pins in ((LEFT, left), (RIGHT, right)):
            strength, friction = self.sides[joint]
            omega = pb.getJointState(self.robot, joint, physicsClientId=c)[1]
            torque = motor_torque(pins, omega, strength)
            moving = abs(omega) > 1e-3
            if abs(torque) <= friction:
                # the motor cannot turn it against its gearbox: it slows to a stop (the friction less
                # what the motor adds along its motion) and stays there, rather than overshooting
                # zero each step and creeping on (a wide dead band's wheel did, 0.4 rad/s)
                along = torque * math.copysign(1.0, omega) if moving else 0.0
                pb.setJointMotorControl2(self.robot, joint, pb.VELOCITY_CONTROL, targetVelocity=0,
                                         force=friction - along, physicsClientId=c)
            else:
                net = torque - (math.copysign(friction, omega) if moving else 0.0)
                pb.setJointMotorControl2(self.robot, joint, pb.VELOCITY_CONTROL,
                                         targetVelocity=math.copysign(SPIN_LIMIT_RAD_S, net), force=abs(net),
                                         physicsClientId=c)

    def step(self) -> None:
        self.world.step()
        self.time_s += self.dt_s

    def state(self) -> JuniorState:
        left, right = (pb.getJointState(self.robot, j, physicsClientId=self.client)[1] for j in (LEFT, RIGHT))
        return JuniorState(*self.world.planar_motion(self.robot), left, right)

    def pose(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """(position, orientation quaternion) of the chassis."""
        return pb.getBasePositionAndOrientation(self.robot, physicsClientId=self.client)

    def place(self, position, orientation) -> None:
        """Put the chassis there (a renderer mirroring another world's robot does this)."""
        pb.resetBasePositionAndOrientation(self.robot, position, orientation, physicsClientId=self.client)

    def _mount(self, offset) -> tuple[list[float], float]:
        """World position of a point on the chassis, and the chassis' yaw."""
        pos, orn = pb.getBasePositionAndOrientation(self.robot, physicsClientId=self.client)
        yaw = pb.getEulerFromQuaternion(orn)[2]
        dx, dy, dz = offset
        return [pos[0] + dx * math.cos(yaw) - dy * math.sin(yaw), pos[1] + dx * math.sin(yaw) + dy * math.cos(yaw),
                pos[2] + dz], yaw

    def ultrasonic_cm(self) -> int:
        """What the HC-SR04 on the front reports, as the firmware reads it: whole cm, 0 for no echo."""
        origin, yaw = self._mount(ULTRASONIC_POS_M)
        return ultrasonic.reading_cm(self.world, origin, yaw, {self.robot, self.world.ground, *self.world.floor})

    def camera(self, width: int, height: int,
               shake_rad: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
        """(RGB uint8 HxWx3, depth float32 HxW [m]) from the ESP32-CAM on the front; shake_rad turns
        it by (yaw, pitch) more, as a loose mount would."""
        position, yaw = self._mount(CAMERA_POS_M)
        return self.world.render(position, yaw + shake_rad[0], CAMERA_PITCH_RAD + shake_rad[1], width, height,
                                 CAMERA_FOV_DEG, body=self.robot)

    def wall_contacts(self, of: list[int] | None = None) -> int:
        """How many walls (or bodies of `of`) the robot touches right now."""
        return self.world.contacts(self.robot, of)

    def close(self) -> None:
        self.world.close()
