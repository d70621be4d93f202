"""Tracks and worlds a car drives in, without any simulator: a closed centre line with a width
per point and the driving area between its walls (roar.tracks.track), the built-in tracks, random
tracks from a seed (random_track), tunnel courses with cones, markers and people (tunnel), and the
file formats of the F1TENTH/ROS world (track_files: centre-line and race-line CSV; occupancy_map:
map YAML + image). A name resolves to a track with get():

    get("oval")  get("random:7")  get("random:7,width=2.2,radius=1")  get("tunnel:3")
    get("my.json")  get("Spielberg_centerline.csv")  get("levine.yaml")
"""

from roar.tracks.track import Track, TrackError
from roar.tracks.names import get

__all__ = ["Track", "TrackError", "get"]
