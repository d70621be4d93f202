"""`roar fit` on hidden cars: five ROAR cars made different at random within what real cars differ
by (issue 46: steering trim within 4 deg, servo lag 20-80 ms, latency 0-60 ms, motor 70-120 %,
grip 70-110 %, ESC dead band 0-60 us; seeded), each driven through the test drive in lockstep
with its pose at 30 Hz and 3 mm of noise (a phone's), fitted, and matched by the simulator.
Targets: each number within 5 % (trim 0.3 deg, latency 5 ms, dead band 5 us); the fitted car's
lap time within 2 % of the hidden car's on three tracks, both raced by the autopilot; and the hidden
car itself, its autopilot planning by the fitted profile at its full limits, within 1.05x its own
physical-limit lap with no wall touched (beside it: the same planned by today's constants)."""

import dataclasses

import numpy as np

from roar.fit.drive import HELD_OUT, Area
from roar.fit.identify import fit
from roar.tracks import get
from roar_sim.plants import car_profile
from roar_sim.runs.fit_drive import drive
from roar_sim.runs.fit_profile import MATCHED, matched_profile
from roar_sim.runs.race import race

TITLE = "roar fit finds five hidden cars (targets: 5 %, trim 0.3 deg, latency 5 ms, dead band 5 us; laps 2 %)"
CARS = 5
AREA = Area(4.0, 6.0)
POSE_HZ, NOISE_M = 30.0, 0.003  # a phone's pose
TRACKS = ("oval", "figure-eight", "course")
LAP_TARGET = 0.02
LIMIT_TARGET = 1.05  # the hidden car's best lap, planned by its fitted profile, over its own physical-limit lap
MARGIN = 1.0  # of the planned limits the autopilot drives at: the fitted profile's limits are the car's
ABSOLUTE = {"steering_trim_deg": 0.3, "latency_s": 0.005, "esc_deadband_us": 5.0}  # else within 5 %
RELATIVE = 0.05


def hidden(seed: int):
    """A ROAR car made different within what real cars differ by (car_profile.REAL_CARS_*), seeded."""
    rng = np.random.default_rng(seed)
    base = car_profile.load()
    spread, share = car_profile.REAL_CARS_ABSOLUTE, car_profile.REAL_CARS_SHARE
    motor = rng.uniform(*share["motor"])
    return dataclasses.replace(
        base, title=f"hidden car {seed}", steering_trim_deg=round(rng.uniform(*spread["steering_trim_deg"]), 2),
        servo_lag_s=round(rng.uniform(*spread["servo_lag_s"]), 3),
        latency_s=round(rng.uniform(*spread["latency_s"]), 3),
        motor_speed_rad_s=round(base.motor_speed_rad_s * motor, 1),
        motor_torque_nm=round(base.motor_torque_nm * motor, 4),
        tyre_friction=round(base.tyre_friction * rng.uniform(*share["tyre_friction"]), 3),
        esc_deadband_us=round(rng.uniform(*spread["esc_deadband_us"]), 1))


def run() -> None:
    missed = 0
    for seed in range(CARS):
        truth = hidden(seed)
        record, stopped = drive(truth, AREA, pose_hz=POSE_HZ, noise_m=NOISE_M, seed=seed)
        result = fit(record, truth.wheelbase_m, held_out=HELD_OUT)
        found, rounds = matched_profile(result.car, result.sigma, car_profile.load(), AREA, POSE_HZ,
                                       noise_m=record.pose_noise_m())
        print(f"  hidden car {seed}{' (drive ended early: ' + stopped + ')' if stopped else ''}: "
              f"{len(rounds) - 1} rounds; held-out sweep predicted within {result.held_out.rms()[0]:.3f} m/s, "
              f"{result.held_out.rms()[1]:.3f} rad/s RMS")
        for key in MATCHED:  # every number the fit finds
            want, got = getattr(truth, key), getattr(found, key)
            error = got - want
            if key in ABSOLUTE:
                ok, shown = abs(error) <= ABSOLUTE[key], f"{error:+.4g} (target {ABSOLUTE[key]:g})"
            else:
                ok, shown = abs(error) <= RELATIVE * abs(want), f"{error / want * 100:+.1f} % (target 5 %)"
            missed += not ok
            print(f"    {key:18} hidden {want:9.4g}  found {got:9.4g}  {shown}{'' if ok else '  MISSED'}")
        for track in TRACKS:
            laps = [race(get(track), 2, profile=p) for p in (truth, found)]
            if not all(r.lap_times_s for r in laps):
                missed += 1
                print(f"    {track:14} MISSED: a car drove no lap")
                continue
            a, b = (min(r.lap_times_s) for r in laps)
            ok = abs(b - a) <= LAP_TARGET * a
            missed += not ok
            print(f"    {track:14} lap: hidden {a:6.2f} s, fitted {b:6.2f} s ({(b - a) / a * 100:+.1f} %)"
                  f"{'' if ok else '  MISSED'}")
        for track in TRACKS:  # the hidden car itself, its autopilot planning by each profile
            runs = {name: race(get(track), 2, profile=truth, plan_profile=plan, margin=MARGIN)
                    for name, plan in (("by its fitted profile", found), ("by today's constants", car_profile.load()),
                                       ("by its true profile", truth))}
            fitted = runs["by its fitted profile"]
            ok = fitted.best_ratio <= LIMIT_TARGET and fitted.wall_contacts == 0
            missed += not ok
            print(f"    {track:14} its limit lap x: " + ", ".join(
                f"{r.best_ratio:.3f} {name} ({r.wall_contacts} wall contacts)" for name, r in runs.items())
                + ("" if ok else "  MISSED"))
    print(f"  {missed} numbers or laps missed their targets" if missed else "  every target met")
    if missed:
        print("  causes: the servo's lag shows mostly as a delay beside the car's own yaw lag, so lag and latency "
              "trade; the grip is what the car shows on a 1.2 m circle, where its rising speed ends the manoeuvre; "
              "the motor's torque shows only where it, not the tyres' traction, limits the car (low throttle); "
              "the autopilot planned by a car's true profile is itself 1.0-1.1x its limit lap (printed beside)")
