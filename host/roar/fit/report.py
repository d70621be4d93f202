"""The fit's report plot: the test drive's path by manoeuvre, and the model's prediction of the
manoeuvre held out of the fit against what was measured (speed and yaw rate).

    plot(record, result, "mycar.png")
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from roar.fit.identify import FitResult
from roar.fit.log import FitLog


def plot(record: FitLog, result: FitResult, path: str | Path, title: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    record = record.shifted()
    fig = plt.figure(figsize=(12, 6.5))
    grid = fig.add_gridspec(2, 2, width_ratios=(1, 1.4))
    ax = fig.add_subplot(grid[:, 0])
    phase = record.phase_at(record.pose_t)
    names = [n for _, n in record.phases]
    colours = plt.get_cmap("tab10")
    for k, name in enumerate(names):
        inside = phase == k
        if inside.any():
            ax.plot(record.x[inside], record.y[inside], ".", ms=2, color=colours(k % 10), label=name)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("the test drive, by manoeuvre")
    ax.legend(fontsize=7, markerscale=4, loc="best")
    held = result.held_out
    label = f"held out of the fit: {result.held_out_name}" if held is not None else "fitted (no manoeuvre held out)"
    shown = held if held is not None else result.fitted
    for row, (measured, model, unit, what) in enumerate(((shown.speed, shown.speed_model, "m/s", "speed"),
                                                         (shown.yaw_rate, shown.yaw_rate_model, "rad/s", "yaw rate"))):
        a = fig.add_subplot(grid[row, 1])
        a.plot(shown.t, measured, ".", ms=3, color="0.3", label="measured (from the poses)")
        a.plot(shown.t, model, "-", lw=1.2, color="tab:red", label="the fitted model")
        rms = float(np.sqrt(np.mean((measured - model) ** 2)))
        a.set_ylabel(f"{what} [{unit}]")
        a.set_title(f"{label}: {what}, error {rms:.3f} {unit} RMS", fontsize=9)
        a.legend(fontsize=7, loc="best")
        if row == 1:
            a.set_xlabel("time into the drive [s]")
    fig.suptitle(title or "roar fit", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
