"""Writing the user's output files: the one owner of every ``--out``, ``--plot``,
``--steptable`` and ``config init`` write.

Rules (nothing the user had is lost): a symlink is written through to its target (the link
stays); a directory, device, FIFO or socket is refused; an existing file is replaced only with
``force``; the data go to a unique temporary file in the target folder that is renamed over
the target, so a failure (full disk, no permission) leaves the old file whole and no temporary
file behind. Every problem is a :class:`~tracker.errors.ConfigError` naming the flag.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import BinaryIO

from tle.textfile import file_kind
from tracker.errors import ConfigError, OutputExistsError, with_advice


def _resolve(path: Path) -> Path:
    """The file a write to ``path`` must change: the final target of a symlink."""
    return Path(os.path.realpath(path)) if os.path.islink(path) else path


def _exists(where: str) -> OutputExistsError:
    return with_advice(OutputExistsError, f"{where} already exists; not overwriting it",
                       " (pass force=True to replace it, or choose another name)")


def check_output(path: str | Path, *, force: bool = False, label: str = "") -> Path:
    """Refuse, before any work is done, a path :func:`write_atomic` would refuse; returns the
    file that will be written (the target of a symlink)."""
    shown = Path(path)
    where = f"{label} {shown}" if label else str(shown)
    target = _resolve(Path(path).expanduser())
    try:
        st = os.stat(target)
    except FileNotFoundError:
        st = None
    except NotADirectoryError:
        raise ConfigError(f"{where}: a part of the path is a file, not a folder; choose a "
                          "path in an existing folder") from None
    except OSError as e:
        raise ConfigError(f"{where}: cannot reach this path ({e.strerror}); choose one in a "
                          "folder you can write") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{where} is {file_kind(st.st_mode)}, not a regular file; give a file "
                          "name")
    if st is not None and not force:
        raise _exists(where)
    folder = target.parent
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise ConfigError(f"{where}: folder {folder} {what}; create it or choose another path")
    return target


def _new_file_mode(target: Path) -> int:
    try:
        return target.stat().st_mode & 0o7777
    except OSError:
        umask = os.umask(0o022)
        os.umask(umask)
        return 0o666 & ~umask


def _keep_owner(fd: int, target: Path) -> None:
    # root replacing a user's file must not hand it over to root.
    if os.geteuid() != 0:
        return
    try:
        st = target.stat()
        os.fchown(fd, st.st_uid, st.st_gid)
    except OSError:
        pass


def _commit(tmp: str, target: Path, force: bool) -> None:
    if force:
        os.replace(tmp, target)
        return
    # No-clobber even if a file appeared since the check: link() fails on an existing name.
    try:
        os.link(tmp, target)
    except FileExistsError:
        raise
    except OSError:  # a file system without hard links: the check above must do
        os.replace(tmp, target)
        return
    os.unlink(tmp)


def _writer(data) -> Callable[[BinaryIO], object]:
    if isinstance(data, str):
        data = data.encode("utf-8")
    if isinstance(data, (bytes, bytearray, memoryview)):
        return lambda f, data=data: f.write(data)
    if callable(data):
        return data
    if isinstance(data, Iterable):
        def write_all(f: BinaryIO) -> None:
            for part in data:
                f.write(part.encode("utf-8") if isinstance(part, str) else part)
        return write_all
    raise TypeError(f"write_atomic needs str, bytes, an iterable of them or a callable, not "
                    f"{type(data).__name__}")


def write_atomic(path: str | Path,
                 data: str | bytes | Iterable[str | bytes] | Callable[[BinaryIO], object],
                 *, force: bool = False, label: str = "") -> Path:
    """Write ``data`` (text is UTF-8, line ends kept byte for byte) to ``path`` under the
    rules in the module docstring; returns ``path``. ``label`` (what the path is for, such as
    the option it came from) prefixes errors.

    ``data`` may also come in parts (an iterable of str/bytes, written as they are produced)
    or be a callable that writes into the open binary file: a large output then never has to
    be held whole, and an error raised while producing it still leaves no file behind."""
    write = _writer(data)
    path = Path(path).expanduser()
    where = f"{label} {path}" if label else str(path)
    target = check_output(path, force=force, label=label)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as e:
        raise ConfigError(f"{where}: cannot write in folder {target.parent} ({e.strerror}); "
                          "choose a writable folder") from None
    try:
        # mkstemp makes the file 0600; give it what a plain open() would (the existing
        # file's mode, else 0666 less the umask) so a shared calendar stays readable.
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), _new_file_mode(target))
            _keep_owner(f.fileno(), target)
            write(f)
            f.flush()
            os.fsync(f.fileno())
        _commit(tmp, target, force)
    except BaseException as e:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(e, FileExistsError):
            raise _exists(where) from None
        if isinstance(e, OSError):
            raise ConfigError(f"{where}: cannot write ({e.strerror or e}); the existing file, "
                              "if any, is unchanged") from None
        raise
    return path
