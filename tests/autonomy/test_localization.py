"""roar.localization on its own (no simulator): the laser scan, odometry, the beam model's table,
low-variance resampling, ray casting against Bresenham, and the particle filter's global start
and kidnap on a synthetic map with synthetic scans -- then the local grid's bookkeeping."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from roar.localization import (BeamModel, BresenhamCaster, Encoder, LaserScan, LocalizationError, Odometry,
                               ParticleFilter, RayMarcher, ScanError)
from roar.localization.local_grid import LocalGrid
from roar.localization.odometry import relative
from roar.localization.particle_filter import low_variance_resample
from roar.tracks.occupancy_map import OccupancyMap

RES = 0.05  # [m]
FOV = math.radians(270)


def room() -> OccupancyMap:
    """A 12 m x 8 m room with an L-shaped block, two pillars and a nook: no two places look alike."""
    w, h = int(12 / RES), int(8 / RES)
    occ = np.zeros((h, w), bool)  # row 0 at the top (y = 8 m)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True

    def block(x0, y0, x1, y1):  # [m]
        occ[h - int(y1 / RES):h - int(y0 / RES), int(x0 / RES):int(x1 / RES)] = True

    block(3.0, 2.0, 7.0, 3.0)
    block(6.0, 3.0, 7.0, 5.5)
    block(9.5, 5.5, 10.0, 6.0)
    block(2.0, 6.0, 2.4, 6.4)
    block(11.0, 0.0, 12.0, 2.5)
    return OccupancyMap(occ, ~occ, RES, (0.0, 0.0, 0.0))


def around(corners, t_s: float, speed: float) -> tuple[float, float, float]:
    """A pose [m, m, rad] at t_s on a loop through the corners [m] at `speed` [m/s]."""
    corners = np.asarray(corners, float)
    sides = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)
    s = (t_s * speed) % sides.sum()
    i = int(np.searchsorted(np.cumsum(sides), s, side="right"))
    a, b = corners[i], corners[(i + 1) % len(corners)]
    p = a + (s - (np.cumsum(sides)[i] - sides[i])) / sides[i] * (b - a)
    return float(p[0]), float(p[1]), math.atan2(b[1] - a[1], b[0] - a[0])


def loop_path(t_s: float) -> tuple[float, float, float]:
    """A pose [m, m, rad] at t_s on a 1 m/s loop round the L-block (period 26 s)."""
    return around([[1.5, 1.2], [8.5, 1.2], [8.5, 6.8], [1.5, 6.8]], t_s, 1.0)


class Synthetic:
    """Scans cast on the map from the true pose (with noise) and odometry that drifts."""

    def __init__(self, grid: OccupancyMap, seed: int = 0) -> None:
        self.caster = RayMarcher(grid)
        self.rng = np.random.default_rng(seed)
        self.angles = np.linspace(-FOV / 2, FOV / 2, 270)
        self.odometry = None

    def scan(self, pose, t_s: float) -> LaserScan:
        ranges = self.caster.cast(np.array([pose]), self.angles)[0]
        hit = ranges < 10.0
        ranges[hit] += self.rng.normal(0.0, 0.015, int(hit.sum()))
        return LaserScan(self.angles, ranges, t_s)

    def odometry_pose(self, before, after):
        """The odometry's pose after the true motion before -> after (5 % scale error, noise)."""
        dx, dy, dyaw = relative(before, after)
        if self.odometry is None:
            self.odometry = before
        x, y, yaw = self.odometry
        d = 1.05 * dx + self.rng.normal(0, 0.002)
        yaw2 = yaw + dyaw * 1.02 + self.rng.normal(0, 0.002)
        self.odometry = (x + d * math.cos(yaw), y + d * math.sin(yaw), yaw2)
        return self.odometry


