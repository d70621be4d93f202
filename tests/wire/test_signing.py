"""Signed control: the golden vectors of protocol/vectors/signed_messages.json in the core (C ABI),
CPython and MicroPython; properties over any key, session and message stream (every forged,
replayed, reordered or unsigned message refused, and nothing refused that should pass); and the
car's key line and session in its non-volatile memory, across reboots."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import ROOT
from roar_wire import control, signing

VECTORS = json.loads((ROOT / "protocol" / "vectors" / "signed_messages.json").read_text())
KEY = bytes.fromhex(VECTORS["key"])
SESSION = VECTORS["session"]
CASES = VECTORS["cases"]
TAKEN = ("ok", "setpoint")


def python_verdicts(case: dict) -> list[str]:
    auth, parser = signing.Authenticator(), control.Parser()
    if case["keyed"]:
        auth.set_key(KEY, SESSION)
    out = []
    for message in case["messages"]:
        results = [r for r in (parser.feed(b) for b in message.encode()) if r]
        assert len(results) == 1, message
        r = results[0]
        out.append(control.token(auth.check(r, parser) if r in (control.OK, control.SETPOINT) else r))
    return out


def core():
    pytest.importorskip("cffi", reason="the core's binding needs roar-platform[sim]")
    from roar_sim.core import car

    return car


def core_verdicts(case: dict) -> list[str]:
    car = core()
    auth, parser = car.Authenticator(), car.ControlParser()
    auth.set_key(KEY if case["keyed"] else None, SESSION)
    out = []
    for message in case["messages"]:
        events = parser.feed(message.encode())
        assert len(events) == 1, message
        r = events[0].result
        out.append(str(auth.check(r, parser) if str(r) in TAKEN else r))
    return out


def test_the_vectors_cover_every_verdict():
    seen = {v for case in CASES for v in case["verdicts"]}
    assert seen == {"ok", "setpoint", "unsigned", "forged", "replay", "nokey"}


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_python_twin(case):
    assert python_verdicts(case) == case["verdicts"]


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_core(case):
    assert core_verdicts(case) == case["verdicts"]


def test_macs_and_fingerprint_in_core_and_twin():
    car = core()
    for m in VECTORS["macs"]:
        args = (KEY, m["session"], ord(m["start"]), m["first"], m["steering"], m["counter"])
        assert "%012x" % signing.message_mac(*args) == "%012x" % car.message_mac(*args) == m["mac"]
    assert signing.fingerprint(KEY) == car.key_fingerprint(KEY) == VECTORS["fingerprint"]


def test_micropython_twin(tmp_path):
    from roar_sim.emulators import micropython

    problem = micropython.available()
    if problem:
        pytest.skip(problem)
    program = tmp_path / "signed.py"
    program.write_text(
        "import json\nfrom roar_wire import control, signing\n"
        "v = json.load(open('/v.json'))\nkey = bytes.fromhex(v['key'])\nout = []\n"
        "for case in v['cases']:\n"
        "    auth, parser, got = signing.Authenticator(), control.Parser(), []\n"
        "    if case['keyed']:\n        auth.set_key(key, v['session'])\n"
        "    for m in case['messages']:\n"
        "        r = [x for x in (parser.feed(b) for b in m.encode()) if x][0]\n"
        "        got.append(control.token(auth.check(r, parser) if r in (control.OK, control.SETPOINT) else r))\n"
        "    out.append(got)\n"
        "macs = ['%012x' % signing.message_mac(key, m['session'], ord(m['start']), m['first'], m['steering'], "
        "m['counter']) for m in v['macs']]\n"
        "print(json.dumps([out, macs, signing.fingerprint(key), signing.sign(b'(1600,1400)', key, v['session'], 1)"
        ".decode()]))\n")
    vectors = ROOT / "protocol" / "vectors" / "signed_messages.json"
    result = micropython.run(program, {**micropython.portable_files(), "/v.json": vectors})
    assert result.returncode == 0, result.stderr
    verdicts, macs, fingerprint, signed = json.loads(result.stdout)
    assert verdicts == [c["verdicts"] for c in CASES]
    assert macs == [m["mac"] for m in VECTORS["macs"]]
    assert fingerprint == VECTORS["fingerprint"]
    assert signed == signing.sign(b"(1600,1400)", KEY, SESSION, 1).decode()


# --- properties ------------------------------------------------------------------------------

keys = st.binary(min_size=16, max_size=16)
sessions = st.integers(1, 2**32 - 1)
commands = st.tuples(st.booleans(), st.integers(1000, 2000), st.integers(1000, 2000), st.integers(-5000, 5000))


def unsigned(cmd) -> bytes:
    setpoint, throttle, steering, speed = cmd
    return control.encode_setpoint(speed, steering) if setpoint else control.encode(throttle, steering)


class Both:
    """The core and the twin, fed the same stream; each message's verdict from both."""

    def __init__(self, key: bytes, session: int) -> None:
        car = core()
        self.c_auth, self.c_parser = car.Authenticator(), car.ControlParser()
        self.c_auth.set_key(key, session)
        self.p_auth, self.p_parser = signing.Authenticator(), control.Parser()
        self.p_auth.set_key(key, session)

    def verdicts(self, data: bytes) -> list[str]:
        got_c = []
        for ev in self.c_parser.feed(data):
            got_c.append(str(self.c_auth.check(ev.result, self.c_parser) if str(ev.result) in TAKEN else ev.result))
        got_p = []
        for b in data:
            r = self.p_parser.feed(b)
            if r:
                got_p.append(control.token(self.p_auth.check(r, self.p_parser)
                                           if r in (control.OK, control.SETPOINT) else r))
        assert got_c == got_p
        return got_c


