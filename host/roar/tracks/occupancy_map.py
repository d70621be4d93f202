"""Occupancy maps in the F1TENTH/ROS format (map_server's): NAME.yaml beside a greyscale image.

    image: NAME.png          # relative to the YAML (PNG, PGM, ...: anything Pillow reads)
    resolution: 0.05         # [m] per pixel
    origin: [x, y, yaw]      # [m, m, rad] the world pose of the image's bottom-left corner
    negate: 0                # 1: white is occupied
    occupied_thresh: 0.65    # a pixel whose occupancy (255 - value) / 255 is above this is a wall
    free_thresh: 0.196       # ... below this is free; in between is unknown

load_map() reads one (every problem one line naming the file), save_map() writes one, and
track_map() draws a track as one: free cells inside its walls, occupied ones along them, unknown
beyond. A map is a world (load_map_track): its walls are the edges of the free space the car is
in, its centre line (and each point's widths) that of NAME_centerline.csv beside it (the F1TENTH
race-track collection's layout: NAME_map.yaml, NAME_map.png, NAME_centerline.csv; a tunnel's
NAME_course.yaml beside them puts its cones, markers and people back) or, without
one, the line midway between the outer wall and the infield's, started nearest the map's origin
(where F1TENTH maps put the car) and driven anticlockwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from roar.checks import number, printable
from roar.tracks.track import MAX_DISTANCE_M, Track, TrackError, evenly_spaced

FREE, UNKNOWN, OCCUPIED = 254, 205, 0  # pixel values map_saver writes
MAX_PIXELS = 50_000_000  # an image beyond this is a mistake (a 50 m x 50 m map at 1 cm is 25 M)
RESOLUTION_RANGE_M = (0.005, 1.0)  # [m] per pixel
DEFAULTS = {"negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}
WALL_CELLS = 2  # occupied cells drawn along a track's walls
CENTRELINE_SPACING_M = 0.1  # [m] between points of a centre line found in the free space


@dataclass(frozen=True)
class OccupancyMap:
    """occupied and free: (rows, cols) bool, row 0 the top of the image (the largest y);
    resolution [m] per cell; origin (x [m], y [m], yaw [rad]) of the bottom-left corner."""

    occupied: np.ndarray
    free: np.ndarray
    resolution_m: float
    origin: tuple[float, float, float]

    def to_world(self, cols, rows) -> np.ndarray:
        """(N, 2) world points [m] of (fractional) cell coordinates, cell centres at integers."""
        ox, oy, yaw = self.origin
        u = (np.asarray(cols, dtype=float) + 0.5) * self.resolution_m
        v = (self.free.shape[0] - 0.5 - np.asarray(rows, dtype=float)) * self.resolution_m
        c, s = math.cos(yaw), math.sin(yaw)
        return np.stack([ox + c * u - s * v, oy + s * u + c * v], axis=-1)

    def to_cells(self, xy) -> np.ndarray:
        """(N, 2) (col, row) fractional cell coordinates of world points."""
        ox, oy, yaw = self.origin
        p = np.asarray(xy, dtype=float) - (ox, oy)
        c, s = math.cos(yaw), math.sin(yaw)
        u, v = c * p[..., 0] + s * p[..., 1], -s * p[..., 0] + c * p[..., 1]
        return np.stack([u / self.resolution_m - 0.5, self.free.shape[0] - 0.5 - v / self.resolution_m], axis=-1)

    def cell_centres(self) -> np.ndarray:
        """(rows * cols, 2) world points [m] of every cell's centre, row by row."""
        rows, cols = self.free.shape
        r, c = np.mgrid[0:rows, 0:cols]
        return self.to_world(c.ravel(), r.ravel())

    def image(self) -> np.ndarray:
        """The uint8 image map_saver would write: free white, walls black, unknown grey."""
        out = np.full(self.free.shape, UNKNOWN, np.uint8)
        out[self.free] = FREE
        out[self.occupied] = OCCUPIED
        return out


