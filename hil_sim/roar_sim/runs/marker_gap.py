"""How well the follower's camera measures the distance to the leader's ArUco marker, against the
simulator's truth: two cars placed a distance apart along a track, on straights and in bends,
the follower's frame searched for the marker (roar.vision.aruco). Where it fails is what ROAR
reported: too far (the marker too few pixels), bends (the leader out of view).

    samples = sightings(get("oval"), distances_m=[0.8, 1.5, 2.5], starts_m=[0.0, 4.0])
    print("\\n".join(table(samples)))
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roar.tracks import Track

SETTLE_S = 0.3  # [s] for the cars to settle on their wheels before the frame
BEND_CURVATURE = 0.2  # [1/m] tighter than 5 m radius between the cars: a bend
DISTANCE_BINS_M = (0.0, 1.0, 2.0, 3.0, 5.0)  # [m] of the table's rows


@dataclass(frozen=True)
class Sighting:
    true_m: float  # [m] the marker's centre from the follower's camera, over the floor
    seen_m: float | None  # [m] as the camera measured it (None: not found)
    curvature: float  # [1/m] of the centre line between the cars, the largest
    start_m: float  # [m] the leader's place along the track

    @property
    def bend(self) -> bool:
        return self.curvature >= BEND_CURVATURE

    @property
    def error_m(self) -> float | None:
        return None if self.seen_m is None else self.seen_m - self.true_m


def sightings(track: Track, distances_m, starts_m) -> list[Sighting]:
    """One frame per (start, distance): the leader start_m along the track, the follower
    distance_m (along the centre line, reference points) behind it."""
    from roar.vision.aruco import MarkerRanger
    from roar.vision.geometry import SIMULATED_CAR_CAMERA
    from roar_sim.plants.racecar import CAMERA_LINK
    from roar_sim.runs.fleet import Fleet
    from roar_sim.plants.racecar import LANE_CAMERA
    from roar_sim.world.bullet import pb
    from roar_sim.world.marker import RearMarker

    ranger = MarkerRanger(SIMULATED_CAR_CAMERA.model(*LANE_CAMERA))
    out = []
    for start in starts_m:
        for distance in distances_m:
            with Fleet(track, count=2, gap_m=distance, start_m=start) as fleet:
                lead, follow = fleet.cars
                marker = RearMarker(lead.plant)
                lead.plant.props.append(marker)
                fleet.run(SETTLE_S)
                seen = ranger.find(follow.plant.camera(*LANE_CAMERA)[0])
                camera = pb.getLinkState(follow.plant.car, CAMERA_LINK, physicsClientId=fleet.world.client)[0]
                centre = marker.pose()[0]
                true = math.hypot(centre[0] - camera[0], centre[1] - camera[1])
            out.append(Sighting(true, None if seen is None else seen.distance_m,
                                _curvature(track, start - distance, start), start))
    return out


def _curvature(track: Track, from_m: float, to_m: float) -> float:
    """[1/m] the largest curvature of the centre line between two places along it."""
    from roar.autopilot import curvature

    along = track.arc_delta(from_m, track.arc_start)  # [m] of each point past from_m
    between = (along >= 0) & (along <= track.arc_delta(from_m, to_m) % track.length_m)
    return float(curvature(track.centerline)[between].max(initial=0.0))


def table(samples: list[Sighting]) -> list[str]:
    """Rows by distance and straight / bend: found share, mean and largest |error|."""
    rows = []
    for lo, hi in zip(DISTANCE_BINS_M, DISTANCE_BINS_M[1:]):
        for bend in (False, True):
            group = [s for s in samples if lo <= s.true_m < hi and s.bend == bend]
            if not group:
                continue
            found = [s for s in group if s.error_m is not None]
            errors = np.array([abs(s.error_m) for s in found])
            shares = np.array([abs(s.error_m) / s.true_m for s in found])
            error = (f"|error| mean {errors.mean() * 100:.1f} cm ({shares.mean() * 100:.1f} %), max {errors.max() * 100:.1f} cm"
                     if found else "never found")
            found = f"found {len(found)}/{len(group)}"
            rows.append(f"{lo:g}-{hi:g} m, {'bend' if bend else 'straight':8}: {found}, {error}")
    return rows


def plot(samples: list[Sighting], run=None):
    """The camera's error against the true distance (straights and bends apart, what it missed at
    the bottom); with a platoon run by marker (roar_sim.runs.platoon), its gap by source."""
    from roar_sim.world import plotting

    fig, axes = plotting.subplots(nrows=2 if run is not None else 1, figsize=(9, 7 if run is not None else 4))
    ax = axes[0] if run is not None else axes
    for bend, colour, name in ((False, "tab:blue", "straight"), (True, "tab:orange", "bend")):
        seen = [s for s in samples if s.bend == bend and s.error_m is not None]
        lost = [s for s in samples if s.bend == bend and s.error_m is None]
        ax.scatter([s.true_m for s in seen], [s.error_m * 100 for s in seen], color=colour, label=f"{name}: found")
        ax.scatter([s.true_m for s in lost], [0.0] * len(lost), color=colour, marker="x", label=f"{name}: not found")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("true distance, camera to marker [m]")
    ax.set_ylabel("measured - true [cm]")
    ax.legend(fontsize=8)
    if run is not None:
        t = np.asarray(run.times_s)
        marker = np.array([np.nan if g is None else g for g in run.marker_gaps_m], dtype=float)
        by_marker = np.asarray([s == "marker" for s in run.sources])
        axes[1].plot(t, run.gaps_m, color="black", label="true gap along the track")
        axes[1].plot(t[:len(marker)], marker, color="tab:green", label="gap by the marker")
        axes[1].fill_between(t, 0, 1, where=~by_marker, transform=axes[1].get_xaxis_transform(), color="tab:red",
                             alpha=0.15, label="marker lost: gap from V2V")
        axes[1].set_xlabel("time [s]")
        axes[1].set_ylabel("gap [m]")
        axes[1].legend(fontsize=8)
    fig.suptitle("the leader's ArUco marker by the follower's camera", fontsize=10)
    return fig
