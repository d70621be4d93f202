"""The AnyFC F7 board's clock in an emulated STM32 (QEMU netduinoplus2): the board's own
clock_source.cpp unlocks and starts the DWT cycle counter, checks that it advances, and falls
back to TIM2 at 1 MHz when it does not, as in QEMU, which does not model the DWT."""

import pytest

from roar_sim.emulators import qemu

from roar_sim.toolchains import arm

if qemu.available():
    pytest.skip(qemu.available(), allow_module_level=True)


@pytest.fixture(scope="module")
def probe():
    return qemu.run(arm.build_clock_probe())


def test_a_stopped_cycle_counter_is_detected_and_timer2_takes_over(probe):
    assert probe.value("clock") == "timer2"


def test_the_fallback_clock_advances_and_never_steps_back(probe):
    assert probe.returncode == 0, probe.lines
    assert int(probe.value("backwards")) == 0
    assert int(probe.value("advanced_us")) > 0


def test_the_sbus_decoder_runs_on_the_emulated_cortex_m4():
    """The core's SbusDecoder, built for the Cortex-M4, decodes every frame of the bench image,
    and its timing (SysTick on the instruction-counted virtual clock) is the same every run."""
    elf = arm.build_sbus_bench()
    first, second = qemu.run(elf), qemu.run(elf)
    assert first.returncode == 0 and first.value("frames") == "50"
    assert first.value("frame_ticks") == second.value("frame_ticks") and int(first.value("frame_ticks")) > 0


def test_the_declared_task_costs_cover_each_task_body_on_a_cortex_m4():
    """The task table's costs (what the scheduler tests prove deadlines with) hold: each body at
    its worst input, counted in instructions, at one cycle each at 16 MHz plus a quarter."""
    from roar_sim.core.iarrc import iarrc_tasks

    result = qemu.run(arm.build_task_bench())
    assert result.returncode == 0, result.lines
    measured = qemu.task_instructions(result)
    tasks = {t.name: t for t in iarrc_tasks()}
    assert set(measured) == set(tasks)
    for name, instructions in measured.items():
        assert 0 < instructions * 1.25 / 16 <= tasks[name].cost_us, (name, instructions)
    assert measured["rc"] > measured["control"]  # 64 SBUS bytes are the heaviest run
