"""Reading the files users write (calibration, tracks, waypoints) with one-line errors."""

from __future__ import annotations

from pathlib import Path


def read_text(path: str | Path, error: type[ValueError]) -> str:
    """The file's text; `error("<path>: <reason>")` when it cannot be read as UTF-8 text."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except OSError as e:
        raise error(f"{path}: cannot read: {e.strerror or e}") from None
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text file") from None
