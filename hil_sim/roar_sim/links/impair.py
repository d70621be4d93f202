"""A seeded impaired link for UDP streams: loss (independent and in bursts), duplication,
reordering, truncation and delay, applied to each datagram between a sender and a receiver.

    link = Impairment(seed=1, loss=0.05, duplicate=0.02, reorder=0.05, truncate=0.01, delay_s=0.005)
    for at_s, datagram in link.apply(datagram, now_s): ...      # what arrives, and when
    relay = await ImpairedRelay.start(link, target=("127.0.0.1", 8001))   # the same on real sockets

The same seed and the same datagrams give the same faults, so a failure replays.
"""

from __future__ import annotations

import asyncio
import random
from dataclasses import dataclass, field


@dataclass
class Impairment:
    seed: int = 0
    loss: float = 0.0  # probability a datagram is lost
    duplicate: float = 0.0  # probability it arrives twice
    reorder: float = 0.0  # probability it is held back behind later ones (by up to reorder_s)
    truncate: float = 0.0  # probability it arrives cut short
    delay_s: float = 0.0  # [s] every datagram is late by up to this (uniform)
    reorder_s: float = 0.01  # [s]
    burst: float = 0.0  # probability a burst of losses starts at a datagram
    burst_length: int = 8  # datagrams lost in a burst
    counts: dict = field(default_factory=lambda: dict.fromkeys(
        ("sent", "lost", "duplicated", "reordered", "truncated"), 0))

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)
        self._burst_left = 0

    def apply(self, datagram: bytes, now_s: float) -> list[tuple[float, bytes]]:
        """[(arrival time [s], datagram)] for one datagram sent at now_s: none, one or two."""
        rng, c = self._rng, self.counts
        c["sent"] += 1
        if self._burst_left == 0 and rng.random() < self.burst:
            self._burst_left = self.burst_length
        if self._burst_left > 0:
            self._burst_left -= 1
            c["lost"] += 1
            return []
        if rng.random() < self.loss:
            c["lost"] += 1
            return []
        copies = 2 if rng.random() < self.duplicate else 1
        c["duplicated"] += copies - 1
        out = []
        for _ in range(copies):
            data = datagram
            if rng.random() < self.truncate and len(data) > 1:
                data = data[:rng.randrange(1, len(data))]
                c["truncated"] += 1
            at = now_s + rng.uniform(0, self.delay_s)
            if rng.random() < self.reorder:
                at += rng.uniform(0, self.reorder_s)
                c["reordered"] += 1
            out.append((at, data))
        return out


class ImpairedRelay(asyncio.DatagramProtocol):
    """A UDP relay on loopback: datagrams to its address go on to `target` through the impairment;
    datagrams back from the target (acks) return to the last sender, unimpaired."""

    def __init__(self, link: Impairment, target: tuple[str, int]) -> None:
        self.link, self.target = link, target
        self.address: tuple[str, int] | None = None
        self._transport: asyncio.DatagramTransport | None = None
        self._client: tuple[str, int] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None

    @classmethod
    async def start(cls, link: Impairment, target: tuple[str, int], host: str = "127.0.0.1") -> ImpairedRelay:
        loop = asyncio.get_running_loop()
        relay = cls(link, target)
        relay._loop = loop
        await loop.create_datagram_endpoint(lambda: relay, local_addr=(host, 0))
        return relay

    def connection_made(self, transport) -> None:
        self._transport = transport
        self.address = transport.get_extra_info("sockname")[:2]

    def datagram_received(self, data: bytes, addr) -> None:
        if tuple(addr[:2]) == tuple(self.target):  # an ack on its way back
            if self._client is not None:
                self._transport.sendto(data, self._client)
            return
        self._client = addr
        now = self._loop.time()
        for at, out in self.link.apply(data, now):
            delay = at - now
            if delay <= 0:
                self._transport.sendto(out, self.target)
            else:
                self._loop.call_later(delay, self._send_late, out)

    def _send_late(self, data: bytes) -> None:
        if self._transport is not None and not self._transport.is_closing():
            self._transport.sendto(data, self.target)

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()
