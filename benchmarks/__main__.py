"""Run all benchmarks: python -m benchmarks"""

import sys

from benchmarks import parser_throughput

BENCHMARKS = [parser_throughput]


def main() -> int:
    for bench in BENCHMARKS:
        print(f"== {bench.TITLE}")
        bench.run()
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
