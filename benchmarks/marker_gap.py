"""The leader's ArUco marker by the follower's 320x240 camera (ROAR's first platoon): the distance
it measures against the simulator's truth, by distance and straight or bend, over places all
round two tracks; where it is not found is where ROAR reported it failing (too far, tight turns).
No target in the issue: the figures are the measurement."""

import numpy as np

TITLE = "ArUco gap by camera: error by distance and bend"
TRACKS = ("oval", "random:31")  # the leader at PLACES places round each
DISTANCES_M = (0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5)  # [m] along the centre line, reference points
PLACES = 8
STRIP, STRIP_PLACES_M = "drag:30", (10.0, 20.0, 30.0)  # and long straights: a drag strip's


def run() -> None:
    try:
        import cv2  # noqa: F401
        import pybullet  # noqa: F401
    except ImportError as e:
        print(f"  skipped: {e}")
        return
    from roar.tracks import get
    from roar_sim.runs.marker_gap import sightings, table

    samples = []
    for name in TRACKS:
        track = get(name)
        samples += sightings(track, DISTANCES_M, np.linspace(4.0, track.length_m, PLACES, endpoint=False))
    samples += sightings(get(STRIP), DISTANCES_M, STRIP_PLACES_M)
    for row in table(samples):
        print(f"  {row}")
