"""The lidar's rays: while a world holds nothing but its walls and the one car, they are cast in a
second client holding only the walls (the car's own wheels and boxes near the rays' starts made
Bullet slow); the answers must be the world's own, and anything else in the world (a box, another
car) sends the rays back to the world."""

import math

import numpy as np
import pytest

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.protocol import encode  # noqa: E402
from roar_sim.robots.esc import EscCar  # noqa: E402
from roar_sim.world.obstacles import add_box  # noqa: E402
from roar_sim.plants.racecar import LIDAR_LINK  # noqa: E402
from roar_sim.sensors.lidar import MIN_RANGE_M  # noqa: E402
from roar_sim.world.bullet import pb  # noqa: E402
from roar.tracks import get  # noqa: E402

BEAMS, RANGE_M = 181, 10.0


def world_scan(plant) -> tuple[np.ndarray, np.ndarray]:
    """The same scan as Racecar.lidar, cast in the car's own world; and which beams hit the car
    itself there (Bullet now and then reports the car's own shapes at distance 0)."""
    c = plant.client
    pos, orn = pb.getLinkState(plant.car, LIDAR_LINK, physicsClientId=c)[:2]
    angles = pb.getEulerFromQuaternion(orn)[2] + np.linspace(-math.radians(135), math.radians(135), BEAMS)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros(BEAMS)], axis=1)
    hits = pb.rayTestBatch((np.asarray(pos) + MIN_RANGE_M * directions).tolist(),
                           (np.asarray(pos) + RANGE_M * directions).tolist(), physicsClientId=c)
    reach = RANGE_M - MIN_RANGE_M
    return (np.array([MIN_RANGE_M + h[2] * reach if h[0] >= 0 else RANGE_M for h in hits]),
            np.array([h[0] == plant.car for h in hits]))


@pytest.mark.parametrize("name", ["oval", "figure-eight", "course"])
def test_the_walls_only_client_answers_as_the_world_does(name):
    with EscCar(get(name)) as sim:
        sim.write(encode(1500, 1500))
        sim.run(0.1)
        for _ in range(12):  # along the track, turning: the walls at every angle
            for _ in range(15):
                sim.write(encode(1600, 1380))
                sim.run(0.02)
            scan = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)
            assert sim.plant.world._rays is not None  # the walls-only client answered
            there, itself = world_scan(sim.plant)
            assert np.allclose(scan[~itself], there[~itself], rtol=0, atol=1e-6)
            assert itself.sum() <= 2 and scan.min() > MIN_RANGE_M + 0.05  # never the car itself
            assert scan.min() < RANGE_M  # walls in sight


def test_a_box_in_the_world_is_seen():
    track = get("oval")
    with EscCar(track) as sim:
        sim.run(0.1)
        ahead = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)[BEAMS // 2]
        x, y, yaw = track.start_pose
        add_box(sim.plant.world, x + 1.5 * math.cos(yaw), y + 1.5 * math.sin(yaw))
        boxed = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)[BEAMS // 2]
    assert boxed < 1.5 < ahead


@pytest.mark.parametrize("name", ["oval", "random:3,width=2.2"])
def test_a_scan_cast_on_the_walls_boxes_reads_as_bullets(name):
    """A race's lidar casts the beams on the walls' boxes itself (for speed): its ranges are
    Bullet's (the same planes in double precision), another car's footprint included."""
    from roar_sim.runs.fleet import Fleet
    from roar_sim.sensors.lidar import Lidar, WallCaster
    from roar_sim.world.scene import WALL_THICKNESS_M

    track = get(name)
    errors = []
    with Fleet(track, count=2, gap_m=1.5) as fleet:
        ahead, ego = fleet.cars
        bullet, cast = Lidar(ego.plant), Lidar(ego.plant, walls=WallCaster(track, WALL_THICKNESS_M))
        for k in range(6):
            ego.write(encode(1600, 1500 + 60 * (k % 3 - 1)))
            ahead.write(encode(1600, 1500))
            fleet.run(0.4)
            a, b = bullet.ranges([ahead.plant]), cast.ranges([ahead.plant])
            errors.append(np.abs(a - b))
    assert np.concatenate(errors).max() < 1e-4  # [m]
