"""The portable protocol module under real MicroPython (the official WebAssembly runtime): the
golden vectors, encode/decode and the Junior query rules give the same answers as on CPython
and in the C++ core."""

import json
import random

import pytest

from conftest import ROOT
from roar_sim.emulators import micropython

if micropython.available():
    pytest.skip(micropython.available(), allow_module_level=True)

PROGRAMS = ROOT / "tests" / "micropython"
VECTORS = ROOT / "protocol" / "vectors" / "control_messages.json"


def run(program: str, **files):
    result = micropython.run(PROGRAMS / program, {**micropython.portable_files(), **files})
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_the_golden_vectors_pass_on_micropython():
    got = json.loads(run("golden_vectors.py", **{"/vectors.json": VECTORS}))
    for case in json.loads(VECTORS.read_text())["cases"]:
        expected = [[e["at"], e["result"], e.get("throttle", e.get("speed")), e.get("steering")] for e in case["events"]]
        assert got[case["name"]] == expected, case["name"]


def test_an_exception_on_micropython_fails_the_run(tmp_path):
    program = tmp_path / "boom.py"
    program.write_text("import roar_wire.control\nraise ValueError('boom')\n")
    result = micropython.run(program, micropython.portable_files())
    assert result.returncode == 1 and "ValueError: boom" in result.stderr


def wire_cases(seed: int = 7, n: int = 600) -> dict:
    """Random control messages (valid, near-valid, junk), pulse pairs and Junior queries."""
    rng = random.Random(seed)
    pieces = ["(", ")", ",", "1500", "2000", "999", "12345", "0", " ", "\n", "x", "(1500,1500)"]
    names = ["forward", "backward", "stop", "turnLeft", "turnRight", "left_spd", "right_spd", "speed", ""]
    values = ["True", "False", "true", "0", "1", "0.5", ".25", "1.0", "1.01", "-0.5", "nan", "0.1234", "", "2"]
    queries = []
    for _ in range(n):
        params = ["%s=%s" % (rng.choice(names), rng.choice(values)) if rng.random() < 0.9 else rng.choice(names)
                  for _ in range(rng.randint(0, 4))]
        queries.append("&".join(params) + ("&" if rng.random() < 0.1 else ""))
    return {
        "decode": ["".join(rng.choice(pieces) for _ in range(rng.randint(1, 4))) for _ in range(n)],
        "encode": [[rng.choice([999, 1000, 1500, 2000, 2001]), rng.randint(990, 2010)] for _ in range(n)],
        "queries": queries,
        "speeds": [rng.choice(values) + rng.choice(["", "5", ".", "x"]) for _ in range(n)],
    }


def test_micropython_and_cpython_answer_alike_and_the_junior_rules_match_the_core(tmp_path):
    from roar_sim.core.junior import JuniorControl
    from roar_wire import control, junior

    cases = wire_cases()
    path = tmp_path / "cases.json"
    path.write_text(json.dumps(cases))
    got = json.loads(run("wire_cases.py", **{"/cases.json": path}))

    def answer(call, *args):
        try:
            return ["ok", call(*args)]
        except ValueError as e:
            return ["error", str(e)]

    assert got["decode"] == [json.loads(json.dumps(answer(control.decode, m.encode()))) for m in cases["decode"]]
    assert got["encode"] == [answer(lambda t, s: control.encode(t, s).decode(), t, s) for t, s in cases["encode"]]
    assert got["speeds"] == [junior.parse_unit_permille(s) for s in cases["speeds"]]
    assert got["queries"] == [json.loads(json.dumps(junior.parse_query(q))) for q in cases["queries"]]
    codes = {junior.UNKNOWN_NAME: "unknown parameter", junior.BAD_FLAG: "bad flag", junior.BAD_SPEED: "bad speed"}
    refused = 0
    for query, (actions, reason) in zip(cases["queries"], got["queries"]):
        applied, error = JuniorControl().apply_query(query, 0)
        if reason is None:
            assert (applied, error) == (len(actions), None), query
        else:
            refused += 1
            assert error == codes[reason.split(":")[0]] and applied == 0, query
    assert 50 < refused < len(cases["queries"]) - 50  # both kinds were exercised


def test_the_sbus_frames_decode_alike_on_micropython():
    path = ROOT / "protocol" / "vectors" / "sbus_frames.json"
    got = json.loads(run("sbus_vectors.py", **{"/sbus.json": path}))
    for case in json.loads(path.read_text())["cases"]:
        assert got[case["name"]] == [True, True, 2 if case["failsafe"] else 1], case["name"]
