"""The C ABI is written once, in c_api.h; the Python binding reads that header with cffi. These
tests hold the views together: the offset and size of every field of every struct as cffi lays it
out must be what a C compiler makes of the same header, and every code that crosses the ABI
must be the core's own."""

import re
import shutil
import subprocess

import pytest

from roar_sim.core import library
from roar_sim.core.library import HEADER, ffi, lib
from roar_sim.toolchains import native


def structs() -> list[str]:
    typedefs, _, _ = ffi.list_types()
    return sorted(name for name in typedefs if ffi.typeof(name).kind == "struct")


def test_the_binding_sees_every_struct_of_the_header():
    assert structs() == ["roar_car_config_t", "roar_car_outputs_t", "roar_flash_t", "roar_host_hal_t", "roar_iarrc_hal_t", "roar_iarrc_status_t",
                         "roar_junior_hal_t", "roar_parse_event_t", "roar_sbus_frame_t", "roar_sbus_status_t",
                         "roar_side_pins_t", "roar_task_spec_t"]


def test_every_field_has_the_offset_and_size_the_c_compiler_gives_it(tmp_path):
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler: apt-get install gcc")
    expected, lines = {}, []
    for name in structs():
        struct = ffi.typeof(name)
        expected[name] = ffi.sizeof(struct)
        lines.append(f'  printf("{name} %zu\\n", sizeof({name}));')
        for field, info in struct.fields:
            key = f"{name}.{field}"
            expected[key] = (info.offset, ffi.sizeof(info.type))
            lines.append(f'  printf("{key} %zu %zu\\n", offsetof({name}, {field}), sizeof((({name} *)0)->{field}));')
    program = tmp_path / "layout.c"
    program.write_text("#include <stddef.h>\n#include <stdio.h>\n#include \"c_api.h\"\n"
                       "int main(void) {\n" + "\n".join(lines) + "\n  return 0;\n}\n")
    exe = tmp_path / "layout"
    native.run_build([cc, "-std=c11", "-Wall", "-Werror", "-I", str(HEADER.parent), str(program), "-o",
                          str(exe)], "layout program build failed")
    measured = {}
    for line in subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.splitlines():
        key, *numbers = line.split()
        measured[key] = int(numbers[0]) if len(numbers) == 1 else (int(numbers[0]), int(numbers[1]))
    assert measured == expected
    assert sum("." in key for key in expected) > 40  # every field of every struct was compared


def test_the_loaded_library_speaks_the_headers_abi_version():
    assert lib().roar_core_abi_version() == lib().ROAR_CORE_ABI_VERSION == 11


# --- the codes that cross the ABI -----------------------------------------------------------

CODES = ("WatchdogEvent", "BrakePhase", "ControlSource", "RcChannel", "HttpRead", "JuniorQueryError", "ModeSwitch",
         "IarrcTask")


def cpp_enums() -> dict[str, dict[str, int]]:
    """Every `enum class` of the core's headers: {name: {MEMBER_IN_UPPER_SNAKE: value}}."""
    found = {}
    for header in sorted((native.CORE / "include").rglob("*.h")):
        text = re.sub(r"//[^\n]*", "", header.read_text())
        for name, body in re.findall(r"enum class (\w+) : uint8_t \{(.*?)\};", text, re.S):
            members, value = {}, -1
            for item in filter(None, (part.strip() for part in body.split(","))):
                member, _, given = (part.strip() for part in item.partition("="))
                value = int(given) if given else value + 1
                members[re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", member).upper()] = value
            found[name] = members
    return found


@pytest.mark.parametrize("name", CODES)
def test_every_code_the_binding_knows_is_the_cores_own(name):
    """The Python enum (built from c_api.h's C enum) has the members and values of the core's
    C++ enum class of the same name: this fails when either changes without the other."""
    python = getattr(library, name)
    assert {m.name: int(m) for m in python} == cpp_enums()[name]


def test_c_api_cpp_holds_every_c_enum_member_to_the_core_at_compile_time():
    source = (native.HOST_BOARD / "c_api.cpp").read_text()
    for name in CODES:
        for member in getattr(library, name):
            camel = "".join(part.capitalize() for part in member.name.split("_"))
            c_name = f"ROAR_{re.sub(r'(?<=[a-z0-9])(?=[A-Z])', '_', name).upper()}_{member.name}"
            assert f"ROAR_SAME_CODE({name}::{camel}, {c_name});" in source


def test_a_core_enum_that_drifts_from_c_api_h_fails_the_build(tmp_path):
    """Change one C++ code and the host build stops at c_api.cpp's static_assert."""
    shutil.copytree(native.CORE / "include", tmp_path / "include")
    header = tmp_path / "include" / "roar" / "brake_fsm.h"
    header.write_text(header.read_text().replace("Tap = 2,", "Tap = 5,"))
    proc = subprocess.run([native.compiler(), "-std=c++17", "-fsyntax-only", "-I", str(tmp_path / "include"), "-I",
                           str(native.HOST_BOARD), str(native.HOST_BOARD / "c_api.cpp")], capture_output=True, text=True)
    assert proc.returncode != 0 and "ROAR_BRAKE_PHASE_TAP in c_api.h differs from BrakePhase::Tap" in proc.stderr
