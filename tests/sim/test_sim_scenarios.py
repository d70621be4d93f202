"""Software-in-the-loop scenarios: the firmware core drives the emulated ESC/servo and the
PyBullet car, lockstep and deterministic."""

import math

import numpy as np
import pytest

from roar.protocol import encode, spec
from roar_sim.world import floor
from roar_sim.plants.esc_servo import EscMode, HobbyEsc, SteeringServo
from roar_sim.core.car import CarConfig
from roar_sim.core.library import ControlSource
from roar_sim.robots.esc import EscCar
from roar_sim.plants.racecar import ackermann_angles
from roar.tracks.track import oval

N = spec.CONTROL_NEUTRAL_US
SEND = spec.TIMING_HOST_SEND_PERIOD_US / 1e6


def send_for(sim, message, seconds):
    for _ in range(round(seconds / SEND)):
        sim.write(message)
        sim.run(SEND)


def armed(**options):
    sim = EscCar(**options)
    send_for(sim, encode(N, N), 0.2)
    return sim


@pytest.mark.parametrize("fsm", [True, False])
def test_forward_then_reverse_needs_the_brake_fsm(fsm):
    """(1) With the FSM the car ends up moving backwards; without it the forward/brake/reverse
    ESC only brakes, and the car stops but never reverses."""
    with armed(firmware=CarConfig(brake_fsm_enabled=fsm)) as sim:
        send_for(sim, encode(1700, N), 1.5)
        assert sim.state().speed > 0.8
        min_speed = math.inf
        for _ in range(150):
            send_for(sim, encode(1300, N), SEND)
            min_speed = min(min_speed, sim.state().speed)
        if fsm:
            assert sim.esc_mode == EscMode.REVERSE and sim.state().speed < -0.3
        else:
            assert sim.esc_mode == EscMode.BRAKE and abs(sim.state().speed) < 0.05 and min_speed > -0.05


def test_silence_sets_neutral_within_the_timeout_and_the_car_comes_to_rest():
    """(2) Commands stop: the ESC sees neutral within the failsafe timeout (plus one output frame)
    and the car rolls to a stop."""
    with armed() as sim:
        send_for(sim, encode(1750, 1600), 1.5)
        last_send = sim.time_s - SEND
        neutral_at = None
        while sim.time_s < last_send + 1.0:
            sim.run(0.001)
            if neutral_at is None and sim.outputs.throttle_us == N and sim.outputs.source == ControlSource.FAILSAFE:
                neutral_at = sim.time_s
        limit = (spec.TIMING_FAILSAFE_TIMEOUT_US + spec.TIMING_SERVO_FRAME_US) / 1e6
        assert neutral_at is not None and neutral_at - last_send <= limit
        assert sim.read()[-1] == "FAILSAFE"
        sim.run(4.0)
        assert abs(sim.state().speed) < 0.05


def test_rc_transmitter_wins_over_host():
    """(3) Receiver pulses present: the manual commands drive the car, not the host's."""
    with armed() as sim:
        sim.rc_transmitter((1700, 1200))  # forward, steering left
        yaw0 = sim.state().yaw
        send_for(sim, encode(1300, 1800), 2.0)  # the host asks for reverse and right
        s = sim.state()
        assert sim.outputs.source == ControlSource.RC
        assert s.speed > 0.5 and s.yaw - yaw0 > 0.5  # forward and turning left


@pytest.mark.parametrize("steer_us, turn", [(1800, "right"), (1200, "left"), (1500, "straight")])
def test_open_loop_drive_signs(steer_us, turn):
    """(4) Throttle above neutral drives forward; steering above neutral turns right."""
    with armed() as sim:
        s0 = sim.state()
        send_for(sim, encode(1680, steer_us), 1.5)
        s = sim.state()
        heading_progress = (s.x - s0.x) * math.cos(s0.yaw) + (s.y - s0.y) * math.sin(s0.yaw)
        assert heading_progress > 0.5 and s.speed > 0.3 and s.encoder_counts > 1000
        dyaw = s.yaw - s0.yaw
        if turn == "right":
            assert dyaw < -0.3 and s.yaw_rate < 0
        elif turn == "left":
            assert dyaw > 0.3 and s.yaw_rate > 0
        else:
            assert abs(dyaw) < 0.05


def test_ackermann_inner_wheel_turns_more():
    left, right = ackermann_angles(0.3)  # turning left: left is the inner wheel
    assert left > 0.3 > right > 0
    left, right = ackermann_angles(-0.3)
    assert right < -0.3 < left < 0
    assert ackermann_angles(0.0) == (0.0, 0.0)


def test_esc_forward_brake_reverse_behaviour():
    esc = HobbyEsc()
    assert esc.pulse(1300).mode == EscMode.REVERSE  # from rest: reverse
    assert esc.pulse(1700).mode == EscMode.FORWARD
    assert esc.pulse(1300).mode == EscMode.BRAKE  # after forward: brake
    assert esc.pulse(1300).mode == EscMode.BRAKE  # held: still brake
    assert esc.pulse(1510).mode == EscMode.NEUTRAL  # inside the deadband
    out = esc.pulse(1000)
    assert out.mode == EscMode.REVERSE and out.drive == -esc.reverse_limit


