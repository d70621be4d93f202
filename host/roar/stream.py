"""Receiving ROAR's UDP chunked stream (protocol/PROTOCOL.md section 5): camera (RGB JPEG +
intrinsics), depth (float32 map + intrinsics) and vehicle state (CSV), each on its own port, as
a phone on the car (or the simulator, `roar sim --stream`) sends them.

    async with StreamReceiver("rgb", port=8001, sender=("192.168.1.20", 8001), ack=True) as rx:
        async for frame in rx:               # Frame: .image (HxWx3 uint8), .intrinsics, .frame_id
            ...

A frame is delivered only when every one of its chunks arrived exactly once (a duplicate is
dropped if it is the same bytes, and spoils the frame if it is not), each of the right length,
and the frame is newer than the last one delivered: never a frame with a missing, duplicated,
stale or truncated chunk. The last chunk may have any length, so its own end is checked by the
payload's framing (whole()): a JPEG ends with its end-of-image marker, a depth map has exactly
2 cx x 2 cy values, a state line ends with a line end. Reassembly goes by the frame id the header's ZZZ carries; against a
sender that leaves ZZZ at 000 (ROAR's phone) use frame_ids=False, which keeps one frame in
flight, as ROAR's pull mode does. Datagrams that are not chunks are counted and dropped.
"""

from __future__ import annotations

import asyncio
import ipaddress
import socket
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roar.checks import number, timeout
from roar.errors import UnknownHost
from roar.protocol import spec
from roar_wire import stream as wire

KINDS = {"rgb": spec.UDP_PORT_RGB, "depth": spec.UDP_PORT_DEPTH, "state": spec.UDP_PORT_VEHICLE_STATE}
FRAME_TIMEOUT_S = spec.UDP_FRAME_TIMEOUT_US / 1e6  # [s]
MAX_PENDING_FRAMES = 4  # frames being reassembled at once; the oldest gives way
MAX_FRAME_WAIT_S = 60.0  # [s] the longest a frame may take to arrive whole
QUEUE_FRAMES = 2  # [frames] delivered but not yet taken; older ones give way to newer (a live stream)
RECEIVE_BUFFER_BYTES = 4 * 1024 * 1024  # [bytes] asked of the socket: a 640x480 depth map is 34 datagrams at once


@dataclass
class Counters:
    datagrams: int = 0
    delivered: int = 0
    garbage: int = 0  # not a chunk header
    oversize: int = 0  # longer than a datagram may be
    truncated: int = 0  # a chunk of the wrong length
    duplicates: int = 0  # the same chunk again, same bytes: dropped
    conflicts: int = 0  # a chunk that disagrees with its frame: the frame is dropped
    stale: int = 0  # a chunk of a frame at or before the last one delivered
    incomplete: int = 0  # frames dropped unfinished (timeout, or overtaken)
    malformed: int = 0  # frames whose payload is cut short by its own framing (a truncated last chunk)
    undecodable: int = 0  # whole frames whose payload did not decode (not JPEG, wrong size, a number not finite)
    overtaken: int = 0  # frames nobody took before newer ones filled the queue


@dataclass
class _Partial:
    last: int
    first_at: float
    chunks: dict[int, bytes] = field(default_factory=dict)


