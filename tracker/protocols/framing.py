"""Line framing shared by drivers and emulators.

A :class:`LineFramer` is fed whatever chunks the port delivers (one byte at a time, a CR split
from its payload, two replies in one read) and hands back complete lines without their
terminators. Bytes after the last terminator stay buffered for the next feed, never dropped.
"""

from __future__ import annotations

import re

from tracker.errors import ProtocolError


class LineFramer:
    """Split a byte stream into lines.

    ``terminators``: bytes that end a line (each byte on its own, like Hamlib's stop sets:
    ``b"\\r\\n"`` means "CR or LF", not the sequence). ``ignore``: bytes dropped wherever they
    appear (a GS-232B ignores LF). ``keep_empty``: whether empty lines are returned (a
    controller answers a blank line with ``?>``; a driver skips the empty half of CR LF).
    ``max_line``: a line longer than this raises :class:`ProtocolError` (the buffer is
    cleared first, so the framer can be fed again).
    """

    def __init__(self, terminators: bytes = b"\r", ignore: bytes = b"",
                 keep_empty: bool = True, max_line: int = 65536):
        if not terminators:
            raise ValueError("terminators must not be empty")
        self.terminators = bytes(terminators)
        self.ignore = bytes(ignore)
        self.keep_empty = keep_empty
        self.max_line = int(max_line)
        self._buf = bytearray()
        self._split = re.compile(b"[" + re.escape(self.terminators) + b"]")

    def feed(self, chunk: bytes) -> list[bytes]:
        """Add ``chunk``; return every line it completed (possibly none)."""
        data = bytes(chunk).translate(None, self.ignore) if self.ignore else bytes(chunk)
        parts = self._split.split(data)
        lines: list[bytes] = []
        for part in parts[:-1]:
            self._buf += part
            if self._buf or self.keep_empty:
                lines.append(bytes(self._buf))
            self._buf.clear()
        self._buf += parts[-1]
        if len(self._buf) > self.max_line:
            raw = bytes(self._buf[:64])
            self._buf.clear()
            raise ProtocolError(
                f"line longer than {self.max_line} bytes without a terminator", raw)
        return lines

    @property
    def pending(self) -> bytes:
        """Bytes received after the last terminator (a partial line)."""
        return bytes(self._buf)

    def clear(self) -> None:
        self._buf.clear()
