"""ROAR's UDP chunked stream: the wire format on both interpreters' module, reassembly that never
delivers a corrupt frame (unit cases, random fault sequences, and 10,000 frames through a seeded
impaired relay on real loopback sockets), and the original receiver's stitching for contrast."""

import asyncio
import importlib.util
import json
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import ROOT
from roar.protocol import spec
from roar.stream import Reassembler, StreamReceiver, whole
from roar_sim.links.impair import ImpairedRelay, Impairment
from roar_wire import stream as wire

pytestmark = pytest.mark.realtime  # keeps to the wall clock: one at a time under xdist (conftest)

CHUNK = wire.CHUNK_BYTES
VECTORS = ROOT / "protocol" / "vectors" / "udp_headers.json"


# Depth maps (height, width) of 1-4 chunks; 12 x 383 makes exactly two full chunks.
SHAPES = [(1, 1), (48, 64), (60, 80), (72, 96), (383, 12)]


def payload(seq: int) -> bytes:
    """Frame seq's depth payload: its number as fx, a shape and values only it has."""
    rng = random.Random(seq)
    height, width = rng.choice(SHAPES)
    return wire.with_intrinsics(float(seq + 1), 1.0, width / 2, height / 2, rng.randbytes(4 * height * width))


def seq_of(data: bytes) -> int:
    return int(wire.intrinsics(data)[0]) - 1


def intact(data: bytes) -> bool:
    try:
        return data == payload(seq_of(data))
    except ValueError:  # not a frame's start: no intrinsics there
        return False


def depth_whole(data: bytes) -> bool:
    return whole("depth", data)


def test_the_header_golden_vectors():
    for v in json.loads(VECTORS.read_text())["headers"]:
        assert wire.header(v["index"], v["last"], v["frame_id"]) == v["bytes"].encode()
        assert wire.parse_header(v["bytes"].encode() + b"data") == (v["index"], v["last"], v["frame_id"] % 1000)
    for bad in json.loads(VECTORS.read_text())["not_headers"]:
        assert wire.parse_header(bad.encode()) is None


def test_chunks_carry_full_chunks_and_the_last_index_roars_receiver_completes_on():
    for n in (1, CHUNK - 1, CHUNK, CHUNK + 1, 3 * CHUNK):
        datagrams = wire.chunks(b"x" * n, frame_id=1234)
        last = len(datagrams) - 1
        assert [wire.parse_header(d) for d in datagrams] == [(i, last, 234) for i in range(last + 1)]
        assert all(len(d) == wire.HEADER_BYTES + CHUNK for d in datagrams[:-1])
        assert len(datagrams) == -(-n // CHUNK)  # ROAR's receiver completes at len(log) - 1 == YYY
    with pytest.raises(ValueError):
        wire.chunks(b"")


def feed(r: Reassembler, datagrams, t0=0.0):
    return [out for i, d in enumerate(datagrams) if (out := r.feed(d, t0 + i * 1e-4)) is not None]


def test_a_whole_frame_is_delivered_once_in_any_order():
    data = payload(3)
    datagrams = wire.chunks(data, 3)
    assert len(datagrams) > 1
    r = Reassembler()
    out = feed(r, list(reversed(datagrams)) + datagrams)  # then every chunk again: stale
    assert [(fid, p) for fid, p, _ in out] == [(3, data)]
    assert r.counters.stale == len(datagrams)


def test_missing_truncated_and_conflicting_chunks_never_make_a_frame():
    data = b"y" * (2 * CHUNK + 10)
    a = wire.chunks(data, 5)
    r = Reassembler()
    assert feed(r, [a[0], a[2]]) == []  # one missing
    assert r.expire(1.0) == 1 and r.counters.incomplete == 1
    assert feed(r, [a[0], a[1][:-1], a[2]]) == [] and r.counters.truncated == 1
    other = wire.chunks(b"z" * (2 * CHUNK + 10), 5)
    assert feed(r, [a[0], other[0], a[1], a[2]]) == []  # the same chunk with other bytes: spoiled
    assert r.counters.conflicts == 1
    assert feed(r, [a[0], a[0], a[1], a[2]])[0][1] == data  # an identical duplicate is harmless
    assert r.counters.duplicates == 1


def test_garbage_oversize_and_wrong_headers_are_counted_and_dropped():
    r = Reassembler()
    for d in (b"", b"ack", b"12345678", b"abc000000data", b"002001000data", b"0" * (spec.UDP_MAX_DATAGRAM_BYTES + 1)):
        assert r.feed(d, 0.0) is None
    assert r.counters.garbage == 5 and r.counters.oversize == 1 and r.counters.delivered == 0


def test_frame_ids_wrap_and_a_phone_that_sends_000_works_without_them():
    r = Reassembler()
    ids = [997, 998, 999, 0, 1]
    assert [fid for fid, _, _ in feed(r, [d for i in ids for d in wire.chunks(b"q", i)])] == ids
    roar_phone = Reassembler(frame_ids=False)
    for k in range(3):
        frame = b"%d" % k * 10000
        datagrams = [d[:6] + b"000" + d[9:] for d in wire.chunks(frame, k)]  # ZZZ always 000
        assert feed(roar_phone, datagrams)[0][1] == frame


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40), st.sampled_from(["ok", "drop", "dup", "cut", "late"])),
                min_size=1, max_size=120))
