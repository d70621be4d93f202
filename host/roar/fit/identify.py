"""Least squares of the car model (roar.fit.model) to a test drive's record: the yaw rate and
the speed measured from the poses against the model's, with 95 % confidence intervals, and the
model's prediction of a manoeuvre held out of the fit.

    result = fit(record, wheelbase_m=0.325)
    result.car.trim_deg, result.interval("trim_deg"), result.held_out
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roar.fit.drive import GRIP, SPEED_MANOEUVRES
from roar.fit.log import SMOOTH_S, FitError, FitLog
from roar.fit.model import (N, NAMES, PARAMS, STEP_S, WINDOW_EVERY_S, WINDOW_S, Car, Inputs, speeds, steering_angle,
                            yaw_rate)

Z95 = 1.96  # a 95 % interval's half width in standard deviations
MOVING_M_S = 0.05  # [m/s] slower than this the yaw rate says nothing of the steering
GRIP_SHARE = 95  # [%] the percentile of the sideways acceleration there taken for the grip
DELAY_SCAN_S = np.arange(0.0, 0.2001, 0.008)  # [s] the delays scanned for the deepest minimum


@dataclass
class Prediction:
    """The model against the measurements over some of the record's poses."""

    t: np.ndarray  # [s] pose times
    speed: np.ndarray  # [m/s] measured
    speed_model: np.ndarray  # [m/s] predicted (over WINDOW_S from each window's measured start)
    yaw_rate: np.ndarray  # [rad/s] measured
    yaw_rate_model: np.ndarray  # [rad/s] predicted

    def rms(self) -> tuple[float, float]:
        """(speed [m/s], yaw rate [rad/s]) root mean square errors."""
        return (float(np.sqrt(np.mean((self.speed - self.speed_model) ** 2))),
                float(np.sqrt(np.mean((self.yaw_rate - self.yaw_rate_model) ** 2))))


@dataclass
class FitResult:
    car: Car
    sigma: dict[str, float]  # one standard deviation of each parameter
    fitted: Prediction  # over the poses the fit used
    held_out: Prediction | None  # over the held-out manoeuvre's poses
    held_out_name: str = ""
    evaluations: int = 0

    def interval(self, name: str) -> tuple[float, float]:
        value, half = getattr(self.car, name), Z95 * self.sigma[name]
        return value - half, value + half

    def table(self) -> str:
        """The fitted numbers with their 95 % intervals, one per line."""
        rows = []
        for p in PARAMS:
            value, half = getattr(self.car, p.name), Z95 * self.sigma[p.name]
            rows.append(f"  {p.name:15} {value:9.4g} ± {half:<9.2g} {p.unit:6} {p.what}")
        return "\n".join(rows)