@settings(max_examples=60, deadline=None)
@given(key=keys, session=sessions, cmds=st.lists(commands, min_size=1, max_size=12),
       steps=st.lists(st.integers(1, 1000), min_size=12, max_size=12), data=st.data())
def test_in_order_passes_and_any_replay_reorder_or_forgery_is_refused(key, session, cmds, steps, data):
    both = Both(key, session)
    counter, sent = 0, []
    for cmd, step in zip(cmds, steps):
        counter += step
        message = signing.sign(unsigned(cmd), key, session, counter)
        assert both.verdicts(message) == ["setpoint" if cmd[0] else "ok"]
        sent.append(message)
    # replay any message already taken, or any earlier one after a later (reordering): refused
    for message in data.draw(st.lists(st.sampled_from(sent), min_size=1, max_size=5)):
        assert both.verdicts(message) == ["replay"]
    # another session, another key, unsigned: refused
    cmd = data.draw(commands)
    counter += 1
    assert both.verdicts(signing.sign(unsigned(cmd), key, session ^ data.draw(sessions), counter)) == ["forged"]
    other = data.draw(keys.filter(lambda k: k != key))
    assert both.verdicts(signing.sign(unsigned(cmd), other, session, counter)) == ["forged"]
    assert both.verdicts(unsigned(cmd)) == ["unsigned"]
    # the refusals changed nothing: the next counter still passes
    assert both.verdicts(signing.sign(unsigned(cmd), key, session, counter)) == ["setpoint" if cmd[0] else "ok"]


@settings(max_examples=80, deadline=None)
@given(key=keys, session=sessions, cmd=commands, counter=st.integers(1, 2**32 - 1), data=st.data())
def test_every_altered_or_truncated_message_is_refused(key, session, cmd, counter, data):
    message = signing.sign(unsigned(cmd), key, session, counter)
    at = data.draw(st.integers(0, len(message) - 1))
    byte = data.draw(st.integers(0, 255).filter(lambda b: b != message[at]))
    altered = message[:at] + bytes([byte]) + message[at + 1:]
    cut = message[:data.draw(st.integers(1, len(message) - 1))]
    for stream in (altered, cut + b"\n"):
        both = Both(key, session)
        verdicts = both.verdicts(stream)
        # an altered byte may still spell the same values (a leading zero); then it is the same
        # message, signed: anything else that parses is forged
        same = [v for v in verdicts if v in TAKEN]
        if same:
            p = control.Parser()
            [p.feed(b) for b in stream]
            q = control.Parser()
            [q.feed(b) for b in message]
            assert (p.throttle_us, p.steering_us, p.speed_mm_s, p.setpoint_steering_us, p.signature) == \
                (q.throttle_us, q.steering_us, q.speed_mm_s, q.setpoint_steering_us, q.signature)
        assert all(v in TAKEN or v != "nokey" for v in verdicts)
        assert len(same) <= 1


