"""The lidar's beams, cast without Bullet on the world's walls, cubes, cones and people (and other
cars' footprints): the ranges must be Bullet's in that world, and a body the world cannot account
for sends the beams back to Bullet's rays. Other sensors' rays, while a world holds nothing but
its walls and the one car, go to a second client holding only the walls: the world's answers."""

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
    """The same scan as Racecar.lidar, by Bullet's rays in the car's own world; and the body each
    beam met there (-1: none; Bullet now and then reports the car's own shapes at distance 0)."""
    c = plant.client
    pos, orn = pb.getLinkState(plant.car, LIDAR_LINK, physicsClientId=c)[:2]
    angles = pb.getEulerFromQuaternion(orn)[2] + np.linspace(-math.radians(135), math.radians(135), BEAMS)
    directions = np.stack([np.cos(angles), np.sin(angles), np.zeros(BEAMS)], axis=1)
    hits = pb.rayTestBatch((np.asarray(pos) + MIN_RANGE_M * directions).tolist(),
                           (np.asarray(pos) + RANGE_M * directions).tolist(), physicsClientId=c)
    reach = RANGE_M - MIN_RANGE_M
    return (np.array([MIN_RANGE_M + h[2] * reach if h[0] >= 0 else RANGE_M for h in hits]),
            np.array([h[0] for h in hits]))


def drive_and_scan(sim, scans: int = 12):
    """Along the track, turning: (the lidar's scan, Bullet's in the world, which body each beam
    met there, the lidar's (x, y, z)) every 0.3 s."""
    sim.write(encode(1500, 1500))
    sim.run(0.1)
    for k in range(scans):
        for _ in range(15):
            sim.write(encode(1600, 1500 + 120 * (k % 3 - 1)))
            sim.run(0.02)
        scan = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)
        there, who = world_scan(sim.plant)
        yield scan, there, who, pb.getLinkState(sim.plant.car, LIDAR_LINK, physicsClientId=sim.plant.client)[0]


@pytest.mark.parametrize("name", ["oval", "figure-eight", "course"])
def test_other_sensors_rays_go_to_a_walls_only_client_that_answers_as_the_world_does(name):
    with EscCar(get(name)) as sim:
        world = sim.plant.world
        for _, there, who, position in drive_and_scan(sim):
            angles = yaw_of(sim.plant) + np.linspace(-math.radians(135), math.radians(135), BEAMS)
            d = np.stack([np.cos(angles), np.sin(angles), np.zeros(BEAMS)], axis=1)
            hits = world.ray_test((np.asarray(position) + MIN_RANGE_M * d).tolist(),
                                  (np.asarray(position) + RANGE_M * d).tolist())
            assert world._rays is not None  # the walls-only client answered
            got = np.array([MIN_RANGE_M + h[2] * (RANGE_M - MIN_RANGE_M) if h[0] >= 0 else RANGE_M for h in hits])
            itself = who == sim.plant.car
            assert np.allclose(got[~itself], there[~itself], rtol=0, atol=1e-6)
            assert itself.sum() <= 2 and got[~itself].min() > MIN_RANGE_M + 0.05  # never the car itself


@pytest.mark.parametrize("name", ["oval", "course", "tunnel:3", "tunnel:5,cones=0,people=8"])
def test_the_lidar_cast_on_walls_cones_people_and_cubes_reads_as_bullets_rays(name):
    """A cone is a 16-sided hull to Bullet, which meets a convex outline with ~1 mm of slack, and a
    circle to the cast: a beam that passes within 5 mm of a cone's or a person's outline may differ
    (a hit to one and a miss to the other); every other beam reads the same to 3 mm, a fifth of the
    lidar's noise (the walls to 0.1 mm). Every beam was cast without Bullet."""
    track = get(name)
    with EscCar(track) as sim:
        world = sim.plant.world
        x, y, yaw = track.start_pose
        add_box(world, x + 1.2 * math.cos(yaw) + 0.3 * math.sin(yaw), y + 1.2 * math.sin(yaw) - 0.3 * math.cos(yaw))
        solids, grazing, seen = np.array(list(world.solids.values())), 0, set()
        for scan, there, who, (ox, oy, oz) in drive_and_scan(sim):
            assert world.lidar_caster(sim.plant.car, 0, RANGE_M) is not None  # cast without Bullet
            itself = who == sim.plant.car
            seen |= {int(b) for b in who} & set(world.solids)
            off = np.abs(scan - there) > 0.003
            walls = np.isin(who, world.walls)
            assert np.abs(scan - there)[walls].max(initial=0) < 1e-4
            for b in np.flatnonzero(off & ~itself):
                angle = yaw_of(sim.plant) + np.linspace(-math.radians(135), math.radians(135), BEAMS)[b]
                gaps = [abs(abs(math.sin(angle) * (sx - ox) - math.cos(angle) * (sy - oy))
                            - (r if r > 0 else -r * (1 - oz / h))) for sx, sy, _, _, _, r, h in solids if r]
                assert min(gaps, default=1.0) < 0.005, (b, scan[b], there[b], int(who[b]))  # a grazing beam
                grazing += 1
        assert grazing <= 0.002 * 12 * BEAMS
        assert len(seen) >= 1  # the cube (and in a tunnel its cones and people) met


