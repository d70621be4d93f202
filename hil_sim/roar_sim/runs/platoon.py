"""Two cars platooning in one world, as ROAR's did: each car's own firmware core and serial link
(roar_sim.runs.fleet), their states shared over real UDP multicast (roar.v2v, loopback by default), the
leader lapping at a steady speed, the follower keeping gap_m behind it along the track.

    run = platoon(get("oval"), gap_m=1.5, cruise_m_s=1.0, seconds=15)
    run.gaps_m, run.follower_speeds       # per control period, measured by the simulator
    platoon(..., silence_from_s=8)        # the leader stops talking at 8 s: the follower stops
"""

from __future__ import annotations

import sys
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field

import numpy as np

from roar.tracks.names import FORMS
from roar.autopilot.platoon import cruise_agent, follow_agent
from roar.cli.sdk import ArgumentParser, ExitStatus, UserError, path_option, run_command
from roar.protocol import spec
from roar.v2v import V2VLink
from roar_sim.core.lockstep import CONTROL_PERIOD_S as PERIOD_S
from roar_sim.links.netns import VethPair, call_in
from roar_sim.robots.esc import MODEL
from roar_sim.runs.fleet import Fleet
from roar_sim.runs.progress import bar
from roar.tracks.track import Track

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
    marker_gaps_m: list[float | None] = field(default_factory=list)  # [m] by the follower's camera (None: not seen)
    sources: list[str] = field(default_factory=list)  # where the follower's gap came from: "marker" or "v2v"


@contextmanager
def _links(port: int, interface: str, across: VethPair | None):
    """The leader's and the follower's V2V links: both on `interface`, or on the two ends of `across`."""
    with V2VLink(LEADER, port=port, interface=across.here_ip if across else interface) as lead:
        if across is None:
            follow = V2VLink(FOLLOWER, port=port, interface=interface)
        else:
            follow = call_in(across.ns, lambda: V2VLink(FOLLOWER, port=port, interface=across.there_ip))
        with follow:
            yield lead, follow


def platoon(track: Track, gap_m: float = 1.5, cruise_m_s: float = 1.0, seconds: float = 15.0,
            silence_from_s: float | None = None, port: int = spec.V2V_PORT, interface: str = "127.0.0.1",
            across: VethPair | None = None, progress: bool = False, by_marker: bool = False) -> PlatoonRun:
    """across: the leader's V2V socket on this side of a veth link (roar_sim.links.netns), the
    follower's in the namespace at its other end, so the messages cross a kernel link.
    progress: a bar of simulated seconds on stderr. by_marker: the leader carries an ArUco
    marker on its rear and the follower keeps the gap its camera measures to it, falling back to
    the V2V positions' gap whenever the marker is not found (too far, out of view in a bend)."""
    run = PlatoonRun(gap_m)
    line = track.centerline
    with _links(port, interface, across) as (lead_link, follow_link), Fleet(track, count=2, gap_m=gap_m) as fleet:
        lead, follow = fleet.cars
        measured = None
        if by_marker:
            from roar.vision.aruco import MarkerRanger
            from roar.vision.geometry import SIMULATED_CAR_CAMERA
            from roar_sim.plants.racecar import LANE_CAMERA
            from roar_sim.world.marker import RearMarker

            lead.plant.props.append(RearMarker(lead.plant))
            ranger = MarkerRanger(SIMULATED_CAR_CAMERA.model(*LANE_CAMERA))

            def measured() -> float | None:
                gap = ranger.gap_m(follow.plant.camera(*LANE_CAMERA)[0])
                run.marker_gaps_m.append(gap)
                return gap
        leader = cruise_agent(line, MODEL, PERIOD_S, cruise_m_s)
        follower = follow_agent(line, MODEL, PERIOD_S, gap_m, leader=lambda: follow_link.latest.get(LEADER),
                                measured=measured)
        for car in fleet.cars:  # arm: each car boots latched until it hears neutral
            car.drive(0.0, 0.0)
        fleet.run(PERIOD_S)
        leader.setup()
        follower.setup()
        hint = {}
        steps = round(seconds / PERIOD_S)
        for step in bar(range(steps), desc="platoon", unit="step", show=progress, leave=False):
            t = fleet.time_s
            observed = {"lead": lead.observe(), "follow": follow.observe()}
            o = observed["lead"]
            if step % V2V_EVERY == 0 and (silence_from_s is None or t < silence_from_s):
                lead_link.send(o.x, o.y, o.yaw, o.speed)
            follow_link.receive(t)
            for car, agent, name in ((lead, leader, "lead"), (follow, follower, "follow")):
                car.send(agent.step(observed[name]))
            fleet.run(PERIOD_S)
            along, speed = {}, {}
            for name, car in (("lead", lead), ("follow", follow)):
                s = car.state()
                hint[name], along[name], _ = track.project((s.x, s.y), hint.get(name), heading=s.yaw)
                speed[name] = s.speed
            run.times_s.append(fleet.time_s)
            run.gaps_m.append((along["lead"] - along["follow"]) % track.length_m)
            run.leader_speeds.append(speed["lead"])
            run.follower_speeds.append(speed["follow"])
            run.contacts += fleet.touching(0, 1)
            run.sources.append(follower.planner.source)
            if by_marker and len(run.marker_gaps_m) < len(run.times_s):  # the follower did not look (silent leader)
                run.marker_gaps_m.append(None)
    return run


