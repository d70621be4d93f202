"""The seeds every corpus starts from, made from the project's own golden vectors and writers
(so a change to a format changes its seeds), and the regression inputs of defects found.

    python -m fuzz seed        writes them into fuzz/corpus/TARGET/, named by their SHA-1 as
                               libFuzzer names what it finds (writing one twice changes nothing)
"""

from __future__ import annotations

import hashlib
import json
import struct
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"
VECTORS = ROOT / "protocol" / "vectors"

# Defects found by fuzzing: target -> inputs that must stay harmless
REGRESSIONS = {
    # a depth frame whose principal point cy is NaN: roar.stream once raised from depth_shape
    # (round(nan)) inside asyncio's datagram handler, and no counter recorded the datagram
    "py_stream": [bytes([25]) + bytes.fromhex("3030303030303030300000803f0000803f0000c07f0000803f")],
}


def sbus_pairs(frame: bytes, pause: int = 200) -> bytes:
    """A frame as the SBUS targets read bytes: (pause / 25 us, byte) pairs, a frame gap first."""
    return b"".join(bytes((pause if i == 0 else 0, b)) for i, b in enumerate(frame))


def control_messages() -> list[bytes]:
    cases = json.loads((VECTORS / "control_messages.json").read_text())["cases"]
    signed = json.loads((VECTORS / "signed_messages.json").read_text())["cases"]
    return ["".join(c["chunks"]).encode() for c in cases] + ["".join(c["messages"]).encode() for c in signed]


def signed_session() -> list[bytes]:
    """The golden vectors' in-order messages, signed under their key for their session."""
    case = next(c for c in json.loads((VECTORS / "signed_messages.json").read_text())["cases"] if c["name"] == "in_order")
    return [m.encode() for m in case["messages"]]


def sbus_frames() -> list[bytes]:
    cases = json.loads((VECTORS / "sbus_frames.json").read_text())["cases"]
    return [bytes.fromhex(c["hex"]) for c in cases]


QUERIES = ["forward=True", "backward=True&left_spd=0.5&right_spd=0.5", "stop=True", "turnLeft=False&speed=1",
           "left_spd=.25", "forward=true", "left_spd=1.01", "x=1&&", "right_spd=0.123456"]


def http_requests() -> list[bytes]:
    from roar_wire import signing

    from fuzz.twins import JUNIOR_SESSION, SIGNING_KEY

    get = "GET /?{} HTTP/1.1\r\nHost: junior\r\nConnection: keep-alive\r\n\r\n"
    signed = [signing.sign_query(q, SIGNING_KEY, JUNIOR_SESSION, n + 1) for n, q in enumerate(QUERIES[:3])]
    return [get.format(q).encode() for q in QUERIES[:3]] + [
        "".join(get.format(q) for q in signed + signed[:1]).encode(),  # signed, then one replayed
        get.format(signed[0].replace("ctr=1", "ctr=9")).encode(),  # altered
        get.format("forward=True&ctr=1&mac=0").encode(),  # truncated
    ] + [
        (get.format(QUERIES[0]) + get.format(QUERIES[2])).encode(),  # pipelined
        b"GET /cam-lo.jpg HTTP/1.0\r\n\r\n",
        b"POST /?forward=True HTTP/1.1\r\nContent-Length: 3\r\n\r\nabc",
        b"GET /?" + b"a" * 300 + b" HTTP/1.1\r\n\r\n",
        b"GET /?forward=True HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n",
    ]


def car_board_inputs() -> list[bytes]:
    def serial(text: bytes, wait: bool = False) -> bytes:
        return bytes((len(text) | (0x80 if wait else 0),)) + text

    def ble(text: bytes) -> bytes:
        return bytes((len(text) | 0x40,)) + text

    key = json.loads((VECTORS / "signed_messages.json").read_text())["key"].encode()
    signed = signed_session()
    return [serial(b"(1500,1500)\n") + serial(b"(1800,1200)\n", True) + serial(b"(1200,1500)\n", True),
            ble(b"(1500,1500)") + ble(b"(2000,2000)"), serial(b"(1500,15"), serial(b"[1000,1500]\n"),
            serial(b"KEY " + key[:28]) + serial(key[28:] + b"\n") + serial(signed[0], True) + ble(signed[1])
            + serial(b"KEY ?\n", True) + ble(b"KEY -\n") + serial(b"KEY -\n", True)]


