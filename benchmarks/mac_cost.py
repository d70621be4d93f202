"""What authenticating a control message would cost the smallest board: SipHash-2-4 (the MAC
chosen for the signed control mode, roar/siphash.h) of a 24-byte message on the ATmega328P in
simavr (exact cycles), fed byte by byte as the parser would. Target: <= 5 % of the CPU at 50
messages a second."""

from roar_sim.emulators import simavr
from roar_sim.toolchains import avr

TITLE = "SipHash-2-4 MAC per control message on the ATmega328P (<= 5 % of the CPU at 50 messages/s)"
MESSAGES_PER_S = 50
TARGET_SHARE = 0.05


def run() -> None:
    missing = simavr.available()
    if missing:
        print(f"  skipped ({missing})")
        return
    with simavr.EmulatedNano(avr.build_parser_bench()) as bench:
        bench.run(0.3)
        cycles = bench.pulse_cycles("B5")[4][1] / avr.BENCH_MACS
    share = cycles * MESSAGES_PER_S / simavr.F_CPU
    verdict = "ok" if share <= TARGET_SHARE else f"MISSED by {share - TARGET_SHARE:.3f}"
    print(f"  {cycles:,.0f} cycles per {avr.BENCH_MAC_BYTES}-byte MAC ({cycles / simavr.CYCLES_PER_US:.0f} us at "
          f"16 MHz); {share:.3f} of the CPU at {MESSAGES_PER_S} messages/s (target <= {TARGET_SHARE}: {verdict})")


if __name__ == "__main__":
    run()