def drive(pf: ParticleFilter, sim: Synthetic, seconds: float, t0: float = 0.0, truth=loop_path,
          period_s: float = 0.04) -> list[tuple[float, float]]:
    """Feed the filter along the path for `seconds`: (t, position error [m]) after each scan."""
    errors = []
    before = truth(t0)
    for k in range(1, int(seconds / period_s) + 1):
        t = t0 + k * period_s
        now = truth(t)
        pf.predict(sim.odometry_pose(before, now))
        pf.correct(sim.scan(now, t))
        errors.append((t, math.hypot(pf.pose[0] - now[0], pf.pose[1] - now[1])))
        before = now
    return errors


def settled_at(errors, within_m: float = 0.3) -> float | None:
    """[s] from when the error stays below within_m to the end (None: never)."""
    bad = [t for t, e in errors if e >= within_m]
    later = [t for t, e in errors if not bad or t > bad[-1]]
    return later[0] if later else None


# --- the laser scan ---------------------------------------------------------------------------------

def test_a_scan_skips_what_is_no_measurement_beam_by_beam():
    scan = LaserScan.fan([1.0, np.nan, -2.0, 0.01, 12.0, np.inf, 3.0], FOV, 0.0)
    assert scan.skipped == 3  # NaN, negative, below the 6 cm minimum
    assert scan.usable().tolist() == [True, False, False, False, True, True, True]
    assert scan.clipped()[4] == scan.clipped()[5] == 10.0  # max readings (+inf too) are the range
    assert len(scan.points()) == 2  # the max readings met nothing: no point


@pytest.mark.parametrize("make, says", [
    (lambda: LaserScan.fan([], FOV, 0.0), "empty scan"),
    (lambda: LaserScan([0.0, 0.1], [1.0], 0.0), "one angle per beam"),
    (lambda: LaserScan([0.0, np.nan], [1.0, 1.0], 0.0), "angles must be finite"),
    (lambda: LaserScan.fan([1.0], FOV, float("nan")), "time must be a finite"),
    (lambda: LaserScan.fan(["a"], FOV, 0.0), "ranges must be numbers"),
    (lambda: LaserScan.fan([1.0], FOV, 0.0, range_min_m=5, range_max_m=1), "range limits"),
])
def test_a_scan_that_cannot_be_used_is_refused_in_one_line(make, says):
    with pytest.raises(ScanError, match=says) as e:
        make()
    assert "\n" not in str(e.value)


def test_a_ros_scan_gives_its_angles():
    scan = LaserScan.from_ros(-1.0, 0.5, [1, 2, 3, 4, 5], 2.0)
    assert scan.angles.tolist() == [-1.0, -0.5, 0.0, 0.5, 1.0] and scan.time_s == 2.0
    assert scan.every(3).angles.tolist() == [-1.0, 0.0, 1.0]


# --- odometry ---------------------------------------------------------------------------------------

def test_odometry_integrates_a_circle_and_ignores_readings_that_are_no_numbers():
    odo = Odometry((0.0, 0.0, 0.0))
    radius, speed, dt = 2.0, 1.0, 0.02
    for k in range(int(2 * math.pi * radius / speed / dt) + 1):
        odo.update(k * dt, speed * k * dt, speed / radius)
    odo.update(99.0, float("nan"), 0.0)
    assert odo.ignored == 1
    assert math.hypot(*odo.pose[:2]) < 0.02  # back where it started after one circle


def test_odometry_from_front_wheel_encoders_keeps_the_rear_axles_arc():
    """Round a 0.75 m circle the front wheels (0.325 m ahead) run 9 % further than the rear axle:
    told where they are, the odometry draws the rear axle's circle; not told, one 9 % wider."""
    radius, wheelbase, speed, dt = 0.75, 0.325, 1.0, 0.02  # [m], [m], [m/s] of the rear axle, [s]
    front = speed * math.hypot(radius, wheelbase) / radius  # [m/s] the front wheels' speed
    told, untold = Odometry((0.0, 0.0, 0.0), front_axle_m=wheelbase), Odometry((0.0, 0.0, 0.0))
    widest = {told: 0.0, untold: 0.0}  # [m] from the start: the circle's diameter
    for k in range(int(2 * math.pi * radius / speed / dt) + 1):
        for odo in (told, untold):
            odo.update(k * dt, front * k * dt, speed / radius)
            widest[odo] = max(widest[odo], math.hypot(*odo.pose[:2]))
    assert widest[told] == pytest.approx(2 * radius, rel=0.01)
    assert widest[untold] == pytest.approx(2 * math.hypot(radius, wheelbase), rel=0.01)


