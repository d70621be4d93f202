"""The SBUS decoder's cost per 25-byte frame (the IARRC car's receiver; a frame every 7 ms):
cycles on the ATmega328P in simavr (exact), and instructions on a Cortex-M4 in QEMU's
netduinoplus2 with -icount (calibrated against a loop of two instructions per iteration; an M4
spends about one cycle per instruction, a little more on loads and taken branches)."""

from roar_sim.emulators import qemu, simavr

from roar_sim.toolchains import arm, avr

TITLE = "SBUS decode cost per frame"
FRAME_PERIOD_S = 0.007  # [s] between frames
M4_HZ = 16e6  # [Hz] the AnyFC F7 glue's core clock (HSI), for the share of its time
M4_FRAMES = 50  # in sbus_bench.cpp


def run() -> None:
    missing = simavr.available()
    if missing:
        print(f"  ATmega328P: skipped ({missing})")
    else:
        cycles = simavr.parser_bench_pulses(0.2)[3][1] / avr.BENCH_SBUS_FRAMES
        share = cycles / (simavr.F_CPU * FRAME_PERIOD_S)
        print(f"  ATmega328P (16 MHz): {cycles:7,.0f} cycles per frame ({cycles / simavr.CYCLES_PER_US:.0f} us; "
              f"{share:.3f} of the CPU)")
    missing = qemu.available()
    if missing:
        print(f"  Cortex-M4: skipped ({missing})")
        return
    result = qemu.run(arm.build_sbus_bench())
    if result.returncode:
        print(f"  Cortex-M4: the bench image failed: {result.lines[-3:]}")
        return
    instructions = qemu.instructions(result, "frame_ticks") / M4_FRAMES
    print(f"  Cortex-M4 (QEMU -icount): {instructions:7,.0f} instructions per frame "
          f"({instructions / M4_HZ * 1e6:.0f} us at 16 MHz; {instructions / (M4_HZ * FRAME_PERIOD_S):.4f} of the CPU)")
