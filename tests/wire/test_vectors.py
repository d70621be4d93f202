"""Both parsers, the Python host decoder and the C++ firmware parser, run every golden vector."""

import json

import pytest

from conftest import ROOT
from roar.protocol import ParseResult, StreamDecoder
from roar_sim.core import car

CASES = json.loads((ROOT / "protocol" / "vectors" / "control_messages.json").read_text())["cases"]
PARSERS = {"python": StreamDecoder, "cpp": car.ControlParser}


def expected(case):
    return [(ev["at"], ev["result"], ev.get("throttle", ev.get("speed")), ev.get("steering"),
             (ev["counter"], int(ev["mac"], 16)) if "mac" in ev else None) for ev in case["events"]]


def run(parser, case):
    got = []
    for chunk in case["chunks"]:
        for ev in parser.feed(chunk.encode("latin-1")):
            cmd, sp = ev.command, ev.setpoint
            first = cmd.throttle_us if cmd else (sp.speed_mm_s if sp else None)
            steering = cmd.steering_us if cmd else (sp.steering_us if sp else None)
            got.append((ev.at, str(ev.result), first, steering, ev.signature))
    return got


@pytest.mark.parametrize("impl", sorted(PARSERS))
@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_vector(impl, case):
    assert run(PARSERS[impl](), case) == expected(case)


def test_vectors_cover_every_rejection_reason():
    """Every result the parser gives (the rest, unsigned .. nokey, are the authenticator's:
    protocol/vectors/signed_messages.json)."""
    seen = {ev["result"] for case in CASES for ev in case["events"]}
    assert seen == {str(r) for r in ParseResult if ParseResult.NONE < r <= ParseResult.SETPOINT}
    assert any("mac" in ev for case in CASES for ev in case["events"])


@pytest.mark.parametrize("impl", sorted(PARSERS))
def test_all_vectors_through_one_parser(impl):
    """Fed one after another with a line end between, every case still gives exactly its own
    events: a line end returns the parser to idle whatever state the previous case left."""
    parser = PARSERS[impl]()
    for case in CASES:
        start = parser.offset
        got = [(at - start, r, t, s, sig) for at, r, t, s, sig in run(parser, case)]
        parser.feed(b"\n")
        assert got == expected(case), case["name"]
