"""Run all benchmarks: python -m benchmarks"""

import sys

from benchmarks import host_latency, parser_throughput, sim_speed

BENCHMARKS = [parser_throughput, sim_speed, host_latency]


def main() -> int:
    for bench in BENCHMARKS:
        print(f"== {bench.TITLE}")
        bench.run()
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
