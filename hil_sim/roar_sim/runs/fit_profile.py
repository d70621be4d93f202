"""From a fitted model (roar.fit.identify) to a car profile the simulator drives like the car:
the simulated car is driven through the same test drive (roar_sim.runs.fit_drive) with a
candidate profile, its record fitted by the same model, and the profile corrected until the
simulator's numbers are the car's (Gauss-Newton steps, damped, through how each profile number
moves the model's, measured once at the base). The model is simple (a lag where the
car has a servo and tyres, a ramp where it has a frame); this loop makes its simplicity cost
nothing: what is matched is the simulator's behaviour, not the model's idea of it.

    profile, rounds = matched_profile(result.car, result.sigma, base, area, pose_hz=50)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from roar.fit.drive import Area
from roar.fit.identify import fit
from roar.fit.model import STEP_S, Car
from roar_sim.plants.car_profile import OPTIONAL_RANGES, RANGES, CarProfile
from roar_sim.runs.fit_drive import drive

# profile key -> (the model numbers it moves, the step its slopes are measured over: a difference,
# or a ratio ("x1.15") for a number that scales). Only these slopes are measured: the others are
# noise between two drives, and would steer the matching astray.
MATCHED = {
    "steering_trim_deg": (("trim_deg",), 2.0),
    "max_steer_rad": (("gain_rad",), "x1.15"),
    "servo_lag_s": (("steer_delay_s", "lag_s"), 0.05),
    "latency_s": (("delay_s", "steer_delay_s"), 0.04),
    "esc_deadband_us": (("deadband_us",), 25.0),
    "motor_speed_rad_s": (("top_m_s",), "x1.2"),
    "motor_torque_nm": (("drive_m_s2",), "x1.5"),
    "rolling_drag_nm": (("coast_m_s2",), "x1.5"),
    "tyre_friction": (("lateral_m_s2",), "x1.3"),
}
# A measured slope of a profile number's first model number this far from what it would be if the
# two were one (a difference moves it by as much; a ratio scales it alike) is taken for noise
# between two drives, and that slope used instead
SLOPE_TRUST = (0.33, 3.0)
DAMPING = 0.8  # of each round's step: a noisy slope overshoots less
REACH = 2.0  # a round moves each number by at most this many of the steps its slope was measured over
# each number away from the base's weighs as a gap of this many of the user's intervals per step its
# slope was measured over: a number the drive shows (a step moves a model number by several
# intervals) hardly feels it, one it does not show (the motor's torque where the tyres limit the
# car) stays near the base's rather than wandering wherever noise pushes it
PRIOR = 0.3
MODEL_KEYS = ("trim_deg", "gain_rad", "steer_delay_s", "lag_s", "delay_s", "deadband_us", "top_m_s", "drive_m_s2",
              "coast_m_s2", "lateral_m_s2")  # the model numbers matched
ROUNDS = 3  # simulated test drives after the base profile's
JACOBIAN_VERSION = 7  # of the test drive and the model: slopes kept in the user's cache by another are measured again


@dataclass
class Round:
    profile: CarProfile
    gap: dict[str, float]  # model number -> (simulated - user's) / the user's 95 % interval half-width


def matched_profile(target: Car, sigma: dict[str, float], base: CarProfile, area: Area, pose_hz: float,
                    rounds: int = ROUNDS, progress=None, noise_m: float = 0.0) -> tuple[CarProfile, list[Round]]:
    """The profile (from `base`: its size, mass and gearing kept) whose simulated test drive fits
    to `target` (the user's car's model numbers, ± 1.96 sigma), and each round on the way. Each
    round's drive has the user's poses' noise (`noise_m` [m], FitLog.pose_noise_m): noise lifts the
    grip measured (3 mm: +3 %), and a simulator matched without it would be grippier. How
    each profile number moves the model's (the Jacobian) is measured once per base profile, test
    drive and pose rate, by driving the base with each number stepped, and kept in the user's cache."""
    keys, model_keys = list(MATCHED), list(MODEL_KEYS)
    want = np.array([getattr(target, m) for m in model_keys])
    # a time the model tells no finer than its step: its cost is jagged at that scale (the pulses
    # move every message), so a delay's interval from the slope at its minimum can be a tenth of
    # that, and a simulated drive's delay 50 of them off while every other number matched
    half = np.array([max(1.96 * sigma[m], STEP_S if m.endswith("_s") else 1e-6) for m in model_keys])
    p = origin = np.array([getattr(base, k) for k in keys], dtype=float)
    jacobian, got = _jacobian(base, area, pose_hz, keys, model_keys, progress)
    history: list[Round] = []
    for n in range(rounds + 1):
        profile = _profile(base, keys, p)
        if n:
            record, _ = drive(profile, area, pose_hz=pose_hz, noise_m=noise_m, seed=n)
            got = np.array([getattr(fit(record, profile.wheelbase_m, start=target).car, m) for m in model_keys])
        gap = (got - want) / half
        history.append(Round(profile, dict(zip(model_keys, gap.tolist()))))
        if progress is not None:
            progress(f"round {n}: " + ", ".join(f"{m} {g:+.1f}" for m, g in history[-1].gap.items()))
        if np.all(np.abs(gap) <= 1.0):  # within the user's own intervals: as close as a fit can tell
            break
        # the step that closes the gaps best, each weighed by how closely the user's car tells it
        scale = _steps(base, keys)
        system = np.vstack([jacobian / half[:, None], np.diag(PRIOR / scale)])
        gaps = np.concatenate([(want - got) / half, PRIOR * (origin - p) / scale])
        step = DAMPING * np.linalg.lstsq(system, gaps, rcond=None)[0]
        p = _clip(keys, _within_reach(keys, p, p + step))
    best = min(history, key=lambda r: float(np.max(np.abs(list(r.gap.values())))))
    # the trim moves the model's trim alone, and nothing else moves that (a car's trim is in its
    # servo's horn; its motor, tyres and lag turn it alike both ways): it is taken from the round
    # that matched it best, as the round best overall may be one where the trim had not yet settled
    # while the speeds' coupled numbers had (0.46 deg off in one drive of five)
    closest = {"steering_trim_deg": min(history, key=lambda r: abs(r.gap["trim_deg"])).profile.steering_trim_deg}
    return dataclasses.replace(best.profile, **closest), history


