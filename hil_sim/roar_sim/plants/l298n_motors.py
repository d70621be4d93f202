"""One side of an L298N driving a TT gear motor, as the Junior's wheels are driven. The side takes
the pins the firmware writes (IN1, IN2, EN duty) and gives the motor its current, averaged over
the 30 kHz PWM period (far faster than the wheel), so the motor sees the duty's share of the
supply:

    IN1 != IN2, EN duty d:   i = (±d V - ke w) / R      (driven)
    IN1 == IN2, EN duty d:   i = -d ke w / R            (both ends tied: the bridge brakes it)
    EN duty 0:               i = 0                      (coast)

and the wheel gets torque kt i, less the gearbox's friction. The constants give a TT motor's
torque-speed line (no-load 19.6 rad/s and stall 0.073 N m at the 5.6 V the L298N leaves of a 7.4 V
pack, less the gearbox's friction). One motor differs from the next: `strength` scales its line
(no-load speed and stall torque alike; a robot's profile holds each side's, roar_sim.plants.junior_profile).
"""

from __future__ import annotations

from roar.protocol import spec
from roar_sim.core.junior import SidePins

SUPPLY_V = 7.4  # [V] 2S lithium pack
BRIDGE_DROP_V = 1.8  # [V] an L298N loses about this much
DRIVE_V = SUPPLY_V - BRIDGE_DROP_V  # [V] across the motor at full duty
MOTOR_KE = 0.286  # [V s/rad] at the wheel (after the 1:48 gearbox): 6 V -> 21 rad/s no-load
MOTOR_KT = MOTOR_KE  # [N m/A]
MOTOR_R_OHM = 22.0  # [ohm] equivalent, gearbox losses included: 6 V stalls at 0.078 N m
STALL_NM = MOTOR_KT * DRIVE_V / MOTOR_R_OHM  # [N m] at the wheel, full duty, standing
FULL_SCALE = spec.L298N_DUTY_FULL_SCALE  # [permille] duty meaning 100 %


def motor_torque(pins: SidePins, omega: float, strength: float = 1.0) -> float:
    """[N m] on the wheel from one L298N side and its motor, at wheel speed omega [rad/s];
    strength: the motor's torque-speed line against a stock TT motor's."""
    duty = pins.duty / FULL_SCALE
    if duty <= 0:
        return 0.0  # EN low: coast
    if pins.in1 == pins.in2:
        return -MOTOR_KT * duty * MOTOR_KE * omega / MOTOR_R_OHM  # terminals tied: brake
    volts = strength * duty * (DRIVE_V if pins.in1 else -DRIVE_V)
    return MOTOR_KT * (volts - MOTOR_KE * omega) / MOTOR_R_OHM
