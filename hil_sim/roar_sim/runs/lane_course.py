"""What the lane driver meets in a race beside its robot: start lights (a seed), boxes on the
track, the TFmini on its nose, a shaky camera, and a folder its frames are written to; and the
driver itself (roar.autopilot.lane_agent) seeing only through that camera."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from roar.autopilot import Agent
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.plants.racecar import LANE_CAMERA
from roar_sim.robots import Robot
from roar_sim.sensors.camera_noise import ShakyCamera
from roar_sim.sensors.tfmini import Tfmini
from roar_sim.world.obstacles import place_boxes, touching
from roar_sim.world.start_lights import GREEN_AFTER_S, StartLights, green_moment


class LaneCourse:
    """What the lane driver meets beside its robot: start lights (a seed), boxes on the track, the
    TFmini on its nose, and a folder its frames are written to."""

    def __init__(self, robot: Robot, start_seed: int | None = None, boxes: Sequence[tuple[float, float]] = (),
                 avoid: bool = False, frames: Path | None = None, shaky_seed: int | None = None,
                 green_span_s: tuple[float, float] = GREEN_AFTER_S) -> None:
        self.robot, self.frames = robot, frames
        world, track = robot.plant.world, robot.track
        self._frame = (ShakyCamera(robot.plant, *LANE_CAMERA, shaky_seed) if shaky_seed is not None else
                       lambda: robot.plant.camera(*LANE_CAMERA))
        self.lights = None
        if start_seed is not None:
            self.lights = StartLights(world, track, green_moment(start_seed, green_span_s))
            robot.plant.props.append(self.lights)
        self.boxes = place_boxes(world, track, boxes)
        self.laser = Tfmini(robot.plant) if avoid else None
        if frames is not None:
            frames.mkdir(parents=True, exist_ok=True)
        self._frames = 0
        self.log = None  # a roar_sim.links.sim_log.SimLog: the driver's frames and what it saw in them

    def camera(self) -> tuple[np.ndarray, np.ndarray]:
        """The lane driver's frame (RGB, depth); with frames, also written as NNNNNN.png and
        NNNNNN_depth.npy (metres), the folder `roar vision` reads."""
        rgb, depth = self._frame()
        if self.log is not None:  # the exact pixels: roar.replay.lanes feeds them to the detector again
            self.log.image(rgb, lossless=True)
        if self.frames is not None:
            from roar.vision.geometry import cv2

            name = f"{self._frames:06d}"
            cv2().imwrite(str(self.frames / f"{name}.png"), np.ascontiguousarray(rgb[:, :, ::-1]))
            np.save(self.frames / f"{name}_depth.npy", depth)
            self._frames += 1
        return rgb, depth

    def agent(self, margin: float) -> Agent:
        """The camera alone drives: the line (and the pose) stay out of the control path."""
        from roar.autopilot.lane_agent import lane_agent
        from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye
        from roar.vision.lanes import LaneDetector
        from roar.vision.start_lights import StartLightDetector
        camera = SIMULATED_CAR_CAMERA.model(*LANE_CAMERA)
        detector = LaneDetector(BirdsEye(camera))
        if self.log is not None:  # what the detector saw, frame by frame, into the recording
            detect, log = detector.detect, self.log

            def detect_logged(rgb):
                lanes = detect(rgb)
                log.lanes(lanes)
                return lanes

            detector.detect = detect_logged
        return lane_agent(self.camera, detector, self.robot.model, PERIOD_S, margin,
                          depth_camera=camera,
                          start=StartLightDetector() if self.lights is not None else None,
                          laser=self.laser.read if self.laser is not None else None)

    def touching_box(self) -> bool:
        return touching(self.robot.plant, self.boxes) > 0
