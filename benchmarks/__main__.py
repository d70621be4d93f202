"""Run all benchmarks: python -m benchmarks"""

import sys

from benchmarks import avr_emulator, host_latency, parser_throughput, race_ratio, sim_speed
from roar_sim import firmware_sizes

BENCHMARKS = [parser_throughput, sim_speed, host_latency, avr_emulator, firmware_sizes, race_ratio]


def main() -> int:
    for bench in BENCHMARKS:
        print(f"== {bench.TITLE}")
        bench.run()
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
