"""Autopilot pieces on their own: PID, pure pursuit against hand-computed cases, the speed
profile, waypoint files and the loop follower, braking through reverse, the agent/runner cycle,
and the simulated car's limits against a fresh measurement."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from roar.autopilot import (PID, Agent, CarLimits, Command, DirectionEstimator, LoopWaypointFollower, Module,
                            Observation, Passthrough, PurePursuit, Runner, SpeedController, WaypointError,
                            curvature, goal_on_path, lap_time, limit_lap_time, load_waypoints, save_waypoints,
                            speed_profile)

LIMITS = CarLimits(max_speed_m_s=3.0, max_accel_m_s2=2.0, max_brake_m_s2=2.5, max_lateral_m_s2=3.0)


def circle(radius, n=200):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([radius * np.cos(t), radius * np.sin(t)], axis=1)


# --- PID -----------------------------------------------------------------------------------------

@given(st.floats(-100, 100), st.floats(0.01, 10), st.floats(0, 5), st.floats(0, 1))
def test_pid_output_has_the_error_sign_and_stays_clamped(error, kp, ki, dt):
    pid = PID(kp=kp, ki=ki, out_min=-1, out_max=1)
    out = pid.step(error, dt + 1e-3)
    assert -1 <= out <= 1
    assert out == 0 or math.copysign(1, out) == math.copysign(1, error)


def test_pid_integral_does_not_wind_up_while_saturated():
    pid = PID(kp=1.0, ki=1.0, out_min=0.0, out_max=1.0)
    for _ in range(500):  # a long stretch far below the setpoint: output pinned at the top
        assert pid.step(5.0, 0.02) == 1.0
    assert pid.integral < 0.1  # nothing stored up while saturated...
    out = [pid.step(-0.2, 0.02) for _ in range(3)]
    assert out[0] == 0.0  # ...so overshooting the setpoint lets go at once


def test_pid_integral_removes_a_steady_error():
    pid = PID(kp=0.5, ki=2.0)
    assert pid.step(0.2, 0.02) < pid.step(0.2, 0.02) < pid.step(0.2, 0.02)


def test_pid_rejects_nan():
    with pytest.raises(ValueError):
        PID(kp=1).step(float("nan"), 0.02)


# --- pure pursuit --------------------------------------------------------------------------------

def test_pure_pursuit_straight_ahead_is_zero():
    assert PurePursuit(0.325).steering_angle(0, 0, 0, (1.0, 0.0)) == 0.0


def test_pure_pursuit_hand_computed():
    pp = PurePursuit(wheelbase_m=0.325)
    # Goal 1 m away at 30 deg left: curvature 2 sin(30)/1 = 1 /m, angle atan(0.325).
    goal = (math.cos(math.radians(30)), math.sin(math.radians(30)))
    assert pp.steering_angle(0, 0, 0, goal) == pytest.approx(math.atan(0.325))
    # The same seen from a car at (2, 3) heading north: the goal is to its right.
    assert pp.steering_angle(2, 3, math.pi / 2, (2 + 0.5, 3 + math.sqrt(3) / 2)) == pytest.approx(-math.atan(0.325))
    # Directly to the left, 0.5 m: curvature 2 / 0.5 = 4 /m.
    assert pp.steering_angle(0, 0, 0, (0.0, 0.5)) == pytest.approx(math.atan(0.325 * 4))


def test_lookahead_grows_with_speed():
    pp = PurePursuit(0.325, k_dd_s=0.4, min_lookahead_m=0.5, max_lookahead_m=1.5)
    assert [pp.lookahead_m(v) for v in (0, 1, 2, 5)] == pytest.approx([0.5, 0.9, 1.3, 1.5])


def test_goal_on_path_interpolates_and_wraps():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    assert goal_on_path(square, 0, 0.5) == pytest.approx((0.5, 0.0))
    assert goal_on_path(square, 3, 1.25) == pytest.approx((0.25, 0.0))


# --- speed profile -------------------------------------------------------------------------------

def test_curvature_of_a_circle():
    assert curvature(circle(2.0)) == pytest.approx(np.full(200, 0.5), rel=1e-3)


def test_on_a_circle_the_profile_is_the_grip_limit_and_the_lap_time_follows():
    pts = circle(1.5)
    v = speed_profile(pts, LIMITS)
    assert v == pytest.approx(np.full(200, math.sqrt(3.0 * 1.5)), rel=1e-3)
    assert lap_time(pts, v) == pytest.approx(2 * math.pi * 1.5 / math.sqrt(4.5), rel=1e-3)


@given(st.floats(0.5, 5), st.floats(0.5, 5), st.floats(0.5, 5))
def test_profile_respects_every_limit(accel, brake, lateral):
    limits = CarLimits(3.0, accel, brake, lateral)
    pts = np.array([[x, 0.0] for x in np.arange(0, 10, 0.1)] + [[10 + 1.0 * math.sin(a), 1 - math.cos(a)]
                    for a in np.linspace(0, math.pi, 30)] + [[x, 2.0] for x in np.arange(10, 0, -0.1)]
                   + [[-1.0 * math.sin(a), 1 + math.cos(a)] for a in np.linspace(0, math.pi, 30)])
    v = speed_profile(pts, limits)
    ds = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
    assert np.all(v <= 3.0 + 1e-9)
    assert np.all(v <= np.sqrt(lateral / np.maximum(curvature(pts), 1e-9)) + 1e-9)
    nxt = np.roll(v, -1)
    assert np.all(nxt ** 2 <= v ** 2 + 2 * accel * ds + 1e-6)
    assert np.all(v ** 2 <= nxt ** 2 + 2 * brake * ds + 1e-6)


def test_more_grip_never_makes_the_limit_lap_slower():
    pts = circle(1.0)
    assert limit_lap_time(pts, LIMITS) > limit_lap_time(pts, CarLimits(3.0, 2.0, 2.5, 6.0))


def test_limits_must_be_positive():
    with pytest.raises(ValueError, match="max_lateral_m_s2"):
        CarLimits(3.0, 2.0, 2.0, 0.0)


# --- waypoints -----------------------------------------------------------------------------------

def test_waypoint_files_round_trip_and_accept_orientation(tmp_path):
    path = tmp_path / "w.txt"
    save_waypoints(path, circle(1.0, 10))
    assert load_waypoints(path)[:, :2] == pytest.approx(circle(1.0, 10), abs=1e-4)
    path.write_text("# recorded\n0,0,0,0,0,90\n\n1,0,0\n1,1,0.5,0,0,45\n")
    assert load_waypoints(path).tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0.5]]


@pytest.mark.parametrize("text, words", [
    ("0,0\n1,1,0\n2,2,0\n", ":1: expected x,y,z"),
    ("0,0,0\n1,x,0\n2,2,0\n", ":2: expected"),
    ("0,0,0\n1,1,0,0\n2,2,0\n", ":2: expected"),
    ("0,0,0\n1,1,nan\n2,2,0\n", ":2: expected"),
    ("0,0,0\n1,1,0\n", "at least 3 distinct waypoints"),
    ("1,1,0\n1,1,0\n1,1,0\n", "at least 3 distinct waypoints"),
    ("0,0,0\n0.1,0,0\n0.1,0.1,0\n", "at least 1 m"),
    ("1e300,0,0\n1,1,0\n2,0,0\n", "beyond 10000 m"),
])
def test_bad_waypoint_files_give_one_line_errors(tmp_path, text, words):
    path = tmp_path / "w.txt"
    path.write_text(text)
    with pytest.raises(WaypointError) as e:
        load_waypoints(path)
    assert words in str(e.value) and str(path) in str(e.value) and "\n" not in str(e.value)


def obs_at(x, y, speed=1.0):
    return Observation(0.0, x, y, 0.0, speed)


def test_follower_skips_close_waypoints_and_wraps():
    pts = np.array([[0, 0], [0.1, 0], [0.2, 0], [1, 0], [2, 0]], dtype=float)
    f = LoopWaypointFollower(pts, closeness_m=0.3, wrap_to=1)
    f.setup()
    assert f.step(obs_at(0, 0)) == 3  # 0, 1, 2 are within 0.3 m
    assert f.step(obs_at(0.5, 0)) == 3  # 0.5 m ahead: keep heading for it
    assert f.step(obs_at(1.5, 0.5)) == 4  # ran wide past it: it is behind, move on
    assert f.step(obs_at(2.0, 0)) == 1 and f.laps == 1  # past the end: wrap to wrap_to


def test_follower_skips_the_first_waypoints_at_start():
    f = LoopWaypointFollower(circle(2.0, 40), skip_at_start=5)
    f.setup()
    assert f.step(obs_at(-2, 0)) == 5


def test_follower_rejects_bad_parameters():
    with pytest.raises(ValueError):
        LoopWaypointFollower(circle(1.0, 10), wrap_to=10)


# --- longitudinal control ------------------------------------------------------------------------

def test_a_car_moving_forward_stays_forward_however_long_it_brakes():
    """Reverse throttle on a car that moves forward is braking until it is seen stopped (a long
    stop from a fast car was taken for reversing after half a second, and it coasted); once
    stopped, reverse throttle moves it backwards."""
    d = DirectionEstimator()
    assert d.direction == 1
    d.update(0.5, 0.0)  # pushed forward from rest
    d.update(0.5, 2.0)
    for _ in range(100):  # two seconds of braking at speed
        assert d.update(-0.5, 6.0) == 1
    d.update(-0.5, 0.1)  # stopped
    assert d.update(-0.5, 0.1) == -1  # reverse now means backwards
    assert d.update(-0.5, 0.8) == -1
    d.update(0.0, 0.05)
    assert d.update(0.3, 0.05) == 1


def test_speed_controller_brakes_by_reversing_then_lets_go():
    c = SpeedController(max_speed_m_s=3.0)
    for _ in range(30):
        c.step(2.5, 2.0, 0.02)  # driving forward
    assert c.step(1.0, 2.5, 0.02) < 0  # much too fast: reverse command, the firmware brakes
    assert c.step(1.0, 1.1, 0.02) >= 0  # close enough: no more braking
    assert c.step(0.0, 0.2, 0.02) == 0  # almost stopped: never brake into reverse


def test_speed_controller_feed_forward_and_deadband():
    c = SpeedController(max_speed_m_s=3.0, deadband=0.05)
    throttle = c.step(1.5, 1.5, 0.02)  # on target: feed-forward only
    assert throttle == pytest.approx(0.05 + 0.95 * 0.5)
    assert c.step(0.0, 0.0, 0.02) == 0.0


# --- agent and runner ----------------------------------------------------------------------------

class Recorder(Module):
    def __init__(self, log, name, value=None):
        self.log, self.name, self.value = log, name, value

    def setup(self):
        self.log.append(f"{self.name}.setup")

    def step(self, value):
        self.log.append(f"{self.name}.step")
        return self.value if self.value is not None else value

    def shutdown(self):
        self.log.append(f"{self.name}.shutdown")


class FakeCar:
    def __init__(self):
        self.t, self.sent = 0.0, []

    def observe(self):
        return Observation(self.t, 0, 0, 0, 0)

    def send(self, command):
        self.sent.append(command)

    def wait(self, seconds):
        self.t += seconds


def test_runner_cycle_and_neutral_on_the_way_out():
    log = []
    agent = Agent(Passthrough(), Recorder(log, "plan", value="p"), Recorder(log, "control", value=Command(0.5, -0.2)))
    car = FakeCar()
    Runner(car, agent, 0.02).run(until=lambda obs: obs.t_s >= 0.05)
    assert log[:2] == ["plan.setup", "control.setup"] and log[-2:] == ["control.shutdown", "plan.shutdown"]
    assert car.sent[:3] == [Command(0.5, -0.2)] * 3 and car.sent[-1] == Command(0.0, 0.0)


def test_runner_sends_neutral_when_the_agent_fails():
    class Broken(Module):
        def step(self, value):
            raise RuntimeError("planner bug")

    car = FakeCar()
    with pytest.raises(RuntimeError):
        Runner(car, Agent(Passthrough(), Broken(), Passthrough()), 0.02).run(until=lambda obs: False)
    assert car.sent == [Command(0.0, 0.0)]


def test_heading_pid_steers_towards_the_goal_and_clamps():
    from roar.autopilot import HeadingController

    h = HeadingController(max_steer_rad=0.4, kp=1.0, kd=0.0)
    car = Observation(0.0, 0.0, 0.0, math.pi / 2, 1.0)  # facing +y
    assert h.steering_angle(car, (-0.1, 1.0), 0.02) == pytest.approx(math.atan2(0.1, 1.0))  # slightly left
    h.reset()
    assert h.steering_angle(car, (1.0, 0.1), 0.02) == -0.4  # far right: clamped at the servo's end
    h.reset()
    behind_left = Observation(0.0, 0.0, 0.0, math.radians(179), 1.0)
    assert h.steering_angle(behind_left, (-1.0, -0.1), 0.02) > 0  # error wraps across +-pi, not a full turn


def test_follower_goes_on_from_the_nearest_waypoint_when_the_pose_jumps():
    """A localization's correction or a car carried off: the next waypoint is suddenly far away."""
    f = LoopWaypointFollower(circle(2.0, 40))
    f.setup()
    assert f.step(obs_at(2, 0)) < 8
    assert 19 <= f.step(obs_at(-2, 0)) <= 26  # half way round: not back where it was


