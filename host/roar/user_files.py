"""Reading the files users write (calibration, tracks, waypoints) with one-line errors, and
checking up front that an output file can be written (before a run, not after it).

Missing folders are made only inside OUTPUT_HOME (out/ in the working directory, where the
defaults write) and the user's roar folder (config_folder(): the calibration and the key), and an
output folder the user names is made if its parent exists: anywhere else a missing folder is
refused, so a typo (/nonexistent/dir) makes nothing."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable


def read_text(path: str | Path, error: type[ValueError]) -> str:
    """The file's text; `error("<path>: <reason>")` when it cannot be read as UTF-8 text (a byte
    order mark before it, as some Windows editors write, is no part of it)."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
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


def _blocked(path: Path) -> str | None:
    """Why no folder can be made at or above path: an ancestor that is a file (one line), or None."""
    for ancestor in [path, *path.parents]:
        if ancestor.exists():
            return None if ancestor.is_dir() else f"{ancestor} is a file, not a folder"
    return None


OUTPUT_HOME = Path("out")  # where the defaults write: missing folders are made in it (relative to the working directory)


def config_folder() -> Path:
    """The user's roar folder: ~/.config/roar (or under $XDG_CONFIG_HOME)."""
    return Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config") / "roar"


def _may_make(folder: Path) -> bool:
    """Whether a missing folder may be made: one inside OUTPUT_HOME or the user's roar folder."""
    return any(folder.resolve().is_relative_to(home.resolve()) for home in (OUTPUT_HOME, config_folder()))


def unwritable(path: str | Path) -> str | None:
    """Why the file `path` cannot be written (one line), or None when it can. Makes its folder only
    inside OUTPUT_HOME; elsewhere a missing folder is refused."""
    path = Path(path)
    if str(path) in ("", "."):
        return "the file name is empty"
    blocked = _blocked(path.parent)
    if blocked:
        return f"cannot write {path}: {blocked}"
    if not path.parent.is_dir() and not _may_make(path.parent):
        return f"cannot write {path}: its folder {path.parent} does not exist (make it first)"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        return f"cannot write {path}: cannot make its folder {path.parent}: {e.strerror or e}"
    if path.is_dir():
        return f"cannot write {path}: it is a folder"
    if not os.access(path if path.exists() else path.parent, os.W_OK):
        return f"cannot write {path}: permission denied"
    return None


def unusable_folder(path: str | Path) -> str | None:
    """Why files cannot be written into the folder `path` (one line), or None when they can.
    Makes it when missing and its parent exists (or inside OUTPUT_HOME)."""
    path = Path(path)
    blocked = _blocked(path)
    if blocked:
        return f"cannot write into {path}: {blocked}"
    if not path.is_dir() and not path.parent.is_dir() and not _may_make(path):
        return f"cannot write into {path}: its parent folder {path.parent} does not exist (make it first)"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        return f"cannot make the folder {path}: {e.strerror or e}"
    if not os.access(path, os.W_OK):
        return f"cannot write into {path}: permission denied"
    return None
