"""Vehicle to vehicle (protocol/PROTOCOL.md section 10 (the V2V message)): each car multicasts its state as one
UTF-8 CSV datagram, "car_id,seq,x,y,yaw,speed", to the V2V group 20 times a second; ROAR's
platooning cars shared positions this way.

    datagram = encode(1, seq, x, y, yaw, speed)
    message = decode(datagram)      # (car_id, seq, x, y, yaw, speed), or None: not a V2V message

Runs unchanged on CPython and MicroPython.
"""

from roar_wire import finite, spec

FIELDS = spec.V2V_FIELDS.split(",")
MAX_BYTES = spec.V2V_MAX_DATAGRAM_BYTES
MAX_CAR_ID = 255
SEQ_MODULUS = 1 << 32


def encode(car_id, seq, x, y, yaw, speed):
    """One datagram (bytes); ValueError for an id outside 0..255 or a value that is not finite."""
    if not 0 <= car_id <= MAX_CAR_ID:
        raise ValueError("car_id must be 0..255")
    values = (x, y, yaw, speed)
    for v in values:
        if not finite(v):
            raise ValueError("V2V values must be finite")
    text = "%d,%d,%.4f,%.4f,%.5f,%.4f" % ((car_id, seq % SEQ_MODULUS) + values)
    return text.encode()


def decode(datagram):
    """(car_id, seq, x, y, yaw, speed), or None for anything that is not a well-formed message."""
    if len(datagram) > MAX_BYTES:
        return None
    try:
        parts = datagram.decode().split(",")
    except UnicodeError:
        return None
    if len(parts) != len(FIELDS):
        return None
    try:
        car_id, seq = int(parts[0]), int(parts[1])
        x, y, yaw, speed = (float(p) for p in parts[2:])
    except ValueError:
        return None
    if not (0 <= car_id <= MAX_CAR_ID and 0 <= seq < SEQ_MODULUS):
        return None
    for v in (x, y, yaw, speed):
        if not finite(v):
            return None
    return car_id, seq, x, y, yaw, speed


def newer(seq, than):
    """Whether sequence number seq comes after `than`, across the wrap at 2^32."""
    return 0 < (seq - than) % SEQ_MODULUS < SEQ_MODULUS // 2
