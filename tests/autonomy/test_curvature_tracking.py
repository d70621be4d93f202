"""The curvature tracker (the gyro closes pure pursuit's steering loop) and the grip that fades
with speed (CarLimits.lateral_fade): what the autopilot plans with must be what the car holds."""

import math

import numpy as np
import pytest

from roar.autopilot import CarLimits, CarModel, Observation, race_agent, speed_profile
from roar.autopilot.curvature_tracking import CurvatureTracker
from roar.autopilot.limits import fade, tracked

PERIOD_S = 0.02  # [s]


def test_the_tracker_adds_what_an_understeering_car_turns_short_of():
    tracker = CurvatureTracker()
    asked, turned_share, speed = 0.5, 0.75, 3.0  # the car turns 3/4 of what its steering asks
    steer_for = asked
    for _ in range(round(4.0 / PERIOD_S)):
        steer_for = tracker.step(asked, speed, speed * turned_share * steer_for, PERIOD_S)
    assert turned_share * steer_for == pytest.approx(asked, rel=0.06)
    assert turned_share * asked < 0.8 * asked  # without it, a quarter short


def test_without_a_gyro_or_at_a_standstill_the_tracker_steers_for_what_is_asked():
    tracker = CurvatureTracker()
    for rate in (None, math.nan):
        assert tracker.step(0.4, 3.0, rate, PERIOD_S) == 0.4
    assert tracker.step(0.4, 0.1, 0.0, PERIOD_S) == 0.4  # too slow for the curvature driven to mean anything


def test_a_car_that_does_not_turn_at_all_is_not_steered_beyond_the_bound():
    tracker = CurvatureTracker()
    for _ in range(500):
        out = tracker.step(0.4, 3.0, 0.0, PERIOD_S)  # a sliding car: the gyro says it goes straight
    assert out == pytest.approx(0.4 + 0.5 * 0.4 + 0.1)


def drive_a_circle(understeer: float, trim_per_m: float, tracker: bool) -> float:
    """[m] the largest miss of a 4 m circle, driven at 3 m/s by the race agent, the car turning
    tan(angle) / wheelbase / (1 + understeer) + trim_per_m (a kinematic bicycle with understeer
    and a steering trim), after its first half lap."""
    radius, wheelbase, speed = 4.0, 0.33, 3.0
    theta = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    line = np.c_[radius * np.cos(theta), radius * np.sin(theta)]
    car = CarModel(wheelbase, 0.42, CarLimits(speed, 3.0, 3.0, 20.0))
    agent = race_agent(line, car, PERIOD_S)
    if not tracker:
        agent.controller.tracker = None
    agent.setup()
    x, y, yaw, rate, worst = radius, 0.0, math.pi / 2, 0.0, 0.0
    for k in range(round(3 * 2 * math.pi * radius / speed / PERIOD_S)):
        command = agent.step(Observation(k * PERIOD_S, x, y, yaw, speed, rate))
        angle = -command.steering * car.max_steer_rad
        rate = speed * (math.tan(angle) / wheelbase / (1 + understeer) + trim_per_m)
        yaw += rate * PERIOD_S
        x, y = x + speed * math.cos(yaw) * PERIOD_S, y + speed * math.sin(yaw) * PERIOD_S
        if k * PERIOD_S * speed > math.pi * radius:
            worst = max(worst, abs(math.hypot(x, y) - radius))
    return worst


@pytest.mark.parametrize("understeer, trim", [(0.3, 0.0), (0.0, 0.05), (0.2, -0.05)])
def test_the_race_agent_holds_its_line_on_a_car_that_understeers_or_whose_trim_is_off(understeer, trim):
    without, with_tracker = drive_a_circle(understeer, trim, False), drive_a_circle(understeer, trim, True)
    assert without > 0.08  # pure pursuit alone runs wide (or cuts in) by 9-17 cm
    assert with_tracker < 0.03 and with_tracker < without / 3


