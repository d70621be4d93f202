"""`roar web URL`: serve a page that drives and watches the car from a browser (roar.web), until
Ctrl-C or --for; neutral at the end."""

from __future__ import annotations

import time
from pathlib import Path

from roar.cli.sdk import (ArgumentParser, UserError, add_calibration_option, listen_address, number_option,
                          open_vehicle, path_option, port_option)


def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar web",
                       description="Serve a page that drives the car (on-screen joystick, keys, gamepad; a "
                                   "max-throttle limit; a stop button) and shows its camera, state and link, "
                                   "with rolling plots; record on/off, and an autopilot on the simulator. One "
                                   "page drives, others watch until they press Drive. The car goes to neutral "
                                   "when the driver's page is hidden, closed, loses its socket or is silent "
                                   "for 250 ms. Bound to 127.0.0.1 unless --host says otherwise; then a "
                                   "token is needed, printed in the URL.")
    p.add_argument("url", metavar="URL", nargs="?", default="sim://",
                   help="the car (default sim://, the simulator: sim://oval gives it a track to follow)")
    p.add_argument("--host", type=listen_address, default="127.0.0.1",
                   help="the IP address to listen on (default 127.0.0.1; 0.0.0.0: every interface, with a token)")
    p.add_argument("--port", type=port_option, default=8887, help="default 8887")
    p.add_argument("--record-dir", type=path_option, default=Path("out/web"), metavar="DIR",
                   help="where the record button writes its MCAP files (default out/web)")
    p.add_argument("--max-speed", type=number_option(0.1, 10, "m/s"), default=2.0, metavar="M/S",
                   help="full stick on a car driven by speed (the IARRC car; default 2)")
    p.add_argument("--for", dest="seconds", type=number_option(0, 86400, "s", low_open=True), default=None,
                   metavar="SECONDS", help="stop serving after this long (default: Ctrl-C)")
    add_calibration_option(p)
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
    try:
        from roar.web.server import WebServer
        import websockets  # noqa: F401  (the page's socket)
    except ImportError as e:
        raise UserError(f"roar web needs {e.name}: pip install 'roar-platform[web]'") from None
    with open_vehicle(args) as car:
        server = WebServer(car, host=args.host, port=args.port, record_dir=args.record_dir,
                           max_speed_m_s=args.max_speed)
        server.start()
        try:
            where = "" if server.loopback else " (anyone with this URL can drive: its token is the key)"
            print(f"roar web: open {server.url}{where}; Ctrl-C ends (the car goes to neutral)", flush=True)
            if server.lan_url:
                print(f"roar web: from another machine (a phone on this network): {server.lan_url}", flush=True)
            end = None if args.seconds is None else time.monotonic() + args.seconds
            while server.serving and (end is None or time.monotonic() < end):
                time.sleep(0.1)
        finally:
            server.stop()
    print(f"served {server.pages_served} page(s); {server.ignored_total()} message(s) ignored, "
          f"{sum(server.refused.values())} request(s) refused; the car was left at neutral")
    return 0