def test_an_encoder_counts_metres():
    assert Encoder(10_240, 0.0505).metres(10_240) == pytest.approx(2 * math.pi * 0.0505)


# --- the beam model ---------------------------------------------------------------------------------

def test_the_beam_models_table_is_a_distribution_per_expected_range_with_its_four_parts():
    model = BeamModel()
    cells = 200
    table = model.table(cells, RES)
    assert np.allclose(table.sum(axis=0), 1.0)
    d = 100  # expected 5 m
    assert int(np.argmax(table[:, d])) == d  # most likely: the wall where the map has it
    assert table[d - 20, d] > table[d + 20, d]  # 1 m short (a person) beats 1 m long (through the wall)
    assert table[cells, d] > 10 * table[cells - 20, d]  # a max reading has its own mass
    assert table[0, d] > 0  # anything at all is possible (z_rand)
    softened = model.log_table(cells, RES)
    assert np.allclose(softened, np.log(table) / 2.2)


# --- resampling -------------------------------------------------------------------------------------

@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=40).filter(lambda w: sum(w) > 1e-6),
       st.integers(1, 200), st.integers(0, 2**32 - 1))
def test_low_variance_resampling_draws_each_particle_as_often_as_its_weight_says(weights, count, seed):
    w = np.array(weights) / sum(weights)
    drawn = np.bincount(low_variance_resample(w, count, np.random.default_rng(seed)), minlength=len(w))
    assert drawn.sum() == count
    assert np.all(drawn >= np.floor(w * count - 1e-9) - 1) and np.all(drawn <= np.ceil(w * count + 1e-9) + 1)
    assert np.all(drawn[w == 0] == 0)


# --- ray casting ------------------------------------------------------------------------------------

def test_ray_marching_reads_the_walls_where_bresenham_does():
    grid = room()
    rng = np.random.default_rng(3)
    free = np.argwhere(grid.free[5:-5, 5:-5]) + 5
    pick = free[rng.integers(0, len(free), 300)]
    xy = grid.to_world(pick[:, 1], pick[:, 0])
    poses = np.column_stack([xy, rng.uniform(-math.pi, math.pi, len(xy))])
    angles = np.linspace(-FOV / 2, FOV / 2, 60)
    marched, walked = RayMarcher(grid).cast(poses, angles), BresenhamCaster(grid).cast(poses, angles)
    differ = np.abs(marched - walked)
    assert np.median(differ) < RES and np.percentile(differ, 95) < 2 * RES
    # from the room's middle, straight down to the floor's wall (2 cells thick at y = 0.1 m)
    assert RayMarcher(grid).cast(np.array([[1.0, 4.0, -math.pi / 2]]), np.array([0.0]))[0, 0] == \
        pytest.approx(3.9, abs=RES)


# --- the particle filter ----------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, says", [
    ({"particles": 0}, "particles must be a whole number 1.."),
    ({"particles": 2.5}, "particles must be a whole number"),
    ({"beams": 0}, "beams must be a whole number"),
    ({"max_range_m": float("nan")}, "max_range_m must be"),
    ({"sensor": (0.0, "a", 0.0)}, "sensor y must be"),
])
def test_a_filter_that_cannot_be_built_says_why_in_one_line(kwargs, says):
    with pytest.raises(LocalizationError, match=says) as e:
        ParticleFilter(room(), **kwargs)
    assert "\n" not in str(e.value)


def test_a_filter_needs_a_map_and_particles_before_a_scan():
    with pytest.raises(LocalizationError, match="needs an OccupancyMap"):
        ParticleFilter("tunnel.yaml")
    pf = ParticleFilter(room(), particles=10)
    with pytest.raises(LocalizationError, match="no particles"):
        pf.correct(LaserScan.fan([1.0], FOV, 0.0))


