"""Timeline plot of a pass list: one row per satellite, one bar per pass (extra ``plot``).

Bars run AOS -> LOS and are shaded by max elevation; with several stations each station gets
its own colour family. Chosen passes of a schedule can be drawn solid and the rest hollow.
Sky plots of single passes come from :func:`tracker.plot.sky_plot` (the planner's plot).
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path

MAX_ROWS = 80  # more satellites than this: keep the ones with the most passes


def timeline_plot(records: Sequence[dict], path: str | Path, start_s: float, end_s: float,
                  title: str = "", chosen: set[int] | None = None, *,
                  force: bool = False) -> Path:
    """Write the timeline of ``records`` (from :func:`tracker.export.pass_records`)."""
    from tracker.plot import _pyplot, check_plot_path, save_figure

    path = check_plot_path(path, force=force)
    plt = _pyplot()
    from matplotlib import dates as mdates

    counts: dict[str, int] = {}
    for r in records:
        counts[r["satellite"]] = counts.get(r["satellite"], 0) + 1
    names = sorted(counts, key=lambda n: (-counts[n], n))[:MAX_ROWS]
    names.sort()
    row_of = {n: i for i, n in enumerate(names)}
    stations = sorted({r["station"] for r in records})
    cmaps = ["Blues", "Oranges", "Greens", "Purples", "Reds", "Greys"]

    def when(t: float):
        return mdates.date2num(datetime.fromtimestamp(t, timezone.utc))

    fig, ax = plt.subplots(figsize=(11, max(2.5, 0.28 * len(names) + 1.5)))
    for i, r in enumerate(records):
        if r["satellite"] not in row_of:
            continue
        cmap = plt.get_cmap(cmaps[stations.index(r["station"]) % len(cmaps)])
        shade = cmap(0.35 + 0.6 * min(1.0, max(0.0, r["max_el_deg"]) / 90.0))
        hollow = chosen is not None and i not in chosen
        x0, x1 = when(r["aos_s"]), when(r["los_s"])
        ax.broken_barh([(x0, max(x1 - x0, 1e-5))], (row_of[r["satellite"]] - 0.35, 0.7),
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
        return save_figure(fig, path, force=force)
    finally:
        plt.close(fig)
