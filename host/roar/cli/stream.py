"""`roar stream udp://HOST`: receive a car's camera, depth and state streams (ROAR's UDP chunked
format; the phone on the car, or `roar sim --stream`), show them, and report once a second:
frames/s per stream, reassembly latency (first chunk to whole frame), and frames lost.

In a window when there is a display; otherwise PNGs in --out (one a second, and the last).
"""

from __future__ import annotations

import asyncio
import os
import sys
import time
from pathlib import Path

import numpy as np

from roar.cli.sdk import ArgumentParser, path_option, seconds_option
from roar.errors import StreamError
from roar.protocol import spec
from roar.stream import KINDS, StreamReceiver, peer
from roar.transports import TransportError, open_url, parse_url
from roar.user_files import unusable_folder

REPORT_PERIOD_S = 1.0  # [s]


def target(url: str) -> tuple[str, bool]:
    """(host, push) of a udp:// URL, read as the udp:// transport reads it (the same rules,
    the same options: ?push=1)."""
    try:
        scheme = parse_url(url)[0]
        if scheme != "udp":
            raise StreamError(f"want udp://HOST (the car's phone, or 127.0.0.1 for `roar sim --stream`), got {url!r}")
        transport = open_url(url)  # built, not opened
    except TransportError as e:
        raise StreamError(str(e)) from None
    return transport.host, transport.push


class _Window:
    """Camera and depth side by side in a matplotlib window (or PNGs when headless)."""

    def __init__(self, out: Path | None) -> None:
        import matplotlib

        self.headless = out is not None or not os.environ.get("DISPLAY")
        if self.headless:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.plt = plt
        self.out = out or Path("out") / "stream"
        self.fig, (self.ax_rgb, self.ax_depth) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
        for ax, title in ((self.ax_rgb, "camera"), (self.ax_depth, "depth [m]")):
            ax.set_title(title)
            ax.axis("off")
        self._rgb = self._depth = None
        if not self.headless:
            plt.ion()
            plt.show()

    def show(self, rgb: np.ndarray | None, depth: np.ndarray | None, text: str) -> None:
        if rgb is not None:
            if self._rgb is None:
                self._rgb = self.ax_rgb.imshow(rgb)
            else:
                self._rgb.set_data(rgb)
        if depth is not None:
            if self._depth is None:
                self._depth = self.ax_depth.imshow(depth, cmap="viridis", vmin=0, vmax=10)
                self.fig.colorbar(self._depth, ax=self.ax_depth, shrink=0.8)
            else:
                self._depth.set_data(depth)
        self.fig.suptitle(text, fontsize=9)
        if not self.headless:
            self.plt.pause(0.001)

    def close(self) -> None:
        self.plt.close(self.fig)

    def save(self, name: str) -> Path:
        self.out.mkdir(parents=True, exist_ok=True)
        path = self.out / name
        self.fig.savefig(path, dpi=90)
        return path


async def watch(host: str, seconds: float, push: bool, out: Path | None, window: bool = True, log=None) -> int:
    """log: a roar.recorder.Recorder each frame (camera, depth, state) and each second's figures go to."""
    address, listen = peer(host)
    receivers = {}
    for kind, port in KINDS.items():
        rx = StreamReceiver(kind, host=listen, port=port if push else 0,
                            sender=None if push else (address, port), ack=not push)
        try:
            await rx.start()
        except OSError as e:
            raise StreamError(f"cannot listen for the {kind} stream: {e.strerror or e}") from None
        receivers[kind] = rx
    view = _Window(out) if window else None
    try:
        return await _watch(host, seconds, receivers, view, log)
    finally:
        if view is not None:
            view.close()  # its figure too: a program calling this again leaks none


async def _watch(host: str, seconds: float, receivers: dict, view, log) -> int:
    latest: dict = {}
    latencies: dict[str, list[float]] = {k: [] for k in KINDS}
    counts = dict.fromkeys(KINDS, 0)
    start = last_report = time.monotonic()
    saved = 0
    try:
        while seconds <= 0 or time.monotonic() - start < seconds:
            for kind, rx in receivers.items():
                frame = await rx.next_frame(0.005)
                if frame is not None:
                    latest[kind] = frame
                    counts[kind] += 1
                    latencies[kind].append(frame.received_at - frame.first_chunk_at)
                    if log is not None:
                        _record(log, kind, frame, int((time.monotonic() - start) * 1e9))
            now = time.monotonic()
            if now - last_report >= REPORT_PERIOD_S:
                line = report(receivers, counts, latencies, now - last_report, latest.get("state"))
                print(line, flush=True)
                if log is not None:
                    log.fields(STATS_TOPIC, figures(receivers, counts, latencies, now - last_report),
                               int((now - start) * 1e9), "roar.StreamStatistics")
                if view is not None and latest:
                    view.show(_image(latest, "rgb"), _image(latest, "depth"), line)
                    if view.headless:
                        view.save(f"frame_{saved:04d}.png")
                        saved += 1
                counts = dict.fromkeys(KINDS, 0)
                latencies = {k: [] for k in KINDS}
                last_report = now
    finally:
        for rx in receivers.values():
            rx.close()
    total = sum(rx.counters.delivered for rx in receivers.values())
    if total == 0:
        raise StreamError(f"no frame from udp://{host} in {seconds:g} s: is a car streaming there "
                          f"(`roar sim --stream`)?")
    if view is not None and view.headless and latest:
        view.show(_image(latest, "rgb"), _image(latest, "depth"), "last frame")
        print(f"plots: {view.save('last.png').parent}/")
    return 0


