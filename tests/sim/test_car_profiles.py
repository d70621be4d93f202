"""A car's own numbers in one profile file: the default is the ROAR car (its physics unchanged, its
limits the measured table), `f1tenth` a faster car whose limits are measured from the profile on
first use and kept in the user's cache; bad profiles are refused in one line."""

import json

import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.protocol import encode  # noqa: E402
from roar_sim.plants import car_profile  # noqa: E402
from roar_sim.plants.car_profile import ProfileError  # noqa: E402
from roar_sim.robots import esc  # noqa: E402


def top_speed(profile) -> float:
    """[m/s] after 4 s at full throttle on an open floor."""
    with esc.EscCar(profile=profile) as car:
        for i in range(200):
            car.write(encode(1500 if i < 5 else 2000, 1500))
            car.run(0.02)
        return car.state().speed


def test_the_shipped_profiles_and_the_default():
    assert {"roar", "f1tenth"} <= set(car_profile.names())
    roar = car_profile.load()
    assert roar.name == "roar" and roar.motor.max_speed_rad_s == 60.0 and roar.scale == 1.0
    f1 = car_profile.load("f1tenth")
    assert f1.wheelbase_m == 0.33 and f1.mass_kg == 3.47 and f1.fingerprint != roar.fingerprint
    with esc.EscCar() as car:
        assert car.limits == esc.LIMITS and car.model.wheelbase_m == 0.325


def test_the_f1tenth_car_is_much_faster_and_its_limits_are_measured_once(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(esc, "_MEASURED", {})
    with esc.EscCar(profile="f1tenth") as car:
        limits = car.limits
    assert "measuring the F1TENTH-like" in capsys.readouterr().err
    assert top_speed("f1tenth") > 2 * top_speed("roar") > 5.5
    kept = list((tmp_path / "roar" / "limits").glob("esc-*.json"))
    assert len(kept) == 1 and json.loads(kept[0].read_text())["max_speed_m_s"] == limits.max_speed_m_s
    assert limits.max_speed_m_s > 7.0 and limits.max_lateral_m_s2 > 2 * esc.LIMITS.max_lateral_m_s2
    monkeypatch.setattr(esc, "_MEASURED", {})
    with esc.EscCar(profile="f1tenth") as car:  # read back from the cache, not measured again
        assert car.limits == limits
    assert "measuring" not in capsys.readouterr().err


@pytest.mark.parametrize("text, fragment", [
    ("title = 'x'\n", "missing"),
    ("title = 'x'\nwheelbase_m = 0.3\ncolour = 1\n", "unknown keys colour"),
    ("title = 'x'\nwheelbase_m = 9\nmass_kg = 3\nmotor_speed_rad_s = 600\ngear_ratio = 10\nmotor_torque_nm = 0.1\n"
     "tyre_friction = 1\nmax_steer_rad = 0.4\nsteer_rate_rad_s = 3\n", "wheelbase_m must be a finite number 0.15..0.6 m, got 9"),
    ("title = 'x'\nwheelbase_m = nan\nmass_kg = 3\nmotor_speed_rad_s = 600\ngear_ratio = 10\nmotor_torque_nm = 0.1\n"
     "tyre_friction = 1\nmax_steer_rad = 0.4\nsteer_rate_rad_s = 3\n", "wheelbase_m must be"),
    ("title = [\n", "not valid TOML"),
])
def test_a_bad_profile_is_refused_in_one_line(tmp_path, text, fragment):
    path = tmp_path / "car.toml"
    path.write_text(text)
    with pytest.raises(ProfileError) as e:
        car_profile.load(str(path))
    assert fragment in str(e.value) and str(path) in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(ProfileError, match="no car profile 'lorry': use"):
        car_profile.load("lorry")


def test_roar_race_takes_a_car_profile(tmp_path):
    from roar.cli import main as roar

    assert roar(["race", "--car-profile", "nope", "--laps", "1"]) == 1
    assert roar(["race", "--robot", "junior", "--car-profile", "f1tenth"]) == 1


def test_a_fast_car_brakes_from_its_top_speed_in_a_straight_line():
    """The speed controller brakes a car of any top speed: the F1TENTH-like car (7.9 m/s) asked to
    slow from 7.5 to 3 m/s slows, and stays pointing down the straight (under full reverse its rear
    wheels lost their grip and it turned 86 degrees; and after half a second of braking the
    controller took it for reversing and let it coast)."""
    import math

    from roar.autopilot.longitudinal import SpeedController
    from roar_sim.robots.esc import EscCar

    with EscCar(profile="f1tenth") as car:
        car.arm()
        control = SpeedController(car.limits.max_speed_m_s, max_reverse=car.limits.max_reverse)
        yaws = []
        while car.time_s < 4.0:
            s = car.state()
            target = 7.5 if car.time_s < 2.5 else 3.0
            car.drive(control.step(target, abs(s.speed), 0.02), 0.0)
            car.run(0.02)
            if car.time_s >= 2.5:
                yaws.append(s.yaw)
        end = car.state()
    assert abs(end.speed - 3.0) < 0.5, end.speed
    assert max(abs(math.degrees(math.remainder(y - yaws[0], math.tau))) for y in yaws) < 5


def test_the_speed_controllers_gains_scale_with_the_top_speed():
    from roar.autopilot.longitudinal import SpeedController

    roar, fast = SpeedController(2.93), SpeedController(7.9)
    assert roar.pid.kp == pytest.approx(0.6) and roar.pid.ki == pytest.approx(0.4) and roar.brake_gain == pytest.approx(1.5)
    assert fast.pid.kp * 7.9 == pytest.approx(roar.pid.kp * 2.93) and fast.brake_gain * 7.9 == pytest.approx(4.395)


def test_the_f1tenth_car_laps_a_random_track_at_its_limit_without_touching_a_wall():
    """Issue 43, item 6 (every profile on every track: make bench). The F1TENTH-like car turns a
    third less than its steering asks at 3.4 m/s and its grip fades above 3.9 m/s: before the
    curvature tracker and the measured fade it touched walls on 11 of 13 tracks."""
    from roar.tracks import get
    from roar_sim.runs.race import race

    with esc.EscCar(profile="f1tenth") as car:
        assert car.limits.lateral_fade  # measured: it holds less grip at its higher speeds
    assert esc.LIMITS.lateral_fade == ()  # the ROAR car holds its grip up to its top speed
    result = race(get("random:1"), laps=2, profile="f1tenth")
    assert len(result.lap_times_s) == 2 and result.wall_contacts == 0
    assert result.best_ratio <= 1.10


def test_a_profile_whose_car_cannot_be_measured_is_refused_in_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    profile = tmp_path / "rocket.toml"  # its wheels would turn at 37 m/s: it never drives a steady run
    profile.write_text('title = "rocket"\nwheelbase_m = 0.2677\nmass_kg = 6.3206\nmotor_speed_rad_s = 4894.6\n'
                       'gear_ratio = 5.5039\nmotor_torque_nm = 3.0045\ntyre_friction = 1.4843\nmax_steer_rad = 0.2127\n'
                       'steer_rate_rad_s = 2.1268\n')
    with pytest.raises(ProfileError, match=r"rocket: its limits cannot be measured.*36.6 m/s") as e:
        esc.profile_limits(car_profile.load(str(profile)))
    assert "\n" not in str(e.value)