# --- the car's board: key line, session in non-volatile memory, failsafe --------------------

def board(nvm=None):
    car = core()
    b = car.CarBoard(nvm=nvm)
    b.begin()
    b.run(2)
    b.boot_lines = b.serial_out().decode().splitlines()
    return b


def exchange(b, data: bytes = b"", ble: bytes = b"", loops: int = 5) -> list[str]:
    if data:
        b.serial_in(data)
    if ble:
        b.ble_write(ble)
    b.run(loops)
    return b.serial_out().decode().splitlines()


def keyed_board():
    b = board()
    assert exchange(b, b"KEY " + KEY.hex().encode() + b"\n") == [f"KEY {VECTORS['fingerprint']}", "SESSION 00000001"]
    return b


def test_a_key_is_set_over_serial_and_survives_a_reboot_with_a_new_session():
    b = keyed_board()
    first = signing.sign(b"(1500,1500)", KEY, 1, 1)
    assert exchange(b, first) == ["ARMED"]
    b1 = board(b.nvm)
    assert b1.boot_lines == ["READY 1", "SESSION 00000002"]
    b2 = board(b1.nvm)  # booted again: never the same session
    assert b2.boot_lines == ["READY 1", "SESSION 00000003"]
    # a message from an earlier session is forged here: a reboot does not reopen replay
    assert exchange(b2, first) == ["ERR forged 00000003"]
    assert b2.hal.wire_us[0] == 1500
    assert exchange(b2, signing.sign(b"(1500,1500)", KEY, 3, 1)) == ["ARMED"]
    assert exchange(b2, b"KEY ?\n") == [f"KEY {VECTORS['fingerprint']}"]


def test_each_boot_writes_a_few_bytes_and_no_message_writes_any():
    b = keyed_board()
    writes = b.hal.nvm_writes
    for counter in range(1, 200):
        exchange(b, signing.sign(b"(1500,1500)", KEY, 1, counter), loops=1)
    assert b.hal.nvm_writes == writes  # counters live in RAM: the session makes that safe
    b2 = core().CarBoard(nvm=b.nvm)
    b2.begin()
    assert 0 < b2.hal.nvm_writes <= 4  # the session's changed bytes and the check


def test_ble_can_neither_set_nor_clear_the_key():
    b = board()
    assert set(exchange(b, ble=b"KEY " + KEY.hex().encode() + b"\n")) == {"ERR garbage"}
    assert exchange(b, b"KEY ?\n") == ["KEY none"]
    b = keyed_board()
    exchange(b, ble=b"KEY -\n")
    assert exchange(b, b"KEY ?\n") == [f"KEY {VECTORS['fingerprint']}"]
    assert exchange(b, b"KEY -\n") == ["KEY none"]
    assert exchange(b, b"(1500,1500)") == ["ARMED"]  # no key: unsigned drives again


def test_bad_key_lines_are_refused_and_do_not_hold_control_back():
    b = keyed_board()
    for line in (b"KEY 0011\n", b"KEY " + KEY.hex().encode() + b"00\n", b"KEY xyz\n", b"KEX\n"):
        assert exchange(b, line)[0] == "ERR syntax", line
    assert exchange(b, b"KEY ?\n") == [f"KEY {VECTORS['fingerprint']}"]  # unchanged
    # a stray K then a message at once: the message is still read
    assert exchange(b, b"K" + signing.sign(b"(1500,1500)", KEY, 1, 5)) == ["ERR syntax", "ARMED"]


def test_the_failsafe_counts_only_authenticated_messages():
    b = keyed_board()
    assert exchange(b, signing.sign(b"(1500,1500)", KEY, 1, 1)) == ["ARMED"]
    assert exchange(b, signing.sign(b"(1700,1500)", KEY, 1, 2), loops=40)[:1] == []
    assert b.hal.wire_us[0] == 1700
    lines = []
    for _ in range(20):  # 400 ms of an attacker's unsigned and replayed messages every 20 ms
        lines += exchange(b, b"(1700,1500)" + signing.sign(b"(1700,1500)", KEY, 1, 2), loops=20)
    assert "FAILSAFE" in lines and "ARMED" not in lines
    assert b.hal.wire_us[0] == 1500