class Reassembler:
    """Chunks in, whole payloads out, without I/O (the endpoint below feeds it; tests too)."""

    def __init__(self, frame_ids: bool = True, timeout_s: float = FRAME_TIMEOUT_S,
                 max_pending: int = MAX_PENDING_FRAMES, whole=None) -> None:
        timeout_s = number("timeout_s", timeout_s, 0, MAX_FRAME_WAIT_S, "s", low_open=True)
        max_pending = int(number("max_pending", max_pending, 1, 1_000_000))
        self.frame_ids, self.timeout_s, self.max_pending = frame_ids, timeout_s, max_pending
        self.whole = whole  # payload -> bool: complete by its own framing (None: not checked)
        self.counters = Counters()
        self._pending: dict[int, _Partial] = {}
        self._last_delivered: int | None = None

    def feed(self, datagram: bytes, now: float) -> tuple[int, bytes, float] | None:
        """(frame id, payload, when its first chunk arrived) when this datagram completed a
        frame, else None."""
        c = self.counters
        c.datagrams += 1
        if len(datagram) > spec.UDP_MAX_DATAGRAM_BYTES:
            c.oversize += 1
            return None
        head = wire.parse_header(datagram)
        if head is None:
            c.garbage += 1
            return None
        index, last, frame_id = head
        data = bytes(datagram[wire.HEADER_BYTES:])
        if not wire.chunk_length_ok(index, last, len(data)):
            c.truncated += 1
            return None
        if not self.frame_ids:
            frame_id = 0
        elif self._last_delivered is not None and not wire.newer(frame_id, self._last_delivered):
            c.stale += 1
            return None
        part = self._pending.get(frame_id)
        if part is None:
            self._make_room(now)
            part = self._pending[frame_id] = _Partial(last, now)
        elif part.last != last:  # two frames under one id: neither can be trusted
            c.conflicts += 1
            del self._pending[frame_id]
            return None
        seen = part.chunks.get(index)
        if seen is not None:
            if seen == data:
                c.duplicates += 1
            else:
                c.conflicts += 1
                del self._pending[frame_id]
            return None
        part.chunks[index] = data
        if len(part.chunks) <= part.last:
            return None
        del self._pending[frame_id]
        payload = b"".join(part.chunks[i] for i in range(part.last + 1))
        if self.whole is not None and not self.whole(payload):
            c.malformed += 1
            return None
        if self.frame_ids:
            self._last_delivered = frame_id
            for old in [k for k in self._pending if not wire.newer(k, frame_id)]:  # overtaken
                del self._pending[old]
                c.incomplete += 1
        c.delivered += 1
        return frame_id, payload, part.first_at

    def expire(self, now: float) -> int:
        """Drop frames not complete timeout_s after their first chunk; returns how many."""
        old = [k for k, p in self._pending.items() if now - p.first_at > self.timeout_s]
        for k in old:
            del self._pending[k]
        self.counters.incomplete += len(old)
        return len(old)

    def _make_room(self, now: float) -> None:
        self.expire(now)
        while len(self._pending) >= self.max_pending:
            oldest = min(self._pending, key=lambda k: self._pending[k].first_at)
            del self._pending[oldest]
            self.counters.incomplete += 1


JPEG_END = b"\xff\xd9"  # end-of-image marker; entropy-coded data never holds it


def peer(host: str) -> tuple[str, str]:
    """(host's IPv4 address, the address to listen on for what it sends: loopback for a peer on
    this machine, every interface otherwise); UnknownHost, at once, if it does not resolve."""
    try:
        address = socket.getaddrinfo(host, None, socket.AF_INET, socket.SOCK_DGRAM)[0][4][0]
    except (OSError, UnicodeError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e) or type(e).__name__
        raise UnknownHost(f"cannot find host {host!r}: {reason}") from None
    return address, "127.0.0.1" if ipaddress.ip_address(address).is_loopback else "0.0.0.0"


def depth_shape(cx: float, cy: float) -> tuple[int, int]:
    """(height, width) of a depth map whose principal point is at its centre."""
    return round(2 * cy), round(2 * cx)


def whole(kind: str, payload: bytes, strict: bool = True) -> bool:
    """Whether a reassembled payload is complete by its own framing. A state line ends with a
    line end (strict=False, for ROAR's phone, whose lines may not: it is 21 numbers)."""
    if kind == "state":
        return payload.endswith(b"\n") if strict else wire.parse_state(payload) is not None
    if len(payload) < wire.INTRINSICS_BYTES:
        return False
    if kind == "rgb":
        return payload.endswith(JPEG_END)
    try:
        _, _, cx, cy = wire.intrinsics(payload)
    except ValueError:  # not positive finite numbers: never a whole frame
        return False
    height, width = depth_shape(cx, cy)
    return len(payload) - wire.INTRINSICS_BYTES == 4 * height * width


@dataclass(frozen=True)
class Frame:
    kind: str  # rgb, depth or state
    frame_id: int
    received_at: float  # time.monotonic() when its last chunk arrived
    first_chunk_at: float  # time.monotonic() when its first chunk arrived
    payload: bytes  # as sent
    image: np.ndarray | None = None  # rgb: HxWx3 uint8; depth: HxW float32 [m]
    intrinsics: tuple[float, float, float, float] | None = None  # fx, fy, cx, cy [pixels]
    state: dict[str, float] | None = None  # state: the CSV's fields


def decode(kind: str, frame_id: int, payload: bytes, first_at: float, at: float) -> Frame | None:
    """The Frame of a payload, or None when it does not decode (not JPEG, wrong size, ...)."""
    if kind == "state":
        state = wire.parse_state(payload)
        return None if state is None else Frame(kind, frame_id, at, first_at, payload, state=state)
    try:
        fx, fy, cx, cy = wire.intrinsics(payload)
    except ValueError:
        return None
    body = payload[wire.INTRINSICS_BYTES:]
    if kind == "rgb":
        from roar.camera import decode_image

        image = decode_image(body)
    else:  # depth: float32 row-major, 2 cy rows of 2 cx (the principal point at the centre)
        height, width = depth_shape(cx, cy)
        image = None
        if height > 0 and width > 0 and len(body) == 4 * height * width:
            image = np.frombuffer(body, dtype="<f4").reshape(height, width)
    if image is None:
        return None
    return Frame(kind, frame_id, at, first_at, payload, image=image, intrinsics=(fx, fy, cx, cy))


