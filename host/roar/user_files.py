"""Reading the files users write (calibration, tracks, waypoints) with one-line errors, and
checking up front that an output file can be written (before a run, not after it)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable


def read_text(path: str | Path, error: type[ValueError]) -> str:
    """The file's text; `error("<path>: <reason>")` when it cannot be read as UTF-8 text."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except OSError as e:
        raise error(f"{path}: cannot read: {e.strerror or e}") from None
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text file") from None


def read_parsed(path: str | Path, loads: Callable[[str], Any], error: type[ValueError], kind: str) -> Any:
    """`loads(text)` of the file; `error("<path>: not valid <kind>: ...")` when it does not parse."""
    text = read_text(path, error)
    try:
        return loads(text)
    except ValueError as e:  # json.JSONDecodeError and tomllib.TOMLDecodeError are ValueErrors
        raise error(f"{Path(path)}: not valid {kind}: {e}") from None
    except RecursionError:
        raise error(f"{Path(path)}: not valid {kind}: nested too deeply") from None


def unwritable(path: str | Path) -> str | None:
    """Why `path` cannot be written (one line), or None when it can. Creates missing folders."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        return f"cannot write {path}: {e.strerror or e}"
    if path.is_dir():
        return f"cannot write {path}: it is a folder"
    if not os.access(path if path.exists() else path.parent, os.W_OK):
        return f"cannot write {path}: permission denied"
    return None
