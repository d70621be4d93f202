"""Start lights read by the camera at a standing start, over fifty seeds: each run its own green
moment, mount shake twice the default and 1.5 x the sensor noise. Targets: no start before green
(a false start), every start on the 1st or 2nd green frame. (The suite runs twelve of these.)"""

import math
from collections import Counter

from roar.tracks import get
from roar.vision.start_lights import StartLightDetector
from roar_sim.plants.racecar import Racecar
from roar_sim.runs.lane_course import LANE_CAMERA, PERIOD_S
from roar_sim.sensors.camera_noise import NOISE, SHAKE_RAD, ShakyCamera
from roar_sim.world.start_lights import StartLights, frames_to_start, green_moment

TITLE = "start lights at a standing start, 50 seeds (targets: no false start, every start within 2 green frames)"
SEEDS = 50
MAX_FRAMES = 2
STEPS_PER_FRAME = round(PERIOD_S / 0.005)  # physics steps between the driver's frames (50 Hz)


def run() -> None:
    w, h = LANE_CAMERA
    track = get("oval")
    plant = Racecar(track)
    lights = StartLights(plant.world, track, green_at_s=math.inf)
    plant.props.append(lights)
    reactions = []
    try:
        for seed in range(SEEDS):
            camera = ShakyCamera(plant, w, h, seed, shake_rad=2 * SHAKE_RAD, noise=1.5 * NOISE)
            frames, _ = frames_to_start(plant, lights, camera, StartLightDetector(), green_moment(seed, (0.2, 1.0)),
                                        STEPS_PER_FRAME)
            reactions.append(frames)
    finally:
        plant.close()
    false = [i for i, r in enumerate(reactions) if r == 0]
    missed = [i for i, r in enumerate(reactions) if r is None]
    late = [i for i, r in enumerate(reactions) if r is not None and r > MAX_FRAMES]
    counts = Counter(r for r in reactions if r)
    print("  green frames seen when it started: " + ", ".join(f"{k}: {counts[k]}" for k in sorted(counts)))
    verdict = "ok" if not (false or missed or late) else \
        f"MISSED: false starts in runs {false}, no start in {missed}, later than {MAX_FRAMES} frames in {late}"
    print(f"  {SEEDS} runs: {len(false)} false starts, {len(missed)} without a start, {len(late)} late ({verdict})")


if __name__ == "__main__":
    run()
