"""The simulated Junior's ESP32-CAM: frames rendered beside the simulation, as a camera sensor
captures them while the last one is being sent.

While a size and format is being asked for, a capture loop starts a render every
render time / workers on the next idle renderer process (each has its own copy of the world, the
robot placed where the simulated one is when the capture starts), so frames come out evenly
spaced at up to `workers` times the rate of one renderer. A request gets the newest frame it has
not yet been given that was captured at most MAX_AGE_S ago, or waits for the next one; capture
stops IDLE_S after the last request, so an idle camera costs nothing.

    camera = Camera(track, lambda: sim.pose)
    seq, jpeg = await camera.frame((320, 240), "JPEG", after=previous_seq)
"""

from __future__ import annotations

import asyncio
import io
import multiprocessing
import signal
from dataclasses import dataclass
from typing import Callable

from roar_sim import CameraOff
from roar.tracks.track import Track

RENDER_WORKERS = 2  # renderer processes
JPEG_QUALITY = 80  # as the robot's camera is set up
IDLE_S = 0.5  # [s] capture stops this long after the last request
MAX_AGE_S = 0.1  # [s] an older frame is never served
MIN_INTERVAL_S = 1 / 60  # [s] between captures: at most 60 frames/s, like the sensor's best mode
FIRST_RENDER_S = 0.04  # [s] render-time estimate before the first render is timed

Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]  # position, quaternion
Key = tuple[tuple[int, int], str]  # (width, height), "JPEG" | "BMP"


def encode_image(rgb, fmt: str) -> bytes:
    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(rgb).save(out, fmt, **({"quality": JPEG_QUALITY} if fmt == "JPEG" else {}))
    return out.getvalue()


def _render_worker(track: Track | None, conn) -> None:
    """A renderer process: its own world, the robot placed as asked, one image per request. It
    ignores Ctrl-C (a terminal sends it to the whole group: the server decides when renderers
    end) and ends when told to or when the server is gone (its pipe closed)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from roar_sim.plants.junior import JuniorPlant

    plant = JuniorPlant(track)
    try:
        while (request := conn.recv()) is not None:
            (position, orientation), (width, height), fmt = request
            plant.place(position, orientation)
            conn.send(encode_image(plant.camera(width, height)[0], fmt))
    except (EOFError, OSError):
        pass
    finally:
        plant.close()


def _call(pipe, request) -> bytes:
    pipe.send(request)
    return pipe.recv()


@dataclass
class Frame:
    seq: int  # counts up per size and format
    captured: float  # [s] loop time the capture started
    image: bytes


class Stream:
    """One size and format: its newest frame and its capture loop."""

    def __init__(self) -> None:
        self.latest: Frame | None = None
        self.seq = 0
        self.wanted = 0.0  # [s] loop time of the latest request
        self.capturing: asyncio.Task | None = None
        self.changed = asyncio.Condition()


class Camera:
    def __init__(self, track: Track | None, pose: Callable[[], Pose], workers: int = RENDER_WORKERS) -> None:
        self._pose = pose
        ctx = multiprocessing.get_context("spawn")  # a fresh interpreter: PyBullet clients do not fork
        self._pipes, self._processes = [], []
        for _ in range(workers):
            ours, theirs = ctx.Pipe()
            process = ctx.Process(target=_render_worker, args=(track, theirs), daemon=True)
            process.start()
            self._pipes.append(ours)
            self._processes.append(process)
        self._idle: asyncio.Queue | None = None
        self._streams: dict[Key, Stream] = {}
        self.render_s = FIRST_RENDER_S  # [s] recent render time, smoothed

    @property
    def workers(self) -> int:
        return len(self._pipes)

    async def frame(self, size: tuple[int, int], fmt: str, after: int = 0) -> tuple[int, bytes]:
        """(seq, image): the newest frame of this size and format numbered above `after`,
        captured at most MAX_AGE_S before the call."""
        loop = asyncio.get_running_loop()
        stream = self._streams.setdefault((size, fmt), Stream())
        stream.wanted = loop.time()
        since = stream.wanted - MAX_AGE_S
        if stream.capturing is None or stream.capturing.done():
            stream.capturing = asyncio.create_task(self._capture(stream, (size, fmt)))

        def fresh() -> bool:
            f = stream.latest
            return f is not None and f.seq > after and f.captured >= since

        async with stream.changed:
            await stream.changed.wait_for(lambda: fresh() or not self.workers)
            if not fresh():
                raise CameraOff("camera off: no renderer is running")
            return stream.latest.seq, stream.latest.image

    async def _capture(self, stream: Stream, key: Key) -> None:
        loop = asyncio.get_running_loop()
        if self._idle is None:
            self._idle = asyncio.Queue()
            for pipe in self._pipes:
                self._idle.put_nowait(pipe)
        renders: set[asyncio.Task] = set()
        try:
            while loop.time() - stream.wanted < IDLE_S and self.workers:
                pipe = await self._idle.get()
                task = asyncio.create_task(self._render(stream, key, pipe))
                renders.add(task)
                task.add_done_callback(renders.discard)
                await asyncio.sleep(max(MIN_INTERVAL_S, self.render_s / self.workers))
        finally:
            await asyncio.gather(*renders, return_exceptions=True)

    async def _render(self, stream: Stream, key: Key, pipe) -> None:
        loop = asyncio.get_running_loop()
        started = loop.time()
        stream.seq += 1
        seq = stream.seq
        try:
            image = await loop.run_in_executor(None, _call, pipe, (self._pose(), *key))
        except (OSError, EOFError):  # the renderer died: the camera goes on with the others
            self._pipes.remove(pipe)
            async with stream.changed:
                stream.changed.notify_all()
            return
        self._idle.put_nowait(pipe)
        self.render_s = 0.8 * self.render_s + 0.2 * (loop.time() - started)
        async with stream.changed:
            if stream.latest is None or seq > stream.latest.seq:
                stream.latest = Frame(seq, started, image)
                stream.changed.notify_all()

    async def stop(self) -> None:
        """End capture (on the loop that captured)."""
        tasks = [s.capturing for s in self._streams.values() if s.capturing is not None]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    def close(self) -> None:
        for pipe in self._pipes:
            try:
                pipe.send(None)
            except OSError:
                pass
        for process in self._processes:
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
