"""Reading the files users write (calibration, tracks, waypoints) with one-line errors."""

from __future__ import annotations

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
