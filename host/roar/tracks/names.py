"""What a track's name may be, wherever one is taken (`roar race --track`, `sim://?track=`, the
Gym environment, `roar sweep`, `roar track`): a built-in track, `random:SEED[,...]`,
`circuit:SEED[,...]` (the shape of a real 1:10 circuit), `tunnel:SEED[,...]`, `drag:LENGTH[,...]` (the IARRC drag race's strip), or a file: .json (the project's), .csv (an F1TENTH/TUM centre line) or
.yaml (an F1TENTH/ROS map)."""

from __future__ import annotations

import re
from pathlib import Path

from roar.checks import printable, shown
from roar.tracks.track import BUILTIN, Track, TrackError

FORMS = "oval, figure-eight, course, random:SEED, circuit:SEED, tunnel:SEED, drag:LENGTH, or a .json, .csv or .yaml file"


MAX_SEED_RANGE = 1000  # seeds one range may name


def split_names(text: str) -> list[str]:
    """Track names from a comma-separated list, each once: `oval,random:3,width=2.2,tunnel:1` is
    oval, random:3,width=2.2 and tunnel:1 (a key=value part belongs to the name before it), and a
    seed range `random:1-16` (or `tunnel:1-10,width=2.2`) is each of its seeds, options and all."""
    names: list[str] = []
    for part in (p.strip() for p in text.split(",")):
        if "=" in part and names and ":" in names[-1]:
            names[-1] += "," + part
        elif part:
            names.append(part)
    return list(dict.fromkeys(n for name in names for n in _seeds(name)))


def _seeds(name: str) -> list[str]:
    """`kind:A-B[,options]` as kind:A .. kind:B, each with the options; any other name as it is."""
    match = re.fullmatch(r"(random|circuit|tunnel):(\d{1,9})-(\d{1,9})(,.*)?", name)
    if not match:
        return [name]
    kind, first, last, options = match.group(1), int(match.group(2)), int(match.group(3)), match.group(4) or ""
    if not first <= last < first + MAX_SEED_RANGE:
        raise TrackError(f"{name}: a seed range is A-B with A <= B, at most {MAX_SEED_RANGE} seeds")
    return [f"{kind}:{seed}{options}" for seed in range(first, last + 1)]


def get(name_or_path: str) -> Track:
    """The track a name or file names; TrackError (one line) for anything else."""
    if not isinstance(name_or_path, str):
        raise TrackError(f"a track is a name or a file's path, got {shown(name_or_path)}")
    name = name_or_path.strip()
    if not name:
        raise TrackError(f"the track name is empty: use {FORMS}")
    if name in BUILTIN:
        return BUILTIN[name]()
    if name.startswith("random:"):
        from roar.tracks import random_track

        return random_track.generate(random_track.parse(name))
    if name.startswith("circuit:"):
        from roar.tracks import circuit_track

        return circuit_track.generate(circuit_track.parse(name))
    if name.startswith("tunnel:"):
        from roar.tracks import tunnel

        return tunnel.generate(tunnel.parse(name))
    if name.startswith("drag:"):
        from roar.tracks import drag_strip

        return drag_strip.generate(drag_strip.parse(name), name)
    suffix = Path(name).suffix.lower()
    if suffix == ".json":
        from roar.tracks.track_files import load_json

        return load_json(name)
    if suffix == ".csv":
        from roar.tracks.track_files import load_centreline_csv

        return load_centreline_csv(name)
    if suffix in (".yaml", ".yml"):
        from roar.tracks.occupancy_map import load_map_track

        return load_map_track(name)
    if Path(name).exists():
        raise TrackError(f"{printable(name)}: a track file ends in .json, .csv (centre line) or .yaml (map)")
    raise TrackError(f"unknown track {printable(name)!r}: use {FORMS}")


def map_of(name: str | Path, resolution_m: float = 0.05):
    """The map (roar.tracks.OccupancyMap) a name stands for: a map YAML as its own grid; anything
    else get() takes (a track name, a .json or .csv) drawn by track_map."""
    from roar.tracks.occupancy_map import load_map, track_map

    if str(name).lower().endswith((".yaml", ".yml")):
        return load_map(name)
    return track_map(get(str(name)), resolution_m)
