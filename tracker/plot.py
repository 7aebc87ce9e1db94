"""Plots (extra ``plot``: matplotlib, imported lazily): the polar sky plot of a MountPlan.

The sky plot shows the target's track, the antenna's predicted boresight (after rate-limited
motion, flipped positions drawn where they actually point) and the horizon mask, north up,
east to the right, zenith in the centre.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tracker.errors import ConfigError

if TYPE_CHECKING:  # pragma: no cover
    from tracker.planner import MountPlan
    from tracker.station import Station


def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise ConfigError("plotting needs matplotlib: pip install 'rotator-tracker[plot]'"
                          ) from None
    matplotlib.use("Agg")  # files only; never opens a window
    import matplotlib.pyplot as plt

    return plt


def _boresight(plan: MountPlan) -> tuple[np.ndarray, np.ndarray]:
    """Bearing and elevation the antenna really points at (el > 90 folded over the top)."""
    b = plan.spec.bearing_of(plan.ant_az_deg)
    e = np.asarray(plan.ant_el_deg, dtype=float)
    over = e > 90.0
    return np.where(over, np.mod(b + 180.0, 360.0), b), np.where(over, 180.0 - e, e)


def check_plot_path(path: str | Path, *, force: bool = False, label: str = "--plot") -> Path:
    """A .png/.svg name :func:`save_figure` can write (checked before drawing)."""
    from tracker.files import check_output

    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg"):
        raise ConfigError(f"{label} {path}: use a .png or .svg file name")
    check_output(path, force=force, label=label)
    return path


def save_figure(fig, path: Path, *, force: bool = False, label: str = "--plot") -> Path:
    """Render ``fig`` in memory and write it with :func:`tracker.files.write_atomic`."""
    import io

    from tracker.files import write_atomic

    buf = io.BytesIO()
    fig.savefig(buf, format=path.suffix.lower().lstrip("."))
    return write_atomic(path, buf.getvalue(), force=force, label=label)


def sky_plot(plan: MountPlan, station: Station, path: str | Path, *, force: bool = False,
             label: str = "--plot") -> Path:
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
