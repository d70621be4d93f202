"""Board firmware: platformio.ini is valid and complete, board folders are thin glue with their
pins in one place and no wire constants of their own, and the boards that this machine's
toolchains can link (classic Nano, AnyFC F7 IARRC controller) build and fit."""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT

FIRMWARE = ROOT / "firmware"
ENVS = {  # env -> board folder
    "nanoatmega328": "arduino_ble",
    "nano33ble": "arduino_ble",
    "esp32cam": "esp32_cam",
    "esp32_junior": "esp32_junior",
    "anyfc_f7": "stm32_freertos",
}
BOARD_FOLDERS = sorted(set(ENVS.values()))


@pytest.fixture(scope="module")
def pio_config():
    pio = shutil.which("pio", path=str(Path(sys.executable).parent)) or shutil.which("pio")
    if pio is None:
        pytest.skip("platformio not installed: pip install platformio (make installs it)")
    proc = subprocess.run([pio, "project", "config", "--json-output"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120, env={"PATH": "/usr/bin:/bin", "HOME": str(ROOT / "build" / "pio-home"),
                                            "PLATFORMIO_CORE_DIR": str(ROOT / "build" / "pio-core")})
    assert proc.returncode == 0, proc.stderr
    return {section: dict(items) for section, items in json.loads(proc.stdout)}


def test_platformio_has_one_env_per_board(pio_config):
    envs = {name.removeprefix("env:"): cfg for name, cfg in pio_config.items() if name.startswith("env:")}
    assert set(envs) == set(ENVS)
    for name, cfg in envs.items():
        assert cfg["build_src_filter"] == [f"+<{ENVS[name]}/>"], name
        assert "symlink://firmware/core" in cfg["lib_deps"], name
        assert re.fullmatch(r"\w+@\^\d+", cfg["platform"]), f"{name}: pin the platform's major version"
        assert cfg["monitor_speed"] == 115200


def test_the_shared_library_and_the_custom_board_are_where_platformio_looks(pio_config):
    library = json.loads((FIRMWARE / "core" / "library.json").read_text())
    assert library["build"] == {"includeDir": "include", "srcDir": "src"}  # every source is every board's
    assert pio_config["platformio"]["src_dir"].endswith("firmware")
    board = json.loads((Path(pio_config["platformio"]["boards_dir"]) / "anyfc_f7.json").read_text())
    assert board["build"]["mcu"] == "stm32f745vgt6" and board["build"]["cpu"] == "cortex-m7"
    assert board["upload"]["maximum_size"] == 1024 * 1024 and board["upload"]["maximum_ram_size"] == 320 * 1024
    ld = pio_config["env:anyfc_f7"]["board_build.ldscript"]
    assert (ROOT / ld).exists()
    for script in pio_config["env:anyfc_f7"]["extra_scripts"]:
        assert (ROOT / script.removeprefix("pre:")).exists()


@pytest.mark.parametrize("folder", BOARD_FOLDERS)
def test_board_folders_are_thin_glue_with_pins_in_one_place(folder):
    board = FIRMWARE / folder
    assert (board / "pins.h").exists() and (board / "main.cpp").exists()
    for src in board.glob("*.cpp"):
        text = re.sub(r"//.*", "", src.read_text())  # code only: comments may explain the wiring
        # Pins are named in pins.h only: no raw pin numbers in calls.
        assert not re.search(r"\b(pinMode|digitalWrite|digitalRead|ledcAttachPin|attachInterrupt)\(\s*\d", text), src
        # Wire facts come from the generated protocol header, never typed again here.
        for literal in ("115200", "19b1", "ROAR Car", "(1500", "20000", "\"True\"", "left_spd"):
            assert literal not in text, f"{src.name} types {literal!r}: use roar/protocol.h"
    # Lines of code (comments and blank lines do not count: glue may explain the hardware).
    lines = sum(1 for p in board.glob("*.cpp") for ln in re.sub(r"//.*", "", p.read_text()).splitlines() if ln.strip())
    # The AnyFC F7 has no vendor framework: its startup code, register-level drivers for five
    # peripherals and two RTOS backends (FreeRTOS, SysTick) are its glue.
    limit = 500 if folder == "stm32_freertos" else 350
    assert lines < limit, f"{folder}: {lines} lines of glue; move logic into firmware/core"


avr = pytest.importorskip("roar_sim.toolchains.avr")
arm = pytest.importorskip("roar_sim.toolchains.arm")


def test_the_nano_firmware_builds_offline_and_fits():
    if avr.available():
        pytest.skip(avr.available())
    elf = avr.build(force=True)
    flash, ram = avr.sizes(elf)
    assert 1000 < flash < avr.FLASH_BYTES
    assert ram < avr.RAM_BYTES - 512  # leave room for the stack
    assert elf.with_suffix(".hex").read_text().startswith(":")


def test_the_anyfc_f7_controller_links_offline_with_its_vector_table_first():
    if not shutil.which("arm-none-eabi-g++"):
        pytest.skip("apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi")
    elf = arm.build()
    symbols = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    vector = next(line.split()[0] for line in symbols.splitlines() if line.endswith("vector_table"))
    assert int(vector, 16) == 0x08000000
    flash, ram = avr.sizes(elf, "arm-none-eabi-size")
    assert flash < 64 * 1024 and ram < 16 * 1024


def test_sizes_are_measured_and_printed_for_every_target(capsys):
    from roar_sim.toolchains import sizes

    missing = avr.available() or (None if shutil.which("arm-none-eabi-g++") else
                                        "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi")
    if missing:
        pytest.skip(f"the size report needs both cross toolchains: {missing}")
    rows = sizes.rows()
    assert [(chip, what) for chip, what, *_ in rows] == [
        ("ATmega328P (Nano)", "core, unlinked objects"), ("nRF52840 (Nano 33 BLE)", "core, unlinked objects"),
        ("STM32F745 (AnyFC F7)", "core, unlinked objects"), ("ATmega328P (Nano)", "whole firmware"),
        ("STM32F745 (AnyFC F7)", "IARRC controller (SysTick build)")]
    for chip, what, flash, ram, note in rows:
        assert note == "" and flash > 2000 and ram is not None, (chip, what, note)
    sizes.run()
    out = capsys.readouterr().out
    assert "skipped" not in out and out.count(" B ") == 2 * len(rows)


# --- what the glue that cannot be compiled here must do (each check failed on the old glue) ---

def glue(folder: str) -> str:
    """The code of a board folder's sources, comments removed."""
    return "\n".join(re.sub(r"//.*", "", p.read_text()) for p in sorted((FIRMWARE / folder).glob("*.cpp")))


@pytest.mark.parametrize("folder", BOARD_FOLDERS)
def test_frames_are_counted_where_they_start_not_estimated_from_the_clock(folder):
    """The brake tap must reach the ESC: frames_started() counts frames the output peripheral
    started, never elapsed time divided by the frame period."""
    code = glue(folder)
    assert not re.search(r"(micros\(\)|now_us\(\))[^;]*/\s*roar::proto::kTimingServoFrameUs", code), folder


WATCHDOGS = {  # folder -> (start, feed): the chip's own watchdog, started by the board
    "arduino_ble": [("wdt_enable(", "wdt_reset()"), ("Watchdog::get_instance().start(", "Watchdog::get_instance().kick()")],
    "esp32_cam": [("esp_task_wdt_add(", "esp_task_wdt_reset()")],
    "esp32_junior": [("esp_task_wdt_add(", "esp_task_wdt_reset()")],
    "stm32_freertos": [("reg::kIwdgStart", "reg::kIwdgFeed")],
}


@pytest.mark.parametrize("folder", BOARD_FOLDERS)
def test_every_board_starts_its_hardware_watchdog_and_feeds_it_from_the_loop(folder):
    code = glue(folder)
    for start, feed in WATCHDOGS[folder]:
        assert start in code and feed in code, (folder, start, feed)
    assert re.search(r"void (\w+::)?feed_watchdog\(\)( override)? \{[^}]*\}", code), f"{folder}: the HAL feeds the watchdog"


def test_ble_writes_reach_the_esp32_loop_through_the_ordered_queue():
    code = glue("esp32_cam")
    assert "roar::SpscBytes<" in code and ".push(" in code and ".pop(" in code
    assert not re.search(r"volatile\s+size_t", code), "hand-made volatile ring indices are not ordered across tasks"


def test_the_junior_serves_without_heap_strings_or_a_blocking_server():
    code = glue("esp32_junior")
    assert "WebServer" not in code and "String" not in code
    assert "O_NONBLOCK" in code and "roar::HttpRequestReader" in code and "board.poll()" in code


# --- the AnyFC F7 on FreeRTOS -------------------------------------------------------------------

def test_freertos_comes_through_platformio_and_is_never_in_the_repository(pio_config):
    env = pio_config["env:anyfc_f7"]
    assert any(dep.startswith("FreeRTOS-Kernel=https://github.com/FreeRTOS/FreeRTOS-Kernel.git#V")
               for dep in env["lib_deps"])
    assert env["lib_ignore"] == ["FreeRTOS-Kernel"] and "-DROAR_FREERTOS=1" in env["build_flags"]
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    assert not [p for p in tracked if Path(p).name in ("tasks.c", "queue.c", "FreeRTOS.h", "port.c")]
    # The PlatformIO script and the offline link compile the same kernel files.
    script = (FIRMWARE / "stm32_freertos" / "pio_freertos.py").read_text()
    assert re.findall(r'"\+<([^>]+)>"', script) == list(arm.FREERTOS_SOURCES)


def test_the_freertos_build_links_against_a_kernel_checkout():
    kernel = os.environ.get("ROAR_FREERTOS_KERNEL")
    if not kernel:
        pytest.skip("set ROAR_FREERTOS_KERNEL to a FreeRTOS-Kernel checkout (the tag platformio.ini names)")
    if not shutil.which("arm-none-eabi-g++"):
        pytest.skip("apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi")
    elf = arm.build_freertos(Path(kernel))
    symbols = subprocess.run(["arm-none-eabi-nm", str(elf)], capture_output=True, text=True, check=True).stdout
    for name in ("xTaskCreateStatic", "xTaskDelayUntil", "xStreamBufferSendFromISR", "SVC_Handler", "PendSV_Handler"):
        assert f" {name}" in symbols, name
