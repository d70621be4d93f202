"""sim://?eeprom=FILE: the simulated board's non-volatile memory (its signing key and the next
session: roar/signing.h) kept in a file between runs, as a real board keeps it in EEPROM or flash.

The file is a first line that says what it is, then the memory's bytes:

    roar board memory esc 32\\n<32 bytes>

A file that is not one is refused in one line and left as it is; so is one of another robot or
size. An image of the board's size with no first line (written before the line existed) is
taken as it is. The file is written only when the board's memory changed, whole (a temporary
file renamed over it), never by a session that only reads (Transport.read_only), and a new file
is made only where the user named one.
"""

from __future__ import annotations

import os
from pathlib import Path

from roar.transports.base import TransportError

HEADER = "roar board memory"  # the first line: HEADER ROBOT SIZE
MAX_HEADER_BYTES = 64  # the first line is never longer
MAX_FILE_BYTES = 1 << 20  # [bytes] a board's memory is far smaller: a larger file is not one


def load(path: Path, robot: str) -> bytes | None:
    """The memory kept in `path` for `robot` (None: no file yet); TransportError, the file left
    untouched, when it is not a board's memory. A headerless image is checked by size in check()."""
    if not path.exists():
        return None
    if path.is_dir():
        raise TransportError(f"eeprom: {path} is a folder, not a board's memory")
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise TransportError(f"eeprom: {path} is not a simulated board's memory ({path.stat().st_size:,} bytes); "
                                 f"it was left as it is: name a new file, or one an eeprom= run wrote")
        data = path.read_bytes()
    except OSError as e:
        raise TransportError(f"eeprom: cannot read {path}: {e.strerror or e}") from None
    first, newline, rest = data[:MAX_HEADER_BYTES].partition(b"\n")
    words = first.decode("ascii", "replace").split()
    if newline and " ".join(words[:3]) == HEADER:
        if len(words) != 5 or not words[4].isdigit() or int(words[4]) != len(data) - len(first) - 1:
            raise TransportError(f"eeprom: {path} is a damaged board memory file (its length is not the one its "
                                 f"first line gives); it was left as it is")
        if words[3] != robot:
            raise TransportError(f"eeprom: {path} holds the memory of the {words[3]} robot, not the {robot}: give "
                                 f"each robot its own file")
        return data[len(first) + 1:]
    return data  # perhaps an image from before the header: check() compares its size with the board's


def check(path: Path, stored: bytes | None, board_memory: bytes) -> None:
    """A file's memory must fit the board exactly; TransportError (the file left untouched) if not."""
    if stored is not None and len(stored) != len(board_memory):
        raise TransportError(f"eeprom: {path} is not a simulated board's memory ({len(stored)} bytes where the board "
                             f"keeps {len(board_memory)}, and no 'roar board memory' first line); it was left as it "
                             f"is: name a new file, or one an eeprom= run wrote")


def save(path: Path, robot: str, memory: bytes) -> None:
    """Write the board's memory to `path`, whole."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(f"{HEADER} {robot} {len(memory)}\n".encode("ascii") + bytes(memory))
    os.replace(tmp, path)
