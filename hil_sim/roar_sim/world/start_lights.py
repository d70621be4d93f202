"""A start light beside the track, as at IARRC: a post outside the road's right edge, a little
ahead of the start, with a red lamp above a green one. Red is lit from the start; at a moment
drawn from a seed it goes dark and green lights. Visual only: nothing to collide with, and the
lidar does not see it (the camera and depth do).

    lights = StartLights(plant.world, track, green_at_s=2.7)
    plant.props.append(lights)            # the plant switches it as simulated time passes
"""

from __future__ import annotations

import math
import random

from roar_sim.world.bullet import pb
from roar_sim.world.appearance import solid_row
from roar.tracks.track import Track

AHEAD_M = 2.0  # [m] from the start along the track
BEYOND_EDGE_M = 0.2  # [m] outside the road's right edge
LAMP_M = 0.12  # [m] a lamp's square face
RED_Z_M, GREEN_Z_M = 0.66, 0.50  # [m] lamp centres above the floor
GREEN_AFTER_S = (1.0, 4.0)  # [s] the range the green moment is drawn from

RED_ON, RED_OFF = (1.0, 0.05, 0.05, 1.0), (0.22, 0.06, 0.06, 1.0)
GREEN_ON, GREEN_OFF = (0.1, 1.0, 0.15, 1.0), (0.05, 0.18, 0.06, 1.0)
HOUSING = (0.05, 0.05, 0.05, 1.0)


def green_moment(seed: int, span_s: tuple[float, float] = GREEN_AFTER_S) -> float:
    """[s] when the light turns green in the run with this seed."""
    return random.Random(seed).uniform(*span_s)


class StartLights:
    """Red until green_at_s [s] of simulated time, then green."""

    def __init__(self, world, track: Track, green_at_s: float) -> None:
        self.world, self.client, self.green_at_s = world, world.client, green_at_s
        self._shape: dict[int, tuple] = {}  # body -> (x, y, z [m], half extents [m]): as the ray camera sees it
        ahead = track.pose_at(AHEAD_M)
        right = track.half_widths_at(track.project(ahead[:2], heading=ahead[2])[0])[1]
        x, y, yaw = track.pose_at(AHEAD_M, -(right + BEYOND_EDGE_M))
        orn = pb.getQuaternionFromEuler([0, 0, yaw])
        self.yaw = yaw
        # the housing and lamps face back along the track, towards the car at the start
        face = (-math.cos(yaw), -math.sin(yaw))
        self.housing = self._box(x, y, (RED_Z_M + GREEN_Z_M) / 2, (0.03, 0.1, 0.17), HOUSING, orn)
        self.post = self._box(x, y, (GREEN_Z_M - 0.1) / 2, (0.02, 0.02, (GREEN_Z_M - 0.1) / 2), HOUSING, orn)
        lamp = (0.01, LAMP_M / 2, LAMP_M / 2)
        lx, ly = x + 0.035 * face[0], y + 0.035 * face[1]
        self.red = self._box(lx, ly, RED_Z_M, lamp, RED_ON, orn)
        self.green = self._box(lx, ly, GREEN_Z_M, lamp, GREEN_OFF, orn)
        self.is_green = False

    def _box(self, x: float, y: float, z: float, half: tuple, rgba: tuple, orn) -> int:
        visual = pb.createVisualShape(pb.GEOM_BOX, halfExtents=list(half), rgbaColor=list(rgba),
                                      physicsClientId=self.client)
        body = pb.createMultiBody(0, -1, visual, [x, y, z], orn, physicsClientId=self.client)
        self._shape[body] = (x, y, z, half)
        self._seen(body, rgba)
        return body

    def _seen(self, body: int, rgba: tuple) -> None:
        """The body in its colour as the ray camera sees it."""
        x, y, z, (hx, hy, hz) = self._shape[body]
        self.world.visuals[body] = solid_row(x, y, self.yaw, hx, hy, 0.0, 2 * hz, z - hz, rgba)

    def _paint(self, body: int, rgba: tuple) -> None:
        """A lamp's colour, to both renderers."""
        pb.changeVisualShape(body, -1, rgbaColor=list(rgba), physicsClientId=self.client)
        self._seen(body, rgba)

    def show(self, green: bool) -> None:
        """Green (red dark), or red (green dark), now."""
        self.is_green = green
        self._paint(self.red, RED_OFF if green else RED_ON)
        self._paint(self.green, GREEN_ON if green else GREEN_OFF)

    def reset(self, green_at_s: float) -> None:
        """Red again, green at green_at_s [s] of simulated time."""
        self.green_at_s = green_at_s
        self.show(False)

    def update(self, time_s: float) -> None:
        if not self.is_green and time_s >= self.green_at_s:
            self.show(True)


def frames_to_start(plant, lights: StartLights, camera, detector, green_in_s: float, steps_per_frame: int,
                    after_frames: int = 4) -> tuple[int | None, int]:
    """A standing start: the light turns green green_in_s from now; frames (every steps_per_frame
    physics steps) go to detector.update until it starts the car or after_frames past green.
    Returns (the green frames it had seen when it started: 0 is a false start; None: no start),
    and the frames it saw red."""
    lights.reset(plant.time_s + green_in_s)
    detector.reset()
    green_frames = red_frames = 0
    while green_frames <= after_frames:
        for _ in range(steps_per_frame):
            plant.step()
        rgb, _ = camera()
        green_frames += lights.is_green
        red_frames += not lights.is_green
        if detector.update(rgb):
            return (green_frames if lights.is_green else 0), red_frames
    return None, red_frames
