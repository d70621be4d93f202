"""The ROAR Junior's control query (PROTOCOL.md section 6), as its firmware reads it:
"forward=True&left_spd=0.5&right_spd=0.5", parameters applied in order; a query with any
parameter that is not understood is refused whole. The same rules as the C++ JuniorControl.

    parse_query("stop=True&left_spd=0.5")     ([(MOTION, STOP), (LEFT, 500)], None)
    parse_unit_permille("0.25")               250

Runs unchanged on CPython and MicroPython.
"""

from roar_wire import spec

# Motions, in the order of the C++ JuniorMotion
STOP, FORWARD, BACKWARD, TURN_LEFT, TURN_RIGHT = 0, 1, 2, 3, 4
FLAGS = {
    spec.JUNIOR_PARAM_FORWARD: FORWARD,
    spec.JUNIOR_PARAM_BACKWARD: BACKWARD,
    spec.JUNIOR_PARAM_STOP: STOP,
    spec.JUNIOR_PARAM_TURN_LEFT: TURN_LEFT,
    spec.JUNIOR_PARAM_TURN_RIGHT: TURN_RIGHT,
}
# What a parameter does: (MOTION, motion or None for a False flag) or (LEFT | RIGHT, permille)
MOTION, LEFT, RIGHT = 0, 1, 2
SPEEDS = {spec.JUNIOR_PARAM_LEFT_SPEED: LEFT, spec.JUNIOR_PARAM_RIGHT_SPEED: RIGHT}

# Why a query is refused: the first words of the 400 reply
UNKNOWN_NAME = "unknown parameter"
BAD_FLAG = "a flag takes True or False"
BAD_SPEED = "a speed takes a number 0..1"
MAX_QUOTED = 40  # [chars] of a refused parameter quoted in the reply


def parse_unit_permille(text):
    """A speed "0", "1", "0.5", ".25", "1.0" (0..1, decimals past the third ignored) in
    permille, or None for anything else (negative, above 1, not a number)."""
    whole, fraction, scale, digits, i, n = 0, 0, 1000, False, 0, len(text)
    while i < n and "0" <= text[i] <= "9":
        whole = whole * 10 + ord(text[i]) - 48
        digits = True
        if whole > 1:
            return None
        i += 1
    if i < n and text[i] == ".":
        i += 1
        while i < n and "0" <= text[i] <= "9":
            digits = True
            if scale > 1:
                scale //= 10
                fraction += (ord(text[i]) - 48) * scale
            i += 1
    if not digits or i != n:
        return None
    value = whole * 1000 + fraction
    return value if value <= spec.L298N_DUTY_FULL_SCALE else None


def parse_query(query):
    """(actions, None) for a query the Junior understands, each action (MOTION, motion or None)
    or (LEFT | RIGHT, permille), in order; or (None, reason) for a refused one, the reason the
    one line a 400 reply carries: "<why>: '<name=value>'"."""
    actions = []
    for param in query.split("&"):
        if not param:
            continue  # "&&" or a trailing '&'
        name, _, value = param.partition("=")
        if name in FLAGS:
            if value == spec.JUNIOR_FLAG_TRUE:
                actions.append((MOTION, FLAGS[name]))
                continue
            if value == spec.JUNIOR_FLAG_FALSE:
                actions.append((MOTION, None))
                continue
            why = BAD_FLAG
        elif name in SPEEDS:
            permille = parse_unit_permille(value)
            if permille is not None:
                actions.append((SPEEDS[name], permille))
                continue
            why = BAD_SPEED
        else:
            why = UNKNOWN_NAME
        return None, "%s: '%s'" % (why, param[:MAX_QUOTED])
    return actions, None