def test_servo_rate_limit_trim_and_end_points():
    servo = SteeringServo(trim_us=20)
    servo.pulse(2000)
    assert servo.target_rad == pytest.approx(-servo.max_angle_rad * (480 / 500))
    angle = servo.advance(0.01)
    assert angle == pytest.approx(-servo.rate_rad_s * 0.01)
    for _ in range(100):
        servo.advance(0.01)
    assert servo.angle_rad == pytest.approx(servo.target_rad)
    servo.pulse(5000)
    assert servo.target_rad == -servo.max_angle_rad


def test_lockstep_is_deterministic():
    def trace():
        with armed() as sim:
            send_for(sim, encode(1700, 1650), 1.0)
            return sim.state()
    assert trace() == trace()


def test_walls_are_built_and_detected():
    with EscCar(oval()) as sim:
        assert len(sim.plant.walls) == 1  # one static mesh
        assert sim.plant.wall_contacts() == 0
        scan = sim.plant.lidar(beams=90)
        assert scan.min() < 1.0 and scan.max() <= 10.0  # walls 0.6 m either side


def test_driving_into_a_wall_is_detected():
    with EscCar(oval()) as sim:
        send_for(sim, encode(N, N), 0.2)
        contacts = 0
        for _ in range(150):  # full left lock: the inner wall is 0.6 m away
            send_for(sim, encode(1700, 1000), SEND)
            contacts += sim.plant.wall_contacts()
        assert contacts > 0


def test_camera_sees_the_walls_and_depth_is_metric():
    with EscCar(oval()) as sim:
        sim.run(0.05)
        rgb, depth = sim.plant.camera(width=80, height=60)
        assert rgb.shape == (60, 80, 3) and depth.shape == (60, 80)
        # Walls 0.6 m to each side: the left and right image edges just above the horizon are close.
        assert float(depth[12, 0]) < 2.0 and float(depth[12, -1]) < 2.0
        # Straight ahead down the straight to the far bend: farther than the side walls.
        assert float(depth[18, 32]) > 2.0
        assert 0.05 <= float(depth.min()) and float(depth.max()) <= 10.0 + 1e-3


def _colour_pixels(rgb, colour, tolerance=30):
    return np.all(np.abs(rgb.astype(int) - colour) < tolerance, axis=2)


def test_camera_sees_the_lane_lines():
    with EscCar(oval()) as sim:
        sim.run(0.05)
        rgb, _ = sim.plant.camera(width=160, height=120)
    lower = rgb[40:]  # the road below the horizon (row 36)
    yellow = _colour_pixels(lower, floor.CENTRE_LINE_RGB)
    white = _colour_pixels(lower, floor.EDGE_LINE_RGB)
    # The dashed centre line runs up the middle of the image, the edge lines on both sides.
    assert yellow[:, 70:90].sum() > 20 and yellow[:, :40].sum() == 0 and yellow[:, -40:].sum() == 0
    assert white[:, :80].sum() > 20 and white[:, 80:].sum() > 20


def test_no_track_no_lane_lines():
    with EscCar() as sim:
        sim.run(0.05)
        rgb, _ = sim.plant.camera(width=80, height=60)
    assert not _colour_pixels(rgb, floor.CENTRE_LINE_RGB).any()


def test_the_floor_is_painted_where_the_track_is():
    track = oval()
    left, right = track.edges()
    start = track.centerline[0]
    assert floor.colour_at(track, start) == floor.CENTRE_LINE_RGB
    inset = floor.EDGE_LINE_INSET_M / (track.width_m / 2)
    for edge in (left, right):
        assert floor.colour_at(track, edge[0] + inset * (start - edge[0])) == floor.EDGE_LINE_RGB
        assert floor.colour_at(track, (start + edge[0]) / 2) == floor.ASPHALT_RGB
    # The dashes leave gaps: half of one dash period after a dash starts is asphalt.
    assert floor.colour_at(track, start + [0.3, 0.0]) == floor.ASPHALT_RGB  # the oval starts on a straight along +x
    # the lines are as wide as painted: 1 mm inside an edge line's border is paint, 1 mm outside is not
    across = (start - left[0]) / np.linalg.norm(start - left[0])
    middle = left[0] + floor.EDGE_LINE_INSET_M * across
    for d, rgb in ((floor.EDGE_LINE_WIDTH_M / 2 - 0.001, floor.EDGE_LINE_RGB),
                   (floor.EDGE_LINE_WIDTH_M / 2 + 0.001, floor.ASPHALT_RGB)):
        assert floor.colour_at(track, middle + d * across) == rgb and floor.colour_at(track, middle - d * across) == rgb


def test_a_busy_simulator_slips_rather_than_tripping_the_failsafe_on_catch_up():
    """Real time: when the simulator's thread is held up (a frame rendered, a browser starting),
    simulated time slips; catching up in a burst would run the firmware past commands the host
    has not sent yet, and its failsafe would trip on a gap no real car sees."""
    import time

    from roar import Vehicle
    from roar.telemetry import EventKind

    with Vehicle("sim://") as car:
        assert car.wait_armed()
        car.drive(0.2, 0.0)
        time.sleep(0.1)
        car.transport._ask(lambda sim: time.sleep(1.5))  # the simulator's thread busy for 1.5 s
        time.sleep(0.3)
        assert not any(e.kind is EventKind.FAILSAFE for e in car.events), list(car.events)
        assert car.latched is False
        assert car.transport.sim._pacer.slips >= 1