def test_a_board_without_non_volatile_memory_refuses_a_key():
    car = core().Car()
    car.boot()
    car.feed(b"KEY " + KEY.hex().encode() + b"\n", 0)
    assert car.replies() == ["READY 1\n", "ERR nokey\n"]


# --- the host: key file, roar key, Vehicle(key=) over the simulated car -------------------------

def roar(capsys, *argv):
    from roar.cli import main

    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out + err


def drive_for(url: str, seconds: float = 1.2, **kw):
    import time

    from roar import Vehicle

    with Vehicle(url, **kw) as car:
        car.drive(throttle=0.4)
        time.sleep(seconds)
        return car.state().speed_m_s, list(car.replies), car.errors, car.signer


def test_one_line_turns_it_on_and_only_the_key_drives(capsys, tmp_path):
    """`roar key set` keys the (simulated) car; from then on the Vehicle signs with the key file
    and drives, a Vehicle without the key cannot, and the car keeps its key across runs."""
    pytest.importorskip("pybullet", reason="the simulated car needs roar-platform[sim]")
    from roar.signing import default_path, read_key_file

    url = f"sim://?eeprom={tmp_path / 'car.eeprom'}"
    code, out = roar(capsys, "key", "set", url)
    assert code == 0 and "now takes only messages signed with key" in out
    fingerprint = signing.fingerprint(read_key_file(default_path()))
    assert roar(capsys, "key", "show", url) == (0, f"your key: {fingerprint} ({default_path()})\n"
                                                   f"{url}: {fingerprint} (yours)\n")
    speed, replies, errors, signer = drive_for(url)  # the key file is used without being named
    assert speed > 0.5 and errors == 0 and signer.session and signer.refused == 0
    assert replies[:3] == ["READY 1", f"SESSION {signer.session:08x}", "ARMED"]
    speed, replies, errors, _ = drive_for(url, key=False)  # unsigned: refused, the car stays put
    assert speed < 0.05 and errors > 10 and all(r.startswith("ERR unsigned") for r in replies[2:])
    speed, replies, errors, signer = drive_for(url, key=bytes(16))  # another key: forged
    assert speed < 0.05 and signer.refused > 10 and "ERR forged" in " ".join(replies)
    assert roar(capsys, "key", "clear", url)[0] == 0
    speed, replies, errors, signer = drive_for(url)  # no key in the car: the Vehicle goes unsigned
    assert speed > 0.5 and signer.unkeyed and errors == 0


def test_a_file_that_is_not_a_boards_memory_is_refused_and_left_as_it_is(capsys, tmp_path):
    """sim://?eeprom= never cuts a user's file down: a file that is not a simulated board's memory
    is refused in one line by every command, and stays byte for byte what it was."""
    pytest.importorskip("pybullet", reason="the simulated car needs roar-platform[sim]")
    notes = tmp_path / "v.txt"
    notes.write_text("".join(f"{i}\n" for i in range(1, 2001)))
    before = notes.read_bytes()
    small = tmp_path / "small.txt"
    small.write_bytes(b"not a board\n")
    for path in (notes, small):
        for argv in (["key", "show"], ["key", "set"], ["key", "clear"]):
            code, out = roar(capsys, *argv, f"sim://?eeprom={path}")
            assert code == 1 and "not a simulated board's memory" in out and "left as it is" in out, (argv, out)
            assert sum("error:" in line for line in out.splitlines()) == 1 and "Traceback" not in out
    assert notes.read_bytes() == before and small.read_bytes() == b"not a board\n"
    from roar import TransportError, Vehicle

    with pytest.raises(TransportError, match="not a simulated board's memory"):
        Vehicle(f"sim://?eeprom={notes}")
    assert notes.read_bytes() == before


