"""Datasets from recordings (roar.recorder's MCAP files) for imitation learning: each camera frame
with the command the car was driving by when it was taken.

    write_donkey("run.mcap", "tub/")     # a DonkeyCar tub v2 (its own Tub class reads it)
    write_npz("run.mcap", "run.npz")     # images (N, H, W, 3) uint8, angle, throttle, t_s: for PyTorch

Angle and throttle are the pulses as fractions: (pulse - 1500 us) / 500 us, in [-1, 1]; angle +1
is full right, as DonkeyCar's user/angle. A speed car's throttle is its setpoint over the
protocol's top speed; the Junior's link carries fractions already. A tub's user/mode is "user" for a run a person drove
and "local" for one an autopilot drove (a race's recording says which driver).

The tub v2 layout, as DonkeyCar's datastore reads it: `manifest.json` (five JSON lines: the
inputs, their types, the user's metadata, the manifest's metadata with its sessions, the catalog
metadata: paths, current index, max length, deleted indexes), `catalog_N.catalog` files of one
JSON record per line (keys sorted) beside `catalog_N.catalog_manifest` (one JSON line: the
catalog's path, creation time, first index and each line's length in bytes, newline included),
and the frames as JPEG files under `images/`, named INDEX_cam_image_array_.jpg.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from roar.replay import ReplayError, messages, metadata

INPUTS = ["cam/image_array", "user/angle", "user/throttle", "user/mode"]
TYPES = ["image_array", "float", "float", "str"]
CATALOG_LEN = 1000  # records per catalog file, as DonkeyCar writes them
NEUTRAL_US, HALF_RANGE_US = 1500, 500  # [us]


def frames(path: str | Path):
    """(log time [ns], RGB HxWx3 uint8, angle, throttle) for each camera frame, with the latest
    command sent before it (neutral before the first): in the order they were recorded, as a
    command and a frame of the same simulated moment are only told apart by it."""
    from roar.vision.geometry import cv2

    angle = throttle = 0.0
    seen = False
    for topic, t, msg in messages(path, ["/control", "/camera/image"], as_written=True):  # a command, then its frame
        if topic == "/control":
            angle, throttle = _command(msg, angle, throttle)
            continue
        seen = True
        bgr = cv2().imdecode(np.frombuffer(msg.data, np.uint8), cv2().IMREAD_COLOR)
        if bgr is None:
            raise ReplayError(f"{path}: a camera frame at {t / 1e9:.3f} s is not an image")
        yield t, np.ascontiguousarray(bgr[:, :, ::-1]), angle, throttle
    if not seen:
        raise ReplayError(f"{path}: no camera frames (record with a camera: Vehicle.camera() in the run)")


def _command(msg: dict, angle: float, throttle: float) -> tuple[float, float]:
    """(angle, throttle) in -1..1 of a control message: pulses, a speed setpoint (throttle: the
    speed over the protocol's top speed), or a link's own fractions (the Junior's); others keep
    the last."""
    from roar.protocol import spec

    if "steering_us" in msg:
        angle = (msg["steering_us"] - NEUTRAL_US) / HALF_RANGE_US
    if "throttle_us" in msg:
        throttle = (msg["throttle_us"] - NEUTRAL_US) / HALF_RANGE_US
    elif "speed_mm_s" in msg:
        throttle = msg["speed_mm_s"] / spec.SETPOINT_MAX_SPEED_MM_S
    elif "throttle" in msg and "steering" in msg:
        angle, throttle = msg["steering"], msg["throttle"]
    return float(angle), float(throttle)


def _mode(run: dict) -> str:
    """A tub's user/mode for a recording's "run" record: an autopilot's race says its driver."""
    return "local" if run.get("driver") else "user"


def write_npz(path: str | Path, out: str | Path) -> int:
    """The frames and their commands as one .npz; returns the number of frames."""
    rows = list(frames(path))
    np.savez_compressed(out, images=np.stack([r[1] for r in rows]), angle=np.array([r[2] for r in rows], np.float32),
                        throttle=np.array([r[3] for r in rows], np.float32),
                        t_s=np.array([r[0] / 1e9 for r in rows], np.float64))
    return len(rows)


def write_donkey(path: str | Path, out: str | Path) -> int:
    """A DonkeyCar tub v2 in the folder out (made; it must not hold a tub already); returns the
    number of records."""
    from roar.vision.geometry import cv2

    out = Path(out)
    if (out / "manifest.json").exists():
        raise ReplayError(f"{out}: already a tub (give a new folder)")
    (out / "images").mkdir(parents=True, exist_ok=True)
    run = metadata(path).get("run", {})
    offset_ms = int(run.get("wall_clock_offset_ns", 0)) // 1_000_000  # monotonic -> wall clock (0: simulated)
    mode = _mode(run)
    day = time.strftime("%y-%m-%d")
    session = f"{day}_0"
    catalogs: list[str] = []
    index = 0
    lines: list[str] = []

    def flush_catalog() -> None:
        name = f"catalog_{len(catalogs)}"
        (out / f"{name}.catalog").write_text("".join(lines), encoding="ascii")
        meta = {"created_at": time.time(), "line_lengths": [len(line) for line in lines], "path":
                f"{name}.catalog_manifest", "start_index": index - len(lines)}
        (out / f"{name}.catalog_manifest").write_text(json.dumps(meta, sort_keys=True) + "\n", encoding="ascii")
        catalogs.append(f"{name}.catalog")
        lines.clear()

    for t, rgb, angle, throttle in frames(path):
        image = f"{index}_cam_image_array_.jpg"
        cv2().imwrite(str(out / "images" / image), np.ascontiguousarray(rgb[:, :, ::-1]))
        record = {"cam/image_array": image, "user/angle": float(angle), "user/throttle": float(throttle),
                  "user/mode": mode, "_timestamp_ms": t // 1_000_000 + offset_ms, "_index": index,
                  "_session_id": session}
        lines.append(json.dumps(record, sort_keys=True) + "\n")
        index += 1
        if len(lines) == CATALOG_LEN:
            flush_catalog()
    if lines or not catalogs:
        flush_catalog()
    manifest = [INPUTS, TYPES, {"recording": str(path), "car": run.get("car", "")},
                {"created_at": time.time(), "sessions": {"all_full_ids": [session], "last_id": 0,
                                                         "last_full_id": session}},
                {"paths": catalogs, "current_index": index, "max_len": CATALOG_LEN, "deleted_indexes": []}]
    (out / "manifest.json").write_text("".join(json.dumps(line) + "\n" for line in manifest), encoding="ascii")
    return index
