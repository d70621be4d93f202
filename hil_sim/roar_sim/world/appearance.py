"""How the world looks and measures, as its renderers and sensors meet it: the walls' size and
colour, the light frames are drawn in, and a solid's row as the ray-cast camera sees it
(roar_sim.world.ray_camera; obstacles and start lights give theirs)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WALL_HEIGHT_M, WALL_THICKNESS_M = 0.3, 0.05  # [m] higher than the lidar (0.17 m)
WALL_RGBA = (0.8, 0.8, 0.8, 1.0)  # light grey

# a solid's row: centre x, y [m], yaw [rad], half length, half width [m] (a box; 0, 0 for a round
# solid), radius [m] (0: a box; > 0 a cylinder; < 0 a cone, -radius at its foot, 0 at its top),
# height [m], its foot above the floor [m], and its colour (RGB 0..255, unlit)
SOLID_COLUMNS = 11
X, Y, YAW, HALF_L, HALF_W, RADIUS, HEIGHT, Z0, RED = range(9)
PAINT_EDGE = 255  # the ray camera's paint raster: a cell an edge crosses (the triangles there say which paint)


def solid_row(x: float, y: float, yaw: float, half_l: float, half_w: float, radius: float, height: float,
              z0: float, rgba) -> tuple[float, ...]:
    """A solid as the camera sees it (SOLID_COLUMNS): rgba 0..1 as PyBullet takes it."""
    return (x, y, yaw, half_l, half_w, radius, height, z0, *(255.0 * c for c in rgba[:3]))


@dataclass(frozen=True)
class Light:
    """The light a world's frames are drawn in: where it comes from (a direction towards it), its
    colour (RGB 0..1) and how much of it is ambient, diffuse and specular (PyBullet's renderers'
    own parameters, which shade faces by their angle to it), and how much of it reaches the
    camera per channel (gain: PyBullet's ambient term ignores the colour, so a dim or tinted
    room is the frame scaled by it). Light.dim(0.4) is a dim room; Light.tinted((1, 0.8, 0.55))
    a warm lamp."""

    direction: tuple[float, float, float] = (0.3, 0.4, 1.0)
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    ambient: float = 0.6
    diffuse: float = 0.35
    specular: float = 0.05
    gain: tuple[float, float, float] = (1.0, 1.0, 1.0)

    @classmethod
    def dim(cls, brightness: float) -> Light:
        return cls.tinted((brightness,) * 3)

    @classmethod
    def tinted(cls, rgb: tuple[float, float, float], direction: tuple[float, float, float] = (0.3, 0.4, 1.0)) -> Light:
        return cls(direction=direction, colour=tuple(rgb), gain=tuple(rgb))

    def lit(self, rgb: np.ndarray) -> np.ndarray:
        if self.gain == (1.0, 1.0, 1.0):
            return rgb
        return np.clip(rgb * np.asarray(self.gain, dtype=np.float32), 0, 255).astype(np.uint8)

    def camera_args(self) -> dict:
        return {"lightDirection": list(self.direction), "lightColor": list(self.colour),
                "lightAmbientCoeff": self.ambient, "lightDiffuseCoeff": self.diffuse,
                "lightSpecularCoeff": self.specular}