def iarrc_board_inputs() -> list[bytes]:
    def to(where: int, data: bytes, wait: bool = False) -> bytes:
        return b"".join(bytes((len(data[i:i + 31]) | where << 5 | (0x80 if wait else 0),)) + data[i:i + 31]
                        for i in range(0, len(data), 31))

    frame = sbus_frames()[0]
    return [to(0, b"[0,1500]\n") + to(0, b"[1500,1600]\n", True), to(1, b"P 800 100 10 500\n"),
            to(2, frame, True) * 4 + to(0, b"[800,1500]\n", True), to(0, b"[-6000,1500]\n")]


def stream_datagrams() -> list[bytes]:
    from roar_wire import stream as wire

    def grams(payload: bytes, frame_id: int) -> bytes:
        return b"".join(bytes((len(g),)) + g for g in wire.chunks(payload, frame_id) if len(g) < 256)

    depth = wire.with_intrinsics(100.0, 100.0, 2.0, 1.0, struct.pack("<8f", *range(8)))
    state = wire.state_line({"x": 1.5, "y": -2.0})
    return [grams(depth, 1), grams(state, 2), grams(b"\xff\xd8" + b"\x00" * 8, 3)]


def lines() -> list[bytes]:
    from roar_wire import stream as wire
    from roar_wire import v2v

    return [b"TEL autonomous none 7400 0 1200 800 800 1600 1500 120 800 100 10 500 0", b"READY 2", b"ERR range",
            b"FAILSAFE", v2v.encode(3, 17, 1.5, -2.25, 0.5, 1.0), wire.state_line({"x": 1.0}), b"0.25,-0.5\n"]


def files() -> dict[str, list[bytes]]:
    """Track, race line, waypoint, calibration and map files as the project writes them."""
    import numpy as np

    from roar.autopilot.waypoints import save_waypoints
    from roar.calibration import Calibration, ChannelCalibration
    from roar.tracks import get
    from roar.tracks.track_files import centreline_csv, raceline_csv, to_json

    track = get("oval")
    with tempfile.TemporaryDirectory() as tmp:
        waypoints = Path(tmp) / "w.csv"
        save_waypoints(waypoints, track.centerline[::8])
        calibration = Path(tmp) / "c.toml"
        Calibration(steering=ChannelCalibration(trim_us=1520, reversed=True)).save(calibration)
        points = track.centerline[::4]
        race = raceline_csv(points, np.full(len(points), 2.0)).encode()
        return {
            "py_track_json": [to_json(track).encode()],
            "py_track_csv": [centreline_csv(track).encode(), race],
            "py_waypoints": [waypoints.read_bytes()],
            "py_calibration": [calibration.read_bytes()],
            "py_map_yaml": [b"image: map.pgm\nresolution: 0.05\norigin: [-1.0, -2.0, 0.0]\nnegate: 0\n"
                            b"occupied_thresh: 0.65\nfree_thresh: 0.196\n"],
        }


def seeds() -> dict[str, list[bytes]]:
    messages = control_messages()
    frames = [sbus_pairs(f) for f in sbus_frames()]
    found = {
        "control_parser": messages, "py_control": messages,
        "sbus": frames, "py_sbus": frames,
        "junior_query": [q.encode() for q in QUERIES], "py_junior_query": [q.encode() for q in QUERIES],
        "junior_http": http_requests(), "car_board": car_board_inputs(), "iarrc_board": iarrc_board_inputs(),
        "py_stream": stream_datagrams(), "py_lines": lines(), **files(),
    }
    for target, inputs in REGRESSIONS.items():
        found[target] = found.get(target, []) + inputs
    return found


def write() -> int:
    """Every seed into its corpus folder; returns how many were new."""
    new = 0
    for target, inputs in seeds().items():
        folder = CORPUS / target
        folder.mkdir(parents=True, exist_ok=True)
        for data in inputs:
            path = folder / hashlib.sha1(data).hexdigest()
            if not path.exists():
                path.write_bytes(data)
                new += 1
    return new
