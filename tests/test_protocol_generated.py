"""The spec is the only place wire facts are typed: generated files must match it."""

import subprocess
import sys

import pytest

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent.parent / "protocol"))
import generate  # noqa: E402

from conftest import ROOT  # noqa: E402


def test_generated_files_are_up_to_date():
    assert generate.stale_files() == [], "run: python protocol/generate.py"


def test_check_mode_reports_clean_tree():
    proc = subprocess.run([sys.executable, str(ROOT / "protocol" / "generate.py"), "--check"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


def test_python_constants_match_spec():
    from roar.protocol import spec
    for k in generate.load_spec():
        if k.section != "parse_result":
            assert getattr(spec, k.py_name) == k.value
    assert spec.CONTROL_EXAMPLE == "(1500,1500)" and len(spec.CONTROL_EXAMPLE) == spec.CONTROL_MAX_MESSAGE_BYTES


def test_cpp_header_carries_every_constant():
    header = generate.CPP_HEADER.read_text()
    for k in generate.load_spec():
        if k.section != "parse_result":
            assert f" {k.cpp_name}" in header


def test_parse_result_codes_agree_with_the_core():
    from roar.protocol.spec import ParseResult
    header = generate.CPP_HEADER.read_text()
    for r in ParseResult:
        camel = "".join(p.capitalize() for p in r.name.lower().split("_"))
        assert f"{camel} = {int(r)}," in header


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
