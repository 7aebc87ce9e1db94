"""Celestial targets: the Sun, the Moon, the planets and fixed RA/Dec sources.

Names (case-insensitive; spaces, ``-`` and ``_`` are ignored, so ``Cas A`` = ``cas-a``):

- ``sun``, ``moon``, ``mercury`` .. ``neptune``, ``pluto`` (JPL DE421, see
  :mod:`tracker.ephemeris`);
- a built-in radio source (:data:`RADIO_SOURCES`: ``cas-a``, ``cyg-a``, ``tau-a``, ``vir-a``,
  ``sgr-a``, ...; J2000 positions from SIMBAD);
- ``radec:HH:MM:SS,+DD:MM:SS`` (RA in hours) or ``radec:83.63,22.01`` (both in degrees), J2000;
- an az/el schedule file: ``schedule:FILE`` or any name ending in ``.csv``
  (:mod:`tracker.pointing_file`).

Positions are *apparent topocentric* (light time, aberration, deflection, precession/nutation
to the true equator of date), **without atmospheric refraction**: refraction depends on weather,
is below 0.6° except near the horizon, and radio refraction differs from optical; leaving it
off keeps results reproducible and matches what rotator users compare against (PyEphem with
``pressure=0``). Rise/set is therefore the centre of the body crossing the geometric horizon
(plus the station's minimum elevation and mask), not the upper limb.

:func:`resolve` is the first of :data:`tracker.targets.RESOLVERS`. Rise, transit and set come
from :func:`tracker.passes.find_passes`, like every other target's passes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from tracker.errors import TargetError
from tracker.event_labels import event_labels
from tracker.skytrack import SkyTrack, enu_to_azel
from tracker.station import Station

# DE421 segment names for each body we accept.
SOLAR_SYSTEM: dict[str, tuple[str, str]] = {
    "sun": ("sun", "sun"),
    "moon": ("moon", "moon"),
    "mercury": ("mercury", "planet"),
    "venus": ("venus", "planet"),
    "mars": ("mars", "planet"),
    "jupiter": ("jupiter barycenter", "planet"),
    "saturn": ("saturn barycenter", "planet"),
    "uranus": ("uranus barycenter", "planet"),
    "neptune": ("neptune barycenter", "planet"),
    "pluto": ("pluto barycenter", "planet"),
}


@dataclass(frozen=True)
class RadioSource:
    """A fixed source: J2000 (ICRS) right ascension in hours, declination in degrees."""

    name: str
    ra_hours: float
    dec_deg: float
    aliases: tuple[str, ...] = ()
    note: str = ""


def _hms(h: float, m: float, s: float) -> float:
    return h + m / 60.0 + s / 3600.0


def _dms(sign: int, d: float, m: float, s: float) -> float:
    return sign * (d + m / 60.0 + s / 3600.0)


# J2000 positions from SIMBAD (CDS, simbad.u-strasbg.fr), rounded to 0.1 s / 1". Antenna beams
# are degrees wide, so proper motion and source structure do not matter here.
RADIO_SOURCES: tuple[RadioSource, ...] = (
    RadioSource("Cas A", _hms(23, 23, 24.0), _dms(+1, 58, 48, 54), ("3c461", "cassiopeiaa"),
                "supernova remnant, brightest source at VHF"),
    RadioSource("Cyg A", _hms(19, 59, 28.4), _dms(+1, 40, 44, 2), ("3c405", "cygnusa"),
                "radio galaxy"),
    RadioSource("Tau A", _hms(5, 34, 31.9), _dms(+1, 22, 0, 52), ("3c144", "crab", "m1"),
                "Crab nebula"),
    RadioSource("Vir A", _hms(12, 30, 49.4), _dms(+1, 12, 23, 28), ("3c274", "m87"),
                "radio galaxy M87"),
    RadioSource("Sgr A", _hms(17, 45, 40.0), _dms(-1, 29, 0, 28), ("sgra*", "galacticcentre",
                                                                    "galacticcenter"),
                "galactic centre (Sgr A*)"),
    RadioSource("Cen A", _hms(13, 25, 27.6), _dms(-1, 43, 1, 9), ("ngc5128", "centaurusa"),
                "radio galaxy NGC 5128"),
    RadioSource("Ori A", _hms(5, 35, 17.3), _dms(-1, 5, 23, 28), ("m42", "oriona"),
                "Orion nebula"),
    RadioSource("Her A", _hms(16, 51, 8.1), _dms(+1, 4, 59, 33), ("3c348", "herculesa"),
                "radio galaxy"),
    RadioSource("Hya A", _hms(9, 18, 5.7), _dms(-1, 12, 5, 44), ("3c218", "hydraa"),
                "radio galaxy"),
    RadioSource("3C 273", _hms(12, 29, 6.7), _dms(+1, 2, 3, 9), (), "quasar"),
)


def _key(name: str) -> str:
    return re.sub(r"[\s\-_]+", "", name.strip().lower())


_SOURCE_INDEX: dict[str, RadioSource] = {}
for _src in RADIO_SOURCES:
    for _alias in (_src.name, *_src.aliases):
        _SOURCE_INDEX[_key(_alias)] = _src


def known_names() -> list[str]:
    """Every built-in celestial name, for help texts and suggestions."""
    return [*SOLAR_SYSTEM, *(_key(s.name) for s in RADIO_SOURCES)]


# --------------------------------------------------------------------------------------------
# Targets

NODE_STEP_S = 30.0


def _interpolation_nodes(t_s: np.ndarray) -> np.ndarray | None:
    """Nodes every NODE_STEP_S covering sorted ``t_s`` if that needs < half the samples."""
    if t_s.size < 64 or not np.all(np.diff(t_s) > 0):
        return None
    span_s = float(t_s[-1] - t_s[0])
    n_nodes = int(np.ceil(span_s / NODE_STEP_S)) + 1
    if n_nodes * 2 > t_s.size:
        return None
    return np.linspace(t_s[0], t_s[0] + (n_nodes - 1) * NODE_STEP_S, n_nodes)


@dataclass(frozen=True)
class _SkyfieldTarget:
    """Common observe() for anything skyfield can ``observe()`` from the ground."""

    name: str
    kind: str
    meta: dict = field(default_factory=dict, compare=False, repr=False)

    def _body(self, kernel):  # pragma: no cover - overridden
        raise NotImplementedError

    def _has_range(self) -> bool:
        return True

    def _apparent(self, station: Station, t_s):
        from tracker.ephemeris import check_range, load_ephemeris, times_from_posix

        kernel = load_ephemeris()
        check_range(kernel, t_s)
        t = times_from_posix(t_s)
        observer = kernel["earth"] + station.topos()
        return observer.at(t).observe(self._body(kernel)).apparent()

    def observe(self, station: Station, t_s) -> SkyTrack:
        """Apparent az/el (no refraction) at UTC POSIX seconds ``t_s``, shape ``(n,)``.

        One vectorised skyfield call for the whole array. ``range_km`` and
        ``range_rate_km_s`` are topocentric for Sun/Moon/planets and NaN for fixed sources;
        ``sunlit`` is always False (it means nothing here).
        """
        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        if t_s.size == 0:
            return SkyTrack.from_azel(t_s, t_s, t_s, name=self.name, kind=self.kind)
        nodes_s = _interpolation_nodes(t_s)
        if nodes_s is not None:
            return self._observe_interpolated(station, t_s, nodes_s)
        return self._observe_exact(station, t_s)

    def _observe_interpolated(self, station: Station, t_s, nodes_s) -> SkyTrack:
        # Dense requests (e.g. 12 h at 1 s) cost ~90 µs per sample in skyfield; these bodies
        # move < 0.15°/30 s across the sky, so a chord between 30 s nodes is off by < 1e-4°.
        exact = self._observe_exact(station, nodes_s)
        enu = exact.unit_vectors()
        interp = np.stack([np.interp(t_s, nodes_s, enu[:, i]) for i in range(3)], axis=-1)
        az_deg, el_deg = enu_to_azel(interp)
        return SkyTrack(t_s, az_deg, el_deg, np.interp(t_s, nodes_s, exact.range_km),
                        np.interp(t_s, nodes_s, exact.range_rate_km_s),
                        np.zeros(t_s.shape, dtype=bool), self.name,
                        {**exact.meta, "interpolated_node_s": NODE_STEP_S})

    def _observe_exact(self, station: Station, t_s) -> SkyTrack:
        app = self._apparent(station, t_s)
        if self._has_range():
            alt, az, _dist, _, _, range_rate = app.frame_latlon_and_rates(station.topos())
            range_km = np.asarray(_dist.km, dtype=float).reshape(t_s.shape)
            rate_km_s = np.asarray(range_rate.km_per_s, dtype=float).reshape(t_s.shape)
        else:
            alt, az, _ = app.altaz()
            range_km = np.full(t_s.shape, np.nan)
            rate_km_s = np.full(t_s.shape, np.nan)
        az_deg = np.mod(np.asarray(az.degrees, dtype=float).reshape(t_s.shape), 360.0)
        el_deg = np.asarray(alt.degrees, dtype=float).reshape(t_s.shape)
        return SkyTrack(t_s, az_deg, el_deg, range_km, rate_km_s,
                        np.zeros(t_s.shape, dtype=bool), self.name,
                        {"kind": self.kind, "refraction": False, **self.meta})

    def elevation(self, station: Station, t_s) -> tuple[np.ndarray, np.ndarray]:
        """``(az_deg, el_deg)`` at times in any order or shape (for event searches)."""
        t_s = np.asarray(t_s, dtype=float)
        flat = np.atleast_1d(t_s).ravel()
        unique_s, inverse = np.unique(flat, return_inverse=True)
        track = self.observe(station, unique_s)
        shape = np.shape(t_s)
        return (track.az_deg[inverse].reshape(shape), track.el_deg[inverse].reshape(shape))

    def hour_angle_deg(self, station: Station, t_s) -> np.ndarray:
        """Local hour angle of date in degrees, wrapped to (-180, 180]; 0 at upper transit.

        :func:`tracker.passes.find_passes` uses it for TCA (the upper transit) and to cut a
        circumpolar span at its lower culminations.
        """
        t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
        ha, _dec, _ = self._apparent(station, t_s).hadec()
        ha_deg = np.asarray(ha.hours, dtype=float).reshape(t_s.shape) * 15.0
        return -np.mod(-ha_deg + 180.0, 360.0) + 180.0


@dataclass(frozen=True)
class SolarSystemTarget(_SkyfieldTarget):
    """The Sun, the Moon or a planet (``kind`` "sun", "moon" or "planet")."""

    segment: str = ""

    def _body(self, kernel):
        return kernel[self.segment]


@dataclass(frozen=True)
class FixedTarget(_SkyfieldTarget):
    """A fixed J2000 position (``kind`` "radio"): built-in radio source or ``radec:``."""

    ra_hours: float = 0.0
    dec_deg: float = 0.0

    def _body(self, kernel):
        from skyfield.starlib import Star

        return Star(ra_hours=self.ra_hours, dec_degrees=self.dec_deg)

    def _has_range(self) -> bool:
        return False


# --------------------------------------------------------------------------------------------
# Parsing names

RADEC_HELP = ("expected radec:HH:MM:SS,+DD:MM:SS (RA in hours) or radec:RA_DEG,DEC_DEG "
              "(both in degrees), J2000, e.g. radec:05:34:31.9,+22:00:52 or radec:83.63,22.01")


def _sexagesimal(text: str) -> tuple[int, float]:
    """(sign, value) of ``[+-]D:M[:S]``; raises ValueError."""
    text = text.strip()
    sign = -1 if text.startswith("-") else 1
    parts = [float(p) for p in text.lstrip("+-").split(":")]
    if not 2 <= len(parts) <= 3 or any(p < 0 for p in parts) or any(p >= 60 for p in parts[1:]):
        raise ValueError(text)
    parts += [0.0] * (3 - len(parts))
    return sign, parts[0] + parts[1] / 60.0 + parts[2] / 3600.0


def parse_radec(spec: str) -> FixedTarget:
    """A FixedTarget from ``radec:...`` (see :data:`RADEC_HELP`); TargetError when malformed."""
    body = spec.split(":", 1)[1] if spec.lower().startswith("radec:") else spec
    fields = body.split(",")
    if len(fields) != 2:
        raise TargetError(f"bad fixed position {spec!r}: {RADEC_HELP}")
    ra_text, dec_text = (f.strip() for f in fields)
    try:
        if ":" in ra_text:
            sign, ra_hours = _sexagesimal(ra_text)
            if sign < 0:
                raise ValueError(ra_text)
        else:
            ra_hours = float(ra_text) / 15.0
        if ":" in dec_text:
            sign, dec_abs = _sexagesimal(dec_text)
            dec_deg = sign * dec_abs
        else:
            dec_deg = float(dec_text)
    except ValueError:
        raise TargetError(f"bad fixed position {spec!r}: {RADEC_HELP}") from None
    if not (0.0 <= ra_hours < 24.0 and np.isfinite(ra_hours)):
        raise TargetError(f"bad fixed position {spec!r}: RA must be 0..24 h (0..360°); "
                          f"{RADEC_HELP}")
    if not (-90.0 <= dec_deg <= 90.0):
        raise TargetError(f"bad fixed position {spec!r}: Dec must be -90..+90°; {RADEC_HELP}")
    name = f"RA {ra_hours:.4f}h Dec {dec_deg:+.4f}°"
    return FixedTarget(name, "radio", {"ra_hours": ra_hours, "dec_deg": dec_deg},
                       ra_hours=ra_hours, dec_deg=dec_deg)


def resolve(name: str):
    """The celestial or schedule Target for ``name``, or None if the name is not one of ours.

    One of :data:`tracker.targets.RESOLVERS`. Raises TargetError / ConfigError only
    when the name is clearly meant for us (``radec:``, ``schedule:``, ``*.csv``) but is
    malformed or the file is missing/bad.
    """
    text = name.strip()
    lower = text.lower()
    if lower.startswith("radec:"):
        return parse_radec(text)
    if lower.startswith("schedule:") or lower.endswith(".csv"):
        from pathlib import Path

        from tracker.pointing_file import ScheduleTarget

        # A name ending in .csv is a file the user meant, not a satellite: a missing one is
        # reported as such rather than as an unknown satellite with odd suggestions.
        path = Path(text.split(":", 1)[1]) if lower.startswith("schedule:") else Path(text)
        return ScheduleTarget.load(path)
    key = _key(text)
    if key in SOLAR_SYSTEM:
        segment, kind = SOLAR_SYSTEM[key]
        return SolarSystemTarget(key.capitalize(), kind, {}, segment=segment)
    src = _SOURCE_INDEX.get(key) or _SOURCE_INDEX.get(key.rstrip("*"))
    if src is not None:
        return FixedTarget(src.name, "radio",
                           {"ra_hours": src.ra_hours, "dec_deg": src.dec_deg,
                            "note": src.note, "reference": "SIMBAD J2000"},
                           ra_hours=src.ra_hours, dec_deg=src.dec_deg)
    return None


__all__ = ["RADIO_SOURCES", "FixedTarget", "RadioSource", "SolarSystemTarget",
           "event_labels", "known_names", "parse_radec", "resolve"]

