"""Shared plotting plumbing for the command-line tools: headless matplotlib, PNG arguments,
and saving with one-line errors."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable


def subplots(**kwargs):
    """(fig, ax) from a headless (Agg) matplotlib."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(constrained_layout=True, **kwargs)


def check_png_argument(parser: argparse.ArgumentParser, path: Path | None) -> None:
    if path is not None and path.suffix.lower() != ".png":
        parser.error(f"--plot must name a .png file, got {path}")


def save(draw: Callable[[], object], path: Path) -> bool:
    """draw() returns a figure; write it to path. Prints 'plot: PATH' or a one-line error."""
    import matplotlib.pyplot as plt

    fig = draw()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=110)
    except OSError as e:
        print(f"error: cannot write {path}: {e.strerror}", file=sys.stderr)
        return False
    finally:
        plt.close(fig)
    print(f"plot: {path}")
    return True
