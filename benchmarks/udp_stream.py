"""ROAR's UDP camera stream on loopback:
* transport: recorded simulator frames (640x480 JPEG) pushed at 40 frames/s through a relay that
  loses 5 % of the datagrams: frames/s delivered (target >= 30) and the p99 latency from a frame's
  first datagram sent to its delivery (target <= 50 ms);
* end to end: the simulated car's phone rendering in real time, read in pull mode, at 320x240 and
  640x480: frames/s delivered beside the renderer's own frames/s;
* against ROAR's original receive loop (no frame id) on the same impaired stream (5 % loss, 2 %
  duplicates, 5 % reordered): intact frames delivered, ratio (target >= 1.5), and the frames the
  original glued together from two frames' chunks."""

import asyncio
import time

from roar.stream import Reassembler, StreamReceiver, whole
from roar_sim.links.impair import ImpairedRelay, Impairment
from roar_sim.world import renderer
from roar_wire import stream as wire

TITLE = "UDP camera stream (ROAR's chunked format)"
PUSH_FPS = 40.0  # [frames/s] the transport run's sender
TRANSPORT_S = 5.0  # [s]
END_TO_END_S = 4.0  # [s] per size
COMPARE_FRAMES = 3000


def recorded_frames(width: int = 640, height: int = 240 * 2, count: int = 8) -> list[bytes]:
    """Camera payloads of the simulated car driving (JPEG + intrinsics), as its phone sends them."""
    from roar.protocol import encode
    from roar_sim.robots.esc import EscCar
    from roar_sim.links.phone_udp import payloads
    from roar.tracks import get

    sim = EscCar(get("oval"))
    sim.write(encode(1500, 1500))
    frames = []
    for _ in range(count):
        sim.write(encode(1650, 1450))
        sim.run(0.25)
        rgb, _ = sim.plant.camera(width, height)
        frames.append(payloads(rgb, None, {}, quality=50)["rgb"])
    sim.close()
    return frames


async def transport(frames: list[bytes]) -> tuple[float, float, float]:
    """(frames/s delivered, p99 latency [s], mean datagrams per frame)."""
    rx = await StreamReceiver("rgb", port=0, decode=False, queue_frames=10_000).start()
    relay = await ImpairedRelay.start(Impairment(seed=5, loss=0.05), rx.address)
    loop = asyncio.get_running_loop()
    sender, _ = await loop.create_datagram_endpoint(asyncio.DatagramProtocol, local_addr=("127.0.0.1", 0))
    sent_at, latencies, datagrams = {}, [], 0
    start = time.monotonic()
    n = 0
    while time.monotonic() - start < TRANSPORT_S:
        chunks = wire.chunks(frames[n % len(frames)], n)
        sent_at[n % wire.MODULUS] = time.monotonic()
        for d in chunks:
            sender.sendto(d, relay.address)
        datagrams += len(chunks)
        n += 1
        while not rx._queue.empty():
            f = rx._queue.get_nowait()
            latencies.append(f.received_at - sent_at[f.frame_id])
        await asyncio.sleep(max(0.0, start + n / PUSH_FPS - time.monotonic()))
    await asyncio.sleep(0.1)
    while not rx._queue.empty():
        f = rx._queue.get_nowait()
        latencies.append(f.received_at - sent_at[f.frame_id])
    sender.close()
    relay.close()
    rx.close()
    latencies.sort()
    return len(latencies) / TRANSPORT_S, latencies[int(len(latencies) * 0.99)], datagrams / n


async def end_to_end(width: int, height: int) -> tuple[float, float, float]:
    """(frames/s delivered, frames/s rendered, ms per render) from the simulated phone."""
    from roar_sim.robots.esc import EscCar
    from roar_sim.links.phone_udp import Phone, StreamConfig

    sim = EscCar()
    phone = await Phone(sim, StreamConfig(width=width, height=height, rate_hz=60.0, depth=False,
                                          ports={"rgb": 0, "depth": 0, "state": 0, "control": 0})).start()
    rx = await StreamReceiver("rgb", port=0, sender=phone.bound("rgb"), ack=True, queue_frames=10_000).start()
    start = time.monotonic()
    await phone.serve(END_TO_END_S)
    wall = time.monotonic() - start
    delivered = rx.counters.delivered
    rx.close()
    phone.close()
    sim.close()
    return delivered / wall, phone.frames_rendered / wall, phone.render_s / max(1, phone.frames_rendered) * 1000


def roar_style(arrivals) -> tuple[int, int]:
    """ROAR's original receive loop on the arrivals: (intact frames, frames glued from two)."""
    log, intact, glued = {}, 0, 0
    for _, d, truth in arrivals:
        head = wire.parse_header(d)
        if head is None:
            continue
        index, last, _ = head
        if index in log:
            log = {}
            continue
        log[index] = (d[9:], truth)
        if len(log) - 1 == last:
            if len({t for _, t in log.values()}) == 1 and len(log) == last + 1:
                intact += 1
            else:
                glued += 1
            log = {}
    return intact, glued


def compare(frames: list[bytes]) -> tuple[int, int, int]:
    """(ours intact, ROAR-style intact, ROAR-style glued) on one impaired stream."""
    link = Impairment(seed=9, loss=0.05, duplicate=0.02, reorder=0.05, reorder_s=0.02, delay_s=0.002)
    arrivals = sorted((at, d, n) for n in range(COMPARE_FRAMES)
                      for i, d in enumerate(wire.chunks(frames[n % len(frames)], n))
                      for at, d in link.apply(d, n / PUSH_FPS + i * 1e-4))
    ours = Reassembler(whole=lambda p: whole("rgb", p))
    delivered = 0
    for at, d, n in arrivals:
        out = ours.feed(d, at)
        if out is not None:
            assert out[1] == frames[n % len(frames)]  # never corrupt
            delivered += 1
    return (delivered, *roar_style(arrivals))


def run() -> None:
    try:
        frames = recorded_frames()
    except ImportError as e:
        print(f"  skipped: the simulator needs {e.name}")
        return
    fps, p99, per_frame = asyncio.run(transport(frames))
    print(f"  transport, 640x480 JPEG ({per_frame:.1f} datagrams a frame) pushed at {PUSH_FPS:g}/s, 5 % loss: "
          f"{fps:.1f} frames/s delivered (target >= 30), p99 latency {p99 * 1000:.1f} ms (target <= 50)")
    for w, h in ((320, 240), (640, 480)):
        delivered, rendered, ms = asyncio.run(end_to_end(w, h))
        print(f"  end to end from the simulator, {w}x{h}: {delivered:.1f} frames/s delivered; "
              f"the renderer {rendered:.1f} frames/s ({ms:.0f} ms a frame, {renderer.wanted()} + JPEG)")
    ours, theirs, glued = compare(frames)
    print(f"  {COMPARE_FRAMES} frames, 5 % loss + 2 % duplicates + 5 % reordered: ours {ours} intact (0 corrupt), "
          f"ROAR's original {theirs} intact + {glued} glued from two frames; ratio {ours / max(1, theirs):.2f} "
          f"(target >= 1.5)")
