"""`roar send URL`: hold one command (throttle or speed, and steering) for a while, then stop, and
say what the car answered."""

from __future__ import annotations

import time

from roar.checks import printable
from roar.cli.sdk import (ArgumentParser, UserError, add_calibration_option, add_log_option, add_url,
                          open_vehicle)
from roar.protocol import ParseResult, spec

MAX_SEND_S = 3600.0  # [s]
# [s] how long to wait at the end for any reply: a classic Nano resets when its port opens and
# takes about 2 s to boot and answer
REPLY_GRACE_S = 3.0


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar send",
                       description="Send throttle and steering (each -1..1) for some seconds, then neutral; "
                                   "or, to a car with a speed controller (READY 2), speed and steering.")
    add_url(p)
    how = p.add_mutually_exclusive_group()
    how.add_argument("--throttle", type=float, default=None, help="-1 (full reverse) .. 1 (full forward); default 0")
    how.add_argument("--speed", type=float, default=None, metavar="M/S",
                     help="the speed to hold [m/s], on a car with a speed controller (e.g. sim://?robot=iarrc)")
    p.add_argument("--steering", type=float, default=0.0, help="-1 (full left) .. 1 (full right); default 0")
    p.add_argument("--for", dest="seconds", type=float, default=1.0, metavar="SECONDS",
                   help="how long to hold it (default 1 s, at most 3600)")
    add_calibration_option(p)
    add_log_option(p)
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
    if not 0 < args.seconds <= MAX_SEND_S:
        raise UserError(f"--for must be more than 0 and at most {MAX_SEND_S:g} s, got {args.seconds:g}")
    with open_vehicle(args) as car:
        if args.speed is not None:
            car.drive(speed=args.speed, steering=args.steering)
            what = f"{args.speed:g} m/s, steering {args.steering:g}"
        else:
            car.drive(args.throttle or 0.0, args.steering)
            what = "({},{})".format(*car.pulses_us())
        print(f"sending {what} to {args.url} for {args.seconds:g} s", flush=True)
        time.sleep(args.seconds)
        car.stop()
        silent = car.transport.replies and car.wait_for(timeout_s=REPLY_GRACE_S, since=0.0) is None
        link_ok = car.connected
        lines = [r for r in car.replies if not r.startswith(spec.TELEMETRY_REPLY)]  # telemetry is summed up below
        replies = ", ".join(printable(r) for r in lines[-5:]) or ("none" if car.transport.replies
                                                                 else "none (this link has none)")
        state = car.state()
        if state.battery_v is not None:
            replies += f"; battery {state.battery_v:.2f} V, driven {state.distance_m:.2f} m, mode {state.mode}"
    if silent:
        raise UserError(f"no reply from a car on {args.url} (no READY, ARMED or FAILSAFE line in "
                        f"{args.seconds + REPLY_GRACE_S:g} s): is a ROAR car running there?")
    if car.errors:
        raise UserError(refused(car, args.url))
    stopped = "zero speed" if args.speed is not None else "neutral"
    if link_ok:
        print(f"done, {stopped} sent; link ok; car replies: {replies}")
    else:  # nothing could be sent at the end: say so, and what stops the car
        print(f"link down: {printable(car.link_error, 200)}; {stopped} could not be sent (the car's failsafe stops "
              f"it when commands stop coming); car replies: {replies}")
    return 0 if link_ok else 1


def refused(car, url: str) -> str:
    """What the car's ERR replies mean for the user, in one line."""
    from roar.signing import default_path

    count, (reason, most) = car.errors, car.refusals.most_common(1)[0]
    if reason == str(ParseResult.UNSIGNED) and car.signer is None:
        return (f"{url} refused every message ({count}): it has a signing key and this host has none; put yours in it "
                f"with `roar key set {url}` (over USB), or copy the car's key file to {default_path()}")
    if reason in (str(ParseResult.FORGED), str(ParseResult.UNSIGNED)):
        return (f"{url} refused {most} of {count} messages as {reason}: this host's key is not the car's "
                f"(`roar key show {url}` compares them)")
    return f"{url} refused {count} message(s), {most} of them {reason or 'with no reason'}: {car.replies[-1]}"
