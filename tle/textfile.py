"""Read a user-named text file into a string, or raise one clear error naming the file.

Every file the user names (element files, config, horizon mask, priorities, stations,
schedules, plan files) goes through :func:`read_text_file`, so all of them refuse the same
things the same way:

* anything but a regular file (a FIFO or a socket would block for ever, ``/dev/zero`` would
  never end, a directory cannot be read) — checked with ``os.stat`` before opening, and the
  file is opened non-blocking in case it changed in between;
* more than ``max_bytes`` (each use passes a cap that fits its kind of file);
* bytes that are not UTF-8 (a binary file, or another encoding);
* a UTF-8 byte-order mark, as Windows Notepad writes it, is dropped rather than refused;
* ``/dev/null`` reads as an empty file (``--config /dev/null`` = no config).

Lives in ``tle`` (the lower package) so both ``tle`` and ``tracker`` can use it; the caller
passes the error type its layer raises.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

MIB = 1 << 20
ELEMENT_FILE_MAX_BYTES = 64 * MIB   # the whole CelesTrak active catalogue as OMM JSON is ~25 MiB
SMALL_FILE_MAX_BYTES = 4 * MIB      # config, mask, priorities, stations, schedules, plans

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"))


def file_kind(mode: int) -> str:
    """What a non-regular file is, for an error line ("a FIFO (named pipe)", ...)."""
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def read_text_file(path: str | Path, what: str, error: type[Exception],
                   max_bytes: int = SMALL_FILE_MAX_BYTES, hint: str = "") -> str:
    """The text of the regular file ``path`` (UTF-8, a leading BOM dropped).

    ``what`` names the file in messages ("element file", "horizon mask"); ``error`` is the
    exception type raised for every problem (its message names ``path``); ``hint`` says what
    the file should hold and is added to the "not a text file" message.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except OSError as e:
        raise error(f"cannot read {what} {path}: {e.strerror or e}") from None
    if _is_devnull(info):
        return ""  # `--config /dev/null`: the usual way to say "an empty file"
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{what} {path} is {file_kind(info.st_mode)}, not a regular file; give the "
                    f"path of a text file")
    if info.st_size > max_bytes:
        raise error(f"{what} {path} is {info.st_size / MIB:.1f} MiB, more than the "
                    f"{max_bytes / MIB:g} MiB such a file can be; is it the right file?")
    data = _read_bounded(path, what, error, max_bytes)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        more = f"; {hint}" if hint else ""
        raise error(f"{path}: not a text file (byte {e.start} is not UTF-8){more}") from None


def _is_devnull(info: os.stat_result) -> bool:
    if not stat.S_ISCHR(info.st_mode):
        return False
    try:
        null = os.stat(os.devnull)
    except OSError:  # pragma: no cover - a system without /dev/null
        return False
    return (info.st_rdev, info.st_dev, info.st_ino) == (null.st_rdev, null.st_dev, null.st_ino)


def _read_bounded(path: Path, what: str, error: type[Exception], max_bytes: int) -> bytes:
    # O_NONBLOCK: if the path became a FIFO after the stat, opening it must not wait for a
    # writer; fstat then refuses it. Reading a regular file ignores the flag.
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as e:
        raise error(f"cannot read {what} {path}: {e.strerror or e}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise error(f"{what} {path} is {file_kind(mode)}, not a regular file; give the "
                        f"path of a text file")
        chunks: list[bytes] = []
        total = 0
        while True:
            chunk = os.read(fd, min(MIB, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > max_bytes:  # the file grew after the stat
                raise error(f"{what} {path} is more than the {max_bytes / MIB:g} MiB such a "
                            f"file can be; is it the right file?")
        return b"".join(chunks)
    except OSError as e:
        raise error(f"cannot read {what} {path}: {e.strerror or e}") from None
    finally:
        os.close(fd)