def test_a_command_that_only_reads_writes_nothing_and_makes_no_file(capsys, tmp_path):
    """roar key show boots the simulated car (which draws a new session) but writes nothing back;
    where the file does not exist, it makes none; set writes the memory with its first line."""
    pytest.importorskip("pybullet", reason="the simulated car needs roar-platform[sim]")
    missing = tmp_path / "none.eeprom"
    assert roar(capsys, "key", "show", f"sim://?eeprom={missing}")[0] == 0
    assert not missing.exists()
    memory = tmp_path / "car.eeprom"
    assert roar(capsys, "key", "set", f"sim://?eeprom={memory}")[0] == 0
    kept = memory.read_bytes()
    assert kept.startswith(b"roar board memory esc ")
    code, out = roar(capsys, "key", "show", f"sim://?eeprom={memory}")
    assert code == 0 and "(yours)" in out and memory.read_bytes() == kept
    sessions = [drive_for(f"sim://?eeprom={memory}", 0.3)[3].session for _ in range(2)]
    assert sessions[0] < sessions[1] and memory.read_bytes() != kept  # each boot a new session, kept: no replay
    kept = memory.read_bytes()
    legacy = tmp_path / "legacy.eeprom"  # an image from before the first line: the board's bytes alone
    legacy.write_bytes(kept.partition(b"\n")[2])
    assert "(yours)" in roar(capsys, "key", "show", f"sim://?eeprom={legacy}")[1]
    iarrc = f"sim://?robot=iarrc&eeprom={memory}"  # another robot's memory: refused, untouched
    code, out = roar(capsys, "key", "show", iarrc)
    assert code == 1 and "memory of the esc robot, not the iarrc" in out and memory.read_bytes() == kept


def test_roar_send_to_a_keyed_car_from_a_host_with_no_key_says_so(capsys, tmp_path, monkeypatch):
    """Not "done, link ok": one line saying every message was refused, why, and what to do; the
    car's refusal is logged once, not fifty times a second."""
    pytest.importorskip("pybullet", reason="the simulated car needs roar-platform[sim]")
    url = f"sim://?eeprom={tmp_path / 'car.eeprom'}"
    assert roar(capsys, "key", "set", url)[0] == 0
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "another-host"))
    code = __import__("roar.cli", fromlist=["main"]).main(["send", url, "--throttle", "0.3", "--for", "0.5"])
    out, err = capsys.readouterr()
    assert code == 1 and "done" not in out and "link ok" not in out
    assert "refused every message" in err and "has a signing key and this host has none" in err and "roar key set" in err
    assert len([line for line in err.splitlines() if line]) <= 2  # the refusal logged once, and the error line


def test_a_key_set_in_a_simulated_car_with_no_file_to_keep_it_is_refused(capsys):
    for action in ("set", "clear"):
        code, out = roar(capsys, "key", action, "sim://")
        assert code == 1 and "sim://?eeprom=FILE" in out, out


def test_a_car_without_a_key_is_driven_unsigned_by_a_host_with_one(tmp_path):
    pytest.importorskip("pybullet", reason="the simulated car needs roar-platform[sim]")
    speed, replies, errors, signer = drive_for("sim://", key=KEY)
    assert speed > 0.5 and errors == 0 and signer.unkeyed and replies[:2] == ["READY 1", "ARMED"]


def test_key_commands_refuse_in_one_line(capsys, tmp_path):
    from roar.signing import default_path

    for argv, words in ((["key", "set", "ble://"], "USB serial link only"),
                        (["key", "set"], "needs the car's URL"),
                        (["key", "show", "--file", str(tmp_path / "none")], "your key: none")):
        code, out = roar(capsys, *argv)
        assert words in out and "Traceback" not in out, argv
    code, out = roar(capsys, "key", "new")
    assert code == 0, out
    mode = default_path().stat().st_mode & 0o777
    assert mode == 0o600
    code, out = roar(capsys, "key", "new")
    assert code != 0 and "already holds a key" in out and "--force" in out
    (tmp_path / "bad").write_text("not a key\n")
    from roar import Vehicle
    from roar.signing import SigningError

    with pytest.raises(SigningError, match="one key of 32 hex digits"):
        Vehicle("loop://", key=tmp_path / "bad")


def test_the_iarrc_car_in_the_simulator_is_keyed_and_driven_by_speed(capsys, tmp_path):
    pytest.importorskip("pybullet", reason="the simulated car needs roar-platform[sim]")
    import time

    from roar import Vehicle

    url = f"sim://?robot=iarrc&eeprom={tmp_path / 'iarrc.flash'}"
    assert roar(capsys, "key", "set", url)[0] == 0
    with Vehicle(url) as car:
        time.sleep(0.3)
        car.drive(speed=1.0)
        time.sleep(1.2)
        assert car.state().speed_m_s > 0.5 and car.errors == 0 and car.signer.refused == 0
        assert any(r.startswith("SESSION ") for r in car.replies)
