"""The ROAR Junior as `roar race` drives it: the simulated Junior serves its HTTP ports in
lockstep, and each command goes out as a user's script sends it, through the http:// transport
(smooth mixing: pure pursuit's curvature -> wheel duties -> one GET over a kept-alive loopback
connection), answered by the Junior's firmware loop before time moves on."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from roar.autopilot import Agent, Command, diff_drive_agent
from roar.transports import open_url
from roar_sim.robots.junior_limits import JUNIOR_LIMITS, JUNIOR_MODEL
from roar_sim.links.junior_http import InBackground
from roar_sim.robots.junior import JuniorSim
from roar_sim.runs.race import LockstepIO
from roar_sim.world.track import Track

MIXING = "smooth"  # DiffDriveController's commands are smooth_mix's inverse


class JuniorIO(LockstepIO):
    """The Junior: commands over HTTP; no brake sequence (with both duties at 0 it coasts)."""

    limits = JUNIOR_LIMITS

    def __init__(self, sim: JuniorSim, control_url: str) -> None:
        super().__init__(sim)
        self.transport = open_url(f"{control_url}?mixing={MIXING}")
        self.transport.open()

    @classmethod
    @contextmanager
    def serving(cls, track: Track, realtime: bool = False, gui: bool = False):
        """A JuniorIO talking to a simulated Junior that serves on free loopback ports."""
        with InBackground(track, render_workers=0, lockstep=True, realtime=realtime, gui=gui) as junior:
            io = cls(junior.server.sim, junior.urls.control_url)
            try:
                yield io
            finally:
                io.transport.close()

    def send(self, command: Command) -> None:
        self.transport.write(self.calibration.message(command.throttle, command.steering))

    def agent(self, line: np.ndarray, margin: float, lateral: str, k_dd_s: float | None = None) -> Agent:
        if lateral != "pursuit":
            raise ValueError("the Junior steers by pure pursuit only (its wheels set the curvature)")
        return diff_drive_agent(line, JUNIOR_MODEL, margin, **({} if k_dd_s is None else {"k_dd_s": k_dd_s}))
