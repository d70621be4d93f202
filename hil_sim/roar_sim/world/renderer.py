"""Which of PyBullet's renderers draws a world's camera frames, and the mesh files both can draw.

    tiny  PyBullet's TinyRenderer: software, in PyBullet itself, always there.
    rays  roar_sim.world.ray_camera: each pixel's ray cast on the floor's paint, the walls and the
          solids in compiled loops, without Bullet, wherever the world accounts for every body the
          camera may see (World.visuals: boxes, cones, people, start lights; not other cars or
          markers); TinyRenderer draws the other frames. ~10x faster than TinyRenderer at 320 x 240
          (make bench); tests/sim/test_renderers.py checks that the lane detector finds the same
          lines as in TinyRenderer's frames.
    egl   PyBullet's EGL plugin: OpenGL without a window (Mesa's llvmpipe here, a GPU where there
          is one): 2.7x faster at 640x480 on this project's two-core machine, 1.1x at 320x240
          (make bench). It must be loaded into a client before any body is added (it never sees
          the shapes made before it), and it cannot draw a mesh given as a list of vertices (the
          plugin crashes on one): every mesh of the scene is written as an OBJ file (`mesh_file`)
          and drawn from there, by either renderer. TinyRenderer's frames are moved by half a
          pixel to sample pixel centres as OpenGL does (World.render), so both draw the pinhole
          camera roar.vision models; tests/sim/test_renderers.py checks that the lane detector
          finds the same lines in both.

A world takes the renderer of its `renderer=` argument, else the one `chosen()` names where it is
made, else ROAR_RENDERER from the environment, else rays (loading EGL costs ~0.12 s a world,
which only worlds that render many frames repay). EGL falls back to tiny, saying so once, where
it cannot start (no libEGL, no driver); a PyBullet window draws with TinyRenderer.

    with renderer.chosen("egl"):            # roar race --renderer egl
        robot = robots.get("esc")(track)
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import os
import pkgutil
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

from roar_sim.world.bullet import pb, silenced

RENDERERS = ("egl", "rays", "tiny")  # what `--renderer` and ROAR_RENDERER take
DEFAULT = "rays"
ENV = "ROAR_RENDERER"

_chosen: contextvars.ContextVar[str | None] = contextvars.ContextVar("roar_renderer", default=None)
_egl_failed = False  # said once: every later world draws with TinyRenderer
_MESHES: tempfile.TemporaryDirectory | None = None  # removed when the process ends


@contextlib.contextmanager
def chosen(name: str | None) -> Iterator[None]:
    """Worlds made within the block render with `name` (None: as outside it)."""
    if name is not None and name not in RENDERERS:
        raise ValueError(f"renderer {name!r}: choose one of {', '.join(RENDERERS)}")
    token = _chosen.set(name) if name is not None else None
    try:
        yield
    finally:
        if token is not None:
            _chosen.reset(token)


def wanted(name: str | None = None) -> str:
    """The renderer a world made now should use: `name`, else chosen(), else ROAR_RENDERER, else DEFAULT."""
    name = name or _chosen.get() or os.environ.get(ENV) or DEFAULT
    if name not in RENDERERS:
        raise ValueError(f"{ENV}={name!r}: choose one of {', '.join(RENDERERS)}")
    return name


def start(client: int, name: str) -> tuple[int, str]:
    """Make `client` draw with `name` before any body is added: (the getCameraImage renderer
    flag, the renderer's name as it turned out: tiny where EGL cannot start)."""
    global _egl_failed
    if name == "rays":
        return pb.ER_TINY_RENDERER, "rays"  # (TinyRenderer for what the rays cannot account for)
    if name == "egl" and not _egl_failed:
        plugin = pkgutil.get_loader("eglRenderer")
        with silenced((1, 2)):  # the plugin prints its OpenGL version on stdout
            loaded = plugin is not None and pb.loadPlugin(plugin.get_filename(), "_eglRendererPlugin",
                                                          physicsClientId=client) >= 0
        if loaded:
            _one_blas_thread()
            return pb.ER_BULLET_HARDWARE_OPENGL, "egl"
        _egl_failed = True
        print("EGL renderer unavailable (install libegl1 and libegl-mesa0, or a GPU's driver): "
              "camera frames from TinyRenderer", file=sys.stderr)
    return pb.ER_TINY_RENDERER, "tiny"


def _one_blas_thread() -> None:
    """NumPy's BLAS to one thread in this process: its threads spin on after every call, and on a
    small machine they took the cores from the software OpenGL's threads (frames 11 -> 21 ms in a
    camera-driven race, measured on two cores)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1, user_api="blas")


def mesh_file(vertices: Sequence, indices: Sequence[int]) -> str:
    """A Wavefront OBJ file of a triangle mesh, written once per mesh in this process, for
    pb.createVisualShape(pb.GEOM_MESH, fileName=...)."""
    global _MESHES
    v = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    f = [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in zip(indices[0::3], indices[1::3], indices[2::3])]
    text = "\n".join([*v, *f, ""])
    _MESHES = _MESHES or tempfile.TemporaryDirectory(prefix="roar-meshes-")
    path = Path(_MESHES.name) / f"{hashlib.sha1(text.encode()).hexdigest()[:20]}.obj"
    if not path.exists():
        partial = path.with_suffix(f".{os.getpid()}.part")
        partial.write_text(text)
        partial.replace(path)
    return str(path)


def mesh_visual(client: int, vertices: Sequence, indices: Sequence[int], rgba: Sequence[float]) -> int:
    """A visual shape of a triangle mesh in one colour that both renderers draw (from its OBJ file)."""
    return pb.createVisualShape(pb.GEOM_MESH, fileName=mesh_file(vertices, indices), rgbaColor=list(rgba),
                                physicsClientId=client)
