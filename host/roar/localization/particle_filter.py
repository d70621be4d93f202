"""Monte Carlo localization on a known occupancy map (AMCL's way): particles moved by odometry
with noise, weighted by how well a subset of each scan's beams fits the map (ray casting and the
beam model's table), resampled with low variance once the weights have grown uneven (the
effective number of particles below half of them); the pose is their weighted mean (a circular
mean for the heading) with a covariance.

    pf = ParticleFilter(grid, particles=2500, beams=60, sensor=(0.265, 0.0, 0.0), seed=1)
    pf.start_at((x, y, yaw))        # or pf.start_global(): particles over all the free space
    pf.predict(odometry_pose)       # each control period: the odometry's pose (it drifts)
    pf.correct(scan)                # each scan (roar.localization.LaserScan)
    pf.pose, pf.covariance, pf.spread_m

Lost and found: after each scan the filter checks how many of its beams agree with the map
seen from the estimate (pf.fit: the share within FIT_TOLERANCE_M of the cast range). It is
localized once the particles have converged and the fit has held above FIT_GOOD while the car
drove LOCALIZED_M; a filter that was localized, or whose particles have converged, and
whose fit stays below FIT_LOST for LOST_SCANS scans -- the car was carried off, or a global
start converged on the wrong place -- is lost, and starts again over the whole free space
(pf.restarts counts it); one that was localized first looks SEARCH_ALONG_M either way along its
heading (odometry that ran long on a straight). Unsure: before a global start declares itself
localized it looks for a rival, a pose RIVAL_APART_M or more away that fits this scan and the
scans kept over the last LOCALIZED_M as well (a look-alike corridor: particles gathered in it have
a small spread and a good fit, so neither catches it); found, the rivals join the particles, the
filter stays unlocalized (pf.unsure says why) and a car drives on its pose only once no rival
is left. Things the map lacks (people, cones)
cut a few beams short: they lower the fit, not below FIT_LOST. Calibrated: while localized, the
filter learns the odometry's scale (pf.odometry_scale) from how far the scans move the estimate
along its heading from where the odometry put it (see _calibrate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.checks import number
from roar.errors import LocalizationError
from roar.localization.beam_model import BeamModel
from roar.localization.odometry import Pose, checked_pose, relative
from roar.localization.raycast import BresenhamCaster, RayMarcher, _kernels
from roar.localization.scan import LaserScan
from roar.tracks.occupancy_map import OccupancyMap

MAX_PARTICLES = 1_000_000
MAX_BEAMS = 2_000
GLOBAL_FACTOR = 20  # a global start draws this many times the particles, down to the usual count once localized
SEARCH_PERIOD_S = 0.1  # [s] a search with those many particles weighs a scan at most this often: each costs 0.1 s
# (20,000 particles x 60 beams) on a 2-core car computer, more than a 25 Hz lidar's 40 ms, so it would fall behind
CONVERGED_M = 0.3  # [m] the particles' spread (position's standard deviation) below which the filter has converged
MIN_MOVE_M, MIN_TURN_RAD = 0.01, math.radians(0.5)  # once localized, a scan corrects only after the car moved
# this much (AMCL's rule: the same scan from the same place, weighed again and again, would make it overconfident)
FIT_TOLERANCE_M = 0.15  # [m] a beam agrees with the map when it reads within this of the range cast from the estimate
FIT_GOOD, LOCALIZED_M = 0.8, 5.0  # share of beams agreeing, held while the car drives this far [m]: localized
# (a corridor or a straight looks like another for a few metres: only a bend tells them apart)
FIT_LOST, LOST_SCANS = 0.6, 8  # below this share for this many scans: lost
SEARCH_SIGMA = 4.0  # until localized, the beam model's hit is this many times wider: a particle 10 cm and 3 degrees
# from the true pose must outlive one that fits a look-alike place exactly, until the car drives past where they differ
SEARCH_TEMPER = 0.25  # ... and the scan's log-likelihood counts a quarter: two places that both fit, one a little
# worse (a person the map lacks hides a few beams), keep particles until the car drives past where they differ
SEARCH_RESAMPLE_BELOW = 0.02  # the same while not localized: resampling often, the few particles at the true pose
# are lost to chance among the many at look-alike places (the far end of a corridor seen the other way round)
NEAR_WALL_M = 3.0  # [m] a global start places particles by the scan's nearest reading when it is this near
NEAR_TOLERANCE_M = 0.1  # [m] (+ 5 % of the range) between that reading and a cell's distance to its nearest wall
NEAR_HEADING_RAD = math.radians(4)  # [rad] spread of the headings drawn from it
SCAN_PLACED = 0.8  # share of a global start's particles placed by the scan (the rest anywhere: the nearest wall
# may be behind the lidar, where it does not see)
RIVAL_CANDIDATES = 20_000  # poses placed by the scan (as a global start places them) to look for a look-alike place
RIVAL_APART_M = 2.0  # [m] a pose this far from the estimate whose scan fits ...
RIVAL_FIT_MARGIN = 0.05  # ... within this share of beams of the estimate's fit is a rival: the filter is unsure
RIVAL_REFINED, RIVAL_JITTERS = 128, 16  # the best candidates refined, the jittered copies of each per round
RIVAL_REFINE = (np.array([0.15, 0.15, 0.05]), np.array([0.05, 0.05, 0.02]))  # [m, m, rad] each round's jitter
RIVAL_HISTORY_M = 1.0  # [m] while searching, a scan is kept each time the car drove this far (LOCALIZED_M's worth):
# a rival must fit them too, seen from where the odometry says the car was (one scan of a winding road fits many
# places; the road's last metres fit only where it winds the same way)
RIVAL_SHARE = 0.3  # share of the particles given to the rivals, so the places compete until the car drives past
# where they differ
SEARCH_ALONG_M = 4.0  # [m] a filter lost after being localized first looks this far either way along its heading
# (4 % of a 90 m straight, the longest of the real circuits': a wheel's radius or its slip that far off) ...
SEARCH_ACROSS_M, SEARCH_YAW_RAD = 0.2, 0.05  # [m], [rad] ... and this much across and turned (standard deviations)
CALIBRATE_EVERY_M = 10.0  # [m] driven localized between two updates of the odometry's scale, from how far the
# scans moved the estimate along its heading from where the odometry alone put it (a wheel's true rolling radius is
# not the one assumed: 3.5 % on the simulated car at 3 m/s; along a straight the scan cannot place the car on, only
# the odometry carries it, 1 m behind after 30 m with that error)
CALIBRATE_GAIN = 0.3  # share of the error seen over those metres corrected at each update ...
CALIBRATE_STEP = 0.02  # ... by at most this much of the scale (a jump of the estimate is not a wheel's radius)
CALIBRATE_RANGE = (0.8, 1.25)  # the scale never leaves these
LEARNT_ALONG_PER_M = 0.03  # [m/m] the motion's noise ahead once the scale is learnt: twice the odometry's error as the
# windows showed it, never below this nor above MotionNoise.along_per_m (an unknown scale: a cloud wide enough to hold
# a 5 % error; kept that wide on a learnt one, the cloud wandered 0.7 m along straights) ...
ERROR_KEPT = 0.8  # ... that error: the largest share a window showed, kept at this much a window after, counting
TOLD_ENOUGH = 10.0  # only windows whose scans narrowed the particles along the heading by this much, summed share by
# share (a window on a straight the scan cannot place the car on shows no error, though the scale may still be off:
# its scans narrow them by 3-6, a bend's by 14-40)
RESAMPLE_BELOW = 0.5  # resample when the effective number of particles falls below this share of them: until
# then the weights carry over from scan to scan and the odometry's noise spreads the particles out


@dataclass(frozen=True)
class MotionNoise:
    """The odometry's error per update, as standard deviations that grow with the motion."""

    along_per_m: float = 0.25  # [m/m] ahead, per metre driven (slip, the wheel's radius)
    across_per_m: float = 0.05  # [m/m] sideways, per metre driven
    turn_per_rad: float = 0.1  # [rad/rad] of heading, per radian turned (the gyro's scale)
    turn_per_m: float = 0.05  # [rad/m] of heading, per metre driven (the gyro's bias)
    floor_m: float = 0.002  # [m] whatever the motion: keeps the particles from collapsing onto one
    floor_rad: float = 0.002  # [rad]


