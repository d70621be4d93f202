"""Track files: the project's JSON, the F1TENTH/TUM centre-line CSV, and TUM's race-line CSV.

JSON (one width):

    {"name": "my-track", "width_m": 1.2, "centerline": [[x0, y0], [x1, y1], ...]}

Centre-line CSV (the F1TENTH race-track collection's and TUM's; a width to each side per point),
lines starting with # are comments:

    # x_m, y_m, w_tr_right_m, w_tr_left_m
    0.0, 0.0, 1.1, 1.1

Race-line CSV (TUM's global race trajectory, semicolon separated):

    # s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2

psi is the heading from north (the y axis), anticlockwise: psi = yaw - pi/2. A last row that
repeats the first (a closed line written out) is dropped. Every error is one line naming the file
(and the line).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from roar.checks import printable, shown
from roar.tracks.track import MAX_NAME_CHARS, MIN_SPACING_M, Track, TrackError

# [decimals of a metre] a written point: micrometres, so a track reads back with the bends it was
# written with (at 0.1 mm, a 2.04 m bend read back as 2.01 m: curvature comes from neighbours 5 cm apart)
DIGITS = 6
from roar.user_files import read_parsed, read_text

CENTRELINE_COLUMNS = "x_m, y_m, w_tr_right_m, w_tr_left_m"
RACELINE_COLUMNS = "s_m; x_m; y_m; psi_rad; kappa_radpm; vx_mps; ax_mps2"
MAX_COORDINATE_M = 10_000.0  # [m] beyond this a number in a track file is a mistake


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def load_json(path: str | Path) -> Track:
    path = Path(path)
    data = read_parsed(path, json.loads, TrackError, "JSON")
    if not isinstance(data, dict) or not {"width_m", "centerline"} <= set(data):
        raise TrackError(f"{path}: a track file needs 'width_m' and 'centerline' (and optionally 'name')")
    unknown = set(data) - {"name", "width_m", "centerline"}
    if unknown:
        raise TrackError(f"{path}: unknown keys {sorted(unknown)}")
    cl = data["centerline"]
    if not isinstance(cl, list) or not all(isinstance(p, list) and len(p) == 2 and
                                           all(_is_number(v) for v in p) for p in cl):
        raise TrackError(f"{path}: centerline must be a list of [x, y] number pairs")
    if not _is_number(data["width_m"]):
        raise TrackError(f"{path}: width_m must be a number of metres, got {data['width_m']!r}")
    name = data.get("name", path.stem)
    if not isinstance(name, str):
        raise TrackError(f"{path}: name must be a string, got {shown(name)}")
    try:
        return Track(printable(name, MAX_NAME_CHARS), np.array(cl, dtype=float), data["width_m"])
    except TrackError as e:
        raise TrackError(f"{path}: {e}") from None


def to_json(track: Track) -> str:
    if not track.uniform_width:
        raise TrackError(f"track {track.name!r} is not one width all round: write it as a centre-line .csv")
    return json.dumps({"name": track.name, "width_m": track.width_m,
                       "centerline": [[round(float(x), DIGITS), round(float(y), DIGITS)] for x, y in track.centerline]})


def _rows(path: Path, separator: str, columns: str) -> list[tuple[int, list[float]]]:
    """(line number, values) of each data line: every field a finite number within reach."""
    count = len(columns.split(separator.strip() or ","))
    rows = []
    for number, line in enumerate(read_text(path, TrackError).splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(separator)]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows and not any(c.isdigit() for c in line):
                continue  # a header line without the #
            values = []
        if len(fields) != count or len(values) != count or not all(map(math.isfinite, values)):
            raise TrackError(f"{path}:{number}: expected {count} finite numbers ({columns}), got "
                             f"{printable(line, 60)!r}")
        if max(abs(v) for v in values) > MAX_COORDINATE_M:
            raise TrackError(f"{path}:{number}: a number beyond {MAX_COORDINATE_M:g}: {printable(line, 60)!r}")
        rows.append((number, values))
    return rows


def _closed(rows: list[tuple[int, list[float]]], x: int) -> list[tuple[int, list[float]]]:
    """Rows without repeats of the point before (nor a last one repeating the first)."""
    kept: list[tuple[int, list[float]]] = []
    for row in rows:
        if kept and math.dist(kept[-1][1][x:x + 2], row[1][x:x + 2]) < MIN_SPACING_M:
            continue
        kept.append(row)
    if len(kept) > 1 and math.dist(kept[0][1][x:x + 2], kept[-1][1][x:x + 2]) < MIN_SPACING_M:
        kept.pop()
    return kept


def load_centreline_csv(path: str | Path, name: str | None = None) -> Track:
    """A track from an F1TENTH/TUM centre-line CSV: x, y and the distances to the right and left
    walls per point."""
    path = Path(path)
    rows = _closed(_rows(path, ",", CENTRELINE_COLUMNS), 0)
    for number, (_, _, right, left) in rows:
        if right <= 0 or left <= 0:
            raise TrackError(f"{path}:{number}: the widths to the walls must be positive, got right {right:g} m, "
                             f"left {left:g} m")
    if not rows:
        raise TrackError(f"{path}: no points ({CENTRELINE_COLUMNS} per line)")
    values = np.array([v for _, v in rows])
    try:
        return Track.with_widths(printable(name or _stem(path), MAX_NAME_CHARS), values[:, :2], values[:, [3, 2]])
    except TrackError as e:
        raise TrackError(f"{path}: {e}") from None


def centreline_csv(track: Track) -> str:
    lines = [f"# {CENTRELINE_COLUMNS}"]
    lines += [f"{x:.{DIGITS}f}, {y:.{DIGITS}f}, {right:.4f}, {left:.4f}"
              for (x, y), (left, right) in zip(track.centerline, track.half_widths)]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class RaceLine:
    """A closed line to drive: points (N, 2) [m] and, where the file gave them, speeds (N,) [m/s]."""

    points: np.ndarray
    speeds: np.ndarray | None = None


def load_raceline_csv(path: str | Path) -> RaceLine:
    """x, y and vx of a TUM race-line CSV (the other columns are checked as numbers, not used)."""
    path = Path(path)
    rows = _closed(_rows(path, ";", RACELINE_COLUMNS), 1)
    if len(rows) < 3:
        raise TrackError(f"{path}: a race line needs at least 3 distinct points ({RACELINE_COLUMNS} per line), "
                         f"has {len(rows)}")
    values = np.array([v for _, v in rows])
    for number, row in rows:
        if row[5] < 0:
            raise TrackError(f"{path}:{number}: vx_mps must not be negative, got {row[5]:g}")
    return RaceLine(values[:, 1:3], values[:, 5])


def raceline_csv(points: np.ndarray, speeds: np.ndarray, accelerations: np.ndarray | None = None) -> str:
    """A closed line in TUM's race-line format (the first point repeated at the end, as TUM's are)."""
    pts = np.vstack([points, points[:1]])
    v = np.append(speeds, speeds[0])
    ds = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(ds)])
    d = (np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)) / 2  # round the closed line
    dd = np.roll(points, -1, axis=0) - 2 * points + np.roll(points, 1, axis=0)
    d, dd = np.vstack([d, d[:1]]), np.vstack([dd, dd[:1]])
    kappa = (d[:, 0] * dd[:, 1] - d[:, 1] * dd[:, 0]) / np.maximum(np.hypot(d[:, 0], d[:, 1]) ** 3, 1e-12)
    psi = np.arctan2(d[:, 1], d[:, 0]) - math.pi / 2
    psi = (psi + math.pi) % (2 * math.pi) - math.pi
    ax = np.append(accelerations, accelerations[0]) if accelerations is not None else \
        np.append((v[1:] ** 2 - v[:-1] ** 2) / (2 * np.maximum(ds, 1e-9)), 0.0)
    lines = [f"# {RACELINE_COLUMNS}"]
    lines += [f"{s[i]:.4f}; {pts[i, 0]:.4f}; {pts[i, 1]:.4f}; {psi[i]:.6f}; {kappa[i]:.6f}; {v[i]:.4f}; {ax[i]:.4f}"
              for i in range(len(pts))]
    return "\n".join(lines) + "\n"


def _stem(path: Path) -> str:
    """A track's name from its file: Spielberg_centerline.csv -> Spielberg."""
    for suffix in ("_centerline", "_centreline", "_map"):
        if path.stem.endswith(suffix) and len(path.stem) > len(suffix):
            return path.stem[: -len(suffix)]
    return path.stem
