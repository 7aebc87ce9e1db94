"""The planetary ephemeris (JPL DE421), loaded offline; times via :mod:`tracker.timescale`.

DE421 comes from the ``skyfield-data`` package (a runtime dependency in pyproject.toml; about
17 MB). Only Sun/Moon/planet targets need it: a satellite's sunlit/visible flags come from
the low-precision Sun of :mod:`tracker.sun`.
``TRACKER_EPHEMERIS=/path/to/file.bsp`` points at another JPL kernel (e.g. de440s.bsp)
instead. Nothing here ever downloads: a missing file is a :class:`~tracker.errors.ConfigError`
that says how to install it.

DE421 covers 1899-07-29 .. 2053-10-08; times outside it raise ``ConfigError`` too.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from tracker.errors import ConfigError

ENV_VAR = "TRACKER_EPHEMERIS"
KERNEL_NAME = "de421.bsp"
INSTALL_HINT = ("install it with: pip install skyfield-data (the skyfield-data "
                f"package), or set {ENV_VAR}=/path/to/de421.bsp")

_UNIX_EPOCH_JD = 2440587.5
_DAY_S = 86400.0


def ephemeris_path() -> Path:
    """Where the JPL kernel is: ``$TRACKER_EPHEMERIS`` or skyfield-data's bundled DE421."""
    override = os.environ.get(ENV_VAR)
    if override:
        path = Path(override).expanduser()
        if not path.is_file():
            raise ConfigError(f"{ENV_VAR}={override}: no such file; point it at a JPL .bsp "
                              "kernel such as de421.bsp")
        return path
    try:
        import skyfield_data
    except ImportError:
        raise ConfigError("the planetary ephemeris (JPL DE421) is not installed; "
                          + INSTALL_HINT) from None
    # Not skyfield_data.get_skyfield_data_path(): it warns about its Earth-orientation table
    # expiring, which we never use (the timescale's built-in tables are enough for pointing).
    path = Path(skyfield_data.__file__).parent / "data" / KERNEL_NAME
    if not path.is_file():
        raise ConfigError(f"skyfield-data is installed but has no {KERNEL_NAME}; "
                          + INSTALL_HINT)
    return path


@lru_cache(maxsize=4)
def _load_kernel(path: str):
    from skyfield.jpllib import SpiceKernel

    try:
        return SpiceKernel(path)
    except (OSError, ValueError) as e:
        raise ConfigError(f"cannot read the ephemeris {path}: {e}") from e


def load_ephemeris():
    """The skyfield ``SpiceKernel`` (opened once per process, memory-mapped, no download)."""
    return _load_kernel(str(ephemeris_path()))


def times_from_posix(t_s):
    """A skyfield ``Time`` for UTC POSIX seconds (the project's shared conversion)."""
    from tracker.timescale import time_from_posix

    return time_from_posix(t_s)


def check_range(kernel, t_s) -> None:
    """Raise ConfigError if any of ``t_s`` is outside the kernel's time span."""
    t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
    if not t_s.size:
        return
    segments = getattr(kernel, "segments", ())
    if not segments:
        return
    # Every segment of DE4xx spans the same interval; use the narrowest to be safe.
    start_jd = max(s.spk_segment.start_jd for s in segments)
    end_jd = min(s.spk_segment.end_jd for s in segments)
    jd = t_s / _DAY_S + _UNIX_EPOCH_JD
    if jd.min() < start_jd or jd.max() > end_jd:
        from tracker.timescale import timescale

        ts = timescale()
        lo = ts.tt_jd(start_jd).utc_strftime("%Y-%m-%d")
        hi = ts.tt_jd(end_jd).utc_strftime("%Y-%m-%d")
        raise ConfigError(f"time outside the ephemeris span {lo} .. {hi}; choose dates in "
                          f"that range or set {ENV_VAR} to a kernel that covers them")
