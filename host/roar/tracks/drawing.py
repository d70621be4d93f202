"""A track drawn on a matplotlib axis: walls black, the centre line dashed grey, closed loops. The
plots of runs (the simulator's) and of recordings (roar replay --plot) draw it alike."""

from __future__ import annotations

import numpy as np


def draw_track(ax, track) -> None:
    """Walls (black) and centre line (dashed grey) of a track, closed loops."""
    for wall in track.walls:
        closed = np.vstack([wall, wall[:1]])
        ax.plot(closed[:, 0], closed[:, 1], color="black", lw=1.5)
    cl = np.vstack([track.centerline, track.centerline[:1]])
    ax.plot(cl[:, 0], cl[:, 1], color="grey", lw=0.8, ls="--", label="centre line")
