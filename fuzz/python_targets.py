"""atheris targets for the host's decoders and file readers: each takes the fuzzer's bytes and
raises AssertionError when an invariant its module promises breaks. Any other exception is a
defect too, except where a reader is documented to refuse bad input with a one-line RoarError.

TARGETS maps a name (its corpus is fuzz/corpus/py_NAME) to the function."""

from __future__ import annotations

import math
import tempfile
from functools import partial
from pathlib import Path


def _split(data: bytes, pieces: int = 64) -> list[bytes]:
    """Length-prefixed pieces (one byte of length each): datagrams, lines, chunks."""
    out, i = [], 0
    while i < len(data) and len(out) < pieces:
        n = data[i]
        out.append(data[i + 1:i + 1 + n])
        i += 1 + n
    return out


def control(data: bytes) -> None:
    """roar.protocol.StreamDecoder (the host's parser, roar_wire's underneath): events in range,
    and the same events however the bytes are split."""
    from roar.protocol import spec
    from roar.protocol.control import StreamDecoder

    whole = StreamDecoder().feed(data)
    for e in whole:
        if e.command is not None:
            assert spec.CONTROL_MIN_US <= e.command.throttle_us <= spec.CONTROL_MAX_US
            assert spec.CONTROL_MIN_US <= e.command.steering_us <= spec.CONTROL_MAX_US
        if e.setpoint is not None:
            assert abs(e.setpoint.speed_mm_s) <= spec.SETPOINT_MAX_SPEED_MM_S
            assert spec.CONTROL_MIN_US <= e.setpoint.steering_us <= spec.CONTROL_MAX_US
    cut = data[0] % (len(data) + 1) if data else 0
    split = StreamDecoder()
    assert split.feed(data[:cut]) + split.feed(data[cut:]) == whole


def sbus(data: bytes) -> None:
    """roar_wire.sbus.Decoder on (pause / 25 us, byte) pairs: frames whole and well formed,
    counters only growing."""
    from roar_wire import sbus as wire

    d = wire.Decoder()
    now = 1000
    for i in range(0, len(data) - 1, 2):
        now += 25 * data[i]
        before = (d.good_frames, d.dropped, d.failsafe_frames)
        r = d.feed(data[i + 1], now)
        assert r in (wire.NONE, wire.FRAME, wire.FAILSAFE, wire.DROPPED)
        assert (d.good_frames, d.dropped, d.failsafe_frames) >= before
        if r == wire.FRAME:
            assert all(0 <= c <= 2047 for c in d.channels) and len(d.channels) == wire.CHANNELS
        if r == wire.DROPPED:
            assert d.dropped > before[1]


def junior_query(data: bytes) -> None:
    """roar_wire.junior.parse_query on what a request line's query can hold (no line ends: they
    end the line): actions in range, or a one-line reason; never both."""
    from roar_wire import junior

    actions, reason = junior.parse_query(data.decode("latin-1").replace("\r", "").replace("\n", ""))
    assert (actions is None) != (reason is None)
    if reason is not None:
        assert "\n" not in reason and len(reason) < 200
    else:
        for what, value in actions:
            assert value is None or isinstance(value, int) and 0 <= value <= 1000 or isinstance(value, str)


def stream(data: bytes) -> None:
    """roar.stream's reassembler and decoder on datagrams: nothing raises, every datagram is
    counted once, and whatever is delivered decodes to a frame of finite numbers or to None."""
    from roar import stream as st

    for kind in ("depth", "rgb", "state"):
        r = st.Reassembler(whole=partial(st.whole, kind))
        grams = _split(data)
        for k, gram in enumerate(grams):
            got = r.feed(gram, now=0.01 * k)
            if got is not None:
                frame_id, payload, first_at = got
                frame = st.decode(kind, frame_id, payload, first_at, 0.01 * k)
                if frame is not None and frame.intrinsics is not None:
                    assert all(math.isfinite(v) and v > 0 for v in frame.intrinsics)
                if frame is not None and frame.state is not None:
                    assert all(math.isfinite(v) for v in frame.state.values())
        c = r.counters
        outcomes = (c.delivered + c.garbage + c.oversize + c.truncated + c.duplicates + c.conflicts + c.stale
                    + c.malformed)
        assert c.datagrams == len(grams) and outcomes <= c.datagrams


