"""ROAR's UDP chunked stream (protocol/PROTOCOL.md section 5): a frame is cut into datagrams of
a 9-byte ASCII header "XXXYYYZZZ" (chunk index, index of the last chunk, frame id mod 1000)
and at most 9,200 data bytes; payloads carry the camera's intrinsics first.

    for datagram in chunks(payload, frame_id=7): sock.sendto(datagram, addr)
    index, last, frame_id = parse_header(datagram)      # or None: not a chunk header
    fx, fy, cx, cy = intrinsics(payload); body = payload[INTRINSICS_BYTES:]

ROAR's phone always sends ZZZ = 000 and, for a frame of exactly k * 9200 bytes, a YYY one too
high; frames from chunks() always have YYY = the last index, which ROAR's receiver completes.
Runs unchanged on CPython and MicroPython.
"""

import struct

from roar_wire import finite, spec

HEADER_BYTES = spec.UDP_HEADER_BYTES
CHUNK_BYTES = spec.UDP_MAX_CHUNK_DATA_BYTES
INTRINSICS_BYTES = spec.UDP_INTRINSICS_BYTES
MODULUS = spec.UDP_FRAME_ID_MODULUS
MAX_CHUNKS = 10 ** spec.UDP_TOTAL_DIGITS  # YYY has three digits: 0..999
MAX_PAYLOAD_BYTES = MAX_CHUNKS * CHUNK_BYTES
STATE_FIELDS = spec.UDP_STATE_FIELDS.split(",")
_DIGITS = b"0123456789"


def _field(value):
    return ("%03d" % value).encode()


def header(index, last, frame_id):
    """The 9 header bytes of chunk `index` of a frame whose last chunk is `last`."""
    if not 0 <= index <= last < MAX_CHUNKS:
        raise ValueError("chunk index %d, last %d: need 0 <= index <= last < %d" % (index, last, MAX_CHUNKS))
    return _field(index) + _field(last) + _field(frame_id % MODULUS)


def chunks(payload, frame_id=0):
    """The datagrams of one frame: every chunk but the last carries exactly CHUNK_BYTES."""
    n = len(payload)
    if not 0 < n <= MAX_PAYLOAD_BYTES:
        raise ValueError("a frame is 1..%d bytes, got %d" % (MAX_PAYLOAD_BYTES, n))
    last = (n - 1) // CHUNK_BYTES
    return [header(i, last, frame_id) + payload[i * CHUNK_BYTES:(i + 1) * CHUNK_BYTES] for i in range(last + 1)]


def parse_header(datagram):
    """(index, last, frame_id) of a chunk, or None when the first 9 bytes are not nine ASCII
    digits with index <= last."""
    if len(datagram) < HEADER_BYTES:
        return None
    for b in datagram[:HEADER_BYTES]:
        if b not in _DIGITS:
            return None
    text = bytes(datagram[:HEADER_BYTES]).decode()
    index, last, frame_id = int(text[0:3]), int(text[3:6]), int(text[6:9])
    if index > last:
        return None
    return index, last, frame_id


def chunk_length_ok(index, last, data_bytes):
    """Whether a chunk's data length is right: CHUNK_BYTES except for the last, which has 1..CHUNK_BYTES."""
    return data_bytes == CHUNK_BYTES if index < last else 0 < data_bytes <= CHUNK_BYTES


def newer(a, b):
    """Whether frame id a comes after frame id b (ids wrap at MODULUS; half the circle ahead is newer)."""
    return 0 < (a - b) % MODULUS < MODULUS // 2


def with_intrinsics(fx, fy, cx, cy, body):
    """A camera or depth payload: fx, fy, cx, cy [pixels] as float32 little-endian, then the body."""
    return struct.pack("<4f", fx, fy, cx, cy) + body


def intrinsics(payload):
    """(fx, fy, cx, cy) [pixels] from the start of a camera or depth payload; ValueError when
    they are not there or not positive finite numbers."""
    if len(payload) < INTRINSICS_BYTES:
        raise ValueError("a camera payload starts with %d bytes of intrinsics" % INTRINSICS_BYTES)
    values = struct.unpack("<4f", payload[:INTRINSICS_BYTES])
    for v in values:
        if not (finite(v) and v > 0):
            raise ValueError("camera intrinsics must be positive finite numbers")
    return values


def state_line(values):
    """The vehicle-state CSV of a dict of STATE_FIELDS values (missing ones 0), ending in a line
    end (a receiver tells a whole line from one cut short by it)."""
    return (",".join("%g" % values.get(name, 0.0) for name in STATE_FIELDS) + "\n").encode()


def parse_state(data):
    """A vehicle-state CSV as a dict of floats, or None when it is not len(STATE_FIELDS) finite
    numbers (a NaN or an infinity never reaches a control loop)."""
    try:
        parts = data.decode().strip().split(",")
        if len(parts) != len(STATE_FIELDS):
            return None
        values = [float(p) for p in parts]
    except (UnicodeError, ValueError):
        return None
    for v in values:
        if not finite(v):
            return None
    return dict(zip(STATE_FIELDS, values))


def control_line(throttle, steering):
    """The control datagram to the phone: "throttle,steering", each clipped to [-1, 1]."""
    clip = lambda v: max(-1.0, min(1.0, float(v)))  # noqa: E731
    return ("%.4f,%.4f" % (clip(throttle), clip(steering))).encode()


def parse_control(data):
    """(throttle, steering) in [-1, 1] from a control datagram, or None when it is not two finite
    numbers in range."""
    try:
        parts = data.decode().strip().split(",")
        if len(parts) != 2:
            return None
        t, s = float(parts[0]), float(parts[1])
    except (UnicodeError, ValueError):
        return None
    if not (-1.0 <= t <= 1.0 and -1.0 <= s <= 1.0):  # also refuses nan
        return None
    return t, s
