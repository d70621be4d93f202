"""The binding of the firmware core's C ABI (firmware/host/c_api.h) through cffi, which reads
the declarations from that header itself: the ABI is written once, in C, and the codes that cross
it are Python enums built from its C enums.

The library is the native build of roar_sim.toolchains.native (built on first use); set
ROAR_CORE_LIB to load another build (the sanitizer test does). Times are the core's 64-bit
microseconds, which never wrap; the board loops run on the wrapping 32-bit counter a board's
hardware has.
"""

from __future__ import annotations

import os
import re
from enum import IntEnum
from functools import lru_cache
from pathlib import Path

from cffi import FFI

from roar_sim import CoreLoadError
from roar_sim.toolchains import native

HEADER = native.HOST_BOARD / "c_api.h"
U32_MASK = 0xFFFFFFFF  # a board's free-running microsecond counter and its frame count wrap at 2^32


def declarations(header_text: str) -> str:
    """c_api.h as cffi's cdef() takes it: the declarations, without the include guard, the
    includes and the C++-only lines; integer #defines stay (cffi knows them)."""
    lines, skipping = [], False
    for line in header_text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#ifdef __cplusplus"):
            skipping = True
        elif skipping:
            skipping = not stripped.startswith("#endif")
        elif not stripped.startswith("#") or re.fullmatch(r"#define\s+ROAR_\w+\s+\d+", stripped):
            lines.append(line)
    return "\n".join(lines)


ffi = FFI()
ffi.cdef(declarations(HEADER.read_text()))


def library_path() -> Path:
    """The library to load: $ROAR_CORE_LIB, or the release host build (built if stale)."""
    override = os.environ.get("ROAR_CORE_LIB")
    if override:
        return Path(override)
    try:
        return native.build("library", "release")
    except native.CoreBuildError as e:
        raise CoreLoadError(str(e)) from None


@lru_cache(maxsize=None)
def _lib_at(path: str):
    try:
        lib = ffi.dlopen(path)
    except OSError as e:
        raise CoreLoadError(f"cannot load firmware core {path}: {e}") from None
    if lib.roar_core_abi_version() != lib.ROAR_CORE_ABI_VERSION:  # a library built from another header
        raise CoreLoadError(f"{path}: C ABI version {lib.roar_core_abi_version()}, "
                            f"{HEADER.name} says {lib.ROAR_CORE_ABI_VERSION}")
    return lib


def lib():
    return _lib_at(str(library_path()))


def new_object(size_fn: str):
    """Zeroed memory for one core object (roar_*_size() bytes), 8-byte aligned (uint64_t units)."""
    size = getattr(lib(), size_fn)()
    return ffi.new("uint64_t[]", (size + 7) // 8)


def as_bytes(data: bytes):
    return ffi.from_buffer("uint8_t[]", bytes(data))


def c_enum(name: str) -> type[IntEnum]:
    """An IntEnum of a C enum of c_api.h: roar_brake_phase's ROAR_BRAKE_PHASE_TAP is BrakePhase.TAP."""
    prefix = name.upper() + "_"
    members = sorted(ffi.typeof(f"enum {name}").relements.items(), key=lambda item: item[1])
    title = "".join(part.capitalize() for part in name.removeprefix("roar_").split("_"))
    return IntEnum(title, [(key.removeprefix(prefix), value) for key, value in members], module=__name__)


# The codes that cross the ABI, each the twin of one of the core's enum classes (c_api.cpp holds
# them equal at compile time; tests/firmware/test_c_abi.py checks the C++ headers against these).
WatchdogEvent = c_enum("roar_watchdog_event")
BrakePhase = c_enum("roar_brake_phase")
ControlSource = c_enum("roar_control_source")
RcChannel = c_enum("roar_rc_channel")
HttpRead = c_enum("roar_http_read")
JuniorQueryError = c_enum("roar_junior_query_error")
ModeSwitch = c_enum("roar_mode_switch")
IarrcTask = c_enum("roar_iarrc_task")

