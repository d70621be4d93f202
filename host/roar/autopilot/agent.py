"""The shape of a driving stack, in the spirit of ROAR: small modules with setup / step /
shutdown; an agent that composes perception, planning and control; a runner that owns the
car link and the setup / loop / finish cycle.

    runner = Runner(car_io, Agent(perception, planner, controller), period_s=0.02)
    runner.run(until=lambda obs: obs.t_s > 60)
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Callable, Generic, Protocol, TypeVar

In = TypeVar("In")
Out = TypeVar("Out")


@dataclass(frozen=True)
class Observation:
    """What the car reports each control period."""

    t_s: float  # [s] since the run started
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad] anticlockwise from +x
    speed: float  # [m/s] magnitude (a speedometer does not know the direction)
    yaw_rate: float | None = None  # [rad/s] the gyro's; None: the car has no gyro


@dataclass(frozen=True)
class Command:
    throttle: float  # [-1, 1]: +1 full forward, -1 full reverse (brakes first)
    steering: float  # [-1, 1]: +1 full right


NEUTRAL = Command(0.0, 0.0)


class Module(ABC, Generic[In, Out]):
    """One piece of the stack: set up once, stepped every control period, shut down once."""

    def setup(self) -> None:
        pass

    @abstractmethod
    def step(self, value: In) -> Out: ...

    def shutdown(self) -> None:
        pass


class Agent(Module[Observation, Command]):
    """perception -> planning -> control. Each stage is a Module; the planner sees what
    perception made of the observation, the controller sees both."""

    def __init__(self, perception: Module, planner: Module, controller: Module) -> None:
        self.perception, self.planner, self.controller = perception, planner, controller

    def setup(self) -> None:
        for m in (self.perception, self.planner, self.controller):
            m.setup()

    def step(self, observation: Observation) -> Command:
        seen = self.perception.step(observation)
        plan = self.planner.step(seen)
        return self.controller.step((seen, plan))

    def shutdown(self) -> None:
        for m in (self.controller, self.planner, self.perception):
            m.shutdown()


class Passthrough(Module[Observation, Observation]):
    """Perception for a car that reports its own pose (the simulator, motion capture)."""

    def step(self, value: Observation) -> Observation:
        return value


class CarIO(Protocol):
    """The runner's view of a car: read an observation, send a command, let time pass."""

    def observe(self) -> Observation: ...

    def send(self, command: Command) -> None: ...

    def wait(self, seconds: float) -> None: ...


class Runner:
    def __init__(self, car: CarIO, agent: Agent, period_s: float) -> None:
        self.car, self.agent, self.period_s = car, agent, period_s

    def run(self, until: Callable[[Observation], bool],
            on_step: Callable[[Observation, Command], None] | None = None) -> Observation:
        """setup, then observe -> step -> send every period until `until(observation)`, then
        finish: neutral to the car and shutdown, also when something raises."""
        self.agent.setup()
        try:
            while True:
                observation = self.car.observe()
                if until(observation):
                    return observation
                command = self.agent.step(observation)
                self.car.send(command)
                if on_step is not None:
                    on_step(observation, command)
                self.car.wait(self.period_s)
        finally:
            self.car.send(NEUTRAL)
            self.agent.shutdown()
