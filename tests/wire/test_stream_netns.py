"""The UDP stream across a real kernel link: a veth pair between this network namespace and a new
one, the sender in the other namespace; with netem on the link (loss, duplication, reordering,
delay) where the kernel has it, skipped with the reason where it does not (or without root)."""

import asyncio
import subprocess
import sys

import pytest

from conftest import ROOT
from roar.stream import StreamReceiver
from roar_sim.links.netns import NetnsUnavailable, veth_pair

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

SENDER = r'''
import socket, sys
sys.path[:0] = [sys.argv[3]]
from roar_wire import stream as wire
sys.path[:0] = [sys.argv[4], sys.argv[4].rsplit('/', 1)[0]]  # tests/wire, and tests/ for its conftest
from test_stream import payload
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
import time
for seq in range(int(sys.argv[2])):
    for d in wire.chunks(payload(seq), seq):
        s.sendto(d, (sys.argv[1], 9001))
    time.sleep(0.002)
'''
FRAMES = 500


def run(*cmd, check=True):
    return subprocess.run(cmd, capture_output=True, text=True, check=check)


@pytest.fixture
def veth():
    """(namespace, link end here, link end there); the pair and the namespace are removed after."""
    try:
        with veth_pair("10.77.0") as link:
            yield link.ns, link.here, link.there
    except NetnsUnavailable as e:
        pytest.skip(str(e))


def stream_across(ns):
    from test_stream import intact

    async def go():
        rx = await StreamReceiver("depth", host="10.77.0.1", port=9001, decode=False, queue_frames=FRAMES).start()
        proc = await asyncio.create_subprocess_exec(
            "ip", "netns", "exec", ns, sys.executable, "-c", SENDER, "10.77.0.1", str(FRAMES),
            str(ROOT / "host"), str(ROOT / "tests" / "wire"))
        await proc.wait()
        await asyncio.sleep(0.3)
        frames = []
        while not rx._queue.empty():
            frames.append(rx._queue.get_nowait())
        rx.close()
        return frames, rx.counters

    frames, counters = asyncio.run(go())
    assert frames and all(intact(f.payload) for f in frames)
    return frames, counters


def test_the_stream_crosses_a_real_link_between_namespaces(veth):
    frames, counters = stream_across(veth[0])
    assert len(frames) > FRAMES * 0.9 and counters.garbage == 0


def test_the_stream_crosses_a_netem_impaired_link_without_a_corrupt_frame(veth):
    ns, _, there = veth
    netem = run("ip", "netns", "exec", ns, "tc", "qdisc", "add", "dev", there, "root", "netem", "loss", "5%",
                "duplicate", "2%", "delay", "2ms", "1ms", "reorder", "10%", check=False)
    if netem.returncode:
        pytest.skip(f"tc netem unavailable here ({netem.stderr.strip()}): the kernel needs sch_netem; "
                    f"the seeded in-process impairment (test_stream.py) covers these faults")
    frames, counters = stream_across(ns)
    assert len(frames) > FRAMES * 0.5 and counters.duplicates + counters.incomplete > 0
