"""SBUS receiver frames, as the C++ core's SbusDecoder reads them (firmware/core/include/roar/
sbus.h has the rules): 25 bytes, 0x0F first, 16 channels of 11 bits packed least significant bit
first, a flags byte, an end byte 0x00 or an SBUS2 slot byte.

    frame = encode([992] * 16, flags=0)           # 25 bytes (a simulated transmitter)
    channels, flags, end = decode_frame(frame)    # or None for bytes that are not a frame
    d = Decoder(); d.feed(byte, now_us)           # NONE, FRAME, FAILSAFE or DROPPED

Runs unchanged on CPython and MicroPython.
"""

from roar_wire import spec

NONE, FRAME = spec.SBUS_RESULT_NONE, spec.SBUS_RESULT_FRAME  # what feed() reports for a byte
FAILSAFE, DROPPED = spec.SBUS_RESULT_FAILSAFE, spec.SBUS_RESULT_DROPPED
FRAME_BYTES = spec.SBUS_FRAME_BYTES
CHANNELS = spec.SBUS_CHANNELS
_MASK = (1 << spec.SBUS_CHANNEL_BITS) - 1
_FLAGS_AT = 1 + CHANNELS * spec.SBUS_CHANNEL_BITS // 8  # byte 23
_KNOWN_FLAGS = spec.SBUS_FLAG_CH17 | spec.SBUS_FLAG_CH18 | spec.SBUS_FLAG_FRAME_LOST | spec.SBUS_FLAG_FAILSAFE
END_BYTES = (spec.SBUS_END_BYTE,) + tuple(spec.SBUS_SBUS2_END_FIRST + i * spec.SBUS_SBUS2_END_STEP
                                          for i in range(spec.SBUS_SBUS2_END_COUNT))


def raw_to_us(raw):
    """[us] of a raw channel value: raw 200..1800 is 1000..2000 us."""
    return spec.SBUS_US_OFFSET + raw * spec.SBUS_US_PER_RAW_NUM // spec.SBUS_US_PER_RAW_DEN


def us_to_raw(us):
    """The raw value nearest to a pulse width [us] (clamped to 0..2047)."""
    raw = ((us - spec.SBUS_US_OFFSET) * spec.SBUS_US_PER_RAW_DEN + spec.SBUS_US_PER_RAW_NUM // 2) // spec.SBUS_US_PER_RAW_NUM
    return min(max(raw, 0), _MASK)


def encode(channels, flags=0, end=spec.SBUS_END_BYTE):
    """The 25 bytes of a frame: 16 raw channel values (0..2047), the flags byte, the end byte."""
    out = bytearray(FRAME_BYTES)
    out[0] = spec.SBUS_START_BYTE
    acc, have, at = 0, 0, 1
    for raw in channels:
        acc |= (raw & _MASK) << have
        have += spec.SBUS_CHANNEL_BITS
        while have >= 8:
            out[at] = acc & 0xFF
            at += 1
            acc >>= 8
            have -= 8
    out[_FLAGS_AT] = flags
    out[FRAME_BYTES - 1] = end
    return bytes(out)


def decode_frame(data):
    """(channels, flags, end) of 25 bytes that are a well-formed frame, else None."""
    flags, end = data[_FLAGS_AT], data[FRAME_BYTES - 1]
    if data[0] != spec.SBUS_START_BYTE or end not in END_BYTES or flags & ~_KNOWN_FLAGS:
        return None
    channels = []
    acc, have, at = 0, 0, 1
    for _ in range(CHANNELS):
        while have < spec.SBUS_CHANNEL_BITS:
            acc |= data[at] << have
            at += 1
            have += 8
        channels.append(acc & _MASK)
        acc >>= spec.SBUS_CHANNEL_BITS
        have -= spec.SBUS_CHANNEL_BITS
    return channels, flags, end


def is_failsafe(channels, flags):
    """The failsafe flag, or a guarded channel (the first four) at raw 0."""
    return bool(flags & spec.SBUS_FLAG_FAILSAFE) or 0 in channels[:spec.SBUS_GUARD_CHANNELS]


class Decoder:
    """Frames out of a byte stream: a pause of SBUS_FRAME_GAP_US starts a new frame; a candidate
    that is not a frame is searched for the next start byte; lock after SBUS_LOCK_FRAMES good
    frames in a row, lost on a failsafe frame."""

    def __init__(self):
        self.buf = bytearray()
        self.channels = [0] * CHANNELS  # of the last good frame
        self.flags = 0
        self.end = spec.SBUS_END_BYTE
        self.good_in_row = 0
        self.good_frames = self.lost_frames = self.failsafe_frames = self.dropped = 0
        self.last_good_us = 0
        self._last_byte_us = None

    @property
    def locked(self):
        return self.good_in_row >= spec.SBUS_LOCK_FRAMES

    def feed(self, byte, now_us):
        result = NONE
        last = self._last_byte_us
        if self.buf and last is not None and now_us - last >= spec.SBUS_FRAME_GAP_US:
            self.buf = bytearray()  # a pause: whatever came before was not a whole frame
            self.dropped += 1
            result = DROPPED
        self._last_byte_us = now_us
        if not self.buf and byte != spec.SBUS_START_BYTE:
            return result  # between frames
        self.buf.append(byte)
        return self._finish(now_us) if len(self.buf) == FRAME_BYTES else result

    def _finish(self, now_us):
        frame = decode_frame(self.buf)
        if frame is None:
            self.dropped += 1
            start = self.buf.find(bytes((spec.SBUS_START_BYTE,)), 1)
            self.buf = self.buf[start:] if start > 0 else bytearray()
            return DROPPED
        self.buf = bytearray()
        channels, flags, end = frame
        if is_failsafe(channels, flags):
            self.failsafe_frames += 1
            self.good_in_row = 0
            return FAILSAFE
        self.channels, self.flags, self.end = channels, flags, end
        self.good_frames += 1
        if flags & spec.SBUS_FLAG_FRAME_LOST:
            self.lost_frames += 1
        self.good_in_row = min(self.good_in_row + 1, spec.SBUS_LOCK_FRAMES)
        self.last_good_us = now_us
        return FRAME