def test_the_grip_fades_as_measured_and_the_profile_plans_with_it():
    limits = CarLimits(8.0, 4.0, 3.5, 8.0, lateral_fade=((4.0, 8.0), (5.0, 6.0)))
    assert limits.lateral_at([3.0, 4.0, 4.5, 5.0]) == pytest.approx([8.0, 8.0, 7.0, 6.0])
    assert limits.lateral_at(10.0) == pytest.approx(6.0 * (5.0 / 10.0) ** 2)  # no tighter than the last circle
    kappa = np.array([1 / 1.0, 1 / 4.0, 1 / 20.0])
    v = limits.corner_speed(kappa)
    assert v ** 2 * kappa == pytest.approx(np.minimum(v ** 2 * kappa, limits.lateral_at(v) + 1e-6))
    assert v[0] == pytest.approx(math.sqrt(8.0))  # a tight bend is slow enough for the peak
    assert v[1] < math.sqrt(8.0 * 4.0) and v[2] < 8.0  # faster bends: the grip held at their speed
    steady = np.c_[20 * np.cos(np.linspace(0, 2 * np.pi, 300, endpoint=False)),
                   20 * np.sin(np.linspace(0, 2 * np.pi, 300, endpoint=False))]
    assert speed_profile(steady, limits).max() == pytest.approx(v[2], rel=0.01)
    assert np.array(limits.with_margin(0.9).lateral_fade) == pytest.approx(np.array([[4.0, 7.2], [5.0, 5.4]]))


def test_a_fade_is_kept_only_where_the_grip_falls_below_its_peak():
    assert fade((3.0, 8.0), [(2.0, 5.0), (3.5, 8.5)]) == ()  # slower, or no lower: the peak holds
    assert fade((3.0, 8.0), [(6.0, 5.0), (5.0, 6.0), (5.5, 7.0)]) == ((3.0, 8.0), (5.0, 6.0), (6.0, 5.0))
    assert tracked(2.0, 2.2) and not tracked(1.0, 3.0)  # 10 % wider is held; three times as wide is not


@pytest.mark.parametrize("fade_points", [((4.0, 6.0),), ((5.0, 6.0), (4.0, 5.0)), ((4.0, 5.0), (5.0, 6.0)),
                                         ((4.0, -1.0), (5.0, -2.0)), "nonsense"])
def test_a_fade_that_is_not_a_falling_curve_is_refused(fade_points):
    with pytest.raises(ValueError, match="lateral_fade"):
        CarLimits(8.0, 4.0, 3.5, 8.0, lateral_fade=fade_points)


class Circling:
    """A car on a steady circle for grip_on_circles: at steering s [m] (its slowest radius) and
    speed v, radius(s, v) [m]; its log is 100 states of that circle."""

    def __init__(self, radius):
        self.radius = radius

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def drive(self, speed, steering):
        r = self.radius(steering, speed)
        state = type("State", (), {"speed": speed, "yaw_rate": speed / r})
        return [(k * PERIOD_S, state) for k in range(100)]


def grip_of(radius):
    pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")
    from roar_sim.robots import grip_on_circles

    car = Circling(radius)
    return grip_on_circles(lambda: car, (1.0, 2.0, 4.0), (1.0, 2.0, 3.0, 4.0, 5.0, 6.0),
                           lambda robot, speed, steering: robot.drive(speed, steering))


def test_circles_give_the_peak_grip_and_where_it_fades():
    # the tyres hold 6 m/s^2 up to 3 m/s, then less: the car runs wide, faster runs wider
    def radius(steering, speed):
        grip = 6.0 if speed <= 3.0 else 6.0 - 1.5 * (speed - 3.0)
        return max(steering, speed ** 2 / grip)

    peak, fade_points = grip_of(radius)
    assert peak == pytest.approx(4.5)  # 3 m/s on the 2 m circle (on the 1 m one, 3 m/s pushes 50 % wide)
    assert fade_points == ((3.0, 4.5), (4.0, 4.0))  # the 4 m circle's last before it ran twice as wide
    assert grip_of(lambda steering, speed: max(steering, speed ** 2 / 6.0))[1] == ()  # no fade below its top speed


def test_a_circle_that_spins_tighter_is_not_grip():
    # from 3 m/s on the 2 m circle the car spins: its circle shrinks to a third
    def radius(steering, speed):
        return steering / 3 if speed >= 3.0 else steering

    peak, _ = grip_of(radius)
    assert peak == pytest.approx(2.0 ** 2 / 1.0)  # the 1 m circle at 2 m/s: no spin counts


def test_the_throttle_is_lifted_in_a_slide_but_not_for_one_periods_jump():
    tracker = CurvatureTracker()
    for _ in range(20):
        tracker.step(0.2, 4.0, 4.0 * 0.2, PERIOD_S)  # turning as asked
    assert tracker.drive_share == 1.0
    tracker.step(0.8, 4.0, 4.0 * 0.2, PERIOD_S)  # one period's jump of what is asked (a corrected pose)
    assert tracker.drive_share > 0.5
    for _ in range(15):  # 0.3 s turning the other way than asked: the rear has stepped out
        tracker.step(0.2, 4.0, -4.0 * 0.2, PERIOD_S)
    assert tracker.drive_share == 0.0
    tracker.reset()
    assert tracker.drive_share == 1.0