def _jacobian(base: CarProfile, area: Area, pose_hz: float, keys: list[str], model_keys: list[str],
              progress=None) -> tuple[np.ndarray, np.ndarray]:
    """(d model numbers / d profile numbers at the base, the base's model numbers)."""
    import hashlib
    import json

    from roar_sim.toolchains.native import user_cache

    name = hashlib.sha256(f"{base.fingerprint} {area} {pose_hz:.1f} {JACOBIAN_VERSION}".encode()).hexdigest()[:16]
    kept = user_cache("fit") / f"jacobian-{name}.json"
    try:
        data = json.loads(kept.read_text())
        return np.array(data["jacobian"]), np.array(data["base"])
    except (OSError, ValueError, KeyError):
        pass
    p = np.array([getattr(base, k) for k in keys], dtype=float)

    start = None  # each stepped drive's fit starts from the base's

    def numbers(values: np.ndarray) -> np.ndarray:
        nonlocal start
        profile = _profile(base, keys, values)
        record, _ = drive(profile, area, pose_hz=pose_hz)
        car = fit(record, profile.wheelbase_m, start=start).car
        start = start or car
        return np.array([getattr(car, m) for m in model_keys])

    at_base = numbers(p)
    jacobian = np.zeros((len(model_keys), len(keys)))
    for j, key in enumerate(keys):
        if progress is not None:
            progress(f"measuring how the simulated car answers its {key} ({j + 1}/{len(keys)}, once for this base)")
        step = MATCHED[key][1]
        moved = p.copy()
        moved[j] = p[j] * float(step[1:]) if isinstance(step, str) else p[j] + step
        slopes = (numbers(moved) - at_base) / (moved[j] - p[j])
        first, *others = MATCHED[key][0]
        i = model_keys.index(first)
        alike = at_base[i] / p[j] if isinstance(step, str) else 1.0  # the slope if the two were one
        trusted = SLOPE_TRUST[0] * alike <= slopes[i] <= SLOPE_TRUST[1] * alike
        jacobian[i, j] = slopes[i] if trusted else alike
        for m in others:  # a coupling: kept where it has the sign it must have
            jacobian[model_keys.index(m), j] = max(slopes[model_keys.index(m)], 0.0)
    try:
        kept.parent.mkdir(parents=True, exist_ok=True)
        kept.write_text(json.dumps({"jacobian": jacobian.tolist(), "base": at_base.tolist()}))
    except OSError:
        pass  # measured again next time
    return jacobian, at_base


def _steps(base: CarProfile, keys: list[str]) -> np.ndarray:
    """Each number's step its slopes were measured over, as a difference at the base."""
    steps = [MATCHED[k][1] for k in keys]
    return np.array([getattr(base, k) * (float(s[1:]) - 1) if isinstance(s, str) else s for k, s in zip(keys, steps)])


def _within_reach(keys: list[str], before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """`after`, each number moved from `before` by at most REACH of the steps its slopes were
    measured over (a ratio's power): the slopes hold near the base, and a number the test drive
    hardly shows (the motor's torque where the tyres limit) would otherwise leap on a noisy gap."""
    out = after.copy()
    for j, key in enumerate(keys):
        step = MATCHED[key][1]
        if isinstance(step, str):
            most = float(step[1:]) ** REACH
            out[j] = min(max(after[j], before[j] / most), before[j] * most) if before[j] > 0 else after[j]
        else:
            out[j] = min(max(after[j], before[j] - REACH * step), before[j] + REACH * step)
    return out


def _clip(keys: list[str], p: np.ndarray) -> np.ndarray:
    ranges = RANGES | OPTIONAL_RANGES
    return np.array([min(max(v, ranges[k][0]), ranges[k][1]) for k, v in zip(keys, p)])


def _profile(base: CarProfile, keys: list[str], p: np.ndarray) -> CarProfile:
    values = dict(zip(keys, (float(v) for v in p)))
    values["esc_deadband_us"] = float(round(values["esc_deadband_us"], 1))
    return dataclasses.replace(base, **values)


def rounded(profile: CarProfile) -> CarProfile:
    """The profile's numbers to the precision a fit can tell (4 significant digits)."""
    values = {k: float(f"{getattr(profile, k):.4g}") for k in MATCHED}
    return dataclasses.replace(profile, **values)


