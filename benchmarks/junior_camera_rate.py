"""The simulated Junior's camera: one client fetches /cam-lo.jpg (320x240) back to back, as a
lane follower would, while a Vehicle drives the robot at 50 Hz over the control port. Counts
frames served per second, each a whole JPEG of the stated size, none served twice (the robot is
moving, so every frame differs). Target: >= 30 frames/s. Best of ROUNDS."""

import http.client
import io
import time

from roar import Vehicle
from roar.protocol import spec
from roar_sim.links.junior_http import InBackground
from roar.tracks.track import oval

TITLE = "Junior camera frames served at 320x240 while driving"
SECONDS = 4.0  # [s] per round
ROUNDS = 2
TARGET_FPS = 30.0


def _get(host: str, port: int, path: str) -> bytes:
    conn = http.client.HTTPConnection(host, port, timeout=10)
    try:
        conn.request("GET", path)
        response = conn.getresponse()
        body = response.read()
        if response.status != 200:
            raise RuntimeError(f"{path}: {response.status} {body[:60]!r}")
        return body
    finally:
        conn.close()


def frames_per_s(host: str, port: int) -> tuple[float, int]:
    """(frames/s, repeated frames) over SECONDS."""
    frames = []
    start = time.perf_counter()
    while time.perf_counter() - start < SECONDS:
        frames.append(_get(host, port, spec.JUNIOR_ROUTE_CAMERA_LOW))
    elapsed = time.perf_counter() - start
    return len(frames) / elapsed, len(frames) - len(set(frames))


def run() -> None:
    from PIL import Image

    with InBackground(oval()) as junior:
        host, port = junior.urls.camera_url.removeprefix("http://").rsplit(":", 1)
        _get(host, int(port), spec.JUNIOR_ROUTE_CAMERA_LOW)  # the renderers are up
        url = junior.urls.vehicle_url
        with Vehicle(url + ("&" if "?" in url else "?") + "mixing=smooth", rate_hz=50) as car:
            car.drive(throttle=0.6, steering=0.4)  # a circle: every frame sees something new
            results = [frames_per_s(host, int(port)) for _ in range(ROUNDS)]
            requests = car.transport.requests
        size = Image.open(io.BytesIO(_get(host, int(port), spec.JUNIOR_ROUTE_CAMERA_LOW))).size
    fps, repeated = max(results)
    print(f"frames served:  {fps:6.1f} /s at {size[0]}x{size[1]}   (target >= {TARGET_FPS:.0f}); "
          f"repeated frames {repeated}")
    print(f"control requests meanwhile: {requests} at 50/s")