def yaw_of(plant) -> float:
    return pb.getEulerFromQuaternion(pb.getLinkState(plant.car, LIDAR_LINK, physicsClientId=plant.client)[1])[2]


def test_a_box_in_the_world_is_seen_and_a_body_it_cannot_account_for_goes_to_bullet():
    from roar_sim.plants.racecar import Racecar

    track = get("oval")
    with EscCar(track) as sim:
        sim.run(0.1)
        world = sim.plant.world
        ahead = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)[BEAMS // 2]
        x, y, yaw = track.start_pose
        add_box(world, x + 1.5 * math.cos(yaw), y + 1.5 * math.sin(yaw))
        boxed = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)[BEAMS // 2]
        assert world.lidar_caster(sim.plant.car, 0, RANGE_M) is not None
        other = Racecar.__new__(Racecar)  # a second car's body in the same world, its footprint not given
        other.car = pb.loadURDF("racecar/racecar.urdf", [x + 1.0 * math.cos(yaw), y + 1.0 * math.sin(yaw), 0.05],
                                physicsClientId=sim.plant.client)
        assert world.lidar_caster(sim.plant.car, 0, RANGE_M) is None  # Bullet's rays must find it
        assert world.lidar_caster(sim.plant.car, 1, RANGE_M) is not None  # one car: its footprint will be given
        blocked = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)[BEAMS // 2]
        pb.removeBody(other.car, physicsClientId=sim.plant.client)
        pb.removeBody(next(iter(world.solids)), physicsClientId=sim.plant.client)  # the box, gone: no frame between
        cleared = sim.plant.lidar(beams=BEAMS, range_m=RANGE_M)[BEAMS // 2]
        assert not world.solids and world.lidar_caster(sim.plant.car, 0, RANGE_M) is not None
    assert blocked < 1.0 < boxed < 1.5 < ahead == pytest.approx(cleared, abs=0.05)


@pytest.mark.parametrize("name", ["oval", "random:3,width=2.2"])
def test_another_cars_footprint_is_met_as_bullets_walls_and_the_slab_test_meet_it(name):
    """A race's lidar meets another car by its footprint: its ranges are those of Bullet's rays
    among the walls (the same planes in double precision) and the footprint's box."""
    from roar_sim.runs.fleet import Fleet
    from roar_sim.sensors.lidar import Lidar, box_ranges
    from roar_sim.world.scene import _walls_only

    track = get(name)
    errors = []
    with Fleet(track, count=2, gap_m=1.5) as fleet:
        ahead, ego = fleet.cars
        client, _, _ = _walls_only(track)
        lidar = Lidar(ego.plant)
        for k in range(6):
            ego.write(encode(1600, 1500 + 60 * (k % 3 - 1)))
            ahead.write(encode(1600, 1500))
            fleet.run(0.4)
            pos = pb.getLinkState(ego.plant.car, LIDAR_LINK, physicsClientId=ego.plant.client)[0]
            angles = yaw_of(ego.plant) + np.linspace(-math.radians(135), math.radians(135), lidar.beams)
            d = np.stack([np.cos(angles), np.sin(angles), np.zeros(len(angles))], axis=1)
            hits = pb.rayTestBatch((np.asarray(pos) + MIN_RANGE_M * d).tolist(),
                                   (np.asarray(pos) + 10.0 * d).tolist(), physicsClientId=client)
            walls = np.array([MIN_RANGE_M + h[2] * (10.0 - MIN_RANGE_M) if h[0] >= 0 else 10.0 for h in hits])
            bullet = np.minimum(walls, box_ranges(pos[:2], angles, [ahead.plant.footprint()]))
            errors.append(np.abs(lidar.ranges([ahead.plant]) - bullet))
    assert np.concatenate(errors).max() < 1e-4  # [m]