def _yaml_number(value):
    """A number as ROS's map_server reads it: YAML 1.1 (PyYAML) takes `1e9` (no dot) for text,
    yaml-cpp for a number, and so does this; anything else as it is."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _number(path: Path, data: dict, key: str, low: float, high: float) -> float:
    """data[key] checked by roar.checks.number, its error naming the file."""
    try:
        return number(key, _yaml_number(data[key]), low, high, given=data[key])
    except ValueError as e:
        raise TrackError(f"{path}: {e}") from None


def load_map(path: str | Path) -> OccupancyMap:
    """The map a YAML names; TrackError naming the file and the problem, in one line."""
    import yaml
    from PIL import Image, UnidentifiedImageError

    from roar.user_files import read_text

    path = Path(path)
    text = read_text(path, TrackError)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise TrackError(f"{path}: not valid YAML{where}: {getattr(e, 'problem', None) or 'cannot parse'}") from None
    if not isinstance(data, dict):
        raise TrackError(f"{path}: a map YAML is a mapping with image, resolution and origin")
    missing = [k for k in ("image", "resolution", "origin") if k not in data]
    if missing:
        raise TrackError(f"{path}: a map YAML needs {', '.join(missing)} (image, resolution [m/px], origin [x, y, yaw])")
    data = {**DEFAULTS, **data}
    resolution = _number(path, data, "resolution", *RESOLUTION_RANGE_M)
    occupied_thresh = _number(path, data, "occupied_thresh", 0.0, 1.0)
    free_thresh = _number(path, data, "free_thresh", 0.0, 1.0)
    if free_thresh >= occupied_thresh:
        raise TrackError(f"{path}: free_thresh ({free_thresh:g}) must be below occupied_thresh ({occupied_thresh:g})")
    if data["negate"] not in (0, 1, True, False):
        raise TrackError(f"{path}: negate must be 0 or 1, got {printable(repr(data['negate']), 40)}")
    origin = [_yaml_number(v) for v in data["origin"]] if isinstance(data["origin"], list) else data["origin"]
    if not isinstance(origin, list) or len(origin) != 3 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in origin):
        raise TrackError(f"{path}: origin must be [x, y, yaw] (finite numbers), got {printable(repr(data['origin']), 40)}")
    if not isinstance(data["image"], str) or not data["image"].strip():
        raise TrackError(f"{path}: image must name the map's image file")
    image_path = path.parent / data["image"]
    Image.MAX_IMAGE_PIXELS = MAX_PIXELS
    try:
        with Image.open(image_path) as im:
            if im.width * im.height > MAX_PIXELS:
                raise TrackError(f"{path}: image {data['image']} has {im.width} x {im.height} pixels (at most "
                                 f"{MAX_PIXELS:,})")
            grey = np.asarray(im.convert("L"), dtype=np.float64)
    except FileNotFoundError:
        raise TrackError(f"{path}: its image {image_path} does not exist") from None
    except (UnidentifiedImageError, Image.DecompressionBombError, OSError, SyntaxError, ValueError) as e:
        reason = "not an image Pillow can read" if isinstance(e, UnidentifiedImageError) else str(e) or type(e).__name__
        raise TrackError(f"{path}: its image {image_path}: {printable(reason, 100)}") from None
    if min(grey.shape) < 2:
        raise TrackError(f"{path}: image {data['image']} is {grey.shape[1]} x {grey.shape[0]} pixels: too small")
    occupancy = grey / 255.0 if data["negate"] else (255.0 - grey) / 255.0
    grid = OccupancyMap(occupancy > occupied_thresh, occupancy < free_thresh, resolution, tuple(map(float, origin)))
    corners = grid.to_world([0, grey.shape[1] - 1, 0, grey.shape[1] - 1], [0, 0, grey.shape[0] - 1, grey.shape[0] - 1])
    nearest = float(np.min(np.linalg.norm(corners, axis=1)))
    inside = np.all((corners.min(axis=0) <= 0) & (corners.max(axis=0) >= 0))
    if not inside and nearest > MAX_DISTANCE_M:
        raise TrackError(f"{path}: origin {origin[:2]} puts the map {nearest:.0f} m from the world's origin (at most "
                         f"{MAX_DISTANCE_M:g} m)")
    if not grid.free.any():
        raise TrackError(f"{path}: the map has no free cells (free_thresh {free_thresh:g}, negate {data['negate']})")
    return grid


def save_map(path: str | Path, grid: OccupancyMap) -> None:
    """NAME.yaml and NAME.png beside it (map_saver's trinary values)."""
    from PIL import Image

    path = Path(path)
    png = path.with_suffix(".png")
    Image.fromarray(grid.image()).save(png)
    ox, oy, yaw = grid.origin
    path.write_text(f"image: {png.name}\nresolution: {grid.resolution_m:g}\norigin: [{ox:.4f}, {oy:.4f}, {yaw:.4f}]\n"
                    f"negate: 0\noccupied_thresh: {DEFAULTS['occupied_thresh']}\n"
                    f"free_thresh: {DEFAULTS['free_thresh']}\n", encoding="utf-8")


def track_map(track: Track, resolution_m: float = 0.05, margin_m: float = 0.5, inset_m: float = 0.0) -> OccupancyMap:
    """The track as a map: its driving area free, WALL_CELLS of wall round it, unknown beyond.
    Only the walls: what stands on a tunnel's floor (cones, people) is not in the map. inset_m [m]:
    the walls' faces stand this far into the driving area (the simulator's walls are centred on its
    edges: roar_sim.world.scene.world_map)."""
    import shapely
    from scipy import ndimage

    lo, hi = np.reshape(track.region.bounds, (2, 2))
    lo, hi = lo - margin_m, hi + margin_m
    cols, rows = np.ceil((hi - lo) / resolution_m).astype(int)
    grid = OccupancyMap(np.zeros((rows, cols), bool), np.zeros((rows, cols), bool), resolution_m,
                        (float(lo[0]), float(lo[1]), 0.0))
    centres = grid.cell_centres()
    area = track.region.buffer(-inset_m) if inset_m > 0 else track.region
    free = shapely.contains_xy(area, centres[:, 0], centres[:, 1]).reshape(rows, cols)
    wall = ndimage.binary_dilation(free, iterations=WALL_CELLS) & ~free
    return OccupancyMap(wall, free, resolution_m, grid.origin)


def free_area(grid: OccupancyMap, near_xy) -> object:
    """The free space connected to the point near_xy as a shapely Polygon (its edges are the walls)."""
    import contourpy
    import shapely
    from scipy import ndimage

    labels, _ = ndimage.label(grid.free)
    col, row = np.round(grid.to_cells(np.asarray(near_xy)[None])[0]).astype(int)
    rows, cols = grid.free.shape
    if not (0 <= row < rows and 0 <= col < cols) or labels[row, col] == 0:
        dist, (ir, ic) = ndimage.distance_transform_edt(labels == 0, return_indices=True)
        row, col = ir[np.clip(row, 0, rows - 1), np.clip(col, 0, cols - 1)], ic[np.clip(row, 0, rows - 1),
                                                                                  np.clip(col, 0, cols - 1)]
    mine = np.pad(labels == labels[row, col], 1).astype(float)  # padded: every edge is a closed contour
    rings = [grid.to_world(line[:, 0] - 1, line[:, 1] - 1)
             for line in contourpy.contour_generator(z=mine, line_type="Separate").lines(0.5) if len(line) >= 4]
    polygons = sorted((shapely.Polygon(ring) for ring in rings), key=lambda p: -p.area)
    outer, holes = polygons[0], [p for p in polygons[1:] if polygons[0].contains(p.representative_point())]
    area = shapely.Polygon(outer.exterior.coords, [h.exterior.coords for h in holes]).buffer(0)
    if area.geom_type != "Polygon":
        area = max(area.geoms, key=lambda g: g.area)
    return area.simplify(grid.resolution_m / 2)


def centreline_of(grid: OccupancyMap, area) -> tuple[np.ndarray, np.ndarray]:
    """(centre line (N, 2) [m], half widths (N, 2) [m]) midway between the free area's outer edge
    and its largest hole, anticlockwise, from the point nearest the world's origin."""
    import contourpy
    import shapely
    from scipy import ndimage

    if not area.interiors:
        raise TrackError("the free space has no infield: no loop to drive (give its centre line as a CSV beside it)")
    rows, cols = grid.free.shape
    centres = grid.cell_centres()
    hole = max(area.interiors, key=lambda ring: shapely.Polygon(ring).area)
    outside = ~shapely.contains_xy(shapely.Polygon(area.exterior), centres[:, 0], centres[:, 1]).reshape(rows, cols)
    infield = shapely.contains_xy(shapely.Polygon(hole), centres[:, 0], centres[:, 1]).reshape(rows, cols)
    between = ndimage.distance_transform_edt(~outside) - ndimage.distance_transform_edt(~infield)
    lines = contourpy.contour_generator(z=between, line_type="Separate").lines(0.0)
    line = max(lines, key=len)
    points = grid.to_world(line[:, 0], line[:, 1])
    if np.allclose(points[0], points[-1]):
        points = points[:-1]
    points = _resampled(points, CENTRELINE_SPACING_M)
    x, y = points[:, 0], points[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
        points = points[::-1]
    points = np.roll(points, -int(np.argmin(np.linalg.norm(points, axis=1))), axis=0)
    clearance = ndimage.distance_transform_edt(grid.free) * grid.resolution_m
    cells = np.round(grid.to_cells(points)).astype(int)
    half = clearance[np.clip(cells[:, 1], 0, rows - 1), np.clip(cells[:, 0], 0, cols - 1)]
    return points, np.stack([half, half], axis=1)


def _resampled(points: np.ndarray, spacing_m: float) -> np.ndarray:
    """A closed polyline smoothed over a few cells and resampled every spacing_m."""
    length = float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum())
    even = evenly_spaced(points, max(8, int(length / spacing_m)))
    k = 5  # a moving average over +-k points takes out the contour's cell steps
    return sum(np.roll(even, j, axis=0) for j in range(-k, k + 1)) / (2 * k + 1)


def load_map_track(path: str | Path) -> Track:
    """A track whose walls are a map's (see the module's text)."""
    from roar.tracks.track_files import _stem, load_centreline_csv

    path = Path(path)
    grid = load_map(path)
    name = _stem(path)
    csv = next((p for p in (path.with_name(f"{name}_centerline.csv"), path.with_name(f"{name}_centreline.csv"),
                            path.with_suffix(".csv")) if p.exists()), None)
    course_file = path.with_name(f"{name}_course.yaml")
    course = None
    if course_file.exists():
        from roar.tracks.tunnel import load_course

        course = load_course(course_file)
    if csv is not None:
        given = load_centreline_csv(csv, name)
        area = free_area(grid, given.centerline[0])
        return Track(given.name, given.centerline, given.width_m, given.half_widths, area=area, course=course)
    area = free_area(grid, (0.0, 0.0))
    try:
        points, halves = centreline_of(grid, area)
        return Track.with_widths(printable(name, 60), points, np.clip(halves, 0.2, 2.5), area=area, course=course)
    except TrackError as e:
        raise TrackError(f"{path}: {str(e).removeprefix(f'track {name!r}: ')}") from None
