"""Two cars platooning in one world, as ROAR's did: each car's own firmware core and serial link
(roar_sim.fleet), their states shared over real UDP multicast (roar.v2v, loopback by default), the
leader lapping at a steady speed, the follower keeping gap_m behind it along the track.

    run = platoon(get("oval"), gap_m=1.5, cruise_m_s=1.0, seconds=15)
    run.gaps_m, run.follower_speeds       # per control period, measured by the simulator
    platoon(..., silence_from_s=8)        # the leader stops talking at 8 s: the follower stops
"""

from __future__ import annotations

from dataclasses import dataclass, field

from roar.autopilot.agent import Observation
from roar.autopilot.platoon import cruise_agent, follow_agent
from roar.calibration import Calibration
from roar.protocol import spec
from roar.v2v import V2VLink
from roar_sim.car_limits import SIMULATED_CAR
from roar_sim.fleet import Fleet
from roar_sim.track import Track

PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s] each car's control period
V2V_EVERY = round(spec.V2V_PERIOD_US / spec.TIMING_HOST_SEND_PERIOD_US)  # control periods per V2V message
LEADER, FOLLOWER = 1, 2  # car ids on the V2V group


@dataclass
class PlatoonRun:
    gap_m: float  # [m] asked for
    times_s: list[float] = field(default_factory=list)
    gaps_m: list[float] = field(default_factory=list)  # [m] along the centre line, leader's rear axle ahead
    leader_speeds: list[float] = field(default_factory=list)  # [m/s]
    follower_speeds: list[float] = field(default_factory=list)  # [m/s]
    contacts: int = 0  # control periods with the cars touching


def platoon(track: Track, gap_m: float = 1.5, cruise_m_s: float = 1.0, seconds: float = 15.0,
            silence_from_s: float | None = None, port: int = spec.V2V_PORT, interface: str = "127.0.0.1") -> PlatoonRun:
    run = PlatoonRun(gap_m)
    line, calibration = track.centerline, Calibration()
    with Fleet(track, count=2, gap_m=gap_m) as fleet, \
            V2VLink(LEADER, port=port, interface=interface) as lead_link, \
            V2VLink(FOLLOWER, port=port, interface=interface) as follow_link:
        lead, follow = fleet.cars
        leader = cruise_agent(line, SIMULATED_CAR, PERIOD_S, cruise_m_s)
        follower = follow_agent(line, SIMULATED_CAR, PERIOD_S, gap_m, leader=lambda: follow_link.latest.get(LEADER))
        for car in fleet.cars:  # arm: each car boots latched until it hears neutral
            car.write(calibration.message(0.0, 0.0))
        fleet.run(PERIOD_S)
        leader.setup()
        follower.setup()
        hint = {}
        for step in range(round(seconds / PERIOD_S)):
            t = fleet.time_s
            observed = {}
            for name, car in (("lead", lead), ("follow", follow)):
                s = car.state()
                observed[name] = Observation(t, s.x, s.y, s.yaw, abs(s.speed), s.yaw_rate)
            o = observed["lead"]
            if step % V2V_EVERY == 0 and (silence_from_s is None or t < silence_from_s):
                lead_link.send(o.x, o.y, o.yaw, o.speed)
            follow_link.receive(t)
            for car, agent, name in ((lead, leader, "lead"), (follow, follower, "follow")):
                command = agent.step(observed[name])
                car.write(calibration.message(command.throttle, command.steering))
            fleet.run(PERIOD_S)
            along, speed = {}, {}
            for name, car in (("lead", lead), ("follow", follow)):
                s = car.state()
                hint[name], along[name], _ = track.project((s.x, s.y), hint.get(name))
                speed[name] = s.speed
            run.times_s.append(fleet.time_s)
            run.gaps_m.append((along["lead"] - along["follow"]) % track.length_m)
            run.leader_speeds.append(speed["lead"])
            run.follower_speeds.append(speed["follow"])
            run.contacts += fleet.touching(0, 1)
    return run
