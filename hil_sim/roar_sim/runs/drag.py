"""The IARRC drag race in the simulator: the IARRC car (its firmware's speed PID, encoder and gyro)
on a drag strip (roar.tracks.drag_strip), a TFmini on its nose and its camera, driven by
roar.autopilot.drag: lane and gyro heading hold flat out to the finish, then the laser's range
brings it to a stop in the stop zone.

    roar race --robot iarrc --event drag [--track drag:40] [--top-speed 4] [--plot out/drag.png]

    result = drag_race(get("drag:40"), top_speed_m_s=3.5, blank_s=(2.0, 2.5))   # camera dark meanwhile
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from roar.autopilot import Runner
from roar.tracks import Track
from roar.tracks.drag_strip import parse
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.plants.esc_servo import SteeringServo
from roar_sim.robots.iarrc import FULL_SCALE_M_S, MODEL, IarrcCar
from roar_sim.plants.racecar import LANE_CAMERA
from roar_sim.sensors.tfmini import MOUNT_X_M, Tfmini
from roar_sim.world import renderer as renderers

BUMP_S = 0.05  # [s] a bump's knock lasts this long
FRONT_M = MOUNT_X_M  # [m] from the car's reference point to its nose, where the laser sits


@dataclass
class DragResult:
    track: Track
    finish_m: float  # [m] x of the finish line
    end_m: float  # [m] x of the end wall's face
    top_speed_m_s: float  # [m/s] asked for
    t: list[float] = field(default_factory=list)  # [s]
    x: list[float] = field(default_factory=list)  # [m] along the strip
    y: list[float] = field(default_factory=list)  # [m] off its centre line, left +
    speed: list[float] = field(default_factory=list)  # [m/s]
    heading_deg: list[float] = field(default_factory=list)  # [deg] against the strip
    states: list[str] = field(default_factory=list)  # the driver's state each control period
    started_s: float | None = None  # [s] the first setpoint
    finish_s: float | None = None  # [s] the finish line crossed
    brake_x_m: float | None = None  # [m] where braking began
    wall_contacts: int = 0  # control periods touching a wall

    @property
    def strip_time_s(self) -> float | None:
        return None if self.finish_s is None else self.finish_s - (self.started_s or 0.0)

    @property
    def max_speed_m_s(self) -> float:
        return max(self.speed, default=0.0)

    @property
    def stopped_x_m(self) -> float:
        return self.x[-1] if self.x else 0.0

    @property
    def nose_gap_m(self) -> float:
        """[m] from the nose to the end wall when it stopped."""
        return self.end_m - (self.stopped_x_m + FRONT_M)

    @property
    def stopping_m(self) -> float | None:
        return None if self.brake_x_m is None else self.stopped_x_m - self.brake_x_m

    @property
    def max_lateral_m(self) -> float:
        return max((abs(v) for v in self.y), default=0.0)

    @property
    def in_stop_zone(self) -> bool:
        return self.finish_m <= self.stopped_x_m and self.nose_gap_m > 0 and self.wall_contacts == 0


def drag_race(track: Track, top_speed_m_s: float = 4.0, blank_s: tuple[float, float] | None = None,
              timeout_s: float | None = None, renderer: str | None = None, seed: int = 0,
              servo_trim_us: int = 0, bump_deg: float = 0.0, log=None) -> DragResult:
    """One run down the strip `track` (a drag:... track) at top_speed_m_s; with blank_s the camera
    gives black frames from blank_s[0] to blank_s[1] [s] after the start, and as it goes dark
    a bump turns the car by bump_deg [deg] (left +); servo_trim_us: [us] the steering servo's
    mechanical offset (a real car's is never quite centred); log: an MCAP file the run is recorded
    into (roar_sim.links.sim_log: the firmware's side, the frames, the lane detector's view and the
    driver's state)."""
    from roar.autopilot.drag import DragState, drag_agent
    from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye
    from roar.vision.lanes import LaneDetector

    if not track.name.startswith("drag:"):
        raise ValueError(f"the drag race needs a drag strip (--track drag:LENGTH), not {track.name!r}")
    spec = parse(track.name)
    result = DragResult(track, spec.length_m, spec.end_m, top_speed_m_s)
    timeout_s = timeout_s or 10.0 + 3 * spec.end_m / top_speed_m_s
    with renderers.chosen(renderer), IarrcCar(track, servo=SteeringServo(trim_us=servo_trim_us)) as car:
        laser = Tfmini(car.plant, seed)
        sim_log = None
        if log is not None:
            from roar_sim.links.sim_log import SimLog

            sim_log = SimLog(car, log, {"driver": "drag"})

        bumped = [False]

        def camera():
            rgb, depth = car.plant.camera(*LANE_CAMERA)
            if blank_s is not None and result.started_s is not None and \
                    blank_s[0] <= car.time_s - result.started_s < blank_s[1]:
                rgb = np.zeros_like(rgb)
                if not bumped[0]:
                    _turn(car.plant, math.radians(bump_deg))
                    bumped[0] = True
            if sim_log is not None:
                sim_log.image(rgb)
            return rgb, depth

        detector = LaneDetector(BirdsEye(SIMULATED_CAR_CAMERA.model(*LANE_CAMERA)))
        agent = drag_agent(camera, detector, laser.read, MODEL, PERIOD_S, top_speed_m_s, FULL_SCALE_M_S)
        planner = agent.planner

        def on_step(obs, command) -> None:
            if result.started_s is None:
                result.started_s = obs.t_s
            result.t.append(obs.t_s)
            result.x.append(obs.x)
            result.y.append(obs.y)
            result.speed.append(obs.speed)
            result.heading_deg.append(math.degrees(obs.yaw))
            result.states.append(planner.state.name)
            if result.finish_s is None and obs.x >= spec.length_m:
                result.finish_s = obs.t_s
            if result.brake_x_m is None and planner.state is DragState.BRAKE:
                result.brake_x_m = obs.x
            result.wall_contacts += car.touching_wall()
            if sim_log is not None:
                sim_log.step()
                sim_log.driver_state(planner.state.name.lower())

        car.arm()
        try:
            Runner(car, agent, PERIOD_S).run(
                until=lambda obs: planner.state is DragState.STOPPED or obs.t_s >= timeout_s, on_step=on_step)
        finally:
            if sim_log is not None:
                sim_log.close()
    return result


def _turn(plant, angle_rad: float) -> None:
    """A bump under one side: the car is set spinning about its vertical axis as a knock of
    angle_rad over BUMP_S would (its tyres then take some of it back); the gyro feels it."""
    from roar_sim.world.bullet import pb

    velocity, (sx, sy, sz) = pb.getBaseVelocity(plant.car, physicsClientId=plant.client)
    pb.resetBaseVelocity(plant.car, velocity, [sx, sy, sz + angle_rad / BUMP_S], physicsClientId=plant.client)


def report(result: DragResult) -> str:
    r = result
    lines = [f"IARRC car, drag race on {r.track.name}: {r.finish_m:g} m to the finish, a "
             f"{r.end_m - r.finish_m:g} m stop zone, top speed asked {r.top_speed_m_s:.2f} m/s"]
    if r.strip_time_s is None:
        lines.append(f"did not reach the finish line: stopped {r.stopped_x_m:.2f} m down the strip")
    else:
        lines.append(f"time over the strip: {r.strip_time_s:.2f} s (top speed {r.max_speed_m_s:.2f} m/s)")
    if r.stopping_m is not None:
        lines.append(f"braking from {r.brake_x_m:.2f} m: stopped after {r.stopping_m:.2f} m, {r.stopped_x_m:.2f} m down "
                     f"the strip, the nose {r.nose_gap_m:.2f} m from the end wall "
                     f"({'in the stop zone' if r.in_stop_zone else 'NOT in the stop zone'})")
    holding = sum(s == "HOLD" for s in r.states) * PERIOD_S
    lines.append(f"largest lateral error {r.max_lateral_m:.3f} m; gyro heading hold {holding:.2f} s; "
                 f"wall contacts {r.wall_contacts}")
    return "\n".join(lines)


def plot(result: DragResult):
    """Speed and heading along the strip, the driver's heading-hold stretches shaded."""
    import matplotlib.pyplot as plt

    fig, (ax_v, ax_h) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    x = np.asarray(result.x)
    ax_v.plot(x, result.speed, label="speed")
    ax_h.plot(x, result.heading_deg, color="tab:orange", label="heading")
    hold = np.asarray([s == "HOLD" for s in result.states])
    for ax in (ax_v, ax_h):
        ax.axvline(result.finish_m, color="k", lw=1, ls="--")
        ax.axvline(result.end_m - (FRONT_M), color="tab:red", lw=1)
        if hold.any():
            ax.fill_between(x, 0, 1, where=hold, transform=ax.get_xaxis_transform(), color="tab:purple",
                            alpha=0.15, label="gyro heading hold")
        ax.grid(alpha=0.3)
    if result.brake_x_m is not None:
        ax_v.axvline(result.brake_x_m, color="tab:green", lw=1, label="braking starts")
    ax_v.set_ylabel("speed [m/s]")
    ax_h.set_ylabel("heading [deg]")
    ax_h.set_xlabel("along the strip [m] (dashed: finish line, red: where the nose meets the end wall)")
    ax_v.legend(loc="upper left")
    time = f"{result.strip_time_s:.2f} s" if result.strip_time_s is not None else "no finish"
    fig.suptitle(f"drag race {result.track.name}: {time}, stopped {result.nose_gap_m:.2f} m short of the wall")
    fig.tight_layout()
    return fig
