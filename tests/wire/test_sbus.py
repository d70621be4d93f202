"""SBUS receiver frames: the C++ core's decoder (firmware/core sbus.h) and the portable one
(roar_wire.sbus) run the golden frames bit for bit, agree on every random stream, and follow the
rules: resync on garbage, frame-lost counted but not a failsafe, the failsafe flag and the
guard on the first four channels honoured, lock after three good frames."""

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from conftest import ROOT
from roar.protocol import spec
from roar_sim.core import iarrc
from roar_wire import sbus

CASES = json.loads((ROOT / "protocol" / "vectors" / "sbus_frames.json").read_text())["cases"]
FRAME_US = 7_000  # [us] between frame starts, as a FrSky receiver in high-speed mode sends them
BYTE_US = 120  # [us] one byte at 100 kbaud 8E2


def reference_bytes(channels, flags, end):
    """The packing written out another way: 16 x 11 bits as one little-endian integer."""
    value = sum(c << (11 * i) for i, c in enumerate(channels))
    return bytes([spec.SBUS_START_BYTE]) + value.to_bytes(22, "little") + bytes([flags, end])


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_golden_frames_bit_for_bit_in_both_decoders(case):
    data = bytes.fromhex(case["hex"])
    assert data == reference_bytes(case["channels"], case["flags"], case["end"])
    for encode, decode in ((iarrc.sbus_encode, iarrc.sbus_decode), (sbus.encode, sbus.decode_frame)):
        assert encode(case["channels"], case["flags"], case["end"]) == data
        assert decode(data) == (case["channels"], case["flags"], case["end"])
    assert sbus.is_failsafe(case["channels"], case["flags"]) == case["failsafe"]
    for decoder in (iarrc.SbusDecoder(), sbus.Decoder()):
        results = [decoder.feed(b, i * BYTE_US) for i, b in enumerate(data)]
        assert results[-1] == (sbus.FAILSAFE if case["failsafe"] else sbus.FRAME) and not any(results[:-1])


channels = st.lists(st.integers(0, 2047), min_size=16, max_size=16)
flags = st.integers(0, 15)
ends = st.sampled_from(sbus.END_BYTES)


@given(channels, flags, ends)
def test_round_trip_and_the_two_encoders_agree(ch, fl, end):
    data = sbus.encode(ch, fl, end)
    assert data == iarrc.sbus_encode(ch, fl, end) == reference_bytes(ch, fl, end)
    assert sbus.decode_frame(data) == iarrc.sbus_decode(data) == (ch, fl, end)


@given(st.binary(min_size=25, max_size=25))
def test_any_25_bytes_decode_alike(data):
    assert sbus.decode_frame(data) == iarrc.sbus_decode(data)


def good_frame(rng_channels=None):
    return sbus.encode(rng_channels or [992] * 16)


pieces = st.one_of(
    st.tuples(st.just("frame"), channels.filter(lambda c: 0 not in c[:4]), st.sampled_from([0, 1, 2, 3, 4]), ends),
    st.tuples(st.just("failsafe"), channels, st.just(8), ends),
    st.tuples(st.just("guard"), channels.map(lambda c: [0] + c[1:]), st.just(0), ends),
    st.tuples(st.just("cut"), channels, st.integers(1, 24), ends),  # a frame cut short
    st.tuples(st.just("junk"), st.binary(min_size=1, max_size=40), st.just(0), st.just(0)),
    st.tuples(st.just("bad_end"), channels, st.just(0), st.sampled_from([1, 0x05, 0x44, 0xFF])),
)


@given(st.lists(st.tuples(pieces, st.sampled_from([0, BYTE_US, 3_000, 7_000])), max_size=30))
def test_random_streams_give_the_same_results_in_both_decoders(stream):
    """Frames, failsafe frames, frames cut short, junk and wrong end bytes, with or without the
    pause between frames: the C++ and portable decoders return the same result for every byte
    and end with the same frame, counters and lock."""
    cpp, py = iarrc.SbusDecoder(), sbus.Decoder()
    t = 0
    for (kind, a, b, c), pause in stream:
        if kind == "junk":
            data = a
        elif kind == "cut":
            data = sbus.encode(a)[:b]
        else:
            data = sbus.encode(a, b, c)
        t += pause
        for byte in data:
            assert cpp.feed(byte, t) == py.feed(byte, t)
            t += BYTE_US
    status = cpp.status()
    assert cpp.frame() == (py.channels, py.flags, py.end)
    assert status == {"locked": py.locked, "good_frames": py.good_frames, "lost_frames": py.lost_frames,
                      "failsafe_frames": py.failsafe_frames, "dropped": py.dropped, "last_good_us": py.last_good_us}


@pytest.mark.parametrize("make", [iarrc.SbusDecoder, sbus.Decoder], ids=["cpp", "python"])
def test_lock_resync_frame_lost_and_failsafe(make):
    d = make()
    feed = lambda data, t: [d.feed(b, t + i * BYTE_US) for i, b in enumerate(data)]  # noqa: E731
    locked = (lambda: d.status()["locked"]) if make is iarrc.SbusDecoder else (lambda: d.locked)
    # starting mid-frame with no pause to go by: resynchronised by the next frames' start bytes
    frame = sbus.encode([1500 - 875 + 100] * 16)  # no 0x0F inside
    assert frame.count(spec.SBUS_START_BYTE) == 1
    results = feed(frame[7:] + frame + frame, 0)
    assert results.count(sbus.FRAME) == 2
    assert not locked()
    assert feed(frame, 20_000)[-1] == sbus.FRAME and locked()  # the third good frame in a row
    # frame-lost: counted, still a good frame, still locked
    assert feed(sbus.encode([992] * 16, spec.SBUS_FLAG_FRAME_LOST), 30_000)[-1] == sbus.FRAME and locked()
    # failsafe flag, and the guard: not frames, and the lock is gone until three good ones
    assert feed(sbus.encode([992] * 16, spec.SBUS_FLAG_FAILSAFE), 40_000)[-1] == sbus.FAILSAFE and not locked()
    feed(frame, 50_000), feed(frame, 60_000)
    assert not locked()
    assert feed(frame, 70_000)[-1] == sbus.FRAME and locked()
    assert feed(sbus.encode([992, 992, 0, 992] + [992] * 12), 80_000)[-1] == sbus.FAILSAFE and not locked()
    # a pause mid-frame drops the partial frame; the next frame stands
    results = feed(frame[:12], 90_000) + feed(frame, 100_000)
    assert sbus.DROPPED in results and results[-1] == sbus.FRAME


def test_raw_values_map_to_pulse_widths():
    assert [sbus.raw_to_us(r) for r in (0, 200, 1024, 1800, 2047)] == [875, 1000, 1515, 2000, 2154]
    assert all(sbus.raw_to_us(sbus.us_to_raw(us)) in (us - 1, us, us + 1) for us in range(1000, 2001))
    assert sbus.us_to_raw(500) == 0 and sbus.us_to_raw(3000) == 2047
