"""Camera frames from a robot's HTTP camera routes (the ROAR Junior's ESP32-CAM, or the
simulated one) as numpy RGB arrays, decoded with Pillow (pip install 'roar-platform[camera]').

    fetch("http://192.168.4.1/cam-lo.jpg")          # one frame, HxWx3 uint8
    for frame in mjpeg_frames("http://192.168.4.1/cam.mjpeg"):
        ...                                          # every whole frame of the stream

A frame is delivered only when its image decodes whole: a truncated JPEG, a part of the stream
that is not an image, or garbage between parts is skipped (counted in MjpegStream.skipped),
never handed on half-drawn.
"""

from __future__ import annotations

import http.client
import io
import re
from collections.abc import Iterator
from urllib.parse import urlsplit

import numpy as np

from roar.checks import timeout
from roar.errors import CameraError

MAX_FRAME_BYTES = 4 * 1024 * 1024  # [bytes] a part larger than this is not a camera frame
MAX_HEADER_BYTES = 8 * 1024  # [bytes]
MAX_CAMERA_WAIT_S = 60.0  # [s] the longest a camera request may wait


def _pillow():
    try:
        from PIL import Image, UnidentifiedImageError
    except ImportError:
        raise CameraError("camera frames need Pillow: pip install 'roar-platform[camera]'") from None
    return Image, UnidentifiedImageError


def decode_image(data: bytes) -> np.ndarray | None:
    """An HxWx3 uint8 RGB array, or None when the bytes are not a whole image (truncated,
    garbage, empty)."""
    Image, Unidentified = _pillow()
    try:
        with Image.open(io.BytesIO(data)) as image:
            image.load()  # decodes everything: a truncated file raises here
            return np.asarray(image.convert("RGB"))
    except (Unidentified, OSError, ValueError, SyntaxError):
        return None


def encode_jpeg(rgb: np.ndarray, quality: int = 80) -> bytes:
    """An HxWx3 uint8 RGB array as JPEG bytes."""
    Image, _ = _pillow()
    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb)).save(out, format="JPEG", quality=quality)
    return out.getvalue()


def _connect(url: str, timeout_s: float) -> tuple[http.client.HTTPConnection, str]:
    parts = urlsplit(url)
    if parts.scheme != "http" or not parts.hostname:
        raise CameraError(f"not an http:// camera URL: {url!r}")
    path = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
    return http.client.HTTPConnection(parts.hostname, parts.port or 80, timeout=timeout_s), path


def fetch(url: str, timeout_s: float = 2.0, redirects: int = 3) -> np.ndarray:
    """One frame from a still-image route (following redirects, as /cam.jpg does)."""
    conn, path = _connect(url, timeout("timeout_s", timeout_s, MAX_CAMERA_WAIT_S))
    try:
        conn.request("GET", path)
        response = conn.getresponse()
        body = response.read(MAX_FRAME_BYTES + 1)
        location = response.getheader("Location")
    except (OSError, http.client.HTTPException) as e:
        raise CameraError(f"camera {url}: {e.strerror if isinstance(e, OSError) and e.strerror else e}") from None
    finally:
        conn.close()
    if response.status in (301, 302, 303, 307, 308) and location and redirects > 0:
        parts = urlsplit(url)
        return fetch(location if "://" in location else f"http://{parts.netloc}{location}", timeout_s, redirects - 1)
    if response.status != 200:
        raise CameraError(f"camera {url}: HTTP {response.status}")
    frame = decode_image(body)
    if frame is None:
        raise CameraError(f"camera {url}: the reply is not a whole image ({len(body)} bytes)")
    return frame


class MjpegStream:
    """Frames of a multipart/x-mixed-replace stream (the ESP32-CAM's /cam.mjpeg), as numpy RGB
    arrays. A part whose Content-Length bytes decode whole is handed on as soon as they are in;
    otherwise parts are found by the boundary the stream announces, not trusted by their length:
    a truncated or garbage part is skipped and the next boundary found."""

    def __init__(self, url: str, timeout_s: float = 5.0) -> None:
        self.url = url
        self.skipped = 0  # parts that were not whole images
        conn, path = _connect(url, timeout("timeout_s", timeout_s, MAX_CAMERA_WAIT_S))
        try:
            conn.request("GET", path)
            self._response = conn.getresponse()
        except (OSError, http.client.HTTPException) as e:
            conn.close()
            raise CameraError(f"camera stream {url}: {e}") from None
        self._conn = conn
        kind = self._response.getheader("Content-Type", "")
        match = re.search(r'boundary="?([^";]+)"?', kind)
        if self._response.status != 200 or not kind.startswith("multipart/") or not match:
            conn.close()
            raise CameraError(f"camera stream {url}: not an MJPEG stream (HTTP {self._response.status}, {kind!r})")
        self._boundary = b"--" + match.group(1).encode()

    def __iter__(self) -> Iterator[np.ndarray]:
        buffer = b""
        while True:
            start = buffer.find(self._boundary)
            whole = self._by_length(buffer, start) if start >= 0 else None
            if whole is not None:  # the part's announced length holds a whole image: no need to wait
                frame, buffer = whole  # for the next boundary, one frame period later
                yield frame
                continue
            end = buffer.find(self._boundary, start + 1) if start >= 0 else -1
            if start >= 0 and end > start:
                part, buffer = buffer[start + len(self._boundary):end], buffer[end:]
                _, sep, body = part.partition(b"\r\n\r\n")
                frame = decode_image(body.rstrip(b"\r\n")) if sep else None
                if frame is None:
                    self.skipped += 1
                else:
                    yield frame
                continue
            if len(buffer) > MAX_FRAME_BYTES + MAX_HEADER_BYTES:  # no boundary in sight: drop what we have
                self.skipped += 1
                buffer = buffer[-len(self._boundary):]
            try:
                chunk = self._response.read1(65536)
            except (OSError, http.client.HTTPException) as e:
                raise CameraError(f"camera stream {self.url}: {e}") from None
            if not chunk:
                return
            buffer += chunk

    def _by_length(self, buffer: bytes, start: int) -> tuple[np.ndarray, bytes] | None:
        """(frame, the rest of buffer) when the part at `start` has a Content-Length, all of its
        bytes are in, and they decode whole; None otherwise (the boundary then decides)."""
        head_end = buffer.find(b"\r\n\r\n", start)
        if head_end < 0:
            return None
        length = re.search(rb"(?im)^content-length:\s*(\d{1,9})\s*$", buffer[start:head_end])
        body_start = head_end + 4
        if not length or len(buffer) < body_start + int(length.group(1)):
            return None
        body_end = body_start + int(length.group(1))
        frame = decode_image(buffer[body_start:body_end])
        return None if frame is None else (frame, buffer[body_end:])

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> MjpegStream:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def mjpeg_frames(url: str, timeout_s: float = 5.0) -> Iterator[np.ndarray]:
    """Every whole frame of an MJPEG stream, until it ends."""
    with MjpegStream(url, timeout("timeout_s", timeout_s, MAX_CAMERA_WAIT_S)) as stream:
        yield from stream
