"""How fast each fuzz target runs (fuzz/): executions per second of every libFuzzer target
(C++ with ASan + UBSan) and atheris target (Python), each for a few seconds on its stored corpus
plus the inputs it makes, nothing kept. No target; a slow target gets fewer inputs in CI's
seconds, so a drop shows here first."""

from __future__ import annotations

TITLE = "fuzzing: executions per second of each target (ASan + UBSan for C++; atheris for Python)"
SECONDS = 5.0  # [s] per target


def run() -> None:
    from fuzz import engine, native

    problem = native.missing()
    built = {} if problem else native.build()
    names = ([] if problem else native.targets()) + ([] if engine.atheris_missing() else engine.python_names())
    if problem:
        print(f"  C++ targets skipped: {problem}")
    for name in names:
        r = engine.run(name, engine.command(name, built), SECONDS)
        print(f"  {name:16} {r.exec_per_s:>9,} exec/s  ({r.executions:,} in {SECONDS:g} s, corpus {r.corpus})"
              + ("" if r.ok else "  FAILED: python -m fuzz check " + name))


if __name__ == "__main__":
    run()
