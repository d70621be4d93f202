"""python -m fuzz COMMAND: see fuzz/__init__.py. Exit status 1 when a target crashed, broke an
invariant or hung, or when the C++ core and a twin answered an input differently."""

from __future__ import annotations

import argparse
import sys

from fuzz import differential, engine, native, seeds

RUN_S = 120.0  # [s] per target for `run` (make fuzz)
CHECK_S = 2.0  # [s] per target for `check` (the suite)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m fuzz", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)
    for name, seconds, what in (("run", RUN_S, "grow each corpus and minimise it into fuzz/corpus"),
                                ("check", CHECK_S, "each target on its corpus plus new inputs; nothing kept")):
        c = sub.add_parser(name, help=what)
        c.add_argument("targets", nargs="*", metavar="TARGET", help="default: all (C++ and py_*)")
        c.add_argument("--seconds", type=float, default=seconds, help=f"per target (default {seconds:g})")
    sub.add_parser("diff", help="every corpus input to the C++ core and its twins (CPython, MicroPython)")
    sub.add_parser("seed", help="write the seeds and regression inputs into fuzz/corpus")
    args = p.parse_args(argv)
    if args.command == "seed":
        print(f"{seeds.write()} new seed(s)")
        return 0
    if args.command == "diff":
        return _diff()
    return _fuzz(args.targets, args.seconds, grow=args.command == "run")


def _fuzz(names: list[str], seconds: float, grow: bool) -> int:
    seeds.write()
    cpp = [n for n in names if not n.startswith(engine.PY_PREFIX)] if names else native.targets()
    py = [n for n in names if n.startswith(engine.PY_PREFIX)] if names else engine.python_names()
    unknown = set(cpp) - set(native.targets()) | set(py) - set(engine.python_names())
    if unknown:
        print(f"fuzz: no target {', '.join(sorted(unknown))}; there are {', '.join(native.targets() + engine.python_names())}",
              file=sys.stderr)
        return 2
    failed = 0
    built = {}
    problem = native.missing()
    if problem and cpp:
        print(f"fuzz: C++ targets skipped: {problem}", file=sys.stderr)
        cpp = []
    if cpp:
        built = native.build(cpp)
    problem = engine.atheris_missing()
    if problem and py:
        print(f"fuzz: Python targets skipped: {problem}", file=sys.stderr)
        py = []
    for name in cpp + py:
        r = engine.run(name, engine.command(name, built), seconds, grow=grow)
        print(f"{name:16} {'ok' if r.ok else 'FAILED':6} {r.executions:>10,} runs {r.exec_per_s:>9,}/s  "
              f"corpus {r.corpus}", flush=True)
        if not r.ok:
            failed += 1
            print("\n".join("    " + line for line in r.log.strip().splitlines()[-25:]), file=sys.stderr)
            print(f"    the input is in {engine.CRASHES / name}/", file=sys.stderr)
    return 1 if failed or _diff() else 0


def _diff() -> int:
    report = differential.compare()
    counts = ", ".join(f"{n} {f}" for f, n in report.inputs.items())
    twins = "CPython" + ("" if report.micropython else " and MicroPython")
    print(f"differential: {counts} inputs, C++ core against {twins}: "
          f"{'the same answers' if report.ok else f'{len(report.divergences)} divergence(s)'}")
    if report.micropython:
        print(f"    MicroPython not asked: {report.micropython}", file=sys.stderr)
    for line in report.divergences[:20]:
        print("    " + line, file=sys.stderr)
    return 0 if report.ok else 1


if __name__ == "__main__":
    sys.exit(main())