class _Problem:
    """The residuals of a record for a model vector, with what they need precomputed."""

    def __init__(self, record: FitLog, wheelbase_m: float, poses: np.ndarray, speed_poses: np.ndarray) -> None:
        self.wheelbase_m = wheelbase_m
        self.inputs = Inputs(record.pulse_t, record.throttle_us, record.steering_us, record.pose_t[-1])
        speed, rate = record.motion()
        keep = poses & (record.pose_t >= record.pulse_t[0])
        self.t, self.speed, self.rate = record.pose_t[keep], speed[keep], rate[keep]
        self.grid_at = np.clip(np.round((self.t - self.inputs.t[0]) / STEP_S).astype(int), 0, len(self.inputs.t) - 1)
        # the yaw rate shows the steering while the car is driven forward; braking through the rear
        # wheels (reverse pulses) turns a car by itself
        driven = np.interp(self.t, record.pulse_t, record.throttle_us) >= N
        self.moving = (self.speed > MOVING_M_S) & driven
        # ... and within the tyres' grip: the grip manoeuvre goes round one circle at the limit, so
        # its yaw rates, clipped one way only, would pull the trim by as much as the grip measured
        # there varies from drive to drive (0.2 deg between two drives of one car; 0.02 without it)
        names = [n for _, n in record.phases]
        at_limit = record.phase_at(self.t) == names.index(GRIP) if GRIP in names else np.zeros(len(self.t), bool)
        self.steered = self.moving & ~at_limit
        steps = int(round(WINDOW_S / STEP_S))
        starts = np.arange(0, len(self.inputs.t) - steps, int(round(WINDOW_EVERY_S / STEP_S)))
        # each window starts at a pose (its measured speed), and is compared at the poses within it
        first = np.searchsorted(self.grid_at, starts)
        ok = first < len(self.grid_at)
        starts, first = self.grid_at[first[ok]], first[ok]
        starts, unique = np.unique(starts, return_index=True)
        first = first[unique]
        speed_poses = speed_poses[keep]
        rows, cols, pose = [], [], []
        for w, (s, f) in enumerate(zip(starts, first)):
            inside = np.arange(f, len(self.grid_at))
            inside = inside[(self.grid_at[inside] < s + steps) & speed_poses[inside]]
            rows += [w] * len(inside)
            cols += (self.grid_at[inside] - s).tolist()
            pose += inside.tolist()
        if not rows:
            raise FitError("the record has no poses while the car was sent pulses")
        self.starts, self.v0, self.steps = starts, self.speed[first], steps
        self.rows, self.cols, self.pose = np.array(rows), np.array(cols), np.array(pose)

    def predict(self, car: Car) -> tuple[np.ndarray, np.ndarray]:
        """(speed per window sample [m/s], yaw rate per pose [rad/s])."""
        throttle, steering = self.inputs.at_delay(car)
        angle = steering_angle(car, steering)[self.grid_at]
        rate = yaw_rate(car, angle, self.speed, self.wheelbase_m)
        v = speeds(car, throttle, self.starts, self.v0, self.steps)[self.rows, self.cols]
        return v, rate

    def residuals(self, vector: np.ndarray, scale: tuple[float, float]) -> np.ndarray:
        v, rate = self.predict(Car(*vector))
        return np.concatenate([(v - self.speed[self.pose]) / scale[0],
                               np.where(self.steered, rate - self.rate, 0.0) / scale[1]])

    def prediction(self, car: Car) -> Prediction:
        v, rate = self.predict(car)
        per_pose = np.full(len(self.t), np.nan)
        per_pose[self.pose] = v  # the latest window's prediction at each pose
        has = ~np.isnan(per_pose)
        return Prediction(self.t[has], self.speed[has], per_pose[has], self.rate[has], rate[has])


