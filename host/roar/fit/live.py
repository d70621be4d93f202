"""The test drive on a car at the end of a URL, in real time: pulses sent at 50 Hz by a Vehicle,
poses read from a pose source, both on this computer's clock, recorded as they happen.

    with Vehicle("serial:///dev/ttyUSB0") as car, Poses.open("udp://192.168.1.20") as poses:
        record = drive_car(car, poses, Area(4, 6), recorder=Recorder("run.mcap"))

A pose source is anything a Vehicle's URL reaches whose state has a position and heading: the
phone on the car (udp://, ROAR's own setup), the simulator (sim://), or the car's own link when
it reports one. Its timestamps are its own clock's: they are put on this computer's clock by the
smallest delay seen over the drive (as NTP does), so a source's transit time is no part of the
delay the fit finds.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from roar.errors import FitError
from roar.fit.drive import Area, Command, TestDrive, recent_speed
from roar.fit.log import PHASE_TOPIC, POSE_TOPIC, PULSE_TOPIC, FitLog
from roar.protocol import spec

PERIOD_S = spec.TIMING_HOST_SEND_PERIOD_US / 1e6  # [s] one command per period, as a Vehicle re-sends
FIRST_POSE_S = 3.0  # [s] a source that gives no pose in this long is none
SPEED_POSES = 50  # the latest poses the driver's speed is measured over (recent_speed takes 0.1 s of them)


class Poses:
    """The latest pose of a source: read() -> (source time [s], x, y, yaw) or None, new ones kept."""

    def __init__(self, read_state: Callable, name: str, close: Callable[[], None] | None = None) -> None:
        self._read_state, self.name, self._close = read_state, name, close
        self.samples: list[tuple[float, float, float, float, float]] = []  # (received, source t, x, y, yaw)
        self._offset = float("inf")  # [s] the smallest delay seen so far

    @classmethod
    def open(cls, url: str) -> Poses:
        """The poses of a URL's state (udp://PHONE, sim://): a link opened for reading only."""
        from roar.transports import open_url

        link = open_url(url)
        link.open()
        return cls(link.state, url, link.close)

    @classmethod
    def of_vehicle(cls, car) -> Poses:
        return cls(car.state, car.url)

    def poll(self) -> bool:
        """Take the source's pose if it is new; True when it was."""
        state = self._read_state()
        if state is None or None in (state.time_s, state.x_m, state.y_m, state.yaw_rad):
            return False
        if self.samples and state.time_s <= self.samples[-1][1]:
            return False
        received = time.monotonic()
        self.samples.append((received, state.time_s, state.x_m, state.y_m, state.yaw_rad))
        self._offset = min(self._offset, received - state.time_s)
        return True

    def wait_first(self, timeout_s: float = FIRST_POSE_S) -> None:
        """FitError (one line) when the source gives no pose within timeout_s."""
        end = time.monotonic() + timeout_s
        while not self.poll():
            if time.monotonic() > end:
                raise FitError(f"{self.name} gave no pose (position and heading) in {timeout_s:g} s: a fit measures "
                               f"the car by its pose: put the phone on the car (--pose udp://PHONE, ROAR's app) or "
                               f"drive it through the phone (udp://PHONE)")
            time.sleep(0.005)

    def offset(self) -> float:
        """[s] add to a source time for this computer's clock: the smallest delay seen."""
        return self._offset

    def close(self) -> None:
        if self._close is not None:
            self._close()


def drive_car(car, poses: Poses, area: Area, wheelbase_m: float, recorder=None, stop: threading.Event | None = None,
              on_phase: Callable[[str, float], None] | None = None) -> tuple[FitLog, str]:
    """(the record, why the drive ended early or "") of the test drive on `car` (a Vehicle), in real
    time; neutral at the end however it ends. stop: set to end it (a key pressed); on_phase(name,
    seconds into the drive) as each manoeuvre begins."""
    plan = TestDrive(area, wheelbase_m)
    poses.wait_first()
    pulses, phases = [], []
    start = next_tick = time.monotonic()
    previous = None
    try:
        while stop is None or not stop.is_set():
            poses.poll()
            now = time.monotonic()
            offset = poses.offset()
            _, t_source, x, y, yaw = poses.samples[-1]
            recent = [sample[1:] for sample in poses.samples[-SPEED_POSES:]]
            command: Command | None = plan.step(now, (x, y, yaw), t_source + offset, recent_speed(recent))
            if command is None:
                break
            car.send_pulses(command.throttle_us, command.steering_us)
            pulses.append((now, command.throttle_us, command.steering_us))
            if recorder is not None:
                recorder.fields(PULSE_TOPIC, {"throttle_us": command.throttle_us, "steering_us": command.steering_us},
                                int(now * 1e9), "roar.fit.Pulses")
            if command.phase != previous:
                previous = command.phase
                phases.append((now, command.phase))
                if recorder is not None:
                    recorder.fields(PHASE_TOPIC, {"name": command.phase}, int(now * 1e9), "roar.fit.Phase")
                if on_phase is not None:
                    on_phase(command.phase, now - start)
            next_tick += PERIOD_S
            while (wait := next_tick - time.monotonic()) > 0:  # poll the poses while waiting
                poses.poll()
                time.sleep(min(wait, 0.002))
        else:
            plan.stopped = plan.stopped or "stopped by a key"
    finally:  # however it ended (Ctrl-C too): neutral, and the poses on the record
        car.send_pulses(spec.CONTROL_NEUTRAL_US, spec.CONTROL_NEUTRAL_US)
        offset = poses.offset()  # (known only now: the smallest delay over the whole drive)
        rows = [(t + offset, x, y, yaw) for _, t, x, y, yaw in poses.samples if t + offset >= start]
        if recorder is not None:
            for t, x, y, yaw in rows:
                recorder.fields(POSE_TOPIC, {"x": x, "y": y, "yaw": yaw, "source": poses.name}, int(t * 1e9),
                                "roar.fit.Pose")
    return FitLog.from_arrays(pulses, rows, phases, poses.name), plan.stopped

