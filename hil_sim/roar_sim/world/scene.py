"""The world every simulated robot drives in: a PyBullet client, an endless ground, the track's
walls (one static mesh) and its painted floor, the GUI framing, and the camera and contact
queries both robots use."""

from __future__ import annotations

import ctypes
import math
import os
import threading
from contextlib import nullcontext

import numpy as np
import pybullet_data

from roar_sim import SimError
from roar_sim.world import renderer as renderers
from roar_sim.world.floor import add_floor
from roar_sim.world.tiles import Tiles, frustum_reach_m, tile_files
from roar_sim.world.obstacles import add_cone, add_person
from roar_sim.world.lidar_caster import Caster, wall_boxes
from roar_sim.world.bullet import pb, silenced
from roar.tracks import Track
from roar.tracks.occupancy_map import OccupancyMap, track_map
from roar_sim.world.cache import per_shape
from roar_sim.world.appearance import WALL_HEIGHT_M, WALL_RGBA, WALL_THICKNESS_M, Light  # noqa: F401 (theirs)

WALL_PIECE_M = 0.15  # [m] longest wall box: the camera's renderer drops whole triangles that cross its near plane
GROUND_HALF_M = 25.0  # [m] asphalt shown beyond the track (or around the origin without one)
EGL_CHATTY_FRAMES = 2  # EGL prints its vendor on stdout within its first frames


SOLVER_ITERATIONS = 10  # contact solver iterations per step (PyBullet default 50): a car on a plane settles in few


def display_problem() -> str | None:
    """Why PyBullet's window cannot open here (one line), or None. PyBullet itself would end the
    whole Python process without a word."""
    display = os.environ.get("DISPLAY")
    if not display:
        return "--gui needs a display: DISPLAY is not set (run without --gui, or under xvfb-run)"
    try:
        x11 = ctypes.CDLL("libX11.so.6")
    except OSError:
        return "--gui needs X11, and libX11 is not installed"
    x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    connection = x11.XOpenDisplay(None)
    if not connection:
        return f"--gui needs a display: cannot open DISPLAY={display}"
    x11.XCloseDisplay(connection)
    return None