def test_the_open_way_steers_for_the_gap_nearest_the_wanted_direction():
    import math

    import numpy as np

    from roar.autopilot.open_way import MAX_THROTTLE, OpenWay
    from roar.localization.scan import LaserScan

    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    walls = np.minimum(2.0 / np.maximum(np.abs(np.cos(angles)), 1e-6), 1.0 / np.maximum(np.abs(np.sin(angles)), 1e-6))
    left = (angles > math.radians(40)) & (angles < math.radians(70))  # a side way open to the left
    right = (angles < -math.radians(40)) & (angles > -math.radians(70))  # and one to the right
    one = LaserScan(angles, np.where(left, 10.0, walls), 0.0)
    assert OpenWay().command(one, 0.0).steering < -0.5  # steering +1 is full right: towards the left gap
    both = LaserScan(angles, np.where(left | right, 10.0, walls), 0.0)
    assert OpenWay().command(both, 0.0, want_rad=-1.0).steering > 0.5
    assert OpenWay().command(both, 0.0, want_rad=1.0).steering < -0.5
    way = OpenWay()
    for _ in range(200):  # standing still: the throttle winds up to its limit, and no further
        command = way.command(one, 0.0)
    assert command.throttle == MAX_THROTTLE
    way.reset()
    assert way.command(one, 5.0).throttle == 0.0  # too fast: no throttle (it never brakes)
