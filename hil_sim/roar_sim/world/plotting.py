"""Shared plotting plumbing for the command-line tools: headless matplotlib, PNG arguments,
and saving with one-line errors."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable

from roar.tracks.drawing import draw_track  # noqa: F401 (the runs' plots draw tracks from here too)


def subplots(**kwargs):
    """(fig, ax) from a headless (Agg) matplotlib."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(constrained_layout=True, **kwargs)


def draw_path(fig, ax, x, y, speed) -> None:
    """The driven path coloured by speed, with equal axes in metres."""
    sc = ax.scatter(x, y, c=speed, s=6, cmap="viridis", label="driven path")
    fig.colorbar(sc, ax=ax, label="speed [m/s]")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def path_figure(track, trace):
    """The track (if any) and a trace of (t, x, y, yaw, speed) rows; returns the figure."""
    fig, ax = subplots(figsize=(8, 6))
    if track is not None:
        draw_track(ax, track)
    t, x, y, _, speed = zip(*trace)
    draw_path(fig, ax, x, y, speed)
    ax.set_title(f"{t[-1]:.1f} s simulated, top speed {max(map(abs, speed)):.2f} m/s", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    return fig


def png_problem(path: Path) -> str | None:
    """Why a plot cannot go to this path (one line), or None."""
    from roar.user_files import unwritable

    if path.suffix.lower() != ".png":
        return f"must name a .png file, got {path}"
    return unwritable(path)


def check_png_argument(parser: argparse.ArgumentParser, path: Path | None) -> None:
    """--plot names a PNG file that can be written, checked before the run."""
    problem = png_problem(path) if path is not None else None
    if problem:
        parser.error(f"--plot {problem}")


def write(draw: Callable[[], object], path: Path) -> str | None:
    """draw() returns a figure; write it to path. Returns None, or why it could not (one line)."""
    import matplotlib.pyplot as plt

    fig = draw()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=110)
    except OSError as e:
        return f"cannot write {path}: {e.strerror or e}"
    finally:
        plt.close(fig)
    return None


def save(draw: Callable[[], object], path: Path) -> bool:
    """write(), then print 'plot: PATH' or the one-line error."""
    problem = write(draw, path)
    print(f"error: {problem}" if problem else f"plot: {path}", file=sys.stderr if problem else sys.stdout)
    return problem is None
