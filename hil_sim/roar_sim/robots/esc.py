"""Software-in-the-loop harness: the board loop every car runs (CarBoard::poll of the C++ core,
host build) drives the emulated ESC and servo, which drive the PyBullet car. Host code talks to
it with the same bytes it would send a real car.

Lockstep: simulated time advances only in run(); with realtime=True run() also sleeps so that
simulated time keeps pace with the wall clock (or `speedup` times faster).

    firmware loop   1 kHz   CarBoard::poll on the board's 32-bit microsecond counter
    output frames   50 Hz   each frame carries the pulses written before it starts; the ESC
                            and the servo take them at the frame start
    physics         200 Hz  PyBullet steps
"""

from __future__ import annotations

from dataclasses import dataclass, field

from roar.protocol import spec
from roar_sim.plants.esc_servo import EscMode, HobbyEsc, SteeringServo
from roar_sim.core.car import CarBoard, CarConfig, CarOutputs
from roar_sim.clock.lockstep import Lockstep
from roar_sim.plants.racecar import CarState, Plant, SimError  # noqa: F401 (SimError: for callers)
from roar_sim.world.track import Track

LOOP_US = 1_000  # [us] firmware main-loop period
PHYSICS_US = 5_000  # [us] physics step
FRAME_US = spec.TIMING_SERVO_FRAME_US  # [us]


@dataclass
class SimConfig:
    firmware: CarConfig = field(default_factory=CarConfig)
    esc: HobbyEsc = field(default_factory=HobbyEsc)
    servo: SteeringServo = field(default_factory=SteeringServo)
    realtime: bool = False
    speedup: float = 1.0  # simulated seconds per wall second when realtime
    gui: bool = False


class SimCar(Lockstep):
    """A simulated car: write() control bytes, run() time, read() the car's reply lines."""

    def __init__(self, track: Track | None = None, config: SimConfig | None = None, world=None,
                 pose: tuple[float, float, float] | None = None) -> None:
        """world (and pose): one car more in a world another steps (roar_sim.runs.fleet)."""
        self.config = config or SimConfig()
        self.track = track
        self.board = CarBoard(self.config.firmware, loop_us=LOOP_US, frame_us=FRAME_US)
        self.esc, self.servo = self.config.esc, self.config.servo
        self.plant = Plant(track, dt_s=PHYSICS_US / 1e6, gui=self.config.gui, world=world, pose=pose)
        self.t_us = 0
        self._frames = self.board.frames
        self._replies: list[str] = []
        self._partial = b""
        self._esc_out = self.esc.pulse(self.board.wire[0])
        self.board.begin()

    # --- what the host sees ------------------------------------------------------------------

    def write(self, data: bytes) -> None:
        """Bytes arriving on the car's serial port now."""
        self.board.serial_in(data)

    def read(self) -> list[str]:
        """Reply lines the car printed since the last read."""
        lines, self._replies = self._replies, []
        return lines

    def rc_transmitter(self, pulses: tuple[int, int] | None) -> None:
        """(throttle, steering) pulses from an RC receiver from now on at 50 Hz; None = switched off."""
        self.board.rc(pulses)

    @property
    def outputs(self) -> CarOutputs:
        """What the firmware decided in its latest loop iteration."""
        return self.board.outputs

    def state(self) -> CarState:
        return self.plant.state()

    @property
    def throttle_out_us(self) -> int:
        """[us] the throttle pulse on the wire now."""
        return self.board.wire[0]

    # --- time --------------------------------------------------------------------------------

    def _advance(self, end_us: int) -> None:
        """Run the firmware up to the next physics step or end_us, whichever comes first; a
        physics period's step follows the loop iteration at its start (where frames start)."""
        t = self.t_us
        self.firmware(loops_until(t, end_us))
        if t % PHYSICS_US == 0:
            self.actuate()
            self.plant.step()

    def firmware(self, loops: int) -> None:
        """`loops` iterations of the board loop; the ESC and servo take a frame that started."""
        self.board.run(loops)
        self.t_us += loops * LOOP_US
        if self.board.frames != self._frames:  # an output frame started: the ESC and servo take it
            self._frames = self.board.frames
            throttle_us, steering_us = self.board.wire
            self._esc_out = self.esc.pulse(throttle_us)
            self.servo.pulse(steering_us)
        out = self.board.serial_out()
        if out:
            *lines, self._partial = (self._partial + out).split(b"\n")
            self._replies += [line.decode("ascii", "replace") for line in lines]

    def actuate(self) -> None:
        """The ESC's and servo's outputs onto the car, for the physics step to come."""
        esc = self._esc_out
        self.plant.apply(esc.drive, esc.brake, self.servo.advance(PHYSICS_US / 1e6))

    @property
    def esc_mode(self) -> EscMode:
        return self.esc.mode


def loops_until(t_us: int, end_us: int) -> int:
    """Board-loop iterations from t_us to the next physics step or end_us, whichever is first."""
    period_end = (t_us // PHYSICS_US + 1) * PHYSICS_US
    return max(1, (min(period_end, end_us) - t_us) // LOOP_US)
