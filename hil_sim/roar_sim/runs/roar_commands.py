"""The `roar` commands the simulator adds, registered through the "roar.commands" entry point
group (pyproject.toml): each names the module that holds its parser() and main(argv)
(roar.cli.sdk.Command), imported only when the command runs, so `roar --help` stays quick and
the simulator's errors reach the `roar` command's one error boundary."""

from __future__ import annotations

from roar.cli.sdk import Command


def _sim_variants():
    from roar_sim.runs.sim import variants

    return variants()


race = Command("race a simulated robot with its autopilot (`roar race --help`)", "roar_sim.runs.race")
sim = Command("run a simulated robot: a race, a serial port (--serial), HTTP (--http) or the phone's UDP (--stream)",
              "roar_sim.runs.sim", variants=_sim_variants)
step_response = Command("the simulated IARRC car's speed PID answering a step, plotted (`roar step-response --help`)",
                        "roar_sim.runs.step_response")
sweep = Command("race a grid of autopilot parameters x tracks on every core; CSV table and plot (`roar sweep --help`)",
                "roar_sim.runs.sweep")
platoon = Command("two simulated cars platooning over UDP multicast (`roar platoon --help`)", "roar_sim.runs.platoon")
fit = Command("fit the simulated car to your car from a test drive: a car profile and its trim (`roar fit --help`)",
              "roar_sim.runs.fit")
limits = Command("measure a simulated robot's physical limits against its table (`roar limits --help`)",
                 "roar_sim.runs.limits")
challenge = Command("the MIT challenge in a tunnel world: the whole autonomy stack, scored (`roar challenge --help`)",
                    "roar_sim.runs.challenge")
track = Command("show a track (random:SEED, a file, a map) and write it as .json, .csv or a map (`roar track --help`)",
                "roar_sim.runs.show_track")
world = Command("show a world (tunnel:SEED: walls, cones, markers, people) and write its map (`roar world --help`)",
                "roar_sim.runs.show_track", main_name="world_main", parser_name="world_parser")
