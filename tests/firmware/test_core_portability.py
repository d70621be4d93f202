"""The firmware core stays portable: no Arduino, RTOS, heap or standard-library dependencies, and
it compiles unchanged for the ATmega328P (Nano) and Cortex-M4F/M7 (nRF52840, STM32F745)."""

import re
import shutil

import pytest

from roar_sim.toolchains import native

PORTABLE = native.core_sources()
HEADERS = sorted((native.CORE / "include").rglob("*.h"))
FORBIDDEN = [
    (r"#include\s*[<\"](Arduino|FreeRTOS|task|Wire|Servo|esp_)", "board or RTOS include"),
    (r"#include\s*<(c?std[a-z]*|new|vector|string|array|algorithm|memory|functional)>", "C++ standard library header"),
    (r"\b(malloc|calloc|realloc|free)\s*\(|\bnew\s+[A-Za-z_]|\bdelete\b", "heap use"),
    (r"\bstd::", "std:: (absent on avr-gcc)"),
    (r"\b(float|double)\b", "floating point (the ATmega has no FPU)"),
]


@pytest.mark.parametrize("path", PORTABLE + HEADERS, ids=lambda p: p.name)
def test_no_board_rtos_heap_or_std_dependencies(path):
    text = re.sub(r"//.*", "", path.read_text())
    for pattern, what in FORBIDDEN:
        m = re.search(pattern, text)
        assert m is None, f"{path.name}: {what}: {m.group(0)!r}"


@pytest.mark.parametrize("target", sorted(native.CROSS_TARGETS))
def test_core_cross_compiles(target):
    cxx, _, packages = native.CROSS_TARGETS[target]
    if not shutil.which(cxx):
        pytest.skip(f"{cxx} not installed: apt-get install {packages}")
    objects = native.cross_compile(target)
    assert len(objects) == len(PORTABLE) and all(o.stat().st_size > 0 for o in objects)