def test_no_fault_sequence_yields_a_wrong_payload(script):
    sent = []
    for seq, fault in script:
        for d in wire.chunks(payload(seq), seq):
            sent.append({"ok": [d], "drop": [], "dup": [d, d], "cut": [d[:len(d) // 2]], "late": []}[fault])
            if fault == "late" and sent:
                sent.insert(max(0, len(sent) - 3), [d])
    r = Reassembler(whole=depth_whole)
    for fid, data, _ in feed(r, [d for group in sent for d in group]):
        assert intact(data) and seq_of(data) % 1000 == fid


async def stream_through(link: Impairment, frames: int, receiver_kwargs=None):
    rx = StreamReceiver("depth", port=0, decode=False, queue_frames=frames, **(receiver_kwargs or {}))
    await rx.start()
    relay = await ImpairedRelay.start(link, rx.address)
    loop = asyncio.get_running_loop()
    sender, _ = await loop.create_datagram_endpoint(asyncio.DatagramProtocol, local_addr=("127.0.0.1", 0))
    got = []

    async def collect():
        while True:
            got.append(await rx._queue.get())

    collector = asyncio.create_task(collect())
    for seq in range(frames):
        for d in wire.chunks(payload(seq), seq):
            sender.sendto(d, relay.address)
        if seq % 2 == 1:
            await asyncio.sleep(0.001)  # about 1,000 frames/s: faster than any camera, and the loopback keeps up
    await asyncio.sleep(0.2)
    collector.cancel()
    sender.close()
    relay.close()
    rx.close()
    return got, rx.counters


def test_ten_thousand_frames_through_mixed_faults_deliver_no_corrupt_frame():
    link = Impairment(seed=14, loss=0.03, duplicate=0.03, reorder=0.05, truncate=0.02, delay_s=0.0005,
                      reorder_s=0.003, burst=0.002, burst_length=6)
    got, counters = asyncio.run(stream_through(link, 10_000))
    corrupt = [f for f in got if not intact(f.payload)]
    assert corrupt == []
    assert all(seq_of(f.payload) % 1000 == f.frame_id for f in got)
    assert len(got) > 6_000  # most frames get through
    seqs = [seq_of(f.payload) for f in got]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)  # in order, each once
    # Every kind of fault reached the receiver and was dealt with.
    assert counters.truncated and counters.malformed and counters.duplicates and counters.stale
    assert counters.incomplete
    assert min(link.counts.values()) > 0


class RoarStyleReceiver:
    """ROAR's original receive loop (roar.md section 3.3), for contrast: no frame id; a chunk
    index seen twice starts over; complete when it holds YYY + 1 distinct indices."""

    def __init__(self):
        self.log = {}

    def feed(self, datagram):
        index, last = int(datagram[0:3]), int(datagram[3:6])
        if index in self.log:
            self.log = {}
            return None
        self.log[index] = datagram[9:]
        if len(self.log) - 1 == last:
            data, self.log = b"".join(self.log[k] for k in sorted(self.log)), {}
            return data
        return None


def test_the_original_receiver_stitches_frames_where_ours_does_not():
    link = Impairment(seed=3, loss=0.05, reorder=0.05, reorder_s=0.004, delay_s=0.001)
    arrivals = sorted((at, n, d) for n, (at, d) in enumerate(
        a for seq in range(2000) for i, d in enumerate(wire.chunks(payload(seq), seq))
        for a in link.apply(d, seq * 0.002 + i * 1e-5)))
    roar, ours = RoarStyleReceiver(), Reassembler(whole=depth_whole)
    roar_frames = [f for _, _, d in arrivals if (f := roar.feed(d)) is not None]
    our_frames = [f for at, _, d in arrivals if (f := ours.feed(d, at)) is not None]
    assert sum(not intact(f) for f in roar_frames) > 10  # chunks of two frames glued together
    assert all(intact(p) for _, p, _ in our_frames) and len(our_frames) > 1500


# --- the simulated car's phone, and roar stream ---------------------------------------------

pytest.importorskip("pybullet", reason="pip install pybullet (make setup installs it)")


async def phone_session(config_kwargs, seconds, control=None, ack=True):
    from roar_sim.robots.esc import EscCar
    from roar_sim.links.phone_udp import Phone, StreamConfig

    sim = EscCar()
    ports = {"rgb": 0, "depth": 0, "state": 0, "control": 0}
    phone = await Phone(sim, StreamConfig(ports=ports, **config_kwargs)).start()
    serving = asyncio.create_task(phone.serve(seconds + 0.3))
    rxs = {k: await StreamReceiver(k, port=0, sender=phone.bound(k), ack=ack).start() for k in ("rgb", "depth", "state")}
    loop = asyncio.get_running_loop()
    ctl, _ = await loop.create_datagram_endpoint(asyncio.DatagramProtocol, local_addr=("127.0.0.1", 0))
    frames = {k: [] for k in rxs}
    t0 = loop.time()
    while loop.time() - t0 < seconds:
        if control is not None:
            ctl.sendto(control(loop.time() - t0), phone.bound("control"))
        for k, rx in rxs.items():
            f = await rx.next_frame(0.005)
            if f is not None:
                frames[k].append(f)
    await serving
    phone.close()
    for rx in rxs.values():
        rx.close()
    ctl.close()
    state, outputs = sim.state(), sim.outputs
    sim.close()
    return phone, frames, (state, outputs)


def test_the_simulated_phone_streams_camera_depth_and_state_and_takes_control():
    phone, frames, (state, _) = asyncio.run(phone_session(
        {"width": 160, "height": 120, "rate_hz": 10}, 2.0, control=lambda t: wire.control_line(0.4, -1.0)))
    assert all(len(f) >= 12 for f in frames.values()), {k: len(f) for k, f in frames.items()}  # about 10/s
    rgb, depth, st = frames["rgb"][-1], frames["depth"][-1], frames["state"][-1]
    assert rgb.image.shape == (120, 160, 3) and depth.image.shape == (120, 160)
    assert rgb.intrinsics[2:] == (80.0, 60.0) and 0.05 < float(depth.image[-1, 80]) < 2.0  # the floor just ahead
    assert st.state["hall_effect_sensor_velocity"] > 0.3 and state.speed > 0.3  # control reached the firmware
    assert state.yaw_rate > 0.2  # steering -1: full left, anticlockwise
    ids = [f.frame_id for f in frames["rgb"]]
    assert ids == sorted(ids) and len(set(ids)) == len(ids)


def test_the_phone_stops_forwarding_when_control_stops_so_the_car_fails_safe():
    phone, frames, (state, outputs) = asyncio.run(phone_session(
        {"width": 64, "height": 48, "rate_hz": 10, "depth": False}, 2.0,
        control=lambda t: wire.control_line(0.5, 0.0) if t < 0.6 else b"garbage"))
    assert phone.bad_control > 0 and frames["depth"] == []
    # It stopped forwarding 250 ms after the last good control: the firmware's failsafe latched
    # neutral, and the car coasts.
    assert outputs.throttle_us == spec.CONTROL_NEUTRAL_US and outputs.latched
    assert state.x > 0.3


def test_roar_stream_reports_and_writes_pngs_headless(tmp_path):
    import subprocess
    import sys as _sys

    sim = subprocess.Popen([_sys.executable, "-m", "roar.cli", "sim", "--stream", "--seconds", "8",
                            "--size", "160x120"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "streaming the simulated car" in sim.stdout.readline()
        out = subprocess.run([_sys.executable, "-m", "roar.cli", "stream", "udp://127.0.0.1", "--seconds", "3",
                              "--out", str(tmp_path), "--log", str(tmp_path / "phone.mcap")], cwd=ROOT,
                             capture_output=True, text=True, timeout=60, env={**__import__("os").environ, "DISPLAY": ""})
    finally:
        sim.kill()
        sim.communicate()
    assert out.returncode == 0, out.stderr
    rates = [float(line.split()[1].removesuffix("/s")) for line in out.stdout.splitlines() if line.startswith("rgb ")]
    assert rates and max(rates) > 10  # 20 frames/s asked of the simulator
    assert (tmp_path / "last.png").stat().st_size > 5_000
    if importlib.util.find_spec("foxglove") is not None:  # --log: every frame and each second's figures recorded
        from roar.replay import messages, read_log

        c = read_log(tmp_path / "phone.mcap").channels
        assert min(c["/camera/image"].count, c["/camera/depth"].count, c["/stream/state"].count) >= 20
        assert c["/stream/statistics"].count >= 2
        depth = next(m for _, _, m in messages(tmp_path / "phone.mcap", ["/camera/depth"]))
        assert (depth.width, depth.height, depth.encoding) == (160, 120, "32FC1")
        stats = [m for _, _, m in messages(tmp_path / "phone.mcap", ["/stream/statistics"])][-1]
        assert stats["rgb"]["frames_per_s"] > 10
    bad = subprocess.run([_sys.executable, "-m", "roar.cli", "stream", "udp://127.0.0.1", "--seconds", "0.5"],
                         cwd=ROOT, capture_output=True, text=True, timeout=60, env={**__import__("os").environ, "DISPLAY": ""})
    assert bad.returncode == 1 and "no frame from udp://127.0.0.1" in bad.stderr  # nothing streaming now


def test_a_vehicle_drives_the_simulated_car_through_its_phone_and_reads_its_streams():
    import subprocess
    import sys as _sys
    import time

    from roar import Vehicle
    from roar.transports import TransportError

    sim = subprocess.Popen([_sys.executable, "-m", "roar.cli", "sim", "--stream", "--seconds", "10",
                            "--size", "160x120"], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "streaming the simulated car" in sim.stdout.readline()
        with Vehicle("udp://127.0.0.1") as car:
            car.drive(throttle=0.4, steering=0.0)
            time.sleep(2.5)
            s = car.state()
            rgb, depth = car.camera()
        assert s.speed_m_s > 0.3 and s.x_m > 0.3 and s.time_s > 1.0
        assert rgb.shape == (120, 160, 3) and depth.shape == (120, 160)
    finally:
        sim.kill()
        sim.communicate()
    with pytest.raises(TransportError, match="HOST only"):
        Vehicle("udp://127.0.0.1:8004")


# --- numbers that are not numbers, hosts that do not exist, one URL parser ------------------------

NAN_STATE = b"000000007" + b",".join([b"nan"] * len(wire.STATE_FIELDS)) + b"\n"  # the datagram


def test_a_state_of_nans_from_the_network_is_dropped_and_counted():
    """The issue's datagram: never a state a control loop could read, counted as undecodable;
    the next good state goes through."""
    import socket

    async def run():
        async with StreamReceiver("state", port=0) as receiver:
            sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                sender.sendto(NAN_STATE, receiver.address)
                for frame_id, bad in ((8, b"inf"), (9, b"-inf"), (10, b"1e999")):
                    line = b",".join([bad] * len(wire.STATE_FIELDS)) + b"\n"
                    sender.sendto(b"%03d%03d%03d" % (0, 0, frame_id) + line, receiver.address)
                good = wire.state_line({name: 1.5 for name in wire.STATE_FIELDS})
                sender.sendto(b"%03d%03d%03d" % (0, 0, 11) + good, receiver.address)
                frame = await receiver.next_frame(5.0)
            finally:
                sender.close()
            return frame, receiver.counters

    frame, counters = asyncio.run(run())
    assert frame is not None and frame.frame_id == 11 and all(v == 1.5 for v in frame.state.values())
    assert counters.undecodable == 4


def test_telemetry_and_v2v_that_are_not_numbers_are_dropped_and_counted():
    import socket
    import time

    from roar import Vehicle
    from roar.v2v import V2VLink
    from roar_wire import v2v

    tel = "TEL autonomous none 11850 1 4321 1498 1500 1712 1540 -2500 500 400 0 110 3"
    with Vehicle("loop://") as car:
        car.transport.inject(tel.replace("1498", "nan"), tel.replace("11850", "inf"),
                             tel.replace("autonomous", "\x1b[31m"), tel)
        deadline = time.monotonic() + 5
        while car.state().speed_m_s is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert car.state().speed_m_s == 1.498 and car.rejected_telemetry == 3
    for text in (b"1,5,nan,0,0,0", b"1,5,0,inf,0,0", b"1,5,0,0,0,-inf", b"1,5,1e999,0,0,0"):
        assert v2v.decode(text) is None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]  # free now
    with V2VLink(0, port=port) as link:
        link._out.sendto(b"1,5,nan,0,0,0", link.address)
        link._out.sendto(v2v.encode(1, 6, 1.0, 2.0, 0.0, 0.5), link.address)
        deadline = time.monotonic() + 5
        while 1 not in link.receive(0.0) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert link.latest[1].x == 1.0 and link.rejected == 1


@pytest.mark.parametrize("argv, words", [
    (["stream", "udp://nonexistent.invalid", "--seconds", "5"], "cannot find host 'nonexistent.invalid'"),
    (["sim", "--stream", "--push", "nonexistent.invalid", "--seconds", "2"], "--push: cannot find host"),
    (["stream", "udp://127.0.0.1?bogus=1", "--seconds", "1"], "unknown option(s) bogus for udp://"),
    (["stream", "udp://127.0.0.1:9?push=1", "--seconds", "1"], "udp:// needs the phone's HOST only"),
    (["stream", "sim://", "--seconds", "1"], "want udp://HOST"),
])
def test_stream_urls_and_hosts_are_refused_at_once(capsys, argv, words):
    import time

    from roar.cli import main

    t0 = time.monotonic()
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert words in err and "\n" not in err and time.monotonic() - t0 < 2.0, err


def test_stream_reads_push_from_the_url_as_the_vehicle_does_and_listens_where_the_peer_is():
    from roar.cli.stream import target
    from roar.stream import peer

    assert target("udp://127.0.0.1?push=1") == ("127.0.0.1", True)
    assert target("udp://127.0.0.1") == ("127.0.0.1", False)
    assert peer("127.0.0.1") == ("127.0.0.1", "127.0.0.1")  # a loopback peer: listen on loopback only
    assert peer("localhost")[1] == "127.0.0.1"


def test_roar_stream_without_matplotlib_names_the_extra(capsys, monkeypatch):
    """A base install (no [camera,vision] extras): one line saying what to install."""
    import sys

    from roar.cli import main

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    assert main(["stream", "udp://127.0.0.1", "--seconds", "1"]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "pip install 'roar-platform[camera,vision]'" in err, err


def test_roar_stream_leaves_no_figure_open_in_the_calling_process(tmp_path, monkeypatch, capsys):
    """A program (or the suite) calling roar stream again and again must not pile up figures."""
    import matplotlib.pyplot as plt

    from roar.cli import main

    monkeypatch.setenv("DISPLAY", "")
    before = len(plt.get_fignums())
    for _ in range(3):
        assert main(["stream", "udp://127.0.0.1", "--seconds", "0.2", "--out", str(tmp_path)]) == 1  # nothing there
    assert len(plt.get_fignums()) == before
    assert "no frame from udp://127.0.0.1" in capsys.readouterr().err


def test_a_phone_with_a_key_drives_only_for_signed_control(tmp_path):
    """The simulated phone with the app's key set: a Vehicle with the key drives the car through
    it (datagrams "t,s,COUNTER,MAC"); one without is answered ERR unsigned and the car stays put."""
    import subprocess
    import sys as _sys
    import time

    from roar import Vehicle
    from roar.signing import write_key_file

    key_file = write_key_file(tmp_path / "key", bytes(range(16)))
    sim = subprocess.Popen([_sys.executable, "-m", "roar.cli", "sim", "--stream", "--seconds", "12", "--size", "64x48",
                            "--key", str(key_file)], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "streaming the simulated car" in sim.stdout.readline()
        for key, moves in ((False, False), (key_file, True), (bytes(16), False)):
            with Vehicle("udp://127.0.0.1", key=key) as car:
                start = None
                for _ in range(60):
                    time.sleep(0.05)
                    state = car.state()
                    if state is not None and start is None:
                        start = state.x_m
                        car.drive(throttle=0.5)
                moved = state is not None and start is not None and abs(state.x_m - start) > 0.2
                assert moved == moves, key
                if key is False:
                    assert car.signer is None
                elif moves:
                    assert car.signer.session == 1 and car.signer.refused == 0
                else:
                    assert car.signer.refused > 5  # forged, each answered
            time.sleep(0.6)  # the phone stops forwarding; the car stops
    finally:
        sim.kill()
        sim.communicate()
