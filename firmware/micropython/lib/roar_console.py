"""The serial console (USB) of a board: bytes in without waiting, lines out."""

import select
import sys


class Console:
    def __init__(self):
        self._poll = select.poll()
        self._poll.register(sys.stdin, select.POLLIN)

    def read(self, n):
        """Up to n bytes that have arrived; b"" when none have."""
        data = b""
        while len(data) < n and self._poll.poll(0):
            byte = sys.stdin.buffer.read(1)
            if not byte:  # closed: readable, but nothing comes
                break
            data += byte
        return data

    def write(self, text):
        sys.stdout.write(text)
