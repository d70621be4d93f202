"""The spec is the only place wire facts are typed: generated files must match it."""

import subprocess
import sys

import pytest

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[2] / "protocol"))
import generate  # noqa: E402

from conftest import ROOT  # noqa: E402


def test_generated_files_are_up_to_date():
    assert generate.stale_files() == [], "run: python protocol/generate.py"


def test_a_run_with_nothing_to_write_says_so():
    proc = subprocess.run([sys.executable, str(ROOT / "protocol" / "generate.py")], capture_output=True, text=True)
    assert proc.returncode == 0 and "generated files up to date with protocol/spec.toml" in proc.stdout


def test_check_mode_reports_clean_tree():
    proc = subprocess.run([sys.executable, str(ROOT / "protocol" / "generate.py"), "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_python_constants_match_spec():
    from roar.protocol import spec
    for k in generate.load_spec():
        assert getattr(spec, k.py_name) == k.value
    assert spec.CONTROL_EXAMPLE == "(1500,1500)" and len(spec.CONTROL_EXAMPLE) == spec.CONTROL_MAX_MESSAGE_BYTES


def test_cpp_header_carries_every_constant():
    header = generate.CPP_HEADER.read_text()
    for k in generate.load_spec():
        if k.section not in generate.ENUMS:
            assert f" {k.cpp_name}" in header


@pytest.mark.parametrize("section", generate.ENUMS)
def test_enum_codes_and_words_agree_between_the_core_and_python(section):
    """Each enum section is a C++ enum class with its words, a Python IntEnum whose str() is the
    word, and the portable module's tuple of words, all with the same codes."""
    from roar.protocol import spec
    from roar_wire import spec as portable

    header = generate.CPP_HEADER.read_text()
    name = "".join(p.capitalize() for p in section.split("_"))
    enum = getattr(spec, name)
    assert [str(e) for e in enum] == list(getattr(portable, f"{section.upper()}_TOKENS"))
    assert f"static constexpr uint8_t k{name}Count = {len(enum)};" in header
    for e in enum:
        camel = "".join(p.capitalize() for p in e.name.lower().split("_"))
        assert f"  {camel} = {int(e)}," in header and f'case {name}::{camel}: return "{e}";' in header


def test_the_telemetry_words_the_core_prints_are_the_spec_s():
    """The IARRC board's TEL line spells its mode and failsafe with the generated words (with no
    transmitter it stays disarmed)."""
    from roar.protocol.spec import IarrcFailsafe, IarrcMode
    from roar_sim.core.iarrc import IarrcBoard

    board = IarrcBoard()
    board.begin()
    for t in range(0, 200_000, 1_000):
        for task in range(6):
            board.run(task, t)
    line = next(line for line in board.host_out.decode().splitlines() if line.startswith("TEL "))
    mode, failsafe = line.split()[1:3]
    assert (mode, failsafe) == (str(IarrcMode.DISARMED), str(IarrcFailsafe.NONE)) == ("disarmed", "none")


@pytest.mark.parametrize("body, message", [
    ('[control]\nmin_us = { value = 1000, unit = "us" }\n', "exactly value, unit, doc"),
    ('[Control]\n', "lower_snake_case"),
    ('[control]\nmin_us = { value = true, unit = "", doc = "x" }\n', "integer, a float or a string"),
    ('[control\n', "invalid TOML"),
    ('[control]\nmin_us = { value = 1, unit = "us", doc = "x" }\n', "missing constant"),
])
def test_bad_spec_gives_one_line_error(tmp_path, body, message):
    bad = tmp_path / "spec.toml"
    bad.write_text(body)
    with pytest.raises(generate.SpecError) as err:
        generate.load_spec(bad)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_inconsistent_spec_is_rejected(tmp_path):
    text = generate.SPEC.read_text().replace("brake_tap_us = { value = 1450", "brake_tap_us = { value = 1600")
    bad = tmp_path / "spec.toml"
    bad.write_text(text)
    with pytest.raises(generate.SpecError, match="slight reverse"):
        generate.load_spec(bad)


@pytest.mark.parametrize("body, message", [
    ('{"cases": []}', "non-empty"),
    ('{"cases": [{"name": "a", "chunks": ["()"], "events": [{"at": 9, "result": "syntax"}]}]}', "bad event"),
    ('{"cases": [{"name": "a", "chunks": ["()"], "events": [{"at": 1, "result": "ok"}]}]}', "carry throttle"),
    ('{"cases": [', "invalid JSON"),
])
def test_bad_vectors_give_one_line_error(tmp_path, body, message):
    bad = tmp_path / "v.json"
    bad.write_text(body)
    with pytest.raises(generate.SpecError, match=message):
        generate.load_vectors(bad)
