"""Two cars in one world: each its own firmware core and serial link, one physics world stepped
once for both, so they collide and the lidar of one sees the other; one car in a fleet moves
exactly as a car alone."""

import math

import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.protocol import encode  # noqa: E402
from roar_sim.runs.fleet import Fleet  # noqa: E402
from roar_sim.robots.esc import EscCar  # noqa: E402
from roar.tracks import get  # noqa: E402

PERIOD_S = 0.02


def drive(cars_and_pulses, fleet, seconds):
    """Send each car its (throttle, steering) pulses every 20 ms for `seconds`."""
    for _ in range(round(seconds / PERIOD_S)):
        for car, (throttle, steering) in cars_and_pulses:
            car.write(encode(throttle, steering))
        fleet.run(PERIOD_S)


def test_each_car_hears_only_its_own_link():
    with Fleet(get("oval"), count=2, gap_m=1.5) as fleet:
        first, second = fleet.cars
        start = [c.state() for c in fleet.cars]
        drive([(first, (1500, 1500))], fleet, 0.1)  # arm the first only
        drive([(first, (1620, 1500))], fleet, 1.5)
        moved = [math.hypot(c.state().x - s.x, c.state().y - s.y) for c, s in zip(fleet.cars, start)]
        assert moved[0] > 0.5 and moved[1] < 0.02
        assert any(line.startswith("READY") for line in second.read())  # its own board booted
        assert second.throttle_out_us == 1500  # never armed, never drove


def test_a_car_driven_into_the_one_ahead_hits_and_pushes_it():
    with Fleet(get("oval"), count=2, gap_m=1.5) as fleet:
        ahead, behind = fleet.cars
        x0 = ahead.state().x
        drive([(ahead, (1500, 1500)), (behind, (1500, 1500))], fleet, 0.1)
        touched = False
        for _ in range(150):  # 3 s
            drive([(ahead, (1500, 1500)), (behind, (1650, 1500))], fleet, PERIOD_S)
            touched = touched or fleet.touching(0, 1)
        assert touched and ahead.state().x - x0 > 0.1


def test_the_lidar_of_one_sees_the_other():
    track = get("oval")
    with Fleet(track, count=2, gap_m=1.5) as fleet:
        fleet.run(0.2)
        behind = fleet.cars[1].plant.lidar(beams=271)[135]  # straight ahead
    with EscCar(track) as alone:
        alone.run(0.2)
        open_road = alone.plant.lidar(beams=271)[135]
    assert behind < 1.5 < open_road


def test_one_car_in_a_fleet_moves_exactly_as_a_car_alone():
    track = get("oval")
    pulses = [(1500, 1500)] * 5 + [(1600, 1400)] * 60
    with Fleet(track, count=1) as fleet, EscCar(track) as alone:
        for throttle, steering in pulses:
            for sim in (fleet.cars[0], alone):
                sim.write(encode(throttle, steering))
            fleet.run(PERIOD_S)
            alone.run(PERIOD_S)
            assert fleet.cars[0].state() == alone.state()


def test_a_fleet_refuses_what_cannot_stand_on_the_track():
    with pytest.raises(ValueError, match="1..8 cars"):
        Fleet(get("oval"), count=0)
    with pytest.raises(ValueError, match="gap_m"):
        Fleet(get("oval"), count=2, gap_m=0.2)
