"""An ArUco marker on a car's rear, facing back, for a follower's camera (roar.vision.aruco):
its black cells and a white quiet zone around them, as geometry (both renderers draw triangles
alike), moved with the car after every physics step.

    plant.props.append(RearMarker(plant))     # the leader's marker
"""

from __future__ import annotations

import math

import numpy as np

from roar.vision.aruco import CELLS, MARKER_ID, MOUNT_BEHIND_M, SIDE_M, marker_cells
from roar_sim.world.bullet import pb
from roar_sim.world.renderer import mesh_visual

CENTRE_Z_M = 0.13  # [m] above the car's base: the middle of its rear
QUIET_CELLS = 1  # white cells round the black square, which the detector needs to find its edge
WHITE = (0.95, 0.95, 0.95, 1.0)
BLACK = (0.05, 0.05, 0.05, 1.0)


def _squares(cells: np.ndarray, cell_m: float, x_m: float) -> tuple[list, list]:
    """(vertices, indices) of a square per True cell, in the plane x = x_m facing -x (y left, z up):
    row 0 at the top and column 0 on the left as seen from behind the car, which is its left too."""
    rows, cols = cells.shape
    vertices, indices = [], []
    for r in range(rows):
        for c in range(cols):
            if not cells[r, c]:
                continue
            y_left, z_top = (cols / 2 - c) * cell_m, (rows / 2 - r) * cell_m
            base = len(vertices)
            vertices += [[x_m, y_left, z_top - cell_m], [x_m, y_left - cell_m, z_top - cell_m],
                         [x_m, y_left - cell_m, z_top], [x_m, y_left, z_top]]
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]  # facing -x, towards the follower
    return vertices, indices


class RearMarker:
    """Marker `marker_id` (SIDE_M across its black square) on the rear of `plant`'s car."""

    def __init__(self, plant, marker_id: int = MARKER_ID) -> None:
        self.plant, self.client = plant, plant.client
        cell = SIDE_M / CELLS
        black = marker_cells(marker_id)
        plate = np.ones((CELLS + 2 * QUIET_CELLS,) * 2, dtype=bool)
        self.bodies = []
        for cells, rgba, x in ((plate, WHITE, 0.0), (black, BLACK, -0.002)):  # black cells just behind the white
            vertices, indices = _squares(cells, cell, x)
            visual = mesh_visual(self.client, vertices, indices, rgba=rgba)
            self.bodies.append(pb.createMultiBody(0, -1, visual, [0, 0, -1], physicsClientId=self.client))
        self.update(0.0)

    def pose(self) -> tuple[list[float], list[float]]:
        """(position, orientation) of the marker's centre in the world."""
        position, orientation = pb.getBasePositionAndOrientation(self.plant.car, physicsClientId=self.client)
        yaw = pb.getEulerFromQuaternion(orientation)[2]
        x = position[0] - MOUNT_BEHIND_M * math.cos(yaw)
        y = position[1] - MOUNT_BEHIND_M * math.sin(yaw)
        return [x, y, position[2] + CENTRE_Z_M], list(pb.getQuaternionFromEuler([0, 0, yaw]))

    def update(self, time_s: float) -> None:
        position, orientation = self.pose()
        for body in self.bodies:
            pb.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=self.client)
