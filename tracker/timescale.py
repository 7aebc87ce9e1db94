"""UTC time: one skyfield Timescale per process, conversions, and the text forms of times.

The one place for: the shared skyfield ``Timescale`` (built-in tables, never downloads);
UTC POSIX seconds (what :class:`~tracker.skytrack.SkyTrack` and the clocks use) to and from
skyfield ``Time`` and aware datetimes; ISO-8601 UTC text, read (:func:`parse_iso_utc`) and
written (:func:`iso_utc`, vectorised :func:`iso_utc_array`, and :func:`utc_strftime` for
other layouts).
"""

from __future__ import annotations

from datetime import datetime, timezone
from functools import cache, lru_cache

import numpy as np

DAY_S = 86400.0
_UNIX_EPOCH_JD = 2440587.5


@lru_cache(maxsize=1)
def timescale():
    """The shared skyfield ``Timescale`` (built-in leap-second and ΔT tables, no download).

    Built from the tables skyfield bundles exactly as ``skyfield.api.load.timescale(builtin=
    True)`` builds it, but without ``skyfield.api``: that imports skyfield's downloader, and
    with it ``ssl`` and ``urllib.request``, which an offline command has no use for.
    """
    from skyfield.functions import load_bundled_npy
    from skyfield.timelib import Timescale

    arrays = load_bundled_npy("iers.npz")
    tt_minus_day = arrays["tt_jd_minus_arange"]
    daily_tt = tt_minus_day + np.arange(len(tt_minus_day))
    daily_delta_t = (arrays["delta_t_1e7"] / 1e7).round(7)
    return Timescale((daily_tt, daily_delta_t), arrays["leap_dates"], arrays["leap_offsets"])


def time_from_posix(t_s):
    """A skyfield ``Time`` (scalar or array) for UTC POSIX seconds ``t_s``.

    POSIX days are exactly 86400 s, so the seconds are split into whole days since 1970 and
    seconds of the day; skyfield applies the leap-second table per day.
    """
    from skyfield.nutationlib import iau2000b_radians

    t_s = np.asarray(t_s, dtype=float)
    days = np.floor(t_s / DAY_S)
    t = timescale().utc(1970, 1, 1 + days, 0, 0, t_s - days * DAY_S)
    # IAU 2000B nutation (skyfield documents this switch) is within 1 milliarcsecond of the
    # default 2000A series and about 50 times cheaper: it decides how many samples we afford.
    t._nutation_angles_radians = iau2000b_radians(t)
    return t


def posix_from_time(t) -> np.ndarray | float:
    """UTC POSIX seconds of a skyfield ``Time`` (inverse of :func:`time_from_posix`)."""
    # Same leap-second lookup skyfield uses for its own UTC (interp over TAI seconds since JD 0).
    ts = timescale()
    whole = np.asarray(t.whole, dtype=float)
    frac = np.asarray(t.tai_fraction, dtype=float)
    tai_minus_utc = np.floor(np.interp(whole * DAY_S + frac * DAY_S, ts._leap_tai,
                                       ts._leap_offsets))
    out = ((whole - _UNIX_EPOCH_JD) * DAY_S + frac * DAY_S) - tai_minus_utc
    return out if np.ndim(out) else float(out)


def to_posix(t: datetime | float) -> float:
    """POSIX seconds of an aware datetime (or pass a number through)."""
    if isinstance(t, datetime):
        if t.tzinfo is None:
            raise ValueError("times must be timezone-aware (UTC); got a naive datetime")
        return t.timestamp()
    return float(t)


def to_datetime(t_s: float) -> datetime:
    """Aware UTC datetime of POSIX seconds."""
    return datetime.fromtimestamp(float(t_s), timezone.utc)


def parse_iso_utc(text: str) -> datetime:
    """An ISO-8601 time as an aware datetime: with its offset (``Z``/``z`` is UTC), or UTC
    when it has none.

    Raises ``ValueError`` for text that is not an ISO-8601 time. The offset is kept (not
    converted) so a time at the edge of ``datetime``'s range still parses.
    """
    s = text.strip()
    if s.endswith(("Z", "z")):
        s = s[:-1] + "+00:00"
    t = datetime.fromisoformat(s)
    return t.replace(tzinfo=timezone.utc) if t.tzinfo is None else t


def iso_utc(t: datetime | float, timespec: str = "seconds") -> str:
    """ISO-8601 UTC with a ``Z``: ``2026-08-22T13:45:07Z``.

    ``timespec="seconds"`` rounds to the nearest second (the form of every export);
    ``"milliseconds"`` keeps milliseconds (``...T13:45:07.250Z``, logs), truncating.
    """
    t_s = to_posix(t)
    if timespec == "seconds":
        return datetime.fromtimestamp(round(t_s), timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return datetime.fromtimestamp(t_s, timezone.utc).isoformat(timespec=timespec) \
        .replace("+00:00", "Z")


def _iso_numpy(whole_s: np.ndarray) -> np.ndarray:
    return np.char.add(np.datetime_as_string(whole_s.astype("datetime64[s]"), unit="s"), "Z")


@cache
def _iso_clock_bytes() -> np.ndarray:
    """``HH:MM:SSZ`` of every second of a day, as a (86400, 9) byte array."""
    text = _iso_numpy(np.arange(86400, dtype=np.int64)).astype("S20")
    return text.view(np.uint8).reshape(86400, 20)[:, 11:]


def iso_utc_array(t_s) -> np.ndarray:
    """:func:`iso_utc` (to the second) of many POSIX times at once, as a numpy string array."""
    t = np.round(np.asarray(t_s, dtype=float))
    finite = np.isfinite(t)
    if t.size == 0 or not finite.all():
        whole = np.where(finite, t, 0).astype(np.int64)
        out = _iso_numpy(whole)
        out[~finite] = "NaTZ"
        return out
    days, sod = np.divmod(t.astype(np.int64), 86400)
    first = int(days.min())
    span = int(days.max()) - first + 1
    if span > max(4096, days.size) or first < -719162 or first + span > 2932897:
        return _iso_numpy(t.astype(np.int64))  # centuries apart, or years outside 1-9999
    # A result spans few days: format each day once and each second from a table, then
    # assemble the bytes (10x faster than formatting every time).
    dates = _iso_numpy(np.arange(first, first + span, dtype=np.int64) * 86400).astype("S20")
    out = np.empty((*t.shape, 20), dtype=np.uint8)
    out[..., :11] = dates.view(np.uint8).reshape(span, 20)[:, :11][days - first]
    out[..., 11:] = _iso_clock_bytes()[sod]
    # The code points as integers: numpy's own S to U cast costs about 0.5 us a cell.
    return out.astype(np.uint32).view("U20")[..., 0]


def utc_strftime(t: datetime | float, layout: str) -> str:
    """A UTC time (POSIX seconds or aware datetime) in a ``strftime`` layout, e.g.
    ``"%H:%M:%S"`` (seconds truncated, as a clock shows them)."""
    return datetime.fromtimestamp(to_posix(t), timezone.utc).strftime(layout)
