"""Benchmarks: `make bench` runs every module listed in benchmarks.__main__ and prints ratios
measured in one run (never used as pass/fail thresholds in tests)."""
