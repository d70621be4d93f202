"""Boxes on the track: obstacles a car must stop for or drive round. Each is a cube resting on
the floor, placed by its distance along the centre line and its offset to the left of it.

    boxes = place_boxes(plant.world, track, [(7.2, -0.25), (9.9, 0.25)])
    touching(plant, boxes)                  # how many of them the car touches now
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from roar_sim.world.bullet import pb
from roar_sim.world.appearance import solid_row
from roar_sim.world.renderer import mesh_visual
from roar.tracks.track import Track

BOX_HALF_M = 0.1  # [m] half a box's side
BOX_RGBA = (0.85, 0.35, 0.1, 1.0)  # traffic-cone orange
CONE_RGBA = (1.0, 0.45, 0.0, 1.0)  # orange
PERSON_RGBA = (0.2, 0.3, 0.6, 1.0)  # dark blue clothes
CONE_SIDES = 16  # the cone mesh's facets round


def cone_row(x: float, y: float) -> tuple[float, ...]:
    """A cone at (x, y) as the ray camera sees it (appearance.solid_row; its first 7 columns the
    lidar's): round, its mesh's facets' corners on the circle."""
    from roar.tracks.tunnel import CONE_HEIGHT_M, CONE_RADIUS_M

    return solid_row(x, y, 0.0, 0.0, 0.0, -CONE_RADIUS_M, CONE_HEIGHT_M, 0.0, CONE_RGBA)


def person_row(x: float, y: float) -> tuple[float, ...]:
    """A person at (x, y) as the ray camera sees it (its first 7 columns the lidar's)."""
    from roar.tracks.tunnel import PERSON_HEIGHT_M, PERSON_RADIUS_M

    return solid_row(x, y, 0.0, 0.0, 0.0, PERSON_RADIUS_M, PERSON_HEIGHT_M, 0.0, PERSON_RGBA)


def _register(world, body: int, row: tuple[float, ...]) -> None:
    """A solid both the lidar (its first 7 columns) and the ray camera meet."""
    world.solids[body], world.visuals[body] = row[:7], row


def add_box(world, x: float, y: float, half_m: float = BOX_HALF_M, yaw: float = 0.0) -> int:
    """A static cube standing on the floor at (x, y) [m]."""
    c = world.client
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[half_m] * 3, physicsClientId=c)
    visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half_m] * 3, rgbaColor=list(BOX_RGBA), physicsClientId=c)
    body = pb.createMultiBody(0, shape, visual, [x, y, half_m], pb.getQuaternionFromEuler([0, 0, yaw]),
                              physicsClientId=c)
    _register(world, body, solid_row(x, y, yaw, half_m, half_m, 0.0, 2 * half_m, 0.0, BOX_RGBA))
    return body


def add_cone(world, x: float, y: float) -> int:
    """A static orange cone (CONE_RADIUS_M at its base, CONE_HEIGHT_M high) standing at (x, y)."""
    from roar.tracks.tunnel import CONE_HEIGHT_M, CONE_RADIUS_M

    c = world.client
    a = np.linspace(0, 2 * np.pi, CONE_SIDES, endpoint=False)
    ring = [[CONE_RADIUS_M * np.cos(t), CONE_RADIUS_M * np.sin(t), 0.0] for t in a]
    vertices = [*ring, [0.0, 0.0, CONE_HEIGHT_M], [0.0, 0.0, 0.0]]
    apex, base = CONE_SIDES, CONE_SIDES + 1
    indices = []
    for i in range(CONE_SIDES):
        j = (i + 1) % CONE_SIDES
        indices += [i, j, apex, j, i, base]
    shape = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, physicsClientId=c)  # its convex hull
    visual = mesh_visual(c, vertices, indices, rgba=CONE_RGBA)
    body = pb.createMultiBody(0, shape, visual, [x, y, 0.0], physicsClientId=c)
    _register(world, body, cone_row(x, y))
    return body


def add_person(world, x: float, y: float) -> int:
    """A person: a static cylinder (PERSON_RADIUS_M, PERSON_HEIGHT_M) standing at (x, y)."""
    from roar.tracks.tunnel import PERSON_HEIGHT_M, PERSON_RADIUS_M

    c = world.client
    shape = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=PERSON_RADIUS_M, height=PERSON_HEIGHT_M,
                                    physicsClientId=c)
    visual = pb.createVisualShape(pb.GEOM_CYLINDER, radius=PERSON_RADIUS_M, length=PERSON_HEIGHT_M,
                                  rgbaColor=list(PERSON_RGBA), physicsClientId=c)
    body = pb.createMultiBody(0, shape, visual, [x, y, PERSON_HEIGHT_M / 2], physicsClientId=c)
    _register(world, body, person_row(x, y))
    return body


def place_boxes(world, track: Track, spots: Sequence[tuple[float, float]]) -> list[int]:
    """A box at each (distance along the centre line [m], offset to its left [m])."""
    bodies = []
    for s_m, offset_m in spots:
        x, y, yaw = track.pose_at(s_m, offset_m)
        bodies.append(add_box(world, x, y, yaw=yaw))
    return bodies


def touching(plant, boxes: Sequence[int]) -> int:
    """How many of `boxes` the car touches right now."""
    return sum(bool(pb.getContactPoints(plant.car, box, physicsClientId=plant.client)) for box in boxes)


LANE_OFFSET_M = 0.25  # [m] a box in the middle of a lane: a quarter of the road's width from its centre
STRAIGHT_BEFORE_M, STRAIGHT_AFTER_M = 1.0, 0.2  # [m] of straight road a box needs before and after it
MIN_GAP_M = 3.5  # [m] between boxes: room to pass one and change lanes before the next
FIRST_M = 3.0  # [m] from the start: the first box is not on the grid


def box_course(track: Track, count: int) -> list[tuple[float, float]]:
    """Up to `count` spots on straight road for an avoidance course: at least MIN_GAP_M apart,
    alternately in the right and the left lane, the first in the right (where a car keeps)."""
    pts = track.centerline
    heading = np.unwrap(np.arctan2(*(np.roll(pts, -1, axis=0) - pts).T[::-1]))
    spots: list[tuple[float, float]] = []
    s = FIRST_M
    while len(spots) < count and s < track.length_m - STRAIGHT_AFTER_M:
        window = np.linspace(s - STRAIGHT_BEFORE_M, s + STRAIGHT_AFTER_M, 14) % track.length_m
        turns = heading[np.searchsorted(track.arc_start, window, side="right") - 1]
        if np.ptp(turns) < 0.02 and (not spots or s - spots[-1][0] >= MIN_GAP_M):
            spots.append((s, LANE_OFFSET_M if len(spots) % 2 else -LANE_OFFSET_M))
        s += 0.1
    return spots
