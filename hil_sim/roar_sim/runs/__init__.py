"""Experiments on the simulated robots, each a `roar` command: races, sweeps, platoons (several
cars in one world), the IARRC car's step response, the scripted drive (`make trace`), the
robots' measured limits."""
