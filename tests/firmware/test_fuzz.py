"""Fuzzing as part of the suite: every libFuzzer target (C++, ASan + UBSan) and every atheris
target (Python) runs a few seconds on its stored corpus plus the inputs it makes, and fails on a
crash, a sanitizer report, a broken invariant or a hang; every corpus input gives the same
answers from the C++ core, CPython and MicroPython; the regression inputs stay harmless."""

from __future__ import annotations

import subprocess
import sys
from functools import partial

import pytest

from conftest import ROOT
from fuzz import differential, engine, native, python_targets, seeds

CHECK_S = 2.0  # [s] per target: every CI run executes each one on its corpus and new inputs


def _need_clang() -> None:
    problem = native.missing()
    if problem:
        pytest.skip(problem)


def _need_atheris() -> None:
    problem = engine.atheris_missing()
    if problem:
        pytest.skip(problem)


@pytest.fixture(scope="module")
def built():
    _need_clang()
    return native.build()


@pytest.mark.parametrize("name", native.targets())
def test_a_cpp_target_runs_clean_on_its_corpus_and_new_inputs(name, built):
    r = engine.run(name, engine.command(name, built), CHECK_S)
    assert r.ok, r.log
    assert r.executions > 100 and r.corpus >= 1


@pytest.mark.parametrize("name", engine.python_names())
def test_a_python_target_runs_clean_on_its_corpus_and_new_inputs(name):
    _need_atheris()
    r = engine.run(name, engine.command(name, {}), CHECK_S)
    assert r.ok, r.log
    assert r.executions > 50


def test_a_broken_invariant_is_caught_and_its_input_kept(built, tmp_path):
    """The machinery fails when a target does: a target whose invariant breaks on inputs
    starting with 'X', with such an input in its corpus."""
    source = tmp_path / "probe.cpp"
    source.write_text('#include "harness.h"\nextern "C" int LLVMFuzzerTestOneInput(const uint8_t* d, size_t n) '
                      '{ CHECK(n == 0 || d[0] != 0x58); return 0; }\n')
    exe = tmp_path / "probe"
    subprocess.run([native.compiler(), *native.FLAGS, f"-I{native.TARGETS_DIR}", "-fsanitize=fuzzer,address",
                    str(source), "-o", str(exe)], check=True, capture_output=True)
    corpus = tmp_path / "corpus"
    corpus.mkdir()
    (corpus / "x").write_bytes(b"X marks it")
    r = engine.run("probe", [str(exe)], 2, corpus=corpus, crashes=tmp_path / "crashes")
    assert not r.ok and "invariant broken" in r.log and "d[0] != 0x58" in r.log
    assert [p.read_bytes() for p in (tmp_path / "crashes").iterdir()] == [b"X marks it"]


def test_a_python_target_fails_on_a_broken_promise(monkeypatch):
    from roar_wire import junior

    monkeypatch.setattr(junior, "parse_query", lambda q: (None, "unknown parameter: 'a\nb'"))
    with pytest.raises(AssertionError):
        python_targets.junior_query(b"a")


def test_the_core_cpython_and_micropython_answer_every_corpus_input_alike():
    pytest.importorskip("cffi", reason="the core's binding needs roar-platform[sim]")
    from roar_sim.emulators import micropython

    report = differential.compare()
    assert report.ok, "\n".join(report.divergences[:10])
    assert all(report.inputs[f] >= 5 for f in differential.FAMILIES), report.inputs
    if micropython.available() is None:
        assert report.micropython == ""  # MicroPython was asked too


def test_a_divergence_is_reported_in_one_line_per_input(monkeypatch):
    pytest.importorskip("cffi", reason="the core's binding needs roar-platform[sim]")
    from fuzz import twins

    monkeypatch.setitem(twins.ANSWERS, "junior", lambda data: [0, 1])  # a twin that refuses everything
    report = differential.compare(("junior",), micropython=False)
    assert not report.ok and all(line.startswith("junior: input ") and "\n" not in line
                                 for line in report.divergences)


def test_the_depth_defect_stays_fixed():
    """A depth frame with a NaN principal point (once an exception in asyncio's datagram
    handler, uncounted): a regression input in the corpus, counted as malformed, never raising."""
    from roar import stream

    (regression,) = seeds.REGRESSIONS["py_stream"]
    assert regression in [p.read_bytes() for p in (seeds.CORPUS / "py_stream").iterdir()]
    python_targets.stream(regression)
    datagram = regression[1:]
    r = stream.Reassembler(whole=partial(stream.whole, "depth"))
    assert r.feed(datagram, 0.0) is None and r.counters.malformed == 1


def test_every_seed_is_in_the_stored_corpus():
    assert seeds.write() == 0, "seeds changed: run `python -m fuzz seed` and commit fuzz/corpus"


def test_the_command_line_checks_and_reports(tmp_path):
    _need_atheris()
    r = subprocess.run([sys.executable, "-m", "fuzz", "check", "--seconds", "1", "py_lines"], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "py_lines" in r.stdout and " ok " in r.stdout and "differential:" in r.stdout
    r = subprocess.run([sys.executable, "-m", "fuzz", "check", "nonsense"], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 2 and "no target nonsense" in r.stderr
