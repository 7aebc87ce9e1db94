"""The catalogue: element sets from several files, looked up by id, name or designator.

Lookup order in :meth:`Catalog.find`: NORAD id, international designator, exact name,
case-insensitive name, a few well-known nicknames ("ISS"), a name part (the text before or
inside the parentheses: "AO-7" finds "OSCAR 7 (AO-7)"), the name or a part with hyphens,
spaces and underscores ignored ("NOAA-20", "noaa20" and "JPSS 1" find "NOAA 20 (JPSS-1)"),
then a unique substring. Several
matches at one step raise :class:`AmbiguousSatelliteError`; none raise
:class:`UnknownSatelliteError` with difflib "did you mean" suggestions.
"""

from __future__ import annotations

import functools
import re
import warnings
from collections.abc import Iterable, Iterator
from datetime import datetime, timezone
from pathlib import Path

from tle.alpha5 import alpha5_to_int
from tle.elements import ElementSet, WarningHandler, format_intl_designator, parse_text
from tle.errors import (
    AmbiguousSatelliteError,
    TleError,
    TleFormatError,
    TleWarning,
    UnknownSatelliteError,
)

AGE_WARN_DAYS = 7.0
AGE_LOUD_DAYS = 30.0
MAX_LISTED = 8
MAX_AGE_LINES = 3  # more stale sets than this get one summary line
SKIPPED_PREFIX = "skipped a broken element set: "  # what tle.elements/omm warn with

# Nicknames people type that match several names otherwise ("ISS" is in both ISS (ZARYA) and
# ISS (NAUKA)); each maps to the object everyone means. Only used if that id is loaded.
NICKNAMES = {"ISS": 25544, "HST": 20580, "HUBBLE": 20580, "CSS": 48274, "TIANGONG": 48274}

_INTL_SHORT = re.compile(r"^\d{5}[A-Z]{1,3}$")
_INTL_LONG = re.compile(r"^\d{4}-\d{3}[A-Z]{1,3}$")
_ALPHA5 = re.compile(r"^[A-HJ-NP-Z]\d{4}$")
_PAREN = re.compile(r"^(.*?)\s*\((.*)\)\s*$")


_SEPARATORS = re.compile(r"[\s_-]+")


def _squashed(text: str) -> str:
    """``text`` case-folded without hyphens, spaces or underscores: how people vary names."""
    return _SEPARATORS.sub("", text.casefold())


def _name_parts(name: str) -> tuple[str, ...]:
    match = _PAREN.match(name)
    if not match:
        return ()
    return tuple(part.casefold() for part in match.groups() if part)


def age_warning(es: ElementSet, now: datetime) -> str | None:
    """None for fresh elements, a warning past 7 days, a louder one past 30 days; the same
    for elements whose epoch lies that far *after* ``now`` (a time asked for with --at)."""
    age_days = es.age_days(now)
    stamp = es.epoch.strftime("%Y-%m-%d %H:%M UTC")
    if -age_days > AGE_WARN_DAYS:
        loud = "WARNING: " if -age_days > AGE_LOUD_DAYS else ""
        return (f"{loud}elements for {es.name} are from {-age_days:.0f} days after the time "
                f"asked for (epoch {stamp}): predictions that far before the epoch may be "
                "off; use elements from near that date")
    if age_days > AGE_LOUD_DAYS:
        return (f"WARNING: elements for {es.name} are {age_days:.0f} days old (epoch {stamp}): "
                "predictions may be off by minutes and many degrees; "
                "run `tracker tle update`")
    if age_days > AGE_WARN_DAYS:
        return (f"elements for {es.name} are {age_days:.1f} days old (epoch {stamp}); "
                "run `tracker tle update` for fresh ones")
    return None


def age_warnings(sets: Iterable[ElementSet], now: datetime,
                 max_lines: int = MAX_AGE_LINES) -> list[str]:
    """:func:`age_warning` for each set, or one summary line when more than ``max_lines``
    sets are stale (a group of 90 satellites gets one line, not 90)."""
    sets = list(sets)
    found = [(es, w) for es in sets if (w := age_warning(es, now))]
    if len(found) <= max_lines:
        return [w for _es, w in found]
    oldest_d = max(abs(es.age_days(now)) for es, _w in found)
    return [f"WARNING: {len(found)} of {len(sets)} element sets are more than "
            f"{AGE_WARN_DAYS:.0f} days from the time asked for (furthest {oldest_d:.0f} days): "
            "predictions may be off; run `tracker tle update`"]


@functools.lru_cache(maxsize=256)
def _group_of(source: str) -> str:
    """The group a set's source file names (``.../amateur.txt`` -> ``amateur``); the few
    sources of a catalogue repeat for every set, so the path is parsed once each."""
    return Path(source).stem


