"""Every corpus input to the C++ object (the core, through its C ABI) and to its twins: roar_wire
on CPython and the same code on MicroPython. Their answers (fuzz/twins.py says what is asked)
must be equal, compared as JSON text.

    families: control  the control and setpoint parser   corpora control_parser, py_control
              sbus     the SBUS decoder                    corpora sbus, py_sbus
              junior   the Junior's query string           corpora junior_query, py_junior_query
              http     the Junior's HTTP reader and board  corpus junior_http (the twin: the
                       MicroPython board's roar_junior.py)
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from fuzz import twins

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"
FAMILIES = {"control": ("control_parser", "py_control"), "sbus": ("sbus", "py_sbus"),
            "junior": ("junior_query", "py_junior_query"), "http": ("junior_http",)}
BOARD_LIB = ROOT / "firmware" / "micropython" / "lib"  # roar_junior.py and roar_clock.py, the HTTP twin
MAX_INPUT_BYTES = 4096  # what libFuzzer makes by default; longer stored inputs are cut


def corpus(family: str) -> list[bytes]:
    """The family's corpus inputs, each once, in a fixed order."""
    found = set()
    for target in FAMILIES[family]:
        folder = CORPUS / target
        if folder.is_dir():
            found.update(p.read_bytes()[:MAX_INPUT_BYTES] for p in folder.iterdir() if p.is_file())
    return sorted(found)


# --- the C++ core's answers ---------------------------------------------------------------------


def core_control(data: bytes) -> list:
    from fuzz.twins import SIGNING_KEY, SIGNING_SESSION
    from roar.protocol.spec import ParseResult
    from roar_sim.core.car import Authenticator, ControlParser

    out = []
    parser, auth = ControlParser(), Authenticator()
    auth.set_key(SIGNING_KEY, SIGNING_SESSION)
    for i in range(len(data)):  # a byte at a time: the authenticator reads the parser after each message
        for e in parser.feed(data[i:i + 1]):
            counter, mac = e.signature if e.signature else (None, None)
            if e.result == ParseResult.OK:
                out.append([e.at, int(e.result), e.command.throttle_us, e.command.steering_us, counter, mac,
                            int(auth.check(e.result, parser))])
            elif e.result == ParseResult.SETPOINT:
                out.append([e.at, int(e.result), e.setpoint.speed_mm_s, e.setpoint.steering_us, counter, mac,
                            int(auth.check(e.result, parser))])
            else:
                out.append([e.at, int(e.result), None, None, None, None, None])
    return out


def core_sbus(data: bytes) -> list:
    from roar.protocol.spec import SbusResult
    from roar_sim.core.iarrc import SbusDecoder

    d, now, out = SbusDecoder(), 1000, []
    for i in range(0, len(data) - 1, 2):
        now += 25 * data[i]
        r = d.feed(data[i + 1], now)
        if r == SbusResult.FRAME:
            channels, flags, end = d.frame()
            out.append([i, int(r), channels, flags, end])
        elif r != SbusResult.NONE:
            out.append([i, int(r), None, None, None])
    s = d.status()
    out.append([s["good_frames"], s["lost_frames"], s["failsafe_frames"], s["dropped"], int(s["locked"]),
                s["last_good_us"]])
    return out


def core_junior(data: bytes) -> list:
    from roar_sim.core.library import lib, new_object

    mem = new_object("roar_junior_size")
    lib().roar_junior_init(mem)
    r = lib().roar_junior_apply_query(mem, data, len(data), 0)
    return [r, 0] if r >= 0 else [0, -r]


def core_http(data: bytes) -> list:
    return [_core_http(data, False), _core_http(data, True)]


def _core_http(data: bytes, keyed: bool) -> list:
    from roar_sim.core.junior import HttpRequestReader, JuniorBoard

    board, out, at = JuniorBoard(), [], 0
    if keyed:  # the key set over its serial port: session 1
        board.serial_in(b"KEY " + twins.SIGNING_KEY.hex().encode() + b"\n")
        board.run(2)
        assert board.serial_out().endswith(b"SESSION %08x\n" % twins.JUNIOR_SESSION)
    board.distance_cm = twins.DISTANCE_CM
    while at < len(data):
        reader = HttpRequestReader()
        used, state = reader.feed(data[at:])
        at += used
        if state == 0:
            break
        reply, keep = board.respond(reader)
        out.append([used, int(state), reply.hex(), 1 if keep else 0])
        if not keep or used == 0:
            break
    return out


CORE = {"control": core_control, "sbus": core_sbus, "junior": core_junior, "http": core_http}


@dataclass
class Report:
    inputs: dict[str, int] = field(default_factory=dict)  # family -> inputs compared
    divergences: list[str] = field(default_factory=list)  # one line each: family, input (hex), who differs
    micropython: str = ""  # why MicroPython was not asked, if it was not

    @property
    def ok(self) -> bool:
        return not self.divergences


def _line(family: str, data: bytes, who: str, a, b) -> str:
    return f"{family}: input {data[:64].hex()}{'...' if len(data) > 64 else ''}: {who}: {a} != {b}"[:600]


def compare(families: tuple[str, ...] = tuple(FAMILIES), micropython: bool = True) -> Report:
    """Every corpus input of each family to the core, CPython's roar_wire and (when Node.js and
    the MicroPython runtime are there) MicroPython's; a divergence is one line in the report."""
    import sys

    if str(BOARD_LIB) not in sys.path:  # the HTTP twin, as CPython imports it
        sys.path.append(str(BOARD_LIB))
    report = Report()
    inputs = {f: corpus(f) for f in families}
    mp_answers = None
    if micropython:
        mp_answers, report.micropython = _micropython(inputs)
    for family, items in inputs.items():
        report.inputs[family] = len(items)
        for k, data in enumerate(items):
            core = json.dumps(CORE[family](data))
            cpython = json.dumps(twins.ANSWERS[family](data))
            if core != cpython:
                report.divergences.append(_line(family, data, "C++ core vs CPython", core, cpython))
            if mp_answers is not None:
                mp = json.dumps(mp_answers[family][k])
                if mp != cpython:
                    report.divergences.append(_line(family, data, "MicroPython vs CPython", mp, cpython))
    return report


def _micropython(inputs: dict[str, list[bytes]]):
    """(MicroPython's answers, "") or (None, why it could not be asked)."""
    try:
        from roar_sim.emulators import micropython
    except ImportError as e:
        return None, f"the simulator is not installed ({e.name})"
    problem = micropython.available()
    if problem:
        return None, problem
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "inputs.json"
        path.write_text(json.dumps({f: [d.hex() for d in items] for f, items in inputs.items()}))
        board_lib = {f"/lib/{name}": BOARD_LIB / name for name in ("roar_junior.py", "roar_clock.py")}
        result = micropython.run(Path(twins.__file__),
                                 {**micropython.portable_files(), **board_lib, "/inputs.json": path})
    if result.returncode != 0:
        return None, f"MicroPython failed: {result.stderr.strip().splitlines()[-1:]}"
    return json.loads(result.stdout), ""