def test_a_scan_with_no_usable_beam_is_skipped_and_counted():
    pf = ParticleFilter(room(), particles=100, seed=1)
    pf.start_at(loop_path(0.0))
    assert pf.correct(LaserScan.fan([np.nan, -1.0, 0.0], FOV, 0.0)) is False
    assert pf.skipped_scans == 1 and pf.skipped_beams == 3


def test_the_filter_tracks_a_car_whose_odometry_drifts():
    grid = room()
    sim = Synthetic(grid, seed=2)
    pf = ParticleFilter(grid, particles=500, seed=2)
    pf.start_at(loop_path(0.0))
    errors = drive(pf, sim, 26.0)  # one loop: its odometry is 5 % long and turns 2 % too far
    assert max(e for _, e in errors) < 0.15 and np.sqrt(np.mean([e * e for _, e in errors])) < 0.06
    assert math.hypot(*(np.array(sim.odometry[:2]) - loop_path(26.0)[:2])) > 0.5  # the odometry alone drifted
    truth = loop_path(26.0)
    assert abs(math.remainder(pf.pose[2] - truth[2], math.tau)) < math.radians(2)
    assert np.all(np.linalg.eigvalsh(pf.covariance) >= -1e-12) and pf.spread_m < 0.1


RING_LENGTH_M, RING_WIDTH_M, RING_LANE_M = 30.0, 8.0, 1.6  # [m] outside, and the corridor's width


def ring() -> OccupancyMap:
    """A corridor round a 30 m x 8 m block: straights three times as long as the lidar sees (10 m),
    where a scan cannot tell how far along the car is, and four corners where it can."""
    w, h = int((RING_LENGTH_M + 2) / RES), int((RING_WIDTH_M + 2) / RES)
    occ = np.zeros((h, w), bool)
    occ[:2, :] = occ[-2:, :] = occ[:, :2] = occ[:, -2:] = True
    inner = int((1 + RING_LANE_M) / RES)
    occ[inner:h - inner, inner:w - inner] = True
    return OccupancyMap(occ, ~occ, RES, (0.0, 0.0, 0.0))


def ring_path(t_s: float, speed: float = 3.0) -> tuple[float, float, float]:
    """A pose [m, m, rad] at t_s along the middle of ring()'s corridor at `speed` [m/s]."""
    c = 1 + RING_LANE_M / 2
    far_x, far_y = RING_LENGTH_M + 2 - c, RING_WIDTH_M + 2 - c
    return around([[c, c], [far_x, c], [far_x, far_y], [c, far_y]], t_s, speed)


def test_the_filter_learns_how_far_its_odometry_reads_wrong_and_lags_less_on_long_straights():
    """Odometry 5 % long: on a straight the scan cannot place the car on, only the odometry carries
    it, 1 m ahead after 20 m; the corners show the filter how far off it was, and it learns the scale."""
    grid, lap_s = ring(), 2 * (RING_LENGTH_M + RING_WIDTH_M - 2 * (1 + RING_LANE_M / 2)) / 3.0
    second_lap = {}
    for calibrate in (False, True):
        pf = ParticleFilter(grid, particles=500, seed=3, calibrate=calibrate)
        pf.start_at(ring_path(0.0))
        errors = [e for t, e in drive(pf, Synthetic(grid, seed=3), 2 * lap_s, truth=ring_path) if t > lap_s]
        second_lap[calibrate] = (float(np.sqrt(np.mean(np.square(errors)))), max(errors), pf.odometry_scale)
    rms, worst, scale = second_lap[True]
    assert abs(scale * 1.05 - 1) < 0.015 and second_lap[False][2] == 1.0, second_lap
    assert rms < 0.6 * second_lap[False][0] and worst < 0.7 * second_lap[False][1], second_lap


@pytest.mark.parametrize("start_s", [0.0, 15.0])
def test_a_global_start_finds_where_the_car_is(start_s):
    grid = room()
    pf = ParticleFilter(grid, particles=500, seed=int(start_s))
    pf.start_global()
    errors = drive(pf, Synthetic(grid, seed=int(start_s)), 8.0, t0=start_s)
    settled = settled_at(errors)
    assert settled is not None and settled - start_s <= 5.0, errors[::25]
    assert pf.localized


