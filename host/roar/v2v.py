"""Vehicle to vehicle over UDP multicast: a car's state to the V2V group, the other cars' newest
states back (roar_wire.v2v is the message; protocol/PROTOCOL.md section 10 (the V2V message)).

    with V2VLink(car_id=2) as link:             # loopback by default; interface="10.0.0.5" on a LAN
        link.send(x, y, yaw, speed)
        for car_id, heard in link.receive(now_s).items():
            heard.x, heard.speed, heard.received_s

Non-blocking: receive() drains what has arrived; older or repeated sequence numbers are dropped
(unless the sender was silent past the V2V timeout: it may have restarted), and so is anything
that is not a V2V message (counted in `rejected`).
"""

from __future__ import annotations

import socket
from dataclasses import dataclass

from roar_wire import spec, v2v


@dataclass(frozen=True)
class Heard:
    car_id: int
    seq: int
    x: float  # [m]
    y: float  # [m]
    yaw: float  # [rad]
    speed: float  # [m/s]
    received_s: float  # [s] on the receiver's clock


def free_port() -> int:
    """A UDP port nobody on this machine uses now: runs side by side on one machine each take
    their own, so they do not hear each other."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("", 0))
        return s.getsockname()[1]


class V2VLink:
    def __init__(self, car_id: int, group: str = spec.V2V_GROUP, port: int = spec.V2V_PORT,
                 interface: str = "127.0.0.1") -> None:
        if not 0 <= car_id <= v2v.MAX_CAR_ID:
            raise ValueError(f"car_id must be 0..{v2v.MAX_CAR_ID}, got {car_id}")
        self.car_id, self.address, self.seq = car_id, (group, port), 0
        self.latest: dict[int, Heard] = {}
        self.rejected = 0
        self._in = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self._in.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._in.bind(("", port))
        self._in.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                            socket.inet_aton(group) + socket.inet_aton(interface))
        self._in.setblocking(False)
        self._out = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
        self._out.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(interface))
        self._out.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, spec.V2V_TTL)
        self._out.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)

    def send(self, x: float, y: float, yaw: float, speed: float) -> None:
        self._out.sendto(v2v.encode(self.car_id, self.seq, x, y, yaw, speed), self.address)
        self.seq = (self.seq + 1) % v2v.SEQ_MODULUS

    def receive(self, now_s: float) -> dict[int, Heard]:
        """The newest state heard from each other car so far (stamped now_s when it arrived)."""
        while True:
            try:
                datagram = self._in.recv(v2v.MAX_BYTES + 1)
            except BlockingIOError:
                break
            message = v2v.decode(datagram)
            if message is None:
                self.rejected += 1
                continue
            car_id, seq = message[0], message[1]
            if car_id == self.car_id:
                continue  # our own, looped back
            before = self.latest.get(car_id)
            restarted = before is not None and now_s - before.received_s > spec.V2V_TIMEOUT_US / 1e6
            if before is None or restarted or v2v.newer(seq, before.seq):
                self.latest[car_id] = Heard(*message, received_s=now_s)
        return self.latest

    def close(self) -> None:
        self._in.close()
        self._out.close()

    def __enter__(self) -> V2VLink:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
