"""The firmware core under AddressSanitizer and UndefinedBehaviorSanitizer (the native C++ test
program, and the Python property tests re-run in a subprocess against the sanitized library),
and under ThreadSanitizer (the native test's two-thread BLE byte queue)."""

import os
import subprocess
import sys

import pytest

from conftest import ROOT
from roar_sim.toolchains import native

CORE_TESTS = ["test_vectors.py", "test_parser_properties.py", "test_brake_fsm.py", "test_failsafe.py", "test_timed_states.py",
              "test_outputs.py", "test_car.py"]


@pytest.mark.parametrize("variant", ["release", "sanitize", "thread"])
def test_native_core_test_program(variant):
    exe = native.build("native_test", variant)
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().splitlines()[-1].endswith(" passed, 0 failed")


def asan_runtime() -> str:
    path = subprocess.run([native.compiler(), "-print-file-name=libasan.so"], capture_output=True,
                          text=True).stdout.strip()
    if not os.path.isabs(path) or not os.path.exists(path):
        pytest.skip("AddressSanitizer runtime not found: apt-get install g++ (libasan)")
    return path


@pytest.mark.sanitizer
def test_property_tests_against_sanitized_core():
    lib = native.build("library", "sanitize")
    env = dict(os.environ, ROAR_CORE_LIB=str(lib), LD_PRELOAD=asan_runtime(),
               ASAN_OPTIONS="detect_leaks=0:abort_on_error=1", UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "not sanitizer",
                           *(str(next((ROOT / "tests").rglob(f))) for f in CORE_TESTS)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-25:])
    assert proc.returncode == 0, tail
    assert " passed" in tail and "failed" not in tail and "error" not in tail.lower()


def test_sanitized_library_really_is_instrumented():
    """Guards the test above against silently loading the plain build."""
    lib = native.build("library", "sanitize")
    symbols = subprocess.run(["nm", "-D", str(lib)], capture_output=True, text=True).stdout
    assert "__asan_" in symbols and "__ubsan_" in symbols
