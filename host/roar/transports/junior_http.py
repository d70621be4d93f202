"""http:// -- a ROAR Junior (ESP32-CAM + L298N) over Wi-Fi, or the simulated one.

    http://192.168.4.1:81                the robot: control port 81, camera on the port below (80)
    http://127.0.0.1:8081                the simulated Junior (`roar sim --robot junior --http`), camera on 8080
    ?mixing=smooth                       how throttle and steering become wheel duties (default
                                         original, as the ROAR Junior client; see roar.junior)
    ?camera=PORT   ?timeout=2            the camera's port; seconds to wait for a reply

Each command the Vehicle sends becomes one GET of the control route over a kept-alive
connection; the reply (the ultrasonic distance) is the car's range in state(). The Junior stops
by itself 500 ms after the last request, so the Vehicle's 50 Hz resend keeps it driving.

Signed control (roar.transports.signing): a signing Vehicle sets `signer`, which appends "&ctr=..&mac=.."
to each query; a Junior with a key answers other queries 403 with the reason ("unsigned
SESSION", "forged SESSION", "replay COUNTER", "nokey"), which refusal() hands back as the
car's ERR line, so the signer learns the session and counter from it.
"""

from __future__ import annotations

import http.client
import math
import socket

import numpy as np

from roar.checks import printable
from roar.junior import MIXES, query_for
from roar.protocol import ParseResult, spec
from roar.telemetry import VehicleState
from roar.transports.base import LinkLost, Transport, TransportError, pop_number, pop_option, unit_command


SIGNING_REFUSALS = {str(r) for r in (ParseResult.UNSIGNED, ParseResult.FORGED, ParseResult.REPLAY, ParseResult.NOKEY)}


def host_port(text: str) -> tuple[str, int] | None:
    """("host", port 0..65535) of "HOST:PORT", or None when it is not that."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        return None
    return host, int(port)


class HttpTransport(Transport):
    scheme = "http"
    signs_itself = True  # the car takes queries: signed through signer.sign_query
    min_period_s = 0.005  # [s] one request and its reply on a good Wi-Fi link

    def __init__(self, host: str, port: int, mixing: str = "original", camera_port: int | None = None,
                 timeout_s: float = 2.0) -> None:
        self.host, self.port, self.mixing, self.timeout_s = host, port, mixing, timeout_s
        self.camera_port = camera_port if camera_port is not None else port - 1
        self._mix = MIXES[mixing]
        self._conn: http.client.HTTPConnection | None = None
        self._reused = False  # the next request goes on a connection that served one before
        self.range_m: float | None = None  # [m] the latest ultrasonic reading; inf: no echo
        self.requests = 0
        self._refusal: str | None = None  # the latest signing refusal, as the car's "ERR ..." line

    @classmethod
    def from_url(cls, target: str, options: dict[str, str]) -> HttpTransport:
        address = host_port(target.strip("/"))
        if address is None or address[1] == 0:
            raise TransportError(f"http:// needs HOST:PORT, e.g. http://192.168.4.1:81, got {target!r}")
        host, port = address
        mixing = pop_option(options, "mixing", str, "original")
        if mixing not in MIXES:
            raise TransportError(f"mixing must be one of {', '.join(MIXES)}, got {mixing!r}")
        camera = pop_option(options, "camera", int, None)
        if camera is not None and not 1 <= camera <= 65535:
            raise TransportError(f"camera must be a port 1..65535, got {camera}")
        timeout = pop_number(options, "timeout", 2.0, 0, 30, "s", low_open=True)
        return cls(host, port, mixing, camera, timeout)

    def open(self) -> None:
        self._conn = http.client.HTTPConnection(self.host, self.port, timeout=self.timeout_s)
        self._get(query_for(0.0, 0.0), TransportError)  # a Junior answers with its distance

    def refusal(self) -> str | None:
        """The car's "ERR <reason> ..." for the latest request it refused for signing, once."""
        line, self._refusal = self._refusal, None
        return line

    def _get(self, query: str, error: type[TransportError]) -> None:
        if self.signer is not None:
            query = self.signer.sign_query(query)
        conn = self._conn
        if conn is None:
            raise LinkLost(f"Junior at {self.host}:{self.port} is not connected")
        try:
            try:
                response = self._exchange(conn, query)
            except (http.client.RemoteDisconnected, ConnectionResetError, BrokenPipeError):
                if not self._reused:
                    raise
                conn.close()  # the robot closed a connection quiet for its idle time: a new one, once
                response = self._exchange(conn, query)
            body = response.read().decode("ascii", "replace").strip()
            self._reused = response.getheader("Connection", "").lower() != "close"
        except (OSError, http.client.HTTPException) as e:
            self._reused = False
            conn.close()
            reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e) or type(e).__name__
            if isinstance(e, socket.timeout):
                reason = f"no reply within {self.timeout_s:g} s"
            raise error(f"Junior at {self.host}:{self.port}: {reason}") from None
        if response.status == 403 and body.split(" ")[0] in SIGNING_REFUSALS:
            self._refusal = f"{spec.SERIAL_REPLY_ERROR} {body}"  # the car is there and says why: not a link fault
            return
        if response.status != 200:
            raise TransportError(f"Junior at {self.host}:{self.port} refused {query!r}: {response.status} "
                                 f"{printable(body)}")
        self.requests += 1
        try:
            cm = float(body)
        except ValueError:
            raise TransportError(f"{self.host}:{self.port} is not a Junior: it replied {body[:40]!r}") from None
        self.range_m = cm / 100 if cm > 0 else math.inf

    def _exchange(self, conn: http.client.HTTPConnection, query: str) -> http.client.HTTPResponse:
        self._reused = self._reused and conn.sock is not None
        conn.request("GET", "/?" + query)
        return conn.getresponse()

    def write(self, data: bytes) -> None:
        throttle, steering = unit_command(data, self.scheme)
        self._get(query_for(*self._mix(throttle, steering)), LinkLost)

    def state(self) -> VehicleState | None:
        return VehicleState(range_m=self.range_m) if self.range_m is not None else None

    def _camera_url(self, route: str) -> str:
        return f"http://{self.host}:{self.camera_port}{route}"

    def camera(self, width: int = spec.JUNIOR_CAMERA_LOW_WIDTH, height: int = spec.JUNIOR_CAMERA_LOW_HEIGHT):
        """(RGB from the camera's JPEG route, None: the ESP32-CAM gives no depth), resized to
        width x height if that is not one of the camera's sizes."""
        from roar.camera import fetch

        low = width <= spec.JUNIOR_CAMERA_LOW_WIDTH and height <= spec.JUNIOR_CAMERA_LOW_HEIGHT
        rgb = fetch(self._camera_url(spec.JUNIOR_ROUTE_CAMERA_LOW if low else spec.JUNIOR_ROUTE_CAMERA_HIGH),
                    self.timeout_s)
        if rgb.shape[:2] != (height, width):
            from PIL import Image

            rgb = np.asarray(Image.fromarray(rgb).resize((width, height)))
        return rgb, None

    def camera_stream(self):
        """The camera's MJPEG stream, frame by frame (numpy RGB arrays)."""
        from roar.camera import mjpeg_frames

        return mjpeg_frames(self._camera_url(spec.JUNIOR_ROUTE_CAMERA_STREAM), max(5.0, self.timeout_s))

    def close(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None:
            conn.close()
