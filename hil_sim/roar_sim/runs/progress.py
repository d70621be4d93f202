"""The progress bar of a run that counts laps, on stderr: `racing oval: ████  1.25/2 laps [00:07]`."""

from __future__ import annotations

import sys


def laps_bar(laps: int, desc: str):
    """A tqdm bar of `laps` laps (fractions shown), at most two updates a second."""
    from tqdm import tqdm

    return tqdm(total=laps, desc=desc, unit="lap", mininterval=0.5, file=sys.stderr,
                bar_format="{desc}: {bar} {n:.2f}/{total} laps [{elapsed}]")