def carried_ahead(seed: int, after_s: float, ahead_s: float, seconds: float):
    """A filter started at the car's pose and driven after_s round the loop; then the car is
    carried ahead_s further round it (at 1 m/s) without a word and driven `seconds` more.
    (the filter, its errors after the carry)"""
    grid = room()
    sim = Synthetic(grid, seed=seed)
    pf = ParticleFilter(grid, particles=500, seed=seed)
    pf.start_at(loop_path(0.0))
    drive(pf, sim, after_s)
    assert pf.localized
    return pf, drive(pf, sim, seconds, t0=after_s, truth=lambda t: loop_path(t + ahead_s))


def test_a_kidnapped_filter_finds_out_and_finds_the_car_again():
    pf, errors = carried_ahead(5, 4.0, 5.0, 10.0)  # 5 m further round the loop from 4 s on
    assert pf.restarts >= 1  # it knew it was lost
    settled = settled_at(errors)
    assert settled is not None and settled - 4.0 <= 10.0, errors[::25]


def test_a_filter_slid_along_its_heading_looks_there_before_it_starts_over():
    """Odometry that ran 2 m long on a straight (a slipping wheel, a straight with nothing ahead to
    measure) leaves the filter lost: it finds the car along its own heading, with no global restart."""
    pf, errors = carried_ahead(7, 2.0, 2.0, 6.0)  # 2 m further along the bottom straight from 2 s on
    assert pf.restarts == 0
    settled = settled_at(errors, within_m=0.15)
    assert settled is not None and settled - 2.0 <= 3.0, errors[::25]


# --- the local grid ---------------------------------------------------------------------------------

def test_the_local_grid_marks_what_the_map_lacks_and_forgets_it():
    grid = room()
    sim = Synthetic(grid)
    pose = (1.5, 4.0, 0.0)
    # a person 2 m ahead: the map does not have them; the scan does
    person = (3.5, 4.0, 0.2)
    scan = sim.scan(pose, 0.0)
    d = person[0] - pose[0]
    blocked = np.abs(np.sin(scan.angles) * d) < person[2]
    ahead = blocked & (np.cos(scan.angles) > 0)
    ranges = scan.ranges.copy()
    ranges[ahead] = (d * np.cos(scan.angles[ahead]) - np.sqrt(person[2] ** 2 - (d * np.sin(scan.angles[ahead])) ** 2))
    local = LocalGrid(10.0, RES, known=grid, half_life_s=1.0)
    for k in range(3):
        local.update(LaserScan(scan.angles, ranges, 0.04 * k), pose)
    cells = local.cell_centres()[local.unmapped()]
    assert len(cells) >= 5
    outline = np.abs(np.hypot(cells[:, 0] - person[0], cells[:, 1] - person[1]) - person[2])
    assert outline.max() <= RES * 1.5  # within a cell of the person's outline, nothing else
    assert local.planner_view()[local.known_walls()].all()
    # the person walks away: the grid sees the floor there, and what it saw fades
    for k in range(3, 40):
        local.update(sim.scan(pose, 0.04 * k), pose)
    assert not local.unmapped().any()


def test_the_local_grid_keeps_what_it_saw_as_the_car_moves_and_skips_beams():
    local = LocalGrid(4.0, 0.1)
    scan = LaserScan([0.0, 0.1, 0.2], [1.0, np.nan, -1.0], 0.0)
    local.update(scan, (0.0, 0.0, 0.0))
    assert local.skipped_beams == 2
    hit = local.cell_centres()[local.occupied()]
    assert len(hit) == 1 and np.allclose(hit[0], [1.05, 0.05])  # (1.0, 0.0) lies in the cell [1.0, 1.1) x [0, 0.1)
    local.update(LaserScan([0.0], [10.0], 0.0), (1.5, 0.5, math.pi / 2))  # moved 1.6 m: the grid scrolled
    assert np.allclose(local.cell_centres()[local.occupied()], hit)  # still there, where it is in the world
