"""Fuzzing, the project's own: coverage-guided fuzz targets for every decoder and board input
path, their corpora kept here, and a differential runner that holds the C++ core, its Python
twins and MicroPython to the same answers on every corpus input.

    fuzz/targets/*.cpp      libFuzzer targets over the core's C ABI (ASan + UBSan), each
                            asserting the invariants its header promises
    fuzz/python_targets.py  atheris targets for the host's decoders and file readers
    fuzz/corpus/TARGET/     the stored corpus of each target (seeds, regressions, what runs found)
    fuzz/differential.py    every corpus input to the C++ object and its twins, compared

    python -m fuzz run [--seconds 120] [TARGET ...]   grow the corpora, minimised into fuzz/corpus (make fuzz)
    python -m fuzz check [--seconds 2]                each target on its corpus plus new inputs (the suite)
    python -m fuzz diff                               the differential run over every corpus
"""
