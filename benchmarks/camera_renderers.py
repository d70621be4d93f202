"""The simulated camera's renderers side by side in one run: an RGB + depth frame from the car's
camera at 320x240 (target <= 10 ms) and 640x480 (target <= 33 ms), over poses along a random
track, by the rays (roar_sim.world.ray_camera, the default), TinyRenderer and EGL; and a
camera-only race's speed against real time at 320x240 (target >= 5x) by each, with where each
control period's time goes."""

import math
import time

import numpy as np

TITLE = "camera frames: rays, TinyRenderer and EGL (targets: 320x240 <= 10 ms, 640x480 <= 33 ms, a camera race >= 5x real time)"
TRACK = "random:31"
LONG_TRACK = "circuit:29"  # 272 m: 70,000 triangles of walls and paint, drawn in tiles (roar_sim.world.tiles)
POSES = 30
FRAME_TARGET_MS = {(320, 240): 10.0, (640, 480): 33.0}  # [ms]
RACE_S = 12.0  # [s] simulated
REALTIME_TARGET = 5.0


def frame_ms(renderer: str, size: tuple[int, int], name: str = TRACK) -> float:
    """[ms] mean per frame over POSES poses along the track, from a car's camera position."""
    from roar.tracks import get
    from roar.vision.geometry import SIMULATED_CAR_CAMERA as CAM
    from roar_sim.world.scene import World

    track = get(name)
    world = World(track, 1 / 240, renderer=renderer)
    try:
        if world.renderer_name != renderer:
            return math.nan
        step = len(track.centerline) // POSES
        poses = []
        for i in range(0, step * POSES, step):
            (x, y), ahead = track.centerline[i], track.centerline[(i + 1) % len(track.centerline)] - track.centerline[i]
            yaw = math.atan2(ahead[1], ahead[0])
            poses.append(((x + CAM.x_m * math.cos(yaw), y + CAM.x_m * math.sin(yaw), CAM.z_m), yaw))
        for position, yaw in poses[:3]:  # the first frames load the scene
            world.render(position, yaw, CAM.pitch_rad, *size, CAM.fov_deg)
        start = time.perf_counter()
        for position, yaw in poses:
            world.render(position, yaw, CAM.pitch_rad, *size, CAM.fov_deg)
        return (time.perf_counter() - start) / len(poses) * 1000
    finally:
        world.close()


def race_speed(renderer: str) -> tuple[float, float, float]:
    """(simulated s per wall s, ms a control period, of which ms rendering) of a camera-only race."""
    from roar.tracks import get
    from roar_sim.runs.race import race
    from roar_sim.world import scene

    spent = []
    render = scene.World.render

    def timed(self, *args, **kwargs):
        start = time.perf_counter()
        try:
            return render(self, *args, **kwargs)
        finally:
            spent.append(time.perf_counter() - start)

    scene.World.render = timed
    try:
        start = time.perf_counter()
        result = race(get(TRACK), laps=1, lateral="lane", timeout_s=RACE_S, renderer=renderer)
        wall = time.perf_counter() - start
    finally:
        scene.World.render = render
    simulated = result.path[-1][4] if result.path else RACE_S
    periods = max(1, len(spent))
    return simulated / wall, wall / periods * 1000, float(np.sum(spent)) / periods * 1000


def run() -> None:
    try:
        import pybullet  # noqa: F401
        import cv2  # noqa: F401
    except ImportError as e:
        print(f"  skipped: {e}")
        return
    for size, target in FRAME_TARGET_MS.items():
        costs = {name: frame_ms(name, size) for name in ("rays", "tiny", "egl")}
        egl = costs["egl"]
        best = min(costs, key=lambda name: costs[name] if not math.isnan(costs[name]) else math.inf)
        verdict = ("ok" if costs[best] <= target else
                   f"MISSED by {costs[best] - target:.1f} ms: every renderer here draws in software on two cores")
        print(f"  {size[0]}x{size[1]} RGB + depth: rays {costs['rays']:.1f} ms, TinyRenderer {costs['tiny']:.1f} ms, "
              + ("EGL cannot start here (apt install libegl1 libegl-mesa0)" if math.isnan(egl) else f"EGL {egl:.1f} ms")
              + f" (rays {costs['tiny'] / costs['rays']:.1f}x faster than TinyRenderer; target <= {target:g} ms) "
              + verdict)
    target = FRAME_TARGET_MS[(320, 240)]
    for name in ("rays", "tiny"):
        long_ms = frame_ms(name, (320, 240), LONG_TRACK)
        verdict = ("ok" if long_ms <= target else
                   "MISSED: the tiles in the camera's reach hold walls in 0.15 m boxes" if name == "tiny" else
                   "MISSED: the walls marched on the long track's distance field, 1,024 bearings a frame")
        print(f"  320x240 on {LONG_TRACK} (272 m), {name}: {long_ms:.1f} ms (target <= {target:g} ms) {verdict}")
    for name in ("rays", "tiny", "egl"):
        factor, period_ms, render_ms = race_speed(name)
        verdict = ("ok" if factor >= REALTIME_TARGET else
                   f"MISSED: a 20 ms control period costs {period_ms:.1f} ms, {render_ms:.1f} ms of it the frame and the "
                   f"rest lane detection, the depth occupancy grid and physics; {REALTIME_TARGET:g}x needs <= "
                   f"{20 / REALTIME_TARGET:.0f} ms in all")
        print(f"  camera-only race on {TRACK} at 320x240, frames by {name}: {factor:.2f}x real time "
              f"(target >= {REALTIME_TARGET:g}x) {verdict}")


if __name__ == "__main__":
    run()
