"""Every plot the tracker draws (extra ``plot``: matplotlib, imported lazily), written to
.png or .svg files only, never a window.

* :func:`sky_plot` - the polar sky plot of one MountPlan: the target's track, the antenna's
  predicted boresight (after rate-limited motion, flipped positions drawn where they actually
  point) and the horizon mask, north up, east to the right, zenith in the centre.
* :func:`timeline_plot` - a pass list: one row per satellite, one bar per pass. Bars run
  AOS -> LOS and are shaded by max elevation; with several stations each station gets its
  own colour family. Chosen passes of a schedule can be drawn solid and the rest hollow.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tracker.errors import ConfigError
from tracker.timescale import to_datetime

if TYPE_CHECKING:  # pragma: no cover
    from tracker.planner import MountPlan
    from tracker.station import Station

TIMELINE_MAX_ROWS = 80  # more satellites than this: keep the ones with the most passes


def require_matplotlib() -> None:
    """Refuse a plot before anything is computed when matplotlib is not installed."""
    import importlib.util

    if importlib.util.find_spec("matplotlib") is None:
        raise ConfigError("plotting needs matplotlib: pip install 'rotator-tracker[plot]'")


def _pyplot():
    require_matplotlib()
    import matplotlib

    matplotlib.use("Agg")  # files only; never opens a window
    import matplotlib.pyplot as plt

    return plt


def _boresight(plan: MountPlan) -> tuple[np.ndarray, np.ndarray]:
    """Bearing and elevation the antenna really points at (el > 90 folded over the top)."""
    b = plan.spec.bearing_of(plan.ant_az_deg)
    e = np.asarray(plan.ant_el_deg, dtype=float)
    over = e > 90.0
    return np.where(over, np.mod(b + 180.0, 360.0), b), np.where(over, 180.0 - e, e)


def check_plot_path(path: str | Path, *, force: bool = False, label: str = "") -> Path:
    """A .png/.svg name :func:`save_figure` can write, and matplotlib to draw it (checked
    before anything is computed)."""
    from tracker.files import check_output

    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg"):
        where = f"{label} {path}" if label else str(path)
        raise ConfigError(f"{where}: use a .png or .svg file name")
    check_output(path, force=force, label=label)
    require_matplotlib()
    return path


def save_figure(fig, path: Path, *, force: bool = False, label: str = "") -> Path:
    """Render ``fig`` in memory and write it with :func:`tracker.files.write_atomic`."""
    import io

    from tracker.files import write_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format=path.suffix.lower().lstrip("."))
    return write_atomic(path, buf.getvalue(), force=force, label=label)


def sky_plot(plan: MountPlan, station: Station, path: str | Path, *, force: bool = False,
             label: str = "") -> Path:
    """Write the polar sky plot of ``plan`` to ``path`` (.png or .svg); returns the path."""
    path = check_plot_path(path, force=force, label=label)
    plt = _pyplot()
    fig = plt.figure(figsize=(6.4, 6.8))
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_rlim(0, 90)
    ax.set_rticks([0, 30, 60, 90])
    ax.set_yticklabels(["90", "60", "30", "0"])

    az_grid = np.arange(0.0, 361.0, 1.0)
    horizon = np.asarray(station.horizon_at(az_grid))
    ax.fill_between(np.radians(az_grid), 90.0 - horizon, 90.0, color="0.85",
                    label="horizon mask", zorder=0)

    vis = plan.visible
    track = plan.track
    ax.plot(np.radians(track.az_deg[vis]), 90.0 - track.el_deg[vis], color="tab:blue",
            lw=2.0, label=f"{track.name or 'target'}")
    vis_idx = np.flatnonzero(vis)
    ax.plot(np.radians(track.az_deg[vis_idx[0]]), 90.0 - track.el_deg[vis_idx[0]], "o",
            color="tab:green", label="AOS")
    ax.plot(np.radians(track.az_deg[vis_idx[-1]]), 90.0 - track.el_deg[vis_idx[-1]], "s",
            color="tab:red", label="LOS")
    b, e = _boresight(plan)
    ax.plot(np.radians(b[vis]), 90.0 - np.clip(e[vis], 0, 90), color="tab:orange", lw=1.2,
            ls="--", label="antenna (predicted)")
    lost = vis & (plan.error_deg > plan.threshold_deg)
    if lost.any():
        ax.plot(np.radians(track.az_deg[lost]), 90.0 - track.el_deg[lost], ".",
                color="tab:red", ms=3, label=f"lost ({plan.lost_track_s:.0f} s)")
    ax.set_title(f"{track.name} on {plan.spec.name}: {plan.mode}\n"
                 f"max error {plan.max_error_deg:.1f}°, lost {plan.lost_track_s:.0f} s, "
                 f"travel {plan.travel_deg:.0f}°", fontsize=10)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.12), fontsize=8, ncol=3)
    fig.tight_layout()
    try:
        return save_figure(fig, path, force=force, label=label)
    finally:
        plt.close(fig)


def timeline_plot(records, path: str | Path, start_s: float, end_s: float,
                  title: str = "", chosen: set[int] | None = None, *,
                  force: bool = False, label: str = "") -> Path:
    """Write the timeline of ``records`` (a :class:`tracker.export.PassRecords`)."""
    path = check_plot_path(path, force=force, label=label)
    plt = _pyplot()
    from matplotlib import dates as mdates

    targets = records["target"].tolist()
    at_station = records["station"].tolist()
    counts: dict[str, int] = {}
    for name in targets:
        counts[name] = counts.get(name, 0) + 1
    names = sorted(counts, key=lambda n: (-counts[n], n))[:TIMELINE_MAX_ROWS]
    names.sort()
    row_of = {n: i for i, n in enumerate(names)}
    stations = sorted(set(at_station))
    cmaps = ["Blues", "Oranges", "Greens", "Purples", "Reds", "Greys"]

    def when(t: float):
        return mdates.date2num(to_datetime(t))

    fig, ax = plt.subplots(figsize=(11, max(2.5, 0.28 * len(names) + 1.5)))
    spans = zip(targets, at_station, records["aos_s"].tolist(), records["los_s"].tolist(),
                records["max_el_deg"].tolist(), strict=True)
    for i, (name, station, aos_s, los_s, max_el_deg) in enumerate(spans):
        if name not in row_of:
            continue
        cmap = plt.get_cmap(cmaps[stations.index(station) % len(cmaps)])
        shade = cmap(0.35 + 0.6 * min(1.0, max(0.0, max_el_deg) / 90.0))
        hollow = chosen is not None and i not in chosen
        x0, x1 = when(aos_s), when(los_s)
        ax.broken_barh([(x0, max(x1 - x0, 1e-5))], (row_of[name] - 0.35, 0.7),
                       facecolors="none" if hollow else shade, edgecolors=shade,
                       linewidth=0.6)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names, fontsize=7)
    ax.set_ylim(-1, len(names))
    ax.set_xlim(when(start_s), when(end_s))
    ax.xaxis.set_major_formatter(mdates.DateFormatter("%m-%d %H:%M"))
    ax.set_xlabel("UTC (bar shade: max elevation" + (
        "; hollow: not scheduled)" if chosen is not None else ")"))
    if len(stations) > 1:
        ax.set_title((title + "  " if title else "") + "stations: " + ", ".join(
            f"{s} ({cmaps[k % len(cmaps)][:-1].lower()})" for k, s in enumerate(stations)),
            fontsize=9)
    elif title:
        ax.set_title(title, fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    fig.autofmt_xdate()
    fig.tight_layout()
    try:
        return save_figure(fig, path, force=force, label=label)
    finally:
        plt.close(fig)
