"""Kernels compiled by Numba (one CPU thread each), built once a process: the particle filter's
ray casting, the local grid's beams, the planner's arcs and footprint checks, the fit's speed model.
Numba keeps their machine code in its disk cache, so a later process loads rather than compiles
them; for that the kernels are module-level functions of modules imported only once Numba is
known to be there (a kernel closed over another one is compiled again in each process).

    kernels = compiled("the particle filter's ray casting", build, "localization")  # build(numba)
"""

from __future__ import annotations

from collections.abc import Callable

from roar.errors import MissingNumba

_COMPILED: dict[str, object] = {}


def compiled(what: str, build: Callable[[object], object], extra: str = "localization"):
    """build(numba) -> kernels, once a process; MissingNumba naming `what` needs it and the extra
    that installs it where Numba is not there."""
    if what not in _COMPILED:
        try:
            import numba
        except ImportError:
            raise MissingNumba(f"{what} needs Numba: pip install 'roar-platform[{extra}]'") from None
        _COMPILED[what] = build(numba)
    return _COMPILED[what]