class Catalog:
    """Element sets keyed by NORAD id (the newest epoch wins), with per-group membership."""

    def __init__(self, sets: Iterable[ElementSet] = (), bundled: bool = False,
                 note: str | None = None):
        self.bundled = bundled
        self._note = note
        self._by_id: dict[int, ElementSet] = {}
        self._groups: dict[str, set[int]] = {}
        self._origins: dict[str, set[str]] = {}  # group -> "cache" / "bundled" / ...
        for es in sets:
            self.add(es)

    def add(self, es: ElementSet, origin: str | None = None) -> None:
        """Add one set; a duplicate id keeps whichever epoch is newer. ``origin`` labels
        where its group came from (see :meth:`group_origins`)."""
        old = self._by_id.get(es.norad_id)
        if old is None or es.epoch > old.epoch:
            self._by_id[es.norad_id] = es
        group = _group_of(es.source)
        self._groups.setdefault(group, set()).add(es.norad_id)
        if origin:
            self._origins.setdefault(group, set()).add(origin)

    def merge(self, other: Catalog) -> None:
        """Add every set and group of ``other``: the freshest set of each object wins, a
        group present in both holds the objects of both."""
        for norad_id, es in other._by_id.items():
            old = self._by_id.get(norad_id)
            if old is None or es.epoch > old.epoch:
                self._by_id[norad_id] = es
        for group, ids in other._groups.items():
            self._groups.setdefault(group, set()).update(ids)
        for group, origins in other._origins.items():
            self._origins.setdefault(group, set()).update(origins)

    @property
    def note(self) -> str | None:
        """What to tell a user about these elements: for the bundled snapshot, that they are
        old and from when (worked out on first use: most commands never show it)."""
        if self._note is None and self.bundled and self._by_id:
            import statistics

            median = statistics.median(es.epoch.timestamp() for es in self)
            day = datetime.fromtimestamp(median, tz=timezone.utc).strftime("%Y-%m-%d")
            self._note = (f"using the bundled element snapshot (epochs around {day}); these "
                          "elements are old, run `tracker tle update` for fresh ones")
        return self._note

    def group_origins(self, name: str) -> tuple[str, ...]:
        """Where group ``name`` came from: "cache", "bundled", or both (sorted)."""
        return tuple(sorted(self._origins.get(name, ())))

    @classmethod
    def load(cls, paths: Iterable[str | Path], skip_bad: bool = True,
             on_warning: WarningHandler | None = None, empty_is_error: bool = True,
             origin: str | None = None) -> Catalog:
        """Load TLE/3LE/OMM files; broken sets are skipped with one warning each by default.

        If every set in the files is broken (nothing loaded), the first fault is raised as a
        :class:`TleFormatError` instead (``empty_is_error``): a catalogue of nothing plus a
        list of warnings would bury the one line that says what to fix.
        """
        from tle.elements import load_file

        faults: list[str] = []
        catalog = cls()
        for path in paths:
            # Collect the skip warnings and pass them on once we know something loaded.
            known_faults = len(faults)
            sets = load_file(path, skip_bad=skip_bad, on_warning=faults.append)
            if empty_is_error and not sets and len(faults) == known_faults:
                raise TleFormatError(f"{path}: the file holds no element sets; expected "
                                     "TLE/3LE lines or OMM JSON/CSV/XML", source=str(path))
            for es in sets:
                catalog.add(es, origin)
        if empty_is_error and faults and not catalog._by_id:
            first = faults[0].removeprefix(SKIPPED_PREFIX)
            more = f" (and {len(faults) - 1} more broken sets)" if len(faults) > 1 else ""
            raise TleFormatError(f"no usable element set: {first}{more}")
        for message in faults:
            if on_warning is not None:
                on_warning(message)
            else:
                warnings.warn(message, TleWarning, stacklevel=2)
        return catalog

    @classmethod
    def bundled_snapshot(cls, on_warning: WarningHandler | None = None) -> Catalog:
        """The snapshot shipped in ``tle/data/`` (read via importlib.resources)."""
        from importlib.resources import files

        catalog = cls(bundled=True)
        data = files("tle").joinpath("data")
        for entry in sorted(data.iterdir(), key=lambda e: e.name):
            if entry.name.endswith(".txt"):
                text = entry.read_text(encoding="utf-8")
                for es in parse_text(text, source=str(entry), skip_bad=True,
                                     on_warning=on_warning):
                    catalog.add(es, "bundled")
        return catalog

    @classmethod
    def default(cls, store=None, on_warning: WarningHandler | None = None) -> Catalog:
        """Every cached group united with the bundled snapshot, the freshest set of each
        object winning: updating one group never hides the others. Without a cache this is
        the bundled snapshot alone (``bundled=True``, with its note)."""
        if store is None:
            from tle.cachedir import default_cache_dir, element_paths

            paths = element_paths(default_cache_dir())
        else:
            paths = store.paths()
        snapshot = cls.bundled_snapshot(on_warning=on_warning)
        if not paths:
            return snapshot
        catalog = cls.load(paths, skip_bad=True, on_warning=on_warning, empty_is_error=False,
                           origin="cache")
        catalog.merge(snapshot)
        return catalog

    def __iter__(self) -> Iterator[ElementSet]:
        return iter(self._by_id.values())

    def __len__(self) -> int:
        return len(self._by_id)

    def __contains__(self, norad_id: object) -> bool:
        return norad_id in self._by_id

    def get(self, norad_id: int) -> ElementSet | None:
        return self._by_id.get(norad_id)

    @property
    def groups(self) -> list[str]:
        return sorted(self._groups)

    def group(self, name: str) -> Catalog:
        """A catalogue of the sets that appeared in group ``name`` (file stem, "amateur").

        Each set is the newest one for its id, even if that came from another group's file.
        """
        ids = self._groups.get(name)
        if ids is None:
            import difflib

            known = ", ".join(self.groups) or "none loaded"
            close = tuple(difflib.get_close_matches(name, self.groups))
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise UnknownSatelliteError(
                f"no group {name!r} in the catalogue (groups: {known}){hint}", close)
        sub = Catalog(bundled=self.bundled, note=self.note)
        for norad_id in sorted(ids):
            sub._by_id[norad_id] = self._by_id[norad_id]
        sub._groups[name] = set(ids)
        if name in self._origins:
            sub._origins[name] = set(self._origins[name])
        return sub

    def search(self, query: str) -> list[ElementSet]:
        """Every set whose name, id or designator contains ``query`` (case-insensitive)."""
        needle = query.strip().casefold()
        return sorted((es for es in self if needle in es.name.casefold()
                       or needle in str(es.norad_id) or needle in es.intl_designator.casefold()),
                      key=lambda es: es.name)

    def _pick(self, query: str, matches: list[ElementSet], how: str) -> ElementSet | None:
        if len(matches) == 1:
            return matches[0]
        if not matches:
            return None
        matches.sort(key=lambda es: es.name)
        listed = ", ".join(f"{es.name} ({es.norad_id})" for es in matches[:MAX_LISTED])
        more = f" and {len(matches) - MAX_LISTED} more" if len(matches) > MAX_LISTED else ""
        raise AmbiguousSatelliteError(
            f"{query!r} matches {len(matches)} satellites by {how}: {listed}{more}; "
            "give the full name or the NORAD id",
            tuple(es.name for es in matches))

    def _find_number(self, text: str) -> ElementSet:
        # A number is a NORAD id: never a piece of some name like "TIANQI-1 (1)".
        if int(text) in self._by_id:
            return self._by_id[int(text)]
        named = [es for es in self if es.name == text]
        if len(named) == 1:
            return named[0]
        where = "the bundled snapshot" if self.bundled else "the catalogue"
        raise UnknownSatelliteError(
            f"no satellite with NORAD id {int(text)} in {where} ({len(self)} sets); check "
            "the number, or `tracker tle update` to fetch more groups")

    def find(self, query: str) -> ElementSet:
        """One set by NORAD id, designator, name (exact, any case, part, unique substring)."""
        text = query.strip()
        if not text:
            raise UnknownSatelliteError("empty satellite name; give a name or a NORAD id")
        if text.isdigit():
            return self._find_number(text)
        if _ALPHA5.match(text.upper()):
            found = self._by_id.get(alpha5_to_int(text.upper()))
            if found:
                return found
        upper = text.upper()
        if _INTL_SHORT.match(upper) or _INTL_LONG.match(upper):
            designator = format_intl_designator(upper) if "-" not in upper else upper
            hit = self._pick(text, [es for es in self if es.intl_designator == designator],
                             "international designator")
            if hit:
                return hit
        folded = text.casefold()
        steps = (
            ("exact name", lambda es: es.name == text),
            ("name", lambda es: es.name.casefold() == folded),
        )
        for how, test in steps:
            hit = self._pick(text, [es for es in self if test(es)], how)
            if hit:
                return hit
        nick = NICKNAMES.get(text.upper())
        if nick in self._by_id:
            return self._by_id[nick]
        squashed = _squashed(text)
        for how, test in (
            ("name part", lambda es: folded in _name_parts(es.name)),
            ("name", lambda es: squashed in {_squashed(k)
                                             for k in (es.name, *_name_parts(es.name))}),
            ("partial name", lambda es: folded in es.name.casefold()),
        ):
            hit = self._pick(text, [es for es in self if test(es)], how)
            if hit:
                return hit
        raise self._unknown(text)

    def _unknown(self, text: str) -> UnknownSatelliteError:
        import difflib

        # Compare with the full names and their parts, so "ISSS" still finds "ISS (ZARYA)".
        keys: dict[str, str] = {}
        for es in sorted(self, key=lambda es: es.norad_id):
            for key in (es.name.casefold(), *_name_parts(es.name)):
                keys.setdefault(key, es.name)
        close = difflib.get_close_matches(text.casefold(), list(keys), n=10, cutoff=0.6)
        suggestions = tuple(dict.fromkeys(keys[c] for c in close))[:5]
        where = "the bundled snapshot" if self.bundled else "the catalogue"
        hint = (f"; did you mean {', '.join(repr(s) for s in suggestions)}?" if suggestions
                else "; try `tracker tle list` / a NORAD id, or `tracker tle update` to fetch "
                     "more groups")
        return UnknownSatelliteError(
            f"no satellite {text!r} in {where} ({len(self)} sets){hint}", suggestions)


__all__ = ["AGE_LOUD_DAYS", "AGE_WARN_DAYS", "Catalog", "TleError", "age_warning",
           "age_warnings"]
