"""The pass suite: real passes of bundled TLE groups over a week from three stations, plus
forced overhead passes. Shared by the pointing, step-table and streaming benchmarks.

``pass_suite(...)`` returns a list of :class:`SuitePass` (SkyTrack + station + metadata).
Positions come straight from SGP4 (``sgp4.api.SatrecArray``, vectorised over satellites and
times) rotated TEME -> Earth-fixed by GMST (the standard SGP4 convention, as skyfield does;
UT1 taken as UTC and polar motion ignored -- arc-seconds, irrelevant here). Passes are found
on a coarse grid (passes shorter than ``coarse_s`` can be missed) and then sampled every
``step_s`` with ``pad_s`` below the horizon at both ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from tracker.skytrack import SkyTrack
from tracker.station import Station
from tracker.testing import synthetic_pass

TLE_DIR = Path(__file__).resolve().parents[1] / "tle" / "data"
STATIONS = (
    Station("mid-latitude (Munich 48N)", 48.15, 11.57, 520.0),
    Station("high-latitude (Fairbanks 65N)", 65.0, -147.7, 150.0),
    Station("equatorial (Singapore 1N)", 1.35, 103.8, 20.0),
)
START = datetime(2026, 8, 22, tzinfo=timezone.utc)
WGS84_A_KM = 6378.137
WGS84_F = 1 / 298.257223563


@dataclass(frozen=True)
class SuitePass:
    track: SkyTrack
    station: Station
    meta: dict = field(default_factory=dict)


def _read_tle(path: Path) -> list[tuple[str, str, str]]:
    lines = [ln.rstrip() for ln in path.read_text().splitlines() if ln.strip()]
    out = []
    i = 0
    while i + 1 < len(lines):
        if lines[i].startswith("1 ") and i + 1 < len(lines) and lines[i + 1].startswith("2 "):
            out.append(("", lines[i], lines[i + 1]))
            i += 2
        elif i + 2 < len(lines) and lines[i + 1].startswith("1 ") and lines[i + 2].startswith(
                "2 "):
            out.append((lines[i].strip(), lines[i + 1], lines[i + 2]))
            i += 3
        else:
            i += 1
    return out


def _station_ecef_enu(st: Station) -> tuple[np.ndarray, np.ndarray]:
    lat, lon = math.radians(st.lat_deg), math.radians(st.lon_deg)
    e2 = WGS84_F * (2 - WGS84_F)
    n = WGS84_A_KM / math.sqrt(1 - e2 * math.sin(lat) ** 2)
    h = st.alt_m / 1000.0
    r = np.array([(n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
                  (n * (1 - e2) + h) * math.sin(lat)])
    rot = np.array([[-math.sin(lon), math.cos(lon), 0.0],
                    [-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon),
                     math.cos(lat)],
                    [math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon),
                     math.sin(lat)]])
    return r, rot


def _jd(t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    days = np.asarray(t_s, dtype=float) / 86400.0
    whole = np.floor(days)
    return whole + 2440587.5, days - whole


def _teme_to_ecef(r_teme: np.ndarray, jd: np.ndarray, fr: np.ndarray) -> np.ndarray:
    from skyfield.sgp4lib import theta_GMST1982

    theta, _ = theta_GMST1982(jd, fr)
    c, s = np.cos(theta), np.sin(theta)
    x, y, z = r_teme[..., 0], r_teme[..., 1], r_teme[..., 2]
    return np.stack([c * x + s * y, -s * x + c * y, z], axis=-1)


def _azel(r_ecef: np.ndarray, st_r: np.ndarray, rot: np.ndarray):
    enu = (r_ecef - st_r) @ rot.T
    e, n, u = enu[..., 0], enu[..., 1], enu[..., 2]
    return (np.mod(np.degrees(np.arctan2(e, n)), 360.0),
            np.degrees(np.arctan2(u, np.hypot(e, n))))


def real_passes(group: str, stations=STATIONS, start: datetime = START, days: float = 7.0,
                step_s: float = 1.0, pad_s: float = 60.0, coarse_s: float = 60.0,
                max_sats: int | None = None) -> list[SuitePass]:
    from sgp4.api import Satrec, SatrecArray

    sets = _read_tle(TLE_DIR / f"{group}.txt")[:max_sats]
    sats = [Satrec.twoline2rv(l1, l2) for _, l1, l2 in sets]
    t0 = start.timestamp()
    t = t0 + np.arange(0.0, days * 86400.0 + coarse_s, coarse_s)
    jd, fr = _jd(t)
    err, r, _ = SatrecArray(sats).sgp4(jd, fr)
    r = np.where((err == 0)[..., None], r, np.nan)
    ecef = _teme_to_ecef(r, jd[None, :], fr[None, :])
    geo = [_station_ecef_enu(st) for st in stations]
    up_all = [_azel(ecef, st_r, rot)[1] > st.min_el_deg for st, (st_r, rot) in
              zip(stations, geo, strict=True)]
    out: list[SuitePass] = []
    n_pad = round(pad_s / step_s)
    for k, (name, l1, _) in enumerate(sets):
        # Every pass of this satellite over every station, sampled in ONE sgp4 call.
        windows = []
        for s_i in range(len(stations)):
            row = up_all[s_i][k]
            if not row.any() or row.all():
                continue  # never up, or always up (GEO): nothing to plan as a pass
            edges = np.flatnonzero(np.diff(row.astype(np.int8)))
            for i0 in (i + 1 for i in edges if not row[i]):
                ends = np.flatnonzero(~row[i0:])
                if not len(ends):
                    break
                i1 = i0 + int(ends[0]) - 1
                windows.append((s_i, np.arange(t[i0 - 1] - pad_s, t[i1 + 1] + pad_s + 1e-9,
                                               step_s)))
        if not windows:
            continue
        tf_all = np.concatenate([w for _, w in windows])
        jf, ff = _jd(tf_all)
        e, rf, _ = sats[k].sgp4_array(jf, ff)
        ecef_f = _teme_to_ecef(rf, jf, ff)
        bounds = np.cumsum([0] + [len(w) for _, w in windows])
        for (s_i, tf), a, b in zip(windows, bounds[:-1], bounds[1:], strict=True):
            if np.any(e[a:b] != 0):
                continue
            st = stations[s_i]
            azf, elf = _azel(ecef_f[a:b], *geo[s_i])
            above = np.flatnonzero(elf >= st.min_el_deg)
            if len(above) < 2:
                continue
            lo = max(0, above[0] - n_pad)
            hi = min(len(tf), above[-1] + n_pad + 1)
            track = SkyTrack.from_azel(tf[lo:hi], azf[lo:hi], elf[lo:hi],
                                       name=name or l1[2:7])
            out.append(SuitePass(track, st, {
                "kind": "real", "group": group, "target": track.name, "station": st.name,
                "max_el_deg": float(elf[above].max())}))
    return out


def overhead_passes(count: int = 24, station: Station = STATIONS[0], seed: int = 3232
                    ) -> list[SuitePass]:
    """Forced near-overhead passes (max el 85-90, any azimuth, 6-12 min): the keyhole cases."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        max_el = float(rng.uniform(85.0, 90.0)) if i % 4 else 90.0
        track = synthetic_pass(max_el, float(rng.uniform(0, 360)), float(rng.uniform(360, 720)),
                               clockwise=bool(rng.integers(2)), name=f"OVERHEAD-{i:02d}")
        out.append(SuitePass(track, station, {"kind": "overhead", "group": "forced",
                                              "target": track.name, "station": station.name,
                                              "max_el_deg": max_el}))
    return out


def pass_suite(groups=("amateur", "weather"), stations=STATIONS, start: datetime = START,
               days: float = 7.0, step_s: float = 1.0, pad_s: float = 60.0,
               max_sats: int | None = None, n_overhead: int = 24) -> list[SuitePass]:
    """All passes of ``groups`` over ``days`` from ``stations`` plus forced overhead passes."""
    out: list[SuitePass] = []
    for g in groups:
        out += real_passes(g, stations, start, days, step_s, pad_s, max_sats=max_sats)
    out += overhead_passes(n_overhead)
    return out


def sample_suite(suite: list[SuitePass], n: int) -> list[SuitePass]:
    """``n`` passes spread evenly over ``suite`` (all of it when ``n`` <= 0 or larger)."""
    if n <= 0 or n >= len(suite):
        return list(suite)
    if n == 1:
        return [suite[0]]
    return [suite[round(i * (len(suite) - 1) / (n - 1))] for i in range(n)]


if __name__ == "__main__":
    import time

    t_start = time.perf_counter()
    suite = pass_suite(days=1.0)
    print(f"{len(suite)} passes in {time.perf_counter() - t_start:.1f} s")
