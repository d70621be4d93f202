"""The autopilots a program may hand the simulated car over sim:// (roar web's "autopilot"): each
steps the robot's own driver on what a host reads through roar.Vehicle -- the pose the simulator
reports, or the camera's frames -- and answers with Vehicle.drive() keywords.

    pose   the robot's race agent on the track's centre line (a track is needed)
    lane   the ESC car's lane driver, by its camera alone (roar.autopilot.lane_agent), at the
           camera's frame rate
"""

from __future__ import annotations

from roar.autopilot import Observation
from roar_sim import AutopilotError

POSE_PERIOD_S = 0.02  # [s] the race agent's control period, as in a race
LANE_PERIOD_S = 0.1  # [s] a frame rendered to order costs ~20 ms of the simulator's thread: 10 a second
LANE_MARGIN = 0.6  # of the car's grip: the lane driver sees its frames a little late in real time


def available(transport) -> tuple[str, ...]:
    """The autopilots the transport's robot can have."""
    sim = transport.sim
    if sim is None:
        return ()
    return (("pose",) if sim.track is not None else ()) + (("lane",) if sim.lane_driving else ())


class SimAutopilot:
    """One of the robot's drivers, stepped by a host every `period_s`."""

    def __init__(self, transport, name: str) -> None:
        sim = transport.sim
        if name not in available(transport):
            raise AutopilotError(f"no {name} autopilot here: {', '.join(available(transport)) or 'none'} "
                                 f"(pose needs a track, lane a robot that drives by camera)")
        self.name, self.robot = name, sim
        if name == "pose":
            self.period_s = POSE_PERIOD_S
            self.agent = sim.agent(sim.track.centerline)
        else:
            from roar.autopilot.lane_agent import lane_agent
            from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye
            from roar.vision.lanes import LaneDetector
            from roar_sim.plants.racecar import LANE_CAMERA

            self.period_s = LANE_PERIOD_S
            camera = SIMULATED_CAR_CAMERA.model(*LANE_CAMERA)
            self.agent = lane_agent(lambda: transport.camera(*LANE_CAMERA), LaneDetector(BirdsEye(camera)),
                                    sim.model, LANE_PERIOD_S, LANE_MARGIN, depth_camera=camera)
        self.agent.setup()
        self._t0: float | None = None

    def step(self, state) -> dict:
        """The next command for the car in `state` (a roar VehicleState), as drive() keywords."""
        if state is None or state.x_m is None:
            return self.robot.host_drive(0.0, 0.0)
        if self._t0 is None:
            self._t0 = state.time_s
        observation = Observation(state.time_s - self._t0, state.x_m, state.y_m, state.yaw_rad,
                                  abs(state.speed_m_s), state.yaw_rate_rad_s)
        command = self.agent.step(observation)
        return self.robot.host_drive(command.throttle, command.steering)

    def shutdown(self) -> None:
        self.agent.shutdown()
