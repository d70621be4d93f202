"""Start lights: the simulator's light turns from red to green at a seeded moment; the camera
detector starts on the second frame that shows green, never before it, however the camera shakes
and whatever noise its sensor adds; the lane driver waits for it and then races."""

import math

import pytest

pytest.importorskip("cv2", reason="pip install opencv-python-headless (make setup installs it)")
pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")

from roar.vision.start_lights import StartLightDetector  # noqa: E402
from roar_sim.sensors.camera_noise import NOISE, SHAKE_RAD, ShakyCamera  # noqa: E402
from roar_sim.plants.racecar import Racecar  # noqa: E402
from roar_sim.runs.lane_course import LANE_CAMERA, PERIOD_S
from roar_sim.runs.race import race  # noqa: E402
from roar_sim.world.start_lights import StartLights, frames_to_start, green_moment  # noqa: E402
from roar.tracks import get  # noqa: E402

W, H = LANE_CAMERA
STEPS_PER_FRAME = round(PERIOD_S / 0.005)  # physics steps between the driver's frames (50 Hz)


@pytest.fixture(scope="module")
def start():
    track = get("oval")
    plant = Racecar(track)
    lights = StartLights(plant.world, track, green_at_s=math.inf)
    plant.props.append(lights)
    yield plant, lights
    plant.close()


def wait_for_green(plant, lights, camera, detector, green_in_s, after_frames=4):
    return frames_to_start(plant, lights, camera, detector, green_in_s, STEPS_PER_FRAME, after_frames)


def test_seeded_starts_react_within_two_frames_and_none_is_false(start):
    """Runs each with its own green moment, mount shake (twice the default) and sensor noise: no
    start before green (0 would be a false start), each on the 1st or 2nd green frame. Twelve
    seeds here, fifty in the benchmark (benchmarks/start_lights.py)."""
    plant, lights = start
    reactions = []
    for seed in range(12):
        camera = ShakyCamera(plant, W, H, seed, shake_rad=2 * SHAKE_RAD, noise=1.5 * NOISE)
        frames, red_frames = wait_for_green(plant, lights, camera, StartLightDetector(),
                                            green_moment(seed, (0.2, 1.0)))
        assert red_frames >= 8, "the light was red too briefly to test the wait"
        reactions.append(frames)
    assert 0 not in reactions, f"false starts in runs {[i for i, r in enumerate(reactions) if r == 0]}"
    assert None not in reactions, f"no start in runs {[i for i, r in enumerate(reactions) if r is None]}"
    assert max(reactions) <= 2, reactions


def test_a_light_that_flashes_green_for_one_frame_does_not_start_the_car(start):
    plant, lights = start
    detector = StartLightDetector()
    lights.reset(math.inf)
    for _ in range(3):
        assert not detector.update(plant.camera(W, H)[0])
    lights.show(True)
    assert not detector.update(plant.camera(W, H)[0])  # green appears: not yet
    lights.show(False)
    for _ in range(5):
        assert not detector.update(plant.camera(W, H)[0])  # red again: never


def test_green_without_red_before_it_is_not_a_start(start):
    """The change is what starts the car: a light already green when the car looks does not."""
    plant, lights = start
    lights.reset(0.0)
    lights.update(plant.time_s)
    detector = StartLightDetector()
    assert not any(detector.update(plant.camera(W, H)[0]) for _ in range(5))


def test_the_lane_driver_waits_for_green_then_drives_the_readmes_lap():
    """`roar race --driver lane --start-lights 7 --laps 1`, as the README shows it: a whole lap."""
    green_s = green_moment(7)
    result = race(get("oval"), laps=1, lateral="lane", start_lights=7)
    assert result.green_at_s == pytest.approx(green_s)
    assert not result.false_start and result.green_frames <= 2
    before = [(x, y) for x, y, _, _, t in result.path if t < result.green_at_s]
    assert len(before) > 20 and all(math.hypot(x - before[0][0], y - before[0][1]) < 0.01 for x, y in before)
    assert len(result.lap_times_s) == 1 and result.wall_contacts == 0 and not result.stops


def test_start_lights_are_for_the_lane_driver():
    with pytest.raises(ValueError, match="lane driver"):
        race(get("oval"), laps=1, start_lights=1)