def lines(data: bytes) -> None:
    """The phone's state and control lines (roar_wire.stream), telemetry and the car's replies
    (roar.telemetry), V2V datagrams (roar_wire.v2v): None or finite numbers, never an exception."""
    from roar.telemetry import parse_event, parse_telemetry
    from roar_wire import stream as wire
    from roar_wire import v2v

    state = wire.parse_state(data)
    assert state is None or all(math.isfinite(v) for v in state.values())
    control_line = wire.parse_control(data)
    assert control_line is None or all(math.isfinite(v) for v in control_line)
    heard = v2v.decode(data)
    assert heard is None or all(math.isfinite(v) for v in heard[2:])
    text = data.decode("latin-1")
    telemetry = parse_telemetry(text)
    assert telemetry is None or all(math.isfinite(v) for v in telemetry.values() if isinstance(v, float))
    parse_event(text, 0.0)


_TMP = Path(tempfile.mkdtemp(prefix="roar-fuzz-"))


def _reads(suffix: str, load, data: bytes) -> None:
    """A file reader on the fuzzer's bytes: a result, or a one-line RoarError (or ValueError
    subclass of one), nothing else."""
    from roar.errors import RoarError

    path = _TMP / f"input{suffix}"
    path.write_bytes(data)
    try:
        load(path)
    except RoarError as e:
        assert "\n" not in str(e).strip(), repr(str(e))


def track_json(data: bytes) -> None:
    from roar.tracks.track_files import load_json

    _reads(".json", load_json, data)


def track_csv(data: bytes) -> None:
    from roar.tracks.track_files import load_centreline_csv, load_raceline_csv

    _reads(".csv", load_centreline_csv, data)
    _reads(".csv", load_raceline_csv, data)


def waypoints(data: bytes) -> None:
    from roar.autopilot.waypoints import load_waypoints

    _reads(".csv", load_waypoints, data)


def calibration(data: bytes) -> None:
    from roar.calibration import Calibration

    _reads(".toml", Calibration.load, data)


def map_yaml(data: bytes) -> None:
    """A map's YAML beside a small valid image (map.pgm), so the YAML's own fields are what is fuzzed."""
    from roar.tracks.occupancy_map import load_map

    image = _TMP / "map.pgm"
    if not image.exists():
        image.write_bytes(b"P5\n4 4\n255\n" + bytes([254] * 8 + [0] * 8))
    _reads(".yaml", load_map, data)


TARGETS = {"control": control, "sbus": sbus, "junior_query": junior_query, "stream": stream, "lines": lines,
           "track_json": track_json, "track_csv": track_csv, "waypoints": waypoints, "calibration": calibration,
           "map_yaml": map_yaml}


def main() -> None:
    """python -m fuzz.python_targets NAME [libFuzzer options] [CORPUS ...]: one target under atheris."""
    import os
    import sys

    import atheris

    name = sys.argv[1]
    with atheris.instrument_imports(include=["roar", "roar_wire"]):  # before anything imports them
        import roar.autopilot.waypoints  # noqa: F401  (what the targets use, instrumented)
        import roar.calibration  # noqa: F401
        import roar.protocol.control  # noqa: F401
        import roar.stream  # noqa: F401
        import roar.telemetry  # noqa: F401
        import roar.tracks.occupancy_map  # noqa: F401
        import roar.tracks.track_files  # noqa: F401
        import roar_wire.junior  # noqa: F401
        import roar_wire.sbus  # noqa: F401
        import roar_wire.v2v  # noqa: F401
    self = os.environ.get("ROAR_FUZZ_SELF", sys.argv[0])  # the script fuzz.engine starts: -merge runs it again
    atheris.Setup([self, *sys.argv[2:]], TARGETS[name])
    atheris.Fuzz()


if __name__ == "__main__":
    main()