SETTLE_S = 6.0  # [s] after the start the follower has closed up to its gap: steady state from here
GAP_TOLERANCE_M = 0.2  # [m] held at steady speed
STOPPED_M_S = 0.1  # [m/s] the follower counts as stopped below this


@dataclass(frozen=True)
class Summary:
    gap_range_m: tuple[float, float, float] | None  # [m] mean, min, max at steady state (None: no steady state)
    held: bool  # the gap stayed within GAP_TOLERANCE_M at steady state
    stopped_at_s: float | None  # [s] when the follower stopped after the leader went silent


def summarise(run: PlatoonRun, silence_from_s: float | None) -> Summary:
    import numpy as np

    t, gaps = np.array(run.times_s), np.array(run.gaps_m)
    steady = (t > SETTLE_S) & (t < (silence_from_s if silence_from_s is not None else np.inf))
    g = gaps[steady]
    gap_range = (float(g.mean()), float(g.min()), float(g.max())) if g.size else None
    held = bool(np.all(np.abs(g - run.gap_m) <= GAP_TOLERANCE_M))
    stopped_at = None
    if silence_from_s is not None:
        after = (t > silence_from_s) & (np.abs(np.array(run.follower_speeds)) < STOPPED_M_S)
        stopped_at = float(t[after][0]) if after.any() else None
    return Summary(gap_range, held, stopped_at)


def report(run: PlatoonRun, summary: Summary, track: Track, cruise_m_s: float, how: str,
           silence_from_s: float | None) -> str:
    lines = [f"platoon on {track.name}: leader cruising at {cruise_m_s:.2f} m/s, follower asked to keep "
             f"{run.gap_m:.2f} m behind (V2V {how})"]
    if summary.gap_range_m:
        mean, low, high = summary.gap_range_m
        lines.append(f"gap from {SETTLE_S:g} s: mean {mean:.2f} m, {low:.2f}..{high:.2f} m "
                     f"({'held' if summary.held else 'NOT held'} within +-{GAP_TOLERANCE_M:g} m)")
    if silence_from_s is not None:
        stopped = ("did NOT stop" if summary.stopped_at_s is None else
                   f"stopped (below {STOPPED_M_S:g} m/s) at {summary.stopped_at_s:.2f} s")
        lines.append(f"leader silent from {silence_from_s:g} s: the follower {stopped} "
                     f"(V2V timeout {spec.V2V_TIMEOUT_US / 1e6:g} s)")
    if run.marker_gaps_m:
        import numpy as np

        by_marker = np.asarray([src == "marker" for src in run.sources])
        seen = np.array([np.nan if g is None else g for g in run.marker_gaps_m], dtype=float)
        error = np.abs(seen - np.asarray(run.gaps_m))
        switches = int(np.count_nonzero(np.diff(by_marker.astype(int)) < 0))
        lines.append(f"gap by the leader's ArUco marker {by_marker.mean() * 100:.0f} % of the time (its error against "
                     f"the gap along the track: mean {np.nanmean(error) * 100:.1f} cm, max {np.nanmax(error) * 100:.1f} cm); "
                     f"marker lost {switches} times, the gap then from V2V")
    lines.append(f"contacts between the cars: {run.contacts} control periods")
    return "\n".join(lines)


def plot(run: PlatoonRun, silence_from_s: float | None):
    from roar_sim.world import plotting

    fig, (ax_gap, ax_v) = plotting.subplots(nrows=2, figsize=(9, 6.5), sharex=True)
    ax_gap.plot(run.times_s, run.gaps_m, color="tab:blue", label="gap along the track")
    ax_gap.axhspan(run.gap_m - GAP_TOLERANCE_M, run.gap_m + GAP_TOLERANCE_M, color="tab:green", alpha=0.15,
                   label=f"asked +-{GAP_TOLERANCE_M:g} m")
    ax_gap.set_ylabel("gap [m]")
    ax_v.plot(run.times_s, run.leader_speeds, color="black", label="leader")
    ax_v.plot(run.times_s, run.follower_speeds, color="tab:orange", label="follower")
    ax_v.set_ylabel("speed [m/s]")
    ax_v.set_xlabel("time [s]")
    for ax in (ax_gap, ax_v):
        if silence_from_s is not None:
            ax.axvline(silence_from_s, color="firebrick", ls="--", label="leader goes silent")
        ax.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"platoon: follower keeping {run.gap_m:g} m behind over V2V", fontsize=10)
    return fig


