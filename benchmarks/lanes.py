"""Driving by camera: lane detection time per 320x240 frame on one core (target <= 10 ms), the
start-light detector's time per frame, the ground-plane occupancy grid's frames/s at 256x192
depth (the phone's size; target >= 30, the ROAR thesis: <= 10), the camera-only lap against the
pose-based autopilot's best lap on the same track in the same run (target <= 1.3), and a lap of
the obstacle course past three boxes (TFmini lane changes; target 0 contacts)."""

import time

TITLE = "Lane detection and the camera-only lap"
FRAMES = 40


def run() -> None:
    try:
        from roar.vision.geometry import BirdsEye
        from roar.vision.lanes import LaneDetector
    except ImportError as e:
        print(f"  skipped: {e}")
        return
    from roar.vision.geometry import SIMULATED_CAR_CAMERA
    from roar_sim.plants.racecar import Racecar
    from roar_sim.runs.lane_course import LANE_CAMERA
    from roar_sim.runs.race import race
    from roar.tracks import get

    w, h = LANE_CAMERA
    plant = Racecar(get("oval"))
    frames = []
    for _ in range(FRAMES):
        plant.apply(0.3, 0.0, 0.0)
        for _ in range(10):
            plant.step()
        frames.append(plant.camera(w, h)[0])
    plant.close()
    detector = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(w, h)))
    times = []
    for rgb in frames:
        start = time.perf_counter()
        detector.detect(rgb)
        times.append(time.perf_counter() - start)
    times.sort()
    print(f"  lane detection, {w}x{h}: median {times[len(times) // 2] * 1000:.1f} ms, "
          f"worst {times[-1] * 1000:.1f} ms per frame (target <= 10 ms)")
    from roar.vision.start_lights import StartLightDetector

    lights = StartLightDetector()
    start = time.perf_counter()
    for rgb in frames:
        lights.update(rgb)
    print(f"  start-light detection, {w}x{h}: {(time.perf_counter() - start) / len(frames) * 1000:.2f} ms per frame")
    from roar.vision.occupancy import occupancy

    plant = Racecar(get("oval"))
    depths = [plant.camera(256, 192)[1] for _ in range(5)]
    plant.close()
    depth_camera = SIMULATED_CAR_CAMERA.model(256, 192)
    start = time.perf_counter()
    for _ in range(4):
        for depth in depths:
            occupancy(depth, depth_camera)
    per_frame = (time.perf_counter() - start) / (4 * len(depths))
    print(f"  ground-plane occupancy, 256x192 depth: {1 / per_frame:.0f} frames/s (target >= 30)")
    for name in ("oval", "figure-eight"):
        track = get(name)
        camera, pose = race(track, laps=2, lateral="lane"), race(track, laps=2)
        ratio = min(camera.lap_times_s) / min(pose.lap_times_s)
        print(f"  {name}: camera-only best lap {min(camera.lap_times_s):.2f} s, pose-based {min(pose.lap_times_s):.2f} s, "
              f"ratio {ratio:.2f} (target <= 1.3); cross-track max {camera.max_cross_track_m:.3f} m, "
              f"wall contacts {camera.wall_contacts}")
    from roar_sim.world.obstacles import box_course

    track = get("course")
    spots = box_course(track, 3)
    result = race(track, laps=1, lateral="lane", boxes=spots, avoid=True)
    lap = f"{result.lap_times_s[0]:.2f} s" if result.lap_times_s else "not completed"
    print(f"  obstacle course ({len(spots)} boxes, TFmini lane changes): lap {lap}, box contacts "
          f"{result.box_contacts}, wall contacts {result.wall_contacts} (target 0 and 0)")
