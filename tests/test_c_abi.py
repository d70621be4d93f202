"""The C ABI is written once, in c_api.h; the Python binding reads that header with cffi. These
tests hold the two views together: the offset and size of every field of every struct as cffi
lays it out must be what a C compiler makes of the same header."""

import shutil
import subprocess

import pytest

from roar_sim.toolchains import native
from roar_sim.core.library import HEADER, ffi, lib


def structs() -> list[str]:
    typedefs, _, _ = ffi.list_types()
    return sorted(name for name in typedefs if ffi.typeof(name).kind == "struct")


def test_the_binding_sees_every_struct_of_the_header():
    assert structs() == ["roar_car_config_t", "roar_car_outputs_t", "roar_host_hal_t", "roar_iarrc_hal_t", "roar_iarrc_status_t",
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
    assert lib().roar_core_abi_version() == lib().ROAR_CORE_ABI_VERSION == 6