def _marker_plot(track: Track, run: PlatoonRun):
    """The camera's error by distance (straights, bends) on this track, and the run's gap by source."""
    from roar_sim.runs.marker_gap import plot as marker_plot, sightings

    places = np.linspace(0.0, track.length_m, 4, endpoint=False)
    return marker_plot(sightings(track, [0.8, 1.2, 1.6, 2.0, 2.5, 3.0], places), run)


def parser():

    p = ArgumentParser(
        prog="roar platoon",
        description="Two simulated cars platoon as ROAR's did: each its own firmware core, one world; the "
                    "leader cruises, the follower keeps a gap behind it from the leader's position over UDP "
                    "multicast (V2V), and stops by itself when the messages stop. It falls short (exit status 2) "
                    "when the cars touched, the gap was not held, or the follower did not stop.")
    p.add_argument("--track", default="oval", help=f"{FORMS} (default: oval)")
    p.add_argument("--gap", type=float, default=1.5, metavar="M", help="gap to keep [m] (default 1.5)")
    p.add_argument("--speed", type=float, default=1.0, metavar="M/S", help="the leader's speed [m/s] (default 1)")
    p.add_argument("--seconds", type=float, default=15.0, help="simulated time [s] (default 15)")
    p.add_argument("--silence-at", type=float, metavar="S",
                   help="the leader stops sending at S seconds: the follower must stop by itself")
    p.add_argument("--netns", action="store_true",
                   help="the follower's V2V socket in another network namespace, over a real veth link (needs "
                        "root); default: loopback")
    p.add_argument("--port", type=int, metavar="PORT",
                   help=f"V2V UDP port (default: a free one; ROAR's cars used {spec.V2V_PORT})")
    p.add_argument("--by-marker", action="store_true",
                   help="ROAR's first platoon: the follower keeps the gap its camera measures to an ArUco marker on "
                        "the leader's rear, and the V2V positions' gap while the marker is lost")
    p.add_argument("--plot", type=path_option, metavar="PNG",
                   help="write gap and speeds over time to this PNG (with --by-marker: the camera's error by distance "
                        "and bend, and the gap by source)")
    return p


def main(argv: list[str] | None = None) -> int:
    from roar.v2v import free_port
    from roar_sim.links.netns import veth_pair
    from roar_sim.world import plotting
    from roar.tracks import get

    p = parser()
    args = p.parse_args(argv)
    if not 0.5 <= args.gap <= 5.0:
        p.error("--gap must be 0.5..5 m")
    if not 0.2 <= args.speed <= 2.5:
        p.error("--speed must be 0.2..2.5 m/s")
    if not 1.0 <= args.seconds <= 600.0:
        p.error("--seconds must be 1..600")
    if args.silence_at is not None and not 0 < args.silence_at < args.seconds:
        p.error("--silence-at must fall within the run (0 < S < --seconds)")
    if args.port is not None and not 1024 <= args.port <= 65535:
        p.error("--port must be 1024..65535")
    plotting.check_png_argument(p, args.plot)
    port = args.port or free_port()
    track = get(args.track)
    try:
        with veth_pair() if args.netns else nullcontext() as link:
            how = (f"over a veth link {link.here_ip} -> {link.there_ip} into namespace {link.ns}" if link
                   else "over loopback") + f", group {spec.V2V_GROUP} port {port}"
            run = platoon(track, args.gap, args.speed, args.seconds, args.silence_at, port=port, across=link,
                          progress=True, by_marker=args.by_marker)
    except OSError as e:
        raise UserError(f"V2V port {port}: {e.strerror or e}") from None
    summary = summarise(run, args.silence_at)
    print(report(run, summary, track, args.speed, how, args.silence_at))
    if args.plot and not plotting.save(lambda: _marker_plot(track, run) if args.by_marker else plot(run, args.silence_at),
                                       args.plot):
        return ExitStatus.ERROR
    failed = run.contacts or not summary.held or (args.silence_at is not None and summary.stopped_at_s is None)
    return ExitStatus.SHORT if failed else ExitStatus.OK


if __name__ == "__main__":
    sys.exit(run_command("roar platoon", main))
