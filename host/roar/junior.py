"""The ROAR Junior's command: two wheel duties <-> its HTTP query (PROTOCOL.md section 6), and
the two ways throttle and steering become wheel duties.

    query_for(0.5, 0.8)                  'forward=True&left_spd=0.500&right_spd=0.800'
    original_mix(0.5, -0.5)              (0.0, 0.9): as the ROAR Junior client maps them
    smooth_mix(0.5, -0.5)                (0.25, 0.75): speed from throttle, turn from steering
"""

from __future__ import annotations

from roar.protocol import spec

ORIGINAL_BASE = 0.8  # the ROAR Junior client's base_throttle


def query_for(left: float, right: float) -> str:
    """The query that sets signed wheel duties (-1..1 each, positive forward): both forward,
    both backward, or spinning (turnLeft: left back, right forward); stop when both are 0."""
    if left == 0 and right == 0:
        return f"{spec.JUNIOR_PARAM_STOP}={spec.JUNIOR_FLAG_TRUE}"
    if left >= 0 and right >= 0:
        flag = spec.JUNIOR_PARAM_FORWARD
    elif left <= 0 and right <= 0:
        flag = spec.JUNIOR_PARAM_BACKWARD
    else:
        flag = spec.JUNIOR_PARAM_TURN_LEFT if left < 0 else spec.JUNIOR_PARAM_TURN_RIGHT
    return (f"{flag}={spec.JUNIOR_FLAG_TRUE}&{spec.JUNIOR_PARAM_LEFT_SPEED}={min(1.0, abs(left)):.3f}"
            f"&{spec.JUNIOR_PARAM_RIGHT_SPEED}={min(1.0, abs(right)):.3f}")


def original_mix(throttle: float, steering: float, base: float = ORIGINAL_BASE) -> tuple[float, float]:
    """The ROAR Junior client's ackermann_to_diff: throttle gives only the direction (0 stops);
    straight ahead both wheels run flat out; steering stops the inner wheel and runs the outer
    one at base + (1 - base) |steering|."""
    if throttle == 0:
        return 0.0, 0.0
    sign = 1.0 if throttle > 0 else -1.0
    if steering == 0:
        return sign, sign
    outer = base + (1 - base) * abs(steering)
    return (sign * outer, 0.0) if steering > 0 else (0.0, sign * outer)


def smooth_mix(throttle: float, steering: float) -> tuple[float, float]:
    """Speed from throttle, turn from steering: left = t (1 + s), right = t (1 - s), scaled
    down together past full duty; with no throttle, steering spins the robot in place."""
    if throttle == 0:
        return steering, -steering  # steering right (+) spins clockwise: left forward, right back
    left, right = throttle * (1 + steering), throttle * (1 - steering)
    peak = max(abs(left), abs(right))
    return (left / peak, right / peak) if peak > 1 else (left, right)


MIXES = {"original": original_mix, "smooth": smooth_mix}