STATS_TOPIC = "/stream/statistics"
STATE_TOPIC = "/stream/state"


def _record(log, kind: str, frame, t_ns: int) -> None:
    if kind == "rgb":
        log.image(frame.image, t_ns)
    elif kind == "depth":
        log.depth(frame.image, t_ns)
    else:
        log.fields(STATE_TOPIC, frame.state, t_ns, "roar.StreamState")


def figures(receivers, counts, latencies, period_s) -> dict:
    """Per stream: frames a second, latency p50 and p99 [ms], frames lost so far."""
    out = {}
    for kind, rx in receivers.items():
        lat = sorted(latencies[kind])
        c = rx.counters
        out[kind] = {"frames_per_s": counts[kind] / period_s,
                     "latency_p50_ms": lat[len(lat) // 2] * 1000 if lat else None,
                     "latency_p99_ms": lat[min(len(lat) - 1, int(len(lat) * 0.99))] * 1000 if lat else None,
                     "lost": c.incomplete + c.malformed + c.undecodable}
    return out


def _image(latest: dict, kind: str):
    frame = latest.get(kind)
    return None if frame is None else frame.image


def report(receivers, counts, latencies, period_s, state_frame) -> str:
    parts = []
    for kind, f in figures(receivers, counts, latencies, period_s).items():
        p50 = "-" if f["latency_p50_ms"] is None else f"{f['latency_p50_ms']:.1f}"
        p99 = "-" if f["latency_p99_ms"] is None else f"{f['latency_p99_ms']:.1f}"
        parts.append(f"{kind} {f['frames_per_s']:4.1f}/s (latency p50 {p50} p99 {p99} ms, lost {f['lost']})")
    if state_frame is not None:
        s = state_frame.state
        parts.append(f"car x {s['x']:.2f} y {s['y']:.2f} m, {s['hall_effect_sensor_velocity']:.2f} m/s")
    return "; ".join(parts)


def receive(url: str, seconds: float, push: bool, out: Path | None, log: Path | None = None) -> int:
    host, url_push = target(url)
    push = push or url_push
    if not 0 <= seconds <= 86400:  # also refuses nan
        raise StreamError(f"--seconds must be 0 (until Ctrl-C) .. 86400, got {seconds:g}")
    problem = out is not None and unusable_folder(out)
    if problem:
        raise StreamError(f"--out {problem}")
    try:
        import matplotlib  # noqa: F401 (the window, or the PNGs)
        import PIL  # noqa: F401 (the camera's JPEGs)
    except ImportError as e:
        raise StreamError(f"roar stream needs {e.name}: pip install 'roar-platform[camera,vision]'") from None
    peer(host)  # a host that does not resolve is an error now, not after --seconds of silence
    print(f"receiving from udp://{host} ({'pushed to this machine' if push else 'asking with ' + repr(spec.UDP_REQUEST_PAYLOAD)}); "
          f"Ctrl-C stops", flush=True)
    if log is None:
        return asyncio.run(watch(host, seconds, push, out))
    from roar.recorder import Recorder

    with Recorder(log, {"car": url, "command": " ".join(sys.argv)}) as recorder:
        return asyncio.run(watch(host, seconds, push, out, log=recorder))



def parser() -> ArgumentParser:
    p = ArgumentParser(prog="roar stream",
                       description="Receive the camera, depth and state streams of a car's phone (ROAR's UDP "
                                   "chunked format; `roar sim --stream` for the simulated car), show them in a "
                                   "window (or PNGs without a display), and print frames/s, latency and loss "
                                   "once a second.")
    p.add_argument("url", metavar="URL", help="udp://HOST, the phone (udp://127.0.0.1 for `roar sim --stream`)")
    p.add_argument("--seconds", type=seconds_option, default=0.0, metavar="S", help="stop after this long (default: Ctrl-C)")
    p.add_argument("--push", action="store_true",
                   help="listen on ports 8001-8003 for pushed frames instead of asking for each with 'ack'")
    p.add_argument("--out", type=path_option, default=None, metavar="DIR",
                   help="write PNGs here (one a second, and the last) instead of opening a window")
    p.add_argument("--log", type=path_option, metavar="MCAP",
                   help="record every frame (camera JPEG, depth, state) and each second's figures into this MCAP file")
    return p


def main(argv: list[str]) -> int:
    args = parser().parse_args(argv)
    return receive(args.url, args.seconds, args.push, args.out, args.log)