def fit(record: FitLog, wheelbase_m: float, held_out: str = "", start: Car | None = None,
        speed_phases: tuple[str, ...] = SPEED_MANOEUVRES) -> FitResult:
    """The model fitted to `record` ([m] wheelbase: the car's own, measured with a ruler); the
    manoeuvre named `held_out` (a phase of the record) is kept out of the fit and predicted.
    Speeds are explained only in the manoeuvres of `speed_phases` (all, in a record without phases)."""
    from scipy.optimize import least_squares

    record.check()
    record = record.shifted()
    phase = record.phase_at(record.pose_t)
    names = [n for _, n in record.phases]
    if held_out and held_out not in names:
        raise FitError(f"the record has no manoeuvre {held_out!r} to hold out (it has {', '.join(names) or 'none'})")
    out = np.array([held_out and 0 <= k < len(names) and names[k] == held_out for k in phase], dtype=bool)
    throttle_only = np.array([not names or (0 <= k < len(names) and names[k] in speed_phases) for k in phase])
    problem = _Problem(record, wheelbase_m, ~out, throttle_only)
    grip, grip_sigma = _grip(problem, record, names)
    free = np.array([n != "lateral_m_s2" for n in NAMES])  # the grip is measured, not fitted
    low = np.array([p.low for p in PARAMS])
    high = np.array([p.high for p in PARAMS])
    whole = np.clip((start or Car.start()).vector(), low, high)
    whole[~free] = np.clip(grip, low[~free], high[~free])
    scale = (0.1, 0.1)  # [m/s], [rad/s]: first pass; then each channel's own error
    evaluations = 0

    def of(part: np.ndarray) -> np.ndarray:
        x = whole.copy()
        x[free] = part
        return x

    def residuals(part: np.ndarray, units: tuple[float, float]) -> np.ndarray:
        return problem.residuals(of(part), units)

    def solve(x0: np.ndarray):
        nonlocal evaluations
        r = least_squares(residuals, x0, bounds=(low[free], high[free]), x_scale=(high - low)[free], args=(scale,),
                          method="trf", max_nfev=100, ftol=1e-6, xtol=1e-6)
        evaluations += r.nfev
        return r

    best = solve(whole[free])
    for _ in range(2):
        # each delay's error has a minimum per frame and per pose: the deepest over a scan of
        # DELAY_SCAN_S, the rest held, then everything again from there
        x = of(best.x)
        for name in ("delay_s", "steer_delay_s"):
            k = NAMES.index(name)
            costs = []
            for delay in DELAY_SCAN_S:
                x[k] = delay
                costs.append(float(np.sum(problem.residuals(x, scale) ** 2)))
            x[k] = DELAY_SCAN_S[int(np.argmin(costs))]
        evaluations += 2 * len(DELAY_SCAN_S)
        again = solve(x[free])
        best = again if again.cost <= best.cost else best
        v, rate = problem.predict(Car(*of(best.x)))  # then each channel weighed by its own error
        scale = (max(float(np.sqrt(np.mean((v - problem.speed[problem.pose]) ** 2))), 1e-3),
                 max(float(np.sqrt(np.mean((rate - problem.rate)[problem.steered] ** 2))), 1e-3))
        best = solve(best.x)  # (its cost in these units, for the next comparison and the intervals)
    x = of(best.x)
    car = Car(*x)
    sigma = np.zeros(len(NAMES))
    sigma[free] = sigma_of(best, len(best.fun), max(1.0, SMOOTH_S / np.median(np.diff(record.pose_t))))
    sigma[~free] = grip_sigma
    held = _Problem(record, wheelbase_m, out, np.ones(len(out), dtype=bool)).prediction(car) if out.any() else None
    return FitResult(car, dict(zip(NAMES, sigma)), problem.prediction(car), held, held_out, evaluations)


def _grip(problem: _Problem, record: FitLog, names: list[str]) -> tuple[float, float]:
    """([m/s^2] the tyres' grip, its standard deviation): the GRIP_SHARE percentile of the
    sideways acceleration (speed x yaw rate) measured while the car was driven forward in the grip
    manoeuvre (anywhere, in a record without one). Measured, not fitted: a yaw rate's brief
    overshoot in a steering step would pull a fitted limit up. Its deviation is the spread of the
    samples about it, not that over their number: they are neighbours along one slide, and the
    level a car slides at differs between two drives of one car by as much (0.13-0.25 m/s^2)."""
    inside = problem.moving.copy()
    if GRIP in names:
        inside &= record.phase_at(problem.t) == names.index(GRIP)
    lateral = np.abs(problem.speed * problem.rate)[inside]
    if len(lateral) < 5:
        return PARAMS[NAMES.index("lateral_m_s2")].start, float("inf")
    grip = float(np.percentile(lateral, GRIP_SHARE))
    top = lateral[lateral >= np.percentile(lateral, 2 * GRIP_SHARE - 100)]
    return grip, float(np.std(top))


def sigma_of(result, n: int, correlated: float = 1.0) -> np.ndarray:
    """Each parameter's standard deviation from the Jacobian at a least-squares solution (scipy's)
    of n residuals, of which `correlated` neighbours are not independent (a test drive's speeds are
    measured over SMOOTH_S: the variance is counted over SMOOTH_S-long pieces, not poses)."""
    jac = result.jac
    dof = max(n - jac.shape[1], 1)
    s2 = 2 * result.cost / dof
    cov = np.linalg.pinv(jac.T @ jac) * s2 * correlated
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))