def _compose(poses: np.ndarray, dx, dy, dyaw) -> np.ndarray:
    """Poses (P, 3) moved by (dx ahead, dy left, dyaw) in each one's own frame (scalars or (P,))."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    out = np.empty_like(poses)
    out[:, 0] = poses[:, 0] + c * dx - s * dy
    out[:, 1] = poses[:, 1] + s * dx + c * dy
    out[:, 2] = np.remainder(poses[:, 2] + dyaw + math.pi, math.tau) - math.pi
    return out


def low_variance_resample(weights: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of `count` particles drawn in proportion to `weights` (summing to 1) with one
    random number: evenly spaced pointers into the cumulative weights (Probabilistic Robotics'
    low-variance sampler). A particle of weight w is drawn floor(w count) or ceil(w count) times."""
    pointers = (rng.uniform(0.0, 1.0 / count) + np.arange(count) / count)
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # no pointer falls past the end through rounding
    return np.searchsorted(cumulative, pointers, side="right").clip(0, len(weights) - 1)


class ParticleFilter:
    def __init__(self, grid: OccupancyMap, particles: int = 2500, beams: int = 60, max_range_m: float = 10.0,
                 sensor: Pose = (0.0, 0.0, 0.0), model: BeamModel = BeamModel(), noise: MotionNoise = MotionNoise(),
                 seed: int | None = None, recovery: bool = True, caster: str = "march",
                 calibrate: bool = True) -> None:
        if not isinstance(grid, OccupancyMap):
            raise LocalizationError(f"a particle filter needs an OccupancyMap (roar.tracks.load_map), got "
                                    f"{type(grid).__name__}")
        for name, value, high in (("particles", particles, MAX_PARTICLES), ("beams", beams, MAX_BEAMS)):
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= high:
                raise LocalizationError(f"{name} must be a whole number 1..{high:,}, got {value!r}")
        try:
            self.max_range_m = number("max_range_m", max_range_m, 10 * grid.resolution_m, 100.0, "m")
            self.sensor = checked_pose("sensor", sensor)
        except ValueError as e:
            raise LocalizationError(str(e)) from None
        self.grid, self.count, self.beams, self.model, self.noise = grid, particles, beams, model, noise
        self.recovery = recovery
        self.rng = np.random.default_rng(seed)
        if caster not in ("march", "bresenham"):
            raise LocalizationError(f"caster must be march or bresenham, got {caster!r}")
        self.caster = RayMarcher(grid, self.max_range_m)
        self._walker = BresenhamCaster(grid, self.max_range_m) if caster == "bresenham" else None
        self.max_cells = int(round(self.caster.max_cells))
        self.log_table = model.log_table(self.max_cells, grid.resolution_m)
        searching = BeamModel(model.z_hit, model.z_short, model.z_max, model.z_rand, model.sigma_hit_m * SEARCH_SIGMA)
        self.search_table = np.ascontiguousarray(SEARCH_TEMPER * searching.log_table(self.max_cells, grid.resolution_m))
        self._weigh = _kernels()["march_log_weights"]
        free = np.argwhere(self.caster.frame.free)  # (ix, iy) of every free cell
        if len(free) == 0:
            raise LocalizationError("the map has no free cells to put particles in")
        self._free = free
        from scipy import ndimage

        occupied = self.caster.frame.occupied
        self._wall_dist, self._wall_at = ndimage.distance_transform_edt(~occupied, return_indices=True) \
            if occupied.any() else (np.full(occupied.shape, np.inf), np.zeros((2, *occupied.shape), int))
        self._place_by_scan = False
        self.poses = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self._odometry: Pose | None = None
        self._moved_m = self._turned_rad = math.inf  # since the last correction: the first scan always corrects
        self._estimate: Pose = (0.0, 0.0, 0.0)  # at the last correction
        self._since: Pose = (0.0, 0.0, 0.0)  # the odometry's motion since then
        self._covariance = np.full((3, 3), np.nan)
        self.fit = math.nan  # share of the last scan's beams agreeing with the map from the estimate
        self.localized = False
        self._good, self._bad = 0.0, 0  # [m] driven with a good fit; scans in a row with a bad one
        self._was_localized = False
        self._searched_along = False  # lost, it looked along its heading: the next loss restarts it globally
        self._from_global = False  # searching from a global start: challenged by rivals before it is localized
        self.unsure = ""  # why a filter that would be localized is not: the look-alike places its scan fits too
        self.challenges = 0  # times a would-be localized filter found a rival place
        self._history: list[tuple] = []  # (odometry pose, angles, ranges, at_max) of scans kept while searching
        self._history_m = 0.0  # [m] driven since the last one kept
        self._scan: LaserScan | None = None  # the last one weighed (a challenge places its rivals by all its beams)
        self._weighed_s: float | None = None  # [s] that scan's time
        self.restarts = 0  # global restarts after the filter was lost
        self.calibrate = calibrate
        self.odometry_scale = 1.0  # the odometry's distances times this are the car's, as learnt (calibrate=True)
        self._drift_m = self._calibrating_m = 0.0  # [m] along the heading, scans against the odometry; [m] driven
        self._told = 0.0  # how much the window's scans narrowed the particles along the heading (see _calibrate)
        self._odometry_error = noise.along_per_m / 2  # its share of the distance the last windows showed (see predict)
        self.corrections = self.skipped_scans = self.skipped_beams = 0

    # --- where the particles start ---------------------------------------------------------------

    def start_at(self, pose: Pose, spread: tuple[float, float, float] = (0.2, 0.2, 0.1)) -> None:
        """Particles round a known pose: normal with standard deviations spread (x [m], y [m], yaw [rad])."""
        x, y, yaw = checked_pose("start pose", pose)
        n = self.count
        self.poses = np.column_stack([self.rng.normal(x, spread[0], n), self.rng.normal(y, spread[1], n),
                                      self.rng.normal(yaw, spread[2], n)])
        self._reset((x, y, yaw))  # started where it is: localized

    def start_global(self) -> None:
        """Particles over the whole free space: the filter does not know where it is. The next
        scan places them (see _fresh_from_scan): most where the map's nearest wall is as far as
        the scan's nearest reading, facing so that it lies where the scan saw it; the rest anywhere."""
        self.poses = self._fresh(self.count * GLOBAL_FACTOR)
        self._reset(None)
        self._place_by_scan = True
        self._from_global = True
        self._history, self._history_m = [], math.inf

    def _reset(self, estimate: Pose | None) -> None:
        self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
        self._since = (0.0, 0.0, 0.0)
        self._moved_m = self._turned_rad = math.inf
        self.localized, self._good, self._bad = estimate is not None, 0, 0
        self._was_localized = self.localized
        self._update_estimate()

    def _fresh_from_scan(self, n: int, angles: np.ndarray, ranges: np.ndarray) -> np.ndarray:
        """n poses that agree with the scan's nearest reading (a sensor-based proposal, as Mixture
        MCL draws them): SCAN_PLACED of them at free cells whose distance to the map's nearest
        wall is that reading's range, each turned so that the wall lies at that beam's angle;
        the others anywhere. Without a near reading, all anywhere."""
        hits = ranges < NEAR_WALL_M
        if not hits.any():
            return self._fresh(n)
        b = int(np.argmin(np.where(hits, ranges, np.inf)))
        r, a = float(ranges[b]), float(angles[b])  # a: in the car's frame (the sensor's yaw added)
        dist_m = self._wall_dist[self._free[:, 0], self._free[:, 1]] * self.grid.resolution_m
        tolerance = NEAR_TOLERANCE_M + 0.05 * r
        near = np.flatnonzero(np.abs(dist_m - r) <= tolerance)
        placed = int(SCAN_PLACED * n) if len(near) else 0
        cells = self._free[near[self.rng.integers(0, len(near), placed)]] if placed else np.zeros((0, 2), int)
        to_wall = self._wall_at[:, cells[:, 0], cells[:, 1]].T - cells  # [cells] towards the nearest wall
        wall_bearing = np.arctan2(to_wall[:, 1], to_wall[:, 0]) + self.caster.frame.grid.origin[2]
        sensor_xy = self.caster.frame.world_points(*(cells + self.rng.uniform(-0.5, 0.5, cells.shape)).T)
        heading = wall_bearing - a + self.rng.normal(0.0, NEAR_HEADING_RAD, placed)
        c, s = np.cos(heading), np.sin(heading)
        mx, my = self.sensor[0], self.sensor[1]  # the car's base behind its sensor
        base = np.column_stack([sensor_xy[:, 0] - c * mx + s * my, sensor_xy[:, 1] - s * mx - c * my, heading])
        return np.concatenate([base, self._fresh(n - placed)])

    def _fresh(self, n: int) -> np.ndarray:
        """n poses drawn evenly over the free cells, any heading."""
        cells = self._free[self.rng.integers(0, len(self._free), n)] + self.rng.uniform(-0.5, 0.5, (n, 2))
        xy = self.caster.frame.world_points(cells[:, 0], cells[:, 1])
        return np.column_stack([xy, self.rng.uniform(-math.pi, math.pi, n)])

    # --- odometry ------------------------------------------------------------------------------

    def predict(self, odometry: Pose) -> None:
        """Move every particle as the odometry's pose moved since the last call, with noise."""
        odometry = tuple(float(v) for v in odometry)
        if not all(math.isfinite(v) for v in odometry):
            return
        if self._odometry is None:
            self._odometry = odometry
            return
        dx, dy, dyaw = relative(self._odometry, odometry)
        dx, dy = dx * self.odometry_scale, dy * self.odometry_scale
        self._odometry = odometry
        if not len(self.poses):
            return
        dist = math.hypot(dx, dy)
        n, nz = len(self.poses), self.noise
        along = min(nz.along_per_m, max(LEARNT_ALONG_PER_M, 2 * self._odometry_error)) if self.calibrate else \
            nz.along_per_m
        self.poses = _compose(self.poses,
                              dx + self.rng.normal(0.0, along * dist + nz.floor_m, n),
                              dy + self.rng.normal(0.0, nz.across_per_m * dist + nz.floor_m, n),
                              dyaw + self.rng.normal(0.0, nz.turn_per_rad * abs(dyaw) + nz.turn_per_m * dist
                                                     + nz.floor_rad, n))
        self._since = tuple(_compose(np.array([self._since]), dx, dy, dyaw)[0])
        self._moved_m += dist
        self._turned_rad += abs(dyaw)

    # --- the scan ------------------------------------------------------------------------------

    def correct(self, scan: LaserScan) -> bool:
        """Weigh the particles by the scan and resample; False when the scan was not used (the
        car has not moved since the last one, or it has no usable beam)."""
        if not len(self.poses):
            raise LocalizationError("the filter has no particles: call start_at(pose) or start_global() first")
        if self.localized and self._moved_m < MIN_MOVE_M and self._turned_rad < MIN_TURN_RAD:
            return False  # (a filter still searching weighs every scan, up to SEARCH_PERIOD_S with many particles)
        if len(self.poses) > self.count and not self.localized and self._weighed_s is not None \
                and 0.0 <= scan.time_s - self._weighed_s < SEARCH_PERIOD_S:
            return False
        subset = scan.every(self.beams)
        usable = subset.usable()
        self.skipped_beams += int(np.count_nonzero(~usable))
        if not usable.any():
            self.skipped_scans += 1
            return False
        angles = np.ascontiguousarray(subset.angles[usable] + self.sensor[2])
        ranges = np.minimum(subset.ranges[usable], self.max_range_m)
        if self._place_by_scan:
            self._place_by_scan = False
            self.poses = self._fresh_from_scan(len(self.poses), *self._every_beam(scan))
            self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
        self._scan, self._weighed_s = scan, scan.time_s
        measured = np.minimum(np.round(ranges / self.grid.resolution_m), self.max_cells).astype(np.int64)
        measured[subset.ranges[usable] >= min(scan.range_max_m, self.max_range_m)] = self.max_cells
        sensors = _compose(self.poses, self.sensor[0], self.sensor[1], 0.0)
        xs, ys, hs = self.caster.frame.cell_poses(sensors)
        log_l = np.empty(len(self.poses))
        table = self.log_table if self.localized else self.search_table
        if self._walker is None:
            self._weigh(self.caster.dist, xs, ys, hs, angles, self.caster.max_cells, measured, table, log_l)
        else:  # the benchmark's plain reference: every ray walked cell by cell, then the table
            expected = np.minimum(self._walker.cast_cells(sensors, angles) + 0.5, self.max_cells).astype(np.int64)
            log_l = table[measured[None, :], expected].sum(axis=1)
        prior = self.weights
        log_w = np.log(np.maximum(prior, 1e-300)) + log_l
        log_w -= log_w.max()
        w = np.exp(log_w)
        self.weights = w / w.sum()
        predicted, driven_m = self.pose, math.hypot(self._since[0], self._since[1])  # where the odometry put it
        heading = self._estimate[2]  # the last scan's, along which the particles' spread is compared
        self._update_estimate()
        self._judge(angles, ranges, measured == self.max_cells, min(self._moved_m, 1.0))
        self._calibrate(predicted, driven_m, prior, heading)
        self.corrections += 1
        self._moved_m = self._turned_rad = 0.0
        if self.recovery and self._bad >= LOST_SCANS and (self._was_localized or self.converged):
            if self._was_localized and not self._searched_along:
                self._search_along()  # first where the odometry says it is, give or take a straight's drift
                return True
            self.restarts += 1
            self.start_global()
            return True
        effective = 1.0 / float(np.sum(self.weights ** 2))
        below = RESAMPLE_BELOW if self.localized else SEARCH_RESAMPLE_BELOW
        if effective < below * len(self.weights) or (len(self.poses) > self.count and self.localized):
            self._resample()
        return True

    def _judge(self, angles: np.ndarray, ranges: np.ndarray, at_max: np.ndarray, moved_m: float) -> None:
        """The fit of the scan from the estimate, and from it whether the filter is localized or lost."""
        self.fit = float(self._fits(np.array([self._estimate]), angles, ranges, at_max)[0])
        if self.fit >= FIT_GOOD:
            self._searched_along = False
        self._good = self._good + moved_m if self.fit >= FIT_GOOD and self.converged else 0.0
        self._bad = self._bad + 1 if self.fit < FIT_LOST else 0
        if self._from_global and not self.localized and self._odometry is not None:
            self._history_m += moved_m
            if self._history_m >= RIVAL_HISTORY_M:
                self._history = self._history[-int(LOCALIZED_M / RIVAL_HISTORY_M):] + [
                    (self._odometry, angles, ranges, at_max)]
                self._history_m = 0.0
        if self._good >= LOCALIZED_M and not self.localized and self._from_global:
            self._challenge(angles, ranges, at_max)
        if self._good >= LOCALIZED_M:
            self.localized = self._was_localized = True
            self._from_global, self.unsure = False, ""
        elif self._bad >= LOST_SCANS:
            self.localized = False

    def _along_spread(self, weights: np.ndarray, heading: float) -> float:
        """[m^2] the particles' variance along `heading` [rad] under these weights."""
        a = self.poses[:, 0] * math.cos(heading) + self.poses[:, 1] * math.sin(heading)
        return float(weights @ (a - weights @ a) ** 2)

    def _calibrate(self, predicted: Pose, driven_m: float, prior: np.ndarray, heading: float) -> None:
        """Learn the odometry's scale while localized with a good fit: the scan moved the estimate
        along its heading from where the odometry put it; summed over CALIBRATE_EVERY_M driven, that
        is the share of the distance the odometry misses (none on a straight the scan cannot place
        the car on: the car is where the odometry says; the lag it built shows at the next bend)."""
        if not (self.calibrate and self.localized and self.fit >= FIT_GOOD):
            self._drift_m = self._calibrating_m = self._told = 0.0  # searching or lost: its jumps tell nothing
            return
        ahead = (math.cos(predicted[2]), math.sin(predicted[2]))
        self._drift_m += (self._estimate[0] - predicted[0]) * ahead[0] + (self._estimate[1] - predicted[1]) * ahead[1]
        self._calibrating_m += driven_m
        told = 1.0 - self._along_spread(self.weights, heading) / max(self._along_spread(prior, heading), 1e-12)
        self._told += max(0.0, told)  # how much this scan narrowed the particles along the heading
        if self._calibrating_m >= CALIBRATE_EVERY_M:
            share = self._drift_m / self._calibrating_m
            change = float(np.clip(CALIBRATE_GAIN * share, -CALIBRATE_STEP, CALIBRATE_STEP))
            self.odometry_scale = float(np.clip(self.odometry_scale * (1 + change), *CALIBRATE_RANGE))
            if self._told >= TOLD_ENOUGH:  # the scans placed the car along its way: the error shown is what is left
                self._odometry_error = max(ERROR_KEPT * self._odometry_error, abs(share))
            self._drift_m = self._calibrating_m = self._told = 0.0

    def _challenge(self, angles: np.ndarray, ranges: np.ndarray, at_max: np.ndarray) -> None:
        """Before a global start declares itself localized: poses placed by this scan all over the
        map are checked for one that fits it about as well as the estimate, RIVAL_APART_M or more
        away (a look-alike corridor fits as well as the right one, and particles may have gathered
        in it with a small spread). Found: the filter stays unsure (.unsure says why), the rivals
        join the particles and the car must drive LOCALIZED_M more with a good fit."""
        candidates = self._fresh_from_scan(RIVAL_CANDIDATES, *self._every_beam(self._scan))
        candidates = candidates[self._apart_m(candidates) >= RIVAL_APART_M]
        fit = self._fits(candidates, angles, ranges, at_max)
        for spread in RIVAL_REFINE:  # the best few, each jittered, the best kept: a coarse pose near a look-alike
            # place fits it as well as the estimate only once it is there within the fit's tolerance
            best = candidates[np.argsort(fit)[-RIVAL_REFINED:]]
            jittered = np.repeat(best, RIVAL_JITTERS, axis=0)
            jittered += self.rng.normal(0.0, spread, jittered.shape)
            apart = self._apart_m(jittered) >= RIVAL_APART_M
            candidates = np.concatenate([best, jittered[apart]])
            fit = np.concatenate([np.sort(fit)[-RIVAL_REFINED:], self._fits(jittered[apart], angles, ranges, at_max)])
        rivals = candidates[fit >= self.fit - RIVAL_FIT_MARGIN]
        if len(rivals) and self._history:  # ... and the scans kept on the way, from where the odometry put them
            own = self._history_fits(np.array([self._estimate]))[0]
            rivals = rivals[self._history_fits(rivals) >= own - RIVAL_FIT_MARGIN]
        if not len(rivals):
            return
        self.challenges += 1
        nearest = float(np.min(self._apart_m(rivals)))
        self.unsure = (f"{len(rivals)} of {RIVAL_CANDIDATES} poses placed by the scan fit it as well {nearest:.1f} m "
                       f"or more from the estimate")
        n = len(self.poses)
        k = min(n, max(1, int(RIVAL_SHARE * n)))
        replaced = self.rng.choice(n, k, replace=False)
        self.poses[replaced] = rivals[self.rng.integers(0, len(rivals), k)]
        self.weights = np.full(n, 1.0 / n)
        self._good = 0.0
        self._update_estimate()

    def _every_beam(self, scan: LaserScan) -> tuple[np.ndarray, np.ndarray]:
        """The scan's usable beams' angles in the car's frame and ranges (what poses are placed by)."""
        full = scan.usable()
        return scan.angles[full] + self.sensor[2], np.minimum(scan.ranges[full], scan.range_max_m)

    def _apart_m(self, poses: np.ndarray) -> np.ndarray:
        """[m] each pose's (P, 3) distance from the estimate."""
        return np.hypot(poses[:, 0] - self._estimate[0], poses[:, 1] - self._estimate[1])

    def _history_fits(self, poses: np.ndarray) -> np.ndarray:
        """Each pose's (P, 3) mean fit of the scans kept while searching, each seen from where the
        odometry says the car was then (the pose moved back by the odometry since)."""
        now = self._odometry
        fits = [self._fits(_compose(poses, *relative(now, odo)), angles, ranges, at_max)
                for odo, angles, ranges, at_max in self._history]
        return np.mean(fits, axis=0)

    def _fits(self, poses: np.ndarray, angles: np.ndarray, ranges: np.ndarray, at_max: np.ndarray) -> np.ndarray:
        """The share of the scan's beams agreeing with the map from each pose (P, 3): the fit."""
        expected = self.caster.cast(_compose(poses, self.sensor[0], self.sensor[1], 0.0), angles)
        return np.where(at_max[None, :], expected >= self.max_range_m - FIT_TOLERANCE_M,
                        np.abs(expected - ranges[None, :]) <= FIT_TOLERANCE_M).mean(axis=1)

    def _search_along(self) -> None:
        """Lost after being localized: particles spread along the estimate's heading, SEARCH_ALONG_M
        either way (what the odometry may have drifted along a straight the scan cannot place the
        car on), before a global restart if that fails too."""
        self._searched_along = True
        n = self.count
        x, y, yaw = self._estimate
        along = self.rng.uniform(-SEARCH_ALONG_M, SEARCH_ALONG_M, n)
        across = self.rng.normal(0.0, SEARCH_ACROSS_M, n)
        c, s = math.cos(yaw), math.sin(yaw)
        self.poses = np.column_stack([x + c * along - s * across, y + s * along + c * across,
                                      self.rng.normal(yaw, SEARCH_YAW_RAD, n)])
        self.weights = np.full(n, 1.0 / n)
        self._bad, self._good = 0, 0.0
        self._moved_m = self._turned_rad = math.inf
        self._update_estimate()

    def _resample(self) -> None:
        n = self.count
        if len(self.poses) > n and not self.localized:
            n = len(self.poses)  # a global start keeps its many particles until it is localized: a place that looks
            # like the right one for a few metres must not take every particle there
        self.poses = self.poses[low_variance_resample(self.weights, n, self.rng)]
        self.weights = np.full(n, 1.0 / n)

    # --- the estimate --------------------------------------------------------------------------

    def _update_estimate(self) -> None:
        w, p = self.weights, self.poses
        x, y = float(w @ p[:, 0]), float(w @ p[:, 1])
        yaw = math.atan2(float(w @ np.sin(p[:, 2])), float(w @ np.cos(p[:, 2])))
        d = np.column_stack([p[:, 0] - x, p[:, 1] - y, np.remainder(p[:, 2] - yaw + math.pi, math.tau) - math.pi])
        self._covariance = (d * w[:, None]).T @ d
        self._estimate, self._since = (x, y, yaw), (0.0, 0.0, 0.0)

    @property
    def pose(self) -> Pose:
        """(x [m], y [m], yaw [rad]): the weighted mean at the last scan, moved on since by the
        odometry (so it is smooth between scans, and may jump at one)."""
        moved = _compose(np.array([self._estimate]), *self._since)[0]
        return float(moved[0]), float(moved[1]), float(moved[2])

    def sensor_pose(self) -> Pose:
        """Where the lidar is by the filter: the pose moved by the sensor's mounting (what a
        local grid is fed from)."""
        x, y, yaw = _compose(np.array([self.pose]), self.sensor[0], self.sensor[1], self.sensor[2])[0]
        return float(x), float(y), float(yaw)

    @property
    def covariance(self) -> np.ndarray:
        """(3, 3) of x [m], y [m], yaw [rad] over the particles at the last scan."""
        return self._covariance.copy()

    @property
    def spread_m(self) -> float:
        """[m] the particles' position standard deviation (the root of the covariance's trace in x, y)."""
        return math.sqrt(max(0.0, self._covariance[0, 0] + self._covariance[1, 1]))

    @property
    def converged(self) -> bool:
        return self.spread_m < CONVERGED_M
