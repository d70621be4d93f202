"""Several cars in one world: each with its own firmware (the ESC car's board loop at 1 kHz, the
IARRC car's tasks on their scheduler, each on its own clock), ESC, servo and serial link; one
PyBullet world, stepped once for all of them at 200 Hz, so they collide, and each one's lidar and
camera see the others.

    with Fleet(get("oval"), count=2, gap_m=1.5) as fleet:
        leader, follower = fleet.cars            # EscCar each: write(), read(), state(), plant
    Fleet(track, poses=[...], robots=["esc", "iarrc"])   # one robot type per car
        leader.write(encode(1600, 1500))
        fleet.run(2.0)
        fleet.touching(0, 1)                     # are the two cars in contact now?
"""

from __future__ import annotations

from roar_sim import robots as robot_kinds
from roar_sim.core.lockstep import LOOP_US, PHYSICS_US, Lockstep, loops_until
from roar_sim.world.bullet import pb
from roar_sim.world.scene import World
from roar.tracks.track import Track

MAX_CARS = 8
FLEET_ROBOTS = ("esc", "iarrc")  # the robots that share a world (the Junior's plant keeps a world of its own)


class Fleet(Lockstep):
    """count cars on `track`, the first start_m [m] along its centre line (at its start by
    default) and each next gap_m [m] behind the one before, along the centre line."""

    def __init__(self, track: Track, count: int = 2, gap_m: float = 1.5, gui: bool = False,
                 start_m: float = 0.0, poses=None, profiles=None, robots=None) -> None:
        """poses: each car's (x, y, yaw) instead (a race's grid); profiles: each car's profile
        (roar_sim.plants.car_profile: a name, a .toml or None for its robot's default); robots:
        each car's robot (FLEET_ROBOTS; default every one the ESC car)."""
        if poses is not None:
            count = len(poses)
        if not 1 <= count <= MAX_CARS:
            raise ValueError(f"a fleet is 1..{MAX_CARS} cars, got {count}")
        if poses is None and not 0.6 <= gap_m <= track.length_m / count:
            raise ValueError(f"gap_m must be 0.6 m (a car's length) .. {track.length_m / count:.1f} m on this "
                             f"track, got {gap_m}")
        robots = robots or ["esc"] * count
        wrong = sorted(set(robots) - set(FLEET_ROBOTS))
        if len(robots) != count or wrong:
            raise ValueError(f"a fleet's robots are {', '.join(FLEET_ROBOTS)}, one per car; got {robots!r}")
        self.world = World(track, PHYSICS_US / 1e6, gui)
        poses = poses or [track.pose_at(start_m - i * gap_m) for i in range(count)]
        profiles = profiles or [None] * count
        self.cars = [robot_kinds.get(robot)(track, pose=pose, world=self.world, profile=profile)
                     for pose, profile, robot in zip(poses, profiles, robots)]
        self.plant = self.cars[0].plant  # state() and the camera of the first car, as an EscCar's
        self.t_us = 0
        if "iarrc" in robots:  # an IARRC car's receiver locks with its mode switch at off before a setpoint
            from roar_sim.robots.iarrc import OPERATOR_LOCK_S

            self.run(OPERATOR_LOCK_S)

    def _advance(self, end_us: int) -> None:
        t = self.t_us
        loops = loops_until(t, end_us)
        for car in self.cars:
            car.firmware(loops)
        self.t_us = t + loops * LOOP_US
        if t % PHYSICS_US == 0:
            for car in self.cars:
                car.actuate()
            self.world.step()
            for car in self.cars:
                car.plant.tick()

    def touching(self, a: int, b: int) -> bool:
        """Whether cars a and b are in contact now."""
        return bool(pb.getContactPoints(bodyA=self.cars[a].plant.car, bodyB=self.cars[b].plant.car,
                                        physicsClientId=self.world.client))

    def touching_pairs(self, count: int | None = None) -> set[tuple[int, int]]:
        """Every pair (a, b), a < b, of the first `count` cars (all by default) in contact now."""
        n = len(self.cars) if count is None else count
        return {(a, b) for a in range(n) for b in range(a + 1, n) if self.touching(a, b)}

    def close(self) -> None:
        self.world.close()
