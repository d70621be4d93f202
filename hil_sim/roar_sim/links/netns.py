"""A real kernel link for traffic between simulated cars: a new network namespace joined to this
one by a veth pair, each end with its address. Sockets made by call_in(ns, ...) live in the other
namespace (a thread enters it, makes them, and ends; the sockets stay there), so what one car
sends another receives over the link, multicast included -- as two cars on one Wi-Fi would.

    with veth_pair() as link:                        # root and iproute2, else NetnsUnavailable
        here = V2VLink(1, interface=link.here_ip)
        there = call_in(link.ns, lambda: V2VLink(2, interface=link.there_ip))
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import threading
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TypeVar

from roar_sim import NetnsUnavailable

CLONE_NEWNET = 0x40000000  # setns(2)'s namespace type for a network namespace
T = TypeVar("T")


@dataclass(frozen=True)
class VethPair:
    ns: str  # the new namespace (ip netns exec NS ...)
    here: str  # the link's end in this namespace
    there: str  # its end in ns
    here_ip: str
    there_ip: str


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], capture_output=True, text=True, check=check)


@contextmanager
def veth_pair(subnet: str = "10.78.0") -> Iterator[VethPair]:
    """A namespace and a veth pair, SUBNET.1 here and SUBNET.2 there (/24); both removed after."""
    if os.geteuid() != 0:
        raise NetnsUnavailable("network namespaces need root")
    if not shutil.which("ip"):
        raise NetnsUnavailable("network namespaces need iproute2 (apt-get install iproute2)")
    tag = uuid.uuid4().hex[:6]
    pair = VethPair(f"roar{tag}", f"rh{tag}", f"rt{tag}", f"{subnet}.1", f"{subnet}.2")
    made = _ip("netns", "add", pair.ns, check=False)
    if made.returncode:
        raise NetnsUnavailable(f"this machine does not allow network namespaces ({made.stderr.strip()})")
    try:
        try:
            _ip("link", "add", pair.here, "type", "veth", "peer", "name", pair.there)
            _ip("link", "set", pair.there, "netns", pair.ns)
            _ip("addr", "add", f"{pair.here_ip}/24", "dev", pair.here)
            _ip("link", "set", pair.here, "up")
            for command in (("addr", "add", f"{pair.there_ip}/24", "dev", pair.there),
                            ("link", "set", pair.there, "up"), ("link", "set", "lo", "up")):
                _ip("netns", "exec", pair.ns, "ip", *command)
        except subprocess.CalledProcessError as e:
            raise NetnsUnavailable(f"cannot set up the veth link: {' '.join(e.cmd)}: {e.stderr.strip()}") from None
        yield pair
    finally:
        _ip("link", "del", pair.here, check=False)
        _ip("netns", "del", pair.ns, check=False)


def call_in(ns: str, make: Callable[[], T]) -> T:
    """make() run by a thread inside namespace ns (this process's other threads stay where they
    are); what it returns -- sockets -- keeps the namespace it was made in."""
    libc = ctypes.CDLL(None, use_errno=True)
    box: dict[str, object] = {}

    def enter_and_make() -> None:
        try:
            with open(f"/var/run/netns/{ns}") as f:
                if libc.setns(f.fileno(), CLONE_NEWNET) != 0:
                    raise OSError(ctypes.get_errno(), f"setns into {ns}: {os.strerror(ctypes.get_errno())}")
            box["value"] = make()
        except BaseException as e:  # noqa: BLE001 -- handed to the caller's thread
            box["error"] = e

    thread = threading.Thread(target=enter_and_make, name=f"netns-{ns}")
    thread.start()
    thread.join()
    if "error" in box:
        raise box["error"]  # type: ignore[misc]
    return box["value"]  # type: ignore[return-value]
