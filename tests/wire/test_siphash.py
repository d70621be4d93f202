"""SipHash-2-4, the MAC the signed control mode is built on: the core (roar/siphash.h, through
its C ABI), roar_wire on CPython and the same file on MicroPython give the published golden
vectors, and streaming a message in any pieces gives the MAC of the whole."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from conftest import ROOT
from roar_wire import siphash

VECTORS = json.loads((ROOT / "protocol" / "vectors" / "siphash24.json").read_text())
KEY = bytes.fromhex(VECTORS["key"])
CASES = [(c["n"], int(c["mac"], 16)) for c in VECTORS["cases"]]


def test_the_python_twin_gives_every_published_vector():
    assert len(CASES) == 64
    assert all(siphash.mac(KEY, bytes(range(n))) == want for n, want in CASES)


def test_the_core_gives_every_published_vector():
    pytest.importorskip("cffi", reason="the core's binding needs roar-platform[sim]")
    from roar_sim.core.library import as_bytes, lib

    assert all(lib().roar_siphash24(as_bytes(KEY), as_bytes(bytes(range(n))), n) == want for n, want in CASES)


def test_micropython_gives_every_published_vector(tmp_path):
    from roar_sim.emulators import micropython

    problem = micropython.available()
    if problem:
        pytest.skip(problem)
    program = tmp_path / "vectors.py"
    program.write_text("import json\nfrom roar_wire import siphash\n"
                       "v = json.load(open('/v.json'))\nkey = bytes.fromhex(v['key'])\n"
                       "print(json.dumps(['%016x' % siphash.mac(key, bytes(range(c['n']))) for c in v['cases']]))\n")
    vectors = ROOT / "protocol" / "vectors" / "siphash24.json"
    result = micropython.run(program, {**micropython.portable_files(), "/v.json": vectors})
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout) == [c["mac"] for c in VECTORS["cases"]]


@given(key=st.binary(min_size=16, max_size=16), data=st.binary(max_size=300))
def test_the_core_and_the_twin_agree_on_any_key_and_message(key, data):
    pytest.importorskip("cffi", reason="the core's binding needs roar-platform[sim]")
    from roar_sim.core.library import as_bytes, lib

    assert lib().roar_siphash24(as_bytes(key), as_bytes(data), len(data)) == siphash.mac(key, data)


def test_a_key_that_is_not_16_bytes_is_refused():
    with pytest.raises(ValueError, match="16 bytes"):
        siphash.mac(b"short", b"")