class StreamReceiver:
    """One stream (rgb, depth or state) on a UDP port, as an async iterator of Frames.

    ack=True asks `sender` for each frame with "ack" (ROAR's pull mode: one request per frame,
    another after FRAME_TIMEOUT_S without one); ack=False takes what the sender pushes.
    decode=False yields Frames with the payload only (no JPEG decoding)."""

    def __init__(self, kind: str = "rgb", host: str = "127.0.0.1", port: int | None = None,
                 sender: tuple[str, int] | None = None, ack: bool = False, frame_ids: bool = True,
                 decode: bool = True, queue_frames: int = QUEUE_FRAMES) -> None:
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        if ack and sender is None:
            raise ValueError("ack=True needs the sender's (host, port) to ask")
        self.kind, self.host, self.port = kind, host, KINDS[kind] if port is None else port
        self.sender, self.ack, self.decode = sender, ack, decode
        self.reassembler = Reassembler(frame_ids=frame_ids, whole=lambda p: whole(kind, p, strict=frame_ids))
        self._queue: asyncio.Queue[Frame] = asyncio.Queue(queue_frames)
        self._transport: asyncio.DatagramTransport | None = None
        self._ticker: asyncio.Task | None = None
        self._asked_at = 0.0
        self.address: tuple[str, int] | None = None  # where it listens (port 0: the one it got)

    @property
    def counters(self) -> Counters:
        return self.reassembler.counters

    async def start(self) -> StreamReceiver:
        loop = asyncio.get_running_loop()
        self._transport, _ = await loop.create_datagram_endpoint(lambda: _Endpoint(self),
                                                                 local_addr=(self.host, self.port))
        self.address = self._transport.get_extra_info("sockname")[:2]
        sock = self._transport.get_extra_info("socket")
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER_BYTES)
        except OSError:  # the system's limit stands
            pass
        self._ticker = asyncio.create_task(self._tick())
        self._ask()
        return self

    def close(self) -> None:
        if self._ticker is not None:
            self._ticker.cancel()
        if self._transport is not None:
            self._transport.close()

    async def __aenter__(self) -> StreamReceiver:
        return await self.start()

    async def __aexit__(self, *exc) -> None:
        self.close()

    def __aiter__(self) -> AsyncIterator[Frame]:
        return self

    async def __anext__(self) -> Frame:
        return await self._queue.get()

    async def next_frame(self, timeout_s: float) -> Frame | None:
        timeout_s = timeout("timeout_s", timeout_s)
        try:
            async with asyncio.timeout(timeout_s):  # unlike 3.11's wait_for, never swallows a cancel
                return await self._queue.get()
        except TimeoutError:
            return None

    def _ask(self) -> None:
        if self.ack and self._transport is not None:
            self._asked_at = time.monotonic()
            self._transport.sendto(spec.UDP_REQUEST_PAYLOAD.encode(), self.sender)

    def _datagram(self, data: bytes) -> None:
        now = time.monotonic()
        done = self.reassembler.feed(data, now)
        if done is None:
            return
        frame_id, payload, first_at = done
        frame = decode(self.kind, frame_id, payload, first_at, now) if self.decode else \
            Frame(self.kind, frame_id, now, first_at, payload)
        if frame is None:
            self.counters.undecodable += 1
        else:
            if self._queue.full():  # a live stream: the newest frame wins
                self._queue.get_nowait()
                self.counters.overtaken += 1
            self._queue.put_nowait(frame)
        self._ask()

    async def _tick(self) -> None:
        while True:
            await asyncio.sleep(FRAME_TIMEOUT_S / 4)
            now = time.monotonic()
            self.reassembler.expire(now)
            if self.ack and now - self._asked_at > FRAME_TIMEOUT_S:  # the request or the frame was lost
                self._ask()


class _Endpoint(asyncio.DatagramProtocol):
    def __init__(self, receiver: StreamReceiver) -> None:
        self.receiver = receiver

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.receiver._datagram(data)

    def error_received(self, exc: Exception) -> None:  # e.g. ICMP port unreachable after an ack
        pass
