"""The progress bars of the simulator's runs, on stderr: `racing oval: ████  1.25/2 laps [00:07]`.
Where stderr is not a terminal (a log, a pipe, CI) a bar would be a stream of carriage-return
frames: there the run says once, in a plain line, that it has started, and its report says the rest."""

from __future__ import annotations

import sys


def bar(iterable=None, **options):
    """A tqdm bar on stderr, at most two updates a second, on a terminal; elsewhere one line
    (`DESC ...`) as the run starts. show=False: neither."""
    from tqdm import tqdm

    options = {"file": sys.stderr, "mininterval": 0.5, **options}
    show = options.pop("show", True)
    if show and not getattr(options["file"], "isatty", lambda: False)():
        print(f"{options.get('desc', 'running')} ...", file=options["file"], flush=True)
        show = False
    return tqdm(iterable, **options, disable=not show)


def laps_bar(laps: int, desc: str):
    """A bar of `laps` laps (fractions shown)."""
    return bar(total=laps, desc=desc, unit="lap", bar_format="{desc}: {bar} {n:.2f}/{total} laps [{elapsed}]")
