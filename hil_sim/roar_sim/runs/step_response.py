"""`roar step-response`: the simulated IARRC car's speed controller answering a speed step. The
transmitter's mode switch goes to autonomous, the host streams setpoints at 50 Hz as a vision
computer would ([0,1500] first, then the step), and the car's true speed is sampled every 5 ms.

Targets (the IARRC seed car: 2 m/s in 0.7 s): 10-90 % rise <= 0.7 s, overshoot <= 10 %,
steady-state error <= 2 % (mean of the last second).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

from roar.cli.sdk import ArgumentParser, ExitStatus, path_option, run_command
from roar_sim import StepError
from roar.protocol import spec
from roar.protocol.control import encode_setpoint
from roar_sim.core.lockstep import CONTROL_PERIOD_S

RISE_TARGET_S = 0.7  # [s] 10-90 %
OVERSHOOT_TARGET = 0.10  # fraction of the step
STEADY_ERROR_TARGET = 0.02  # fraction of the step
ARM_S = 0.1  # [s] mode switch at off while the receiver locks
SETTLE_S = 0.3  # [s] armed at zero speed before the step
SAMPLE_S = 0.005  # [s]


@dataclass(frozen=True)
class StepResponse:
    speed_m_s: float  # [m/s] the step
    times_s: list[float]  # [s] from the step
    speeds_m_s: list[float]  # [m/s] the car's true speed
    estimates_m_s: list[float]  # [m/s] the controller's encoder estimate
    throttle_us: list[int]  # [us] the ESC pulse
    rise_s: float | None  # [s] 10-90 %, None when 90 % was never reached
    overshoot: float  # fraction of the step above it
    steady_error: float  # fraction of the step, mean of the last second

    def meets_targets(self) -> bool:
        return (self.rise_s is not None and self.rise_s <= RISE_TARGET_S and self.overshoot <= OVERSHOOT_TARGET
                and self.steady_error <= STEADY_ERROR_TARGET)

    def summary(self) -> str:
        rise = f"{self.rise_s:.2f} s" if self.rise_s is not None else "never reached 90 %"
        return (f"0 -> {self.speed_m_s:.2f} m/s: rise (10-90 %) {rise} [target <= {RISE_TARGET_S} s], "
                f"overshoot {self.overshoot:.1%} [<= {OVERSHOOT_TARGET:.0%}], "
                f"steady error {self.steady_error:.1%} [<= {STEADY_ERROR_TARGET:.0%}]")


def figures(times, speeds, step, last_s: float = 1.0) -> tuple[float | None, float, float]:
    """(rise [s], overshoot, steady error) of a sampled response to a step of `step`."""
    t10 = next((t for t, v in zip(times, speeds) if v >= 0.1 * step), None)
    t90 = next((t for t, v in zip(times, speeds) if v >= 0.9 * step), None)
    rise = t90 - t10 if t10 is not None and t90 is not None else None
    overshoot = max(0.0, (max(speeds) - step) / step)
    tail = [v for t, v in zip(times, speeds) if t >= times[-1] - last_s]
    return rise, overshoot, abs(sum(tail) / len(tail) - step) / step


def measure(speed_m_s: float = 2.0, seconds: float = 3.0, gains: tuple[int, int, int, int] | None = None,
            steering_us: int = spec.CONTROL_NEUTRAL_US) -> StepResponse:
    from roar_sim.robots.iarrc import IarrcCar

    with IarrcCar(operator=False) as car:  # the switches are this run's
        if gains is not None:
            car.board.set_pid(*gains)
        car.run(ARM_S)  # the receiver locks with the mode switch at off: the car disarmed
        car.transmitter.mode = "autonomous"
        t = 0.0
        while t < SETTLE_S:
            car.host(encode_setpoint(0, steering_us))
            car.run(CONTROL_PERIOD_S)
            t += CONTROL_PERIOD_S
        target = encode_setpoint(round(speed_m_s * 1000), steering_us)
        times, speeds, estimates, throttle = [], [], [], []
        steps_per_send = round(CONTROL_PERIOD_S / SAMPLE_S)
        for n in range(round(seconds / SAMPLE_S)):
            if n % steps_per_send == 0:
                car.host(target)
            car.run(SAMPLE_S)
            times.append((n + 1) * SAMPLE_S)
            speeds.append(car.state().speed)
            status = car.status()
            estimates.append(status["speed_mm_s"] / 1000)
            throttle.append(car.board.pulses[0])
        if status["mode"] != "autonomous":
            raise StepError(f"the car left autonomous mode ({status['mode']}, failsafe {status['failsafe']})")
    rise, overshoot, steady = figures(times, speeds, speed_m_s)
    return StepResponse(speed_m_s, times, speeds, estimates, throttle, rise, overshoot, steady)


def figure(r: StepResponse):
    from roar_sim.world.plotting import subplots

    fig, (ax, ax2) = subplots(nrows=2, figsize=(8, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax.step([-SAMPLE_S, 0, r.times_s[-1]], [0, r.speed_m_s, r.speed_m_s], where="post", color="black", lw=1,
            label="setpoint")
    ax.axhspan(r.speed_m_s * (1 - STEADY_ERROR_TARGET), r.speed_m_s * (1 + STEADY_ERROR_TARGET), color="green",
               alpha=0.15, label=f"±{STEADY_ERROR_TARGET:.0%}")
    ax.axhline(r.speed_m_s * (1 + OVERSHOOT_TARGET), color="red", lw=0.8, ls=":", label="overshoot limit")
    ax.plot(r.times_s, r.speeds_m_s, label="speed (true)")
    ax.plot(r.times_s, r.estimates_m_s, lw=0.8, alpha=0.7, label="speed (encoder estimate)")
    ax.set_ylabel("speed [m/s]")
    ax.set_title(r.summary().replace(", overshoot", "\novershoot"), fontsize=9)
    ax.legend(loc="lower right", fontsize=8)
    ax2.plot(r.times_s, r.throttle_us, color="tab:purple")
    ax2.set_ylabel("ESC [us]")
    ax2.set_xlabel("time since the step [s]")
    return fig


def gains_argument(text: str) -> tuple[int, int, int, int]:
    parts = text.split(",")
    try:
        values = tuple(int(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 4 or not all(0 <= v <= spec.TELEMETRY_MAX_GAIN_PM for v in values):
        raise argparse.ArgumentTypeError(f"want KP,KI,KD,FF: four integers 0..{spec.TELEMETRY_MAX_GAIN_PM}, "
                                         f"got {text!r}")
    return values


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(prog="roar step-response", description=__doc__)
    p.add_argument("--speed", type=float, default=2.0, help="the step [m/s] (default 2.0)")
    p.add_argument("--seconds", type=float, default=3.0, help="how long after the step (default 3)")
    p.add_argument("--gains", type=gains_argument, metavar="KP,KI,KD,FF",
                   help="PID gains in per mille, as the PID telemetry command takes them (default: the core's)")
    p.add_argument("--plot", type=path_option, default=Path("out/step_response.png"), metavar="PNG",
                   help="where to draw the response beside the setpoint (default out/step_response.png)")
    return p


def main(argv: list[str] | None = None) -> int:
    p = parser()
    args = p.parse_args(argv)
    limit = spec.SETPOINT_MAX_SPEED_MM_S / 1000
    if not 0 < args.speed <= limit:
        p.error(f"--speed must be in (0, {limit}] m/s, got {args.speed}")
    if not 1.0 <= args.seconds <= 60.0:
        p.error(f"--seconds must be 1..60 (the steady error is the mean of the last second), got {args.seconds}")
    from roar_sim.world.plotting import check_png_argument, save

    check_png_argument(p, args.plot)
    r = measure(args.speed, args.seconds, args.gains)
    print(r.summary())
    print("targets met" if r.meets_targets() else "targets NOT met")
    if not save(lambda: figure(r), args.plot):
        return ExitStatus.ERROR
    return ExitStatus.OK if r.meets_targets() else ExitStatus.TARGETS_MISSED


if __name__ == "__main__":
    sys.exit(run_command("roar step-response", main))
