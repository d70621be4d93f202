"""ROAR's combined driver in the simulator: two ESC cars on one track (roar_sim.runs.fleet). The
leader drives the right lane by its pose, moving to the left lane round every box in its way, and
sends its position over V2V (real UDP multicast on loopback); the follower drives by its camera
alone (roar.autopilot.lane_agent): keeps the right lane, changes lanes round boxes (its TFmini
and depth camera), and keeps its gap to the leader while the leader is ahead in its lane.

    roar race --driver lane --avoid --follow [--boxes 3] [--track course] [--plot out/combined.png]

    result = combined_race(get("course"), boxes=box_course(track, 3))
    result.transitions                   # [(time s, metres along the lap, from state, to state)]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from roar.autopilot.lane_agent import FOLLOW_GAP_M, LANE_OFFSET_M, Leader, LaneState, lane_agent
from roar.autopilot.platoon import cruise_agent
from roar.protocol import spec
from roar.tracks import Track
from roar.v2v import V2VLink, free_port
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.plants.racecar import LANE_CAMERA
from roar_sim.robots.esc import MODEL
from roar_sim.runs.fleet import Fleet
from roar_sim.runs.platoon import FOLLOWER as FOLLOWER_ID, LEADER as LEADER_ID, V2V_EVERY
from roar_sim.runs.progress import laps_bar
from roar_sim.sensors.tfmini import Tfmini
from roar_sim.world.obstacles import place_boxes, touching

LEADER_SPEED_M_S = 0.8  # [m/s] slower than the follower keeping a lane (1.3 m/s): it catches up
START_GAP_M = 3.0  # [m] the follower starts this far behind the leader
SWERVE_BEFORE_M, SWERVE_AFTER_M = 2.0, 1.0  # [m] the leader is in the other lane from before a box to after it
RAMP_M = 1.0  # [m] over which the leader's line moves across


@dataclass
class CombinedResult:
    track: Track
    boxes: int
    laps: int = 0  # the follower's
    t: list[float] = field(default_factory=list)  # [s]
    s: list[float] = field(default_factory=list)  # [m] the follower's distance along the lap
    states: list[str] = field(default_factory=list)  # the follower's driver state, each control period
    gaps_m: list[float] = field(default_factory=list)  # [m] true gap, follower to leader along the road
    speeds: list[float] = field(default_factory=list)  # [m/s] the follower's
    transitions: list[tuple[float, float, str, str]] = field(default_factory=list)
    box_contacts: int = 0  # control periods with the follower touching a box
    car_contacts: int = 0  # ... touching the leader
    wall_contacts: int = 0
    leader_box_contacts: int = 0
    travelled_m: float = 0.0  # [m] the follower's

    def time_in(self, state: LaneState) -> float:
        return sum(s == state.name for s in self.states) * PERIOD_S


def leader_line(track: Track, boxes: Sequence[tuple[float, float]]) -> np.ndarray:
    """The leader's line: the middle of the right lane, in the left lane round every box in the right."""
    s = np.concatenate([[0.0], np.cumsum(track.segment_lengths)[:-1]])
    offset = np.full(len(s), -LANE_OFFSET_M)
    for box_s, box_offset in boxes:
        if box_offset >= 0:
            continue
        ahead = track.arc_delta(box_s, s)  # [m] of each point past the box (negative: before it)
        into = np.clip((ahead + SWERVE_BEFORE_M) / RAMP_M, 0.0, 1.0)
        out = np.clip((SWERVE_AFTER_M + RAMP_M - ahead) / RAMP_M, 0.0, 1.0)
        offset = np.maximum(offset, -LANE_OFFSET_M + 2 * LANE_OFFSET_M * np.minimum(into, out))
    return track.centerline + offset[:, None] * track.normals


HEARD_LEADER = "/v2v/leader"  # the leader's pose as the follower last heard it
TRUE_LEADER = "/sim/leader"  # ... and where it was


