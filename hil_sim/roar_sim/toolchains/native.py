"""Native build of the firmware core (firmware/core, with the host board of firmware/host): a shared
library the simulator loads, and the native C++ test program, each in a plain and a sanitized
(-fsanitize=address,undefined) variant.

In a checkout the sources are the checkout's and the builds go to build/host/; an installed wheel
carries the sources inside this package (setup.py puts them there) and builds into the user's
cache (~/.cache/roar/core, or under $XDG_CACHE_HOME) on first use. Builds are incremental
(rebuilt when any source or header is newer) and atomic (written to a temporary name, then
renamed), so parallel processes can share them.

    python -m roar_sim.toolchains.native [--variant release|sanitize] [--force]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from roar_sim import CoreBuildError
from roar_sim.toolchains import build_lock, stale

ROOT = Path(__file__).resolve().parents[3]  # the checkout, when this runs from one
PACKAGED = Path(__file__).resolve().parent / "firmware"  # an installed wheel's copy of firmware/core and /host
INSTALLED = PACKAGED.is_dir()
FIRMWARE = PACKAGED if INSTALLED else ROOT / "firmware"
CORE = FIRMWARE / "core"
HOST_BOARD = FIRMWARE / "host"  # the C ABI and the memory-backed HALs: host build only


def user_cache(part: str) -> Path:
    """The user's cache folder for `part` of the simulator (~/.cache/roar/PART, or under
    $XDG_CACHE_HOME): an installed core's build, measured car limits."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "roar" / part


BUILD = user_cache("core") if INSTALLED else ROOT / "build" / "host"

WARNINGS = ["-Wall", "-Wextra", "-Wpedantic", "-Werror"]
VARIANTS = {
    "release": ["-O2"],
    "sanitize": ["-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"],
    "thread": ["-O1", "-g", "-fsanitize=thread"],  # the native test's two-thread queue test, raced
}
TARGETS = {
    "library": ("libroarcore.so", ["-shared", "-fPIC"], []),
    "native_test": ("test_core", ["-pthread"], [CORE / "test" / "test_core.cpp"]),
}


# Microcontroller targets: the core must compile for them unchanged. avr-gcc 5.4 (Debian) knows
# C++17 only as gnu++1z, which is why the core sticks to C++14 features and <stdint.h>.
CROSS_TARGETS = {
    "atmega328p": ("avr-g++", ["-std=gnu++1z", "-mmcu=atmega328p", "-DF_CPU=16000000L"], "gcc-avr avr-libc"),
    "cortex-m4f": ("arm-none-eabi-g++", ["-std=c++17", "-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16",
                                         "-mfloat-abi=hard"], "gcc-arm-none-eabi libnewlib-arm-none-eabi"),
    "cortex-m7": ("arm-none-eabi-g++", ["-std=c++17", "-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-sp-d16",
                                        "-mfloat-abi=hard"], "gcc-arm-none-eabi libnewlib-arm-none-eabi"),
}
# Every microcontroller build: small code, unused sections dropped, no exceptions/RTTI, no warnings.
EMBEDDED_FLAGS = ["-Os", "-ffunction-sections", "-fdata-sections", "-fno-exceptions", "-fno-rtti",
                  "-Wall", "-Wextra", "-Werror"]


def run_build(cmd: list[str], failure: str) -> None:
    """Run a compiler or linker; on failure raise CoreBuildError("<failure>: <first error line>")."""
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        first = next((ln for ln in proc.stderr.splitlines() if "error" in ln), proc.stderr.strip()[:300])
        raise CoreBuildError(f"{failure}: {first}")


def core_sources() -> list[Path]:
    return sorted((CORE / "src").glob("*.cpp"))


def host_sources() -> list[Path]:
    return sorted(HOST_BOARD.glob("*.cpp"))


def _inputs(extra: list[Path]) -> list[Path]:
    return (core_sources() + host_sources() + sorted((CORE / "include").rglob("*.h")) + sorted(HOST_BOARD.glob("*.h"))
            + sorted((CORE / "test").glob("*.h")) + extra)


def output_path(target: str = "library", variant: str = "release") -> Path:
    return BUILD / variant / TARGETS[target][0]


def compiler() -> str:
    """The C++ compiler: $CXX, or c++ / g++ on the PATH; CoreBuildError (one line) if there is none."""
    wanted = os.environ.get("CXX")
    cxx = shutil.which(wanted) if wanted else shutil.which("c++") or shutil.which("g++")
    if not cxx:
        missing = f"CXX={wanted} is not a program here" if wanted else "there is no C++ compiler here"
        raise CoreBuildError(f"the simulator builds the firmware core with a C++ compiler, and {missing}: install g++ "
                             f"(apt-get install g++) or set CXX")
    return cxx


def build(target: str = "library", variant: str = "release", force: bool = False) -> Path:
    """Build (if stale) and return the path of the target."""
    if not CORE.is_dir():
        raise CoreBuildError(f"the firmware core's sources are not at {CORE}: reinstall roar-platform[sim]")
    if target not in TARGETS or variant not in VARIANTS:
        raise CoreBuildError(f"unknown build {target}/{variant}: targets {sorted(TARGETS)}, variants {sorted(VARIANTS)}")
    out = output_path(target, variant)
    with build_lock(out):
        if force or stale(out, _inputs(TARGETS[target][2])):
            _build(target, variant, out)
    return out


def _build(target: str, variant: str, out: Path) -> None:
    name, link_flags, extra = TARGETS[target]
    fd, tmp = tempfile.mkstemp(prefix=name + ".", dir=out.parent)
    os.close(fd)
    cmd = [compiler(), "-std=c++17", *WARNINGS, *VARIANTS[variant], *link_flags, "-I", str(CORE / "include"),
           "-I", str(HOST_BOARD), "-I", str(CORE / "test"), *map(str, core_sources() + host_sources() + extra), "-o", tmp]
    try:
        run_build(cmd, f"host build of firmware/core failed ({variant})")
    except CoreBuildError:
        os.unlink(tmp)
        raise
    os.chmod(tmp, 0o755)
    os.replace(tmp, out)


def cross_compile(target: str) -> list[Path]:
    """Compile the portable core sources for a microcontroller; returns the object files."""
    cxx, flags, packages = CROSS_TARGETS[target]
    if not shutil.which(cxx):
        raise CoreBuildError(f"{cxx} not found: apt-get install {packages}")
    out_dir = ROOT / "build" / "cross" / target
    out_dir.mkdir(parents=True, exist_ok=True)
    objects = []
    for src in core_sources():
        obj = out_dir / (src.stem + ".o")
        with build_lock(obj):  # the suite's workers and the size report compile the same objects
            tmp = obj.with_suffix(".o.tmp")
            run_build([cxx, *flags, *EMBEDDED_FLAGS, "-I", str(CORE / "include"), "-c", str(src), "-o", str(tmp)],
                      f"{target} build of firmware/core failed")
            os.replace(tmp, obj)
        objects.append(obj)
    return objects


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Build the firmware core for the host.")
    parser.add_argument("--variant", choices=sorted(VARIANTS), default="release")
    parser.add_argument("--target", choices=sorted(TARGETS), default="library")
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    try:
        print(build(args.target, args.variant, args.force).relative_to(ROOT))
    except CoreBuildError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