class World:
    """A PyBullet client (DIRECT, or GUI when gui=True) with gravity, the ground and, with a
    track, its walls and painted floor. Robots add their own bodies to `client`. Camera frames
    come from `renderer` ("rays", "tiny" or "egl"; default: roar_sim.world.renderer.wanted())."""

    def __init__(self, track: Track | None, dt_s: float, gui: bool = False, renderer: str | None = None) -> None:
        problem = display_problem() if gui else None
        if problem:
            raise SimError(problem)
        self.track, self.dt_s = track, dt_s
        self._rays: tuple[int, int, threading.Lock] | None = None  # ray_test's walls-only client
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        c = self.client
        # before any body: the EGL plugin never sees the shapes made before it
        # (with a window, TinyRenderer: the window's own OpenGL is not a second EGL context's)
        self._rendered = 0  # frames drawn
        self.light: Light | None = None  # the light frames are drawn in (None: PyBullet's own)
        self.renderer, self.renderer_name = renderers.start(c, "tiny" if gui else renderers.wanted(renderer))
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setTimeStep(dt_s, physicsClientId=c)
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=c)
        # Nearest-first for the camera's software renderer: a pixel already covered by a wall or the
        # floor is rejected by its depth test before it is shaded again for what lies beneath.
        self._cull = self.renderer_name != "egl" and not gui  # tiles out of a frame's reach hidden (tiles.py)
        self.walls = [_mesh_body(c, *wall_mesh(track))] if track else []  # one body: the physics stays fast
        self.tiles = [Tiles.add(c, wall_tile_files(track), WALL_RGBA)] if track else []  # what the camera sees of them
        # the static solids the lidar meets, by body (lidar_caster.Caster's rows; obstacles.py adds them)
        self.solids: dict[int, tuple[float, ...]] = {}
        # what the ray-cast camera sees of the bodies that are neither walls, ground nor paint, by body
        # (ray_camera.solid_row's rows: the solids above, and visual-only ones such as start lights)
        self.visuals: dict[int, tuple[float, ...]] = {}
        self._ray_scene = None  # (ray_camera.Scenes of this world, the visuals' rows it holds, its light)
        self._ids: list[int] = []  # the bodies, as _bodies() last listed them
        self._unseen_by: tuple[list[int] | None, int, list[int]] = (None, 0, [])  # (for _ids, visuals counted,
        #                                                                            the bodies the rays cannot draw)
        self._casters: dict[float, tuple[Caster, list[int] | None]] = {}  # (a caster, the _ids its solids are for)
        self._colliding: tuple[list[int] | None, list[int]] = (None, [])  # (for _ids, colliding unaccounted for)
        course = track.course if track else None  # a tunnel world's cones and people (not in its map)
        self.cones = [add_cone(self, x, y) for x, y in course.cones] if course else []
        self.people = [add_person(self, x, y) for x, y in course.people] if course else []
        paint = add_floor(track, c) if track else []
        self.floor = [b for tiles in paint for b in tiles.bodies]  # the paint's bodies
        self.tiles += paint
        self.ground = self._add_ground(track)
        if gui:
            self._frame_gui(track)

    def start_pose(self) -> tuple[float, float, float]:
        return self.track.start_pose if self.track else (0.0, 0.0, 0.0)

    def _add_ground(self, track: Track | None) -> int:
        """An endless flat ground (a collision plane, so no track can reach its edge) shown as dark
        asphalt (plain, so walls stand out for the camera) under the track and a margin around it."""
        c = self.client
        centre, half = np.zeros(2), GROUND_HALF_M
        if track is not None:
            lo, hi = np.reshape(track.region.bounds, (2, 2))
            centre, half = (lo + hi) / 2, float(max(hi - lo)) / 2 + GROUND_HALF_M
        shape = pb.createCollisionShape(pb.GEOM_PLANE, planeNormal=[0, 0, 1], physicsClientId=c)
        # one quad, not a box: the camera's software renderer pays for every screen-sized triangle
        corners = [[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]]
        visual = renderers.mesh_visual(c, corners, [0, 1, 2, 0, 2, 3], rgba=[0.25, 0.25, 0.27, 1])
        body = pb.createMultiBody(0, shape, visual, [float(centre[0]), float(centre[1]), 0], physicsClientId=c)
        pb.changeDynamics(body, -1, lateralFriction=1.0, physicsClientId=c)  # as PyBullet's plane.urdf
        return body

    def _frame_gui(self, track: Track | None) -> None:
        """Hide the debug panels and look down on the whole track."""
        c = self.client
        pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=c)
        centre, size = (0.0, 0.0), 2.0
        if track is not None:
            lo, hi = np.reshape(track.region.bounds, (2, 2))
            centre, size = tuple((lo + hi) / 2), float(max(hi - lo))
        pb.resetDebugVisualizerCamera(size, 0, -60, [centre[0], centre[1], 0], physicsClientId=c)

    def ray_test(self, starts: list, ends: list) -> list:
        """pb.rayTestBatch for a sensor on a robot in this world. While the world holds nothing but
        its walls, ground, floor and that robot, the rays go to a second client that holds only the
        walls: the same mesh, so the same answers, without the robot's own wheels and boxes near
        the rays' starts, which cost Bullet up to 2 ms a 72-beam scan."""
        c = self.client
        if not self.walls or pb.getNumBodies(physicsClientId=c) != len(self._own_bodies()) + 1:
            return pb.rayTestBatch(starts, ends, physicsClientId=c)
        if self._rays is None:
            self._rays = _walls_only(self.track)
        client, walls, lock = self._rays
        with lock:
            hits = pb.rayTestBatch(starts, ends, physicsClientId=client)
        return [(self.walls[0], *h[1:]) if h[0] == walls else h for h in hits]

    def lidar_caster(self, body: int | None, others: int, range_m: float) -> Caster | None:
        """The world as a level lidar on `body` meets it, cast without Bullet (its walls and
        self.solids), while every other body that collides is one of `others` cars (whose
        footprints the lidar is given); None otherwise: Bullet's rays must find what it is."""
        if body is None or len(self._unaccounted(body)) != others:
            return None
        if range_m not in self._casters:
            walls = wall_boxes(self.track, WALL_THICKNESS_M) if self.track else np.zeros((0, 5))
            self._casters[range_m] = (Caster(walls, [], range_m), None)
        caster, for_ids = self._casters[range_m]
        if for_ids is not self._ids:  # a body added or removed since: the solids anew
            caster.solids = np.asarray(list(self.solids.values()), dtype=float).reshape(-1, 7)
            self._casters[range_m] = (caster, self._ids)
        return caster

    def _bodies(self, by_count: bool = False) -> list[int]:
        """The world's bodies now (a new list only when they changed). A body removed since leaves
        self.solids and self.visuals: neither the lidar nor the camera meets it any more. by_count:
        listed anew only when their number changed (the lidar's, every scan: listing a circuit's 155
        bodies would add 12 % to a scan; a body removed and another added between scans is missed)."""
        c = self.client
        count = pb.getNumBodies(physicsClientId=c)
        if by_count and count == len(self._ids):
            return self._ids
        ids = [pb.getBodyUniqueId(i, physicsClientId=c) for i in range(count)]
        if ids != self._ids:
            present = set(ids)
            for registry in (self.visuals, self.solids):
                for gone in [b for b in registry if b not in present]:
                    del registry[gone]
            self._ids = ids
        return self._ids

    def _unaccounted(self, body: int) -> list[int]:
        """The bodies but `body` that collide and are neither walls, ground nor solids (robots)."""
        c, ids = self.client, self._bodies(by_count=True)
        if self._colliding[0] is not ids:
            known = {*self.walls, self.ground, *self.solids}
            self._colliding = (ids, [b for b in ids if b not in known and any(
                pb.getCollisionShapeData(b, link, physicsClientId=c)
                for link in range(-1, pb.getNumJoints(b, physicsClientId=c)))])
        return [b for b in self._colliding[1] if b != body]

    def _own_bodies(self) -> list[int]:
        return [*self.walls, *(b for tiles in self.tiles for b in tiles.bodies), self.ground]

    def planar_motion(self, body: int) -> tuple[float, float, float, float, float]:
        """(x [m], y [m], yaw [rad], speed along the heading [m/s], yaw rate [rad/s]) of a body
        on the floor."""
        c = self.client
        (x, y, _), orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
        (vx, vy, _), (_, _, wz) = pb.getBaseVelocity(body, physicsClientId=c)
        yaw = pb.getEulerFromQuaternion(orn)[2]
        return x, y, yaw, vx * math.cos(yaw) + vy * math.sin(yaw), wz

    def contacts(self, body: int, of: list[int] | None = None) -> int:
        """How many wall bodies (or bodies of `of`: self.cones, self.people) `body` touches now."""
        touching = {pt[2] for pt in pb.getContactPoints(bodyA=body, physicsClientId=self.client)}
        return len(touching & set(self.walls if of is None else of))

    def render(self, position, yaw: float, pitch: float, width: int, height: int, fov_deg: float,
               far_m: float = 10.0, near_m: float = 0.05, body: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(RGB uint8 HxWx3, depth float32 HxW [m]) from a camera at `position` looking along `yaw`,
        tilted down by `pitch` [rad], in the world's light (self.light: None is PyBullet's own).
        body: the robot the camera is on (the ray-cast camera leaves it out: it looks ahead of it)."""
        if self.renderer_name == "rays" and self.track is not None and not self._unseen(body):
            return self._ray_render(position, yaw, pitch, width, height, fov_deg, far_m)
        if self._cull:
            reach = frustum_reach_m(far_m, fov_deg, width / height)
            for tiles in self.tiles:
                tiles.show_near(position, yaw, reach)
        forward = np.array([math.cos(yaw), math.sin(yaw), -math.tan(pitch)])
        view = pb.computeViewMatrix(list(position), (np.array(position) + forward).tolist(), [0, 0, 1])
        proj = pb.computeProjectionMatrixFOV(fov_deg, width / height, near_m, far_m)
        if self.renderer_name != "egl":  # OpenGL samples pixel centres, TinyRenderer their corners:
            proj = list(proj)  # half a pixel down and right, and both draw a pinhole camera's image with
            proj[8] += 1.0 / width  # its centre between the middle pixels (roar.vision's CameraModel)
            proj[9] += 1.0 / height  # (column-major: the clip x and y added per unit of depth)
        with silenced((1,)) if self._rendered < EGL_CHATTY_FRAMES and self.renderer_name == "egl" else nullcontext():
            _, _, rgba, depth_buf, _ = pb.getCameraImage(width, height, view, proj, renderer=self.renderer,
                                                         shadow=0, flags=pb.ER_NO_SEGMENTATION_MASK,
                                                         physicsClientId=self.client,
                                                         **(self.light.camera_args() if self.light else {}))
        self._rendered += 1
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]
        if self.light is not None:
            rgb = self.light.lit(rgb)
        d = np.asarray(depth_buf, dtype=np.float32).reshape(height, width)
        return rgb, far_m * near_m / (far_m - (far_m - near_m) * d)

    def _unseen(self, body: int | None) -> list[int]:
        """The bodies but `body` the ray-cast camera cannot draw: neither walls, ground, paint nor
        self.visuals (other robots, markers). A body removed since leaves visuals and solids."""
        ids = self._bodies()
        if self._unseen_by[0] is not ids or self._unseen_by[1] != len(self.visuals):  # (visuals come after their body)
            known = {*self._own_bodies(), *self.visuals}
            self._unseen_by = (ids, len(self.visuals), [b for b in ids if b not in known])
        return [b for b in self._unseen_by[2] if b != body]

    def _ray_render(self, position, yaw: float, pitch: float, width: int, height: int, fov_deg: float,
                    far_m: float) -> tuple[np.ndarray, np.ndarray]:
        from roar_sim.world import ray_camera

        rows = tuple(self.visuals.values())
        if self._ray_scene is None or self._ray_scene[2] is not self.light:  # (a light set since: shades anew)
            self._ray_scene = (ray_camera.Scenes([self.track], self.light), None, self.light)
        scene, held, light = self._ray_scene
        if rows != held:
            scene.set_solids(0, rows)
            self._ray_scene = (scene, rows, light)
        cam = np.array([[position[0], position[1], position[2], yaw, pitch]])
        rgb, depth = ray_camera.render(scene, cam, 0, width, height, fov_deg, far_m)
        self._rendered += 1
        return (rgb[0] if self.light is None else self.light.lit(rgb[0])), depth[0]

    def step(self) -> None:
        pb.stepSimulation(physicsClientId=self.client)

    def close(self) -> None:
        if pb.isConnected(self.client):
            with silenced((1,)) if self.renderer_name == "egl" else nullcontext():  # EGL says goodbye on stdout
                pb.disconnect(self.client)


def _walls_only(track: Track) -> tuple[int, int, threading.Lock]:
    """(client, wall body, its lock): a client holding only the track's walls, shared by every
    world of that track in this process (the walls never move)."""
    def make() -> tuple[int, int, threading.Lock]:
        client = pb.connect(pb.DIRECT)
        return client, _mesh_body(client, *wall_mesh(track)), threading.Lock()

    return per_shape("walls-only ray client", track, make)


def wall_mesh(track: Track) -> tuple[list[list[float]], list[int]]:
    """(vertices, indices) of the wall boxes along the edges of the track's driving area
    (Track.walls: folds trimmed, a figure-eight's crossing open), computed once per track shape."""
    return per_shape("wall mesh", track, lambda: _build_wall_mesh(track))


def world_map(track: Track, resolution_m: float = 0.05) -> OccupancyMap:
    """The map of a track's simulated world (roar.tracks.occupancy_map.track_map) with the walls
    where their faces stand: the boxes are centred on the track's edges, half their thickness in.
    Drawn at the edges, every wall lay 2.5 cm beyond where the lidar read it, and the particle
    filter slid along straights."""
    return track_map(track, resolution_m, inset_m=WALL_THICKNESS_M / 2)


def wall_tile_files(track: Track) -> list:
    """The wall mesh in tiles, as OBJ files (what the renderers draw), written once per track shape."""
    return per_shape("wall tile files", track, lambda: tile_files(*wall_mesh(track)))


def _build_wall_mesh(track: Track) -> tuple[list[list[float]], list[int]]:
    vertices: list[list[float]] = []
    indices: list[int] = []
    for wall in track.walls:
        for a, b in zip(wall, np.roll(wall, -1, axis=0)):
            pieces = max(1, int(np.ceil(np.linalg.norm(b - a) / WALL_PIECE_M)))
            for k in range(pieces):  # short boxes: TinyRenderer drops a triangle crossing its near plane
                _add_box(vertices, indices, a + (b - a) * k / pieces, a + (b - a) * (k + 1) / pieces)
    return vertices, indices


def _mesh_body(client: int, vertices: list, indices: list) -> int:
    """A static body of the triangle mesh, unseen (World.tiles draw it): its visual shape is one
    point-sized transparent triangle (without one, the EGL plugin draws the collision mesh, and
    crashes on a mesh given as vertices)."""
    shape = pb.createCollisionShape(pb.GEOM_MESH, vertices=vertices, indices=indices,
                                    flags=pb.GEOM_FORCE_CONCAVE_TRIMESH, physicsClientId=client)
    unseen = renderers.mesh_visual(client, [[0.0, 0.0, -1.0]] * 3, [0, 1, 2], rgba=[0, 0, 0, 0])
    return pb.createMultiBody(0, shape, unseen, [0, 0, 0], physicsClientId=client)


def _add_box(vertices: list, indices: list, a: np.ndarray, b: np.ndarray) -> None:
    """Append a wall box from a to b (WALL_THICKNESS_M thick, WALL_HEIGHT_M high) as 12 triangles."""
    direction = (b - a) / max(1e-9, float(np.linalg.norm(b - a)))
    a, b = a - direction * WALL_THICKNESS_M / 2, b + direction * WALL_THICKNESS_M / 2
    normal = np.array([-direction[1], direction[0]]) * WALL_THICKNESS_M / 2
    base = len(vertices)
    for z in (0.0, WALL_HEIGHT_M):
        for p in (a - normal, b - normal, b + normal, a + normal):
            vertices.append([float(p[0]), float(p[1]), z])
    faces = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4),
             (1, 2, 6), (1, 6, 5), (2, 3, 7), (2, 7, 6), (3, 0, 4), (3, 4, 7)]
    for f in faces:
        indices.extend(base + k for k in f)