def combined_race(track: Track, laps: int = 1, boxes: Sequence[tuple[float, float]] = (), timeout_s: float | None = None,
                  margin: float = 0.9, progress: bool = False, distance_m: float | None = None,
                  log=None) -> CombinedResult:
    """The follower's laps (or, with distance_m, that many metres) behind the leader, with boxes at
    (distance along the centre line, offset to its left) [m]. log: an MCAP file the follower's run
    is recorded into (roar_sim.links.sim_log), with the leader as it was heard over V2V and as it was."""
    from roar.vision.geometry import SIMULATED_CAR_CAMERA, BirdsEye
    from roar.vision.lanes import LaneDetector

    result = CombinedResult(track, len(boxes))
    timeout_s = timeout_s or 20.0 + 3.0 * laps * track.length_m / LEADER_SPEED_M_S
    port = free_port()
    with V2VLink(LEADER_ID, port=port) as lead_link, V2VLink(FOLLOWER_ID, port=port) as follow_link, \
            Fleet(track, count=2, gap_m=START_GAP_M) as fleet:
        lead, follow = fleet.cars
        bodies = place_boxes(fleet.world, track, boxes)
        laser = Tfmini(follow.plant)
        camera_model = SIMULATED_CAR_CAMERA.model(*LANE_CAMERA)
        hint: dict[str, int | None] = {"lead": None, "follow": None, "heard": None}
        sim_log = None
        if log is not None:
            from roar_sim.links.sim_log import SimLog

            sim_log = SimLog(follow, log, {"driver": "combined"})

        def camera():
            frame = follow.plant.camera(*LANE_CAMERA)
            if sim_log is not None:
                sim_log.image(frame[0])
            return frame

        def where(name: str, x: float, y: float, yaw: float) -> tuple[float, float]:
            hint[name], s, left = track.project((x, y), hint[name], heading=yaw)
            return s, left

        def leader(obs) -> Leader | None:
            heard = follow_link.latest.get(LEADER_ID)
            if heard is None or obs.t_s - heard.received_s > spec.V2V_TIMEOUT_US / 1e6:
                return None
            s_lead, left = where("heard", heard.x, heard.y, heard.yaw)
            s_self, _ = where("follow", obs.x, obs.y, obs.yaw)
            return Leader(track.arc_delta(s_self, s_lead), left, heard.speed)

        follower = lane_agent(camera, LaneDetector(BirdsEye(camera_model)), MODEL,
                              PERIOD_S, margin, depth_camera=camera_model, laser=laser.read, leader=leader)
        leader_agent = cruise_agent(leader_line(track, boxes), MODEL, PERIOD_S, LEADER_SPEED_M_S)
        for car in fleet.cars:  # each boots latched until it hears neutral
            car.drive(0.0, 0.0)
        fleet.run(PERIOD_S)
        follower.setup()
        leader_agent.setup()
        planner = follower.planner
        travelled, last_s, step = 0.0, None, 0
        bar = laps_bar(laps, f"combined driver on {track.name}") if progress else None
        goal_m = distance_m if distance_m is not None else laps * track.length_m
        while fleet.time_s < timeout_s and travelled < goal_m:
            t = fleet.time_s
            o_lead, o_follow = lead.observe(), follow.observe()
            if step % V2V_EVERY == 0:
                lead_link.send(o_lead.x, o_lead.y, o_lead.yaw, o_lead.speed)
            follow_link.receive(t)
            lead.send(leader_agent.step(o_lead))
            follow.send(follower.step(o_follow))
            fleet.run(PERIOD_S)
            step += 1
            here, there = follow.state(), lead.state()
            s_follow, _ = where("follow", here.x, here.y, here.yaw)
            s_lead, _ = where("lead", there.x, there.y, there.yaw)
            travelled += 0.0 if last_s is None else track.arc_delta(last_s, s_follow)
            last_s = s_follow
            state = planner.state.name
            if result.states and result.states[-1] != state:
                result.transitions.append((t, s_follow, result.states[-1], state))
            result.t.append(t)
            result.s.append(s_follow)
            result.states.append(state)
            result.gaps_m.append(track.arc_delta(s_follow, s_lead))
            result.speeds.append(here.speed)
            result.box_contacts += touching(follow.plant, bodies) > 0
            result.leader_box_contacts += touching(lead.plant, bodies) > 0
            result.car_contacts += fleet.touching(0, 1)
            result.wall_contacts += follow.touching_wall()
            if sim_log is not None:
                sim_log.step()
                sim_log.driver_state(planner.state.value)
                sim_log.pose(TRUE_LEADER, (there.x, there.y, there.yaw))
                heard = follow_link.latest.get(LEADER_ID)
                if heard is not None:
                    sim_log.pose(HEARD_LEADER, (heard.x, heard.y, heard.yaw))
            if bar:
                bar.update(max(0.0, min(laps, travelled / track.length_m) - bar.n))
        if bar:
            bar.close()
        if sim_log is not None:
            sim_log.close()
        result.laps = int(travelled // track.length_m)
        result.travelled_m = travelled
    return result


def report(result: CombinedResult) -> str:
    r = result
    names = {state.name: state.value for state in LaneState}
    lines = [f"combined driver on {r.track.name} ({r.boxes} boxes): the follower by camera behind a leader over V2V "
             f"({LEADER_SPEED_M_S:g} m/s), {r.laps} lap(s)"]
    lines.append("states: " + ", ".join(f"{names[s.name]} {r.time_in(s):.1f} s" for s in LaneState if r.time_in(s)))
    lines.append("transitions:")
    lines += [f"  {t:6.2f} s, {s:5.1f} m: {names[a]} -> {names[b]}" for t, s, a, b in r.transitions]
    behind = np.asarray([st == LaneState.BEHIND_LEADER.name for st in r.states])
    if behind.any():
        gaps = np.asarray(r.gaps_m)[behind]
        lines.append(f"behind the leader: gap {gaps.mean():.2f} m mean, {gaps.min():.2f}..{gaps.max():.2f} m "
                     f"(kept: {FOLLOW_GAP_M:g} m)")
    lines.append(f"contacts: boxes {r.box_contacts}, the leader {r.car_contacts}, walls {r.wall_contacts} "
                 f"(control periods)")
    return "\n".join(lines)


def plot(result: CombinedResult):
    """The follower's state, gap and speed along the lap."""
    from roar_sim.world import plotting

    fig, (ax_state, ax_gap) = plotting.subplots(nrows=2, figsize=(10, 6), sharex=True)
    order = [state.name for state in LaneState]
    t = np.asarray(result.t)
    ax_state.step(t, [order.index(s) for s in result.states], where="post")
    ax_state.set_yticks(range(len(order)), [state.value for state in LaneState], fontsize=7)
    ax_gap.plot(t, result.gaps_m, label="gap to the leader [m]")
    ax_gap.plot(t, result.speeds, label="follower's speed [m/s]")
    ax_gap.axhline(FOLLOW_GAP_M, color="k", lw=0.8, ls="--")
    ax_gap.set_xlabel("time [s]")
    ax_gap.legend(fontsize=8)
    for when, _, _, _ in result.transitions:
        ax_state.axvline(when, color="grey", lw=0.5)
    fig.suptitle(f"combined driver on {result.track.name}: the follower's states", fontsize=10)
    return fig
