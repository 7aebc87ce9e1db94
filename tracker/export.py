"""Export pass lists: records, CSV, JSON (schema in docs/batch-json-schema.md), iCalendar.

Everything goes through plain *records* (one dict per pass, see :func:`pass_records`), so the
batch list and the one-rotator schedule export the same way; files are written by
:func:`tracker.files.write_atomic`.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
from collections.abc import Iterable, Sequence
from datetime import datetime, timezone

from tracker.errors import ConfigError

JSON_SCHEMA_ID = "rotator-tracker/batch-passes/1"

CSV_FIELDS = (
    "satellite", "station", "aos", "tca", "los", "duration_s", "max_el_deg", "aos_az_deg",
    "tca_az_deg", "los_az_deg", "aos_clipped", "los_clipped", "sunlit", "visible",
    "plan_mode", "plan_max_error_deg", "plan_preposition", "priority",
)


def iso(t_s: float) -> str:
    """POSIX seconds as ISO-8601 UTC, to the second (``2026-08-22T13:45:07Z``)."""
    return datetime.fromtimestamp(round(float(t_s)), timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def pass_records(table, plans: Sequence[dict | None] | None = None,
                 rows: Iterable[int] | None = None) -> list[dict]:
    """One dict per pass of a :class:`~tracker.batch.PassTable` (optionally only ``rows``),
    with the planner summary from ``plans`` (same order as the table) when given."""
    out = []
    idx = range(len(table.passes)) if rows is None else rows
    for i in idx:
        p = table.passes[i]
        plan = plans[i] if plans is not None else None
        out.append({
            "satellite": table.names[int(p["sat"])],
            "station": table.stations[int(p["station"])].name,
            "aos": iso(p["aos_s"]), "tca": iso(p["tca_s"]), "los": iso(p["los_s"]),
            "aos_s": float(p["aos_s"]), "tca_s": float(p["tca_s"]), "los_s": float(p["los_s"]),
            "duration_s": round(float(p["los_s"] - p["aos_s"]), 1),
            "max_el_deg": round(float(p["max_el_deg"]), 2),
            "aos_az_deg": round(float(p["aos_az_deg"]), 1),
            "tca_az_deg": round(float(p["tca_az_deg"]), 1),
            "los_az_deg": round(float(p["los_az_deg"]), 1),
            "aos_clipped": bool(p["aos_clipped"]), "los_clipped": bool(p["los_clipped"]),
            "sunlit": bool(p["sunlit"]), "visible": bool(p["visible"]),
            "plan": None if plan is None else {
                "mode": plan["mode"], "max_error_deg": plan["max_error_deg"],
                "preposition": iso(plan["preposition_s"]), "reason": plan.get("reason", "")},
        })
    return out


def _flat(rec: dict) -> dict:
    plan = rec.get("plan") or {}
    row = {k: rec.get(k, "") for k in CSV_FIELDS}
    row["plan_mode"] = plan.get("mode", "")
    row["plan_max_error_deg"] = plan.get("max_error_deg", "")
    row["plan_preposition"] = plan.get("preposition", "")
    row["priority"] = rec.get("priority", "")
    for k in ("aos_clipped", "los_clipped", "sunlit", "visible"):
        row[k] = "true" if rec.get(k) else "false"
    return row


def to_csv(records: Sequence[dict]) -> str:
    """CSV with a header row (columns :data:`CSV_FIELDS`; times ISO-8601 UTC)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
    w.writeheader()
    for rec in records:
        w.writerow(_flat(rec))
    return buf.getvalue()


def to_json(records: Sequence[dict], meta: dict | None = None,
            errors: Sequence[dict] = ()) -> str:
    """The documented JSON document: ``{"schema", "meta", "passes", "errors"}``."""
    doc = {"schema": JSON_SCHEMA_ID, "meta": dict(meta or {}), "passes": list(records),
           "errors": list(errors)}
    return json.dumps(doc, indent=1) + "\n"


def to_table(records: Sequence[dict]) -> str:
    """A fixed-width text table for the terminal."""
    head = (f"{'satellite':<24} {'station':<12} {'AOS (UTC)':<20} {'LOS':>8} {'max el':>6} "
            f"{'az AOS>LOS':>11} {'lit':>3} {'plan':<8} {'err':>5}")
    lines = [head, "-" * len(head)]
    for r in records:
        plan = r.get("plan") or {}
        err = plan.get("max_error_deg")
        lines.append(
            f"{r['satellite'][:24]:<24} {r['station'][:12]:<12} "
            f"{r['aos'].replace('T', ' ')[:19]:<20} {r['los'][11:19]:>8} "
            f"{r['max_el_deg']:>6.1f} {r['aos_az_deg']:>5.0f}>{r['los_az_deg']:<5.0f} "
            f"{'yes' if r['sunlit'] else 'no':>3} {plan.get('mode', '-'):<8} "
            f"{'-' if err is None else f'{err:.1f}':>5}")
    return "\n".join(lines) + "\n"


# iCalendar (RFC 5545) ---------------------------------------------------------------------


def _utc(t_s: float) -> datetime:
    return datetime.fromtimestamp(round(float(t_s)), timezone.utc)


def pass_uid(rec: dict) -> str:
    """A UID stable across runs: satellite, station and the TCA minute."""
    key = f"{rec['satellite']}|{rec['station']}|{round(rec['tca_s'] / 60.0)}"
    return hashlib.sha1(key.encode()).hexdigest()[:20] + "@rotator-tracker"


def _description(rec: dict) -> str:
    parts = [f"{rec['satellite']} from {rec['station']}",
             f"AOS {rec['aos']} az {rec['aos_az_deg']:.0f}",
             f"TCA {rec['tca']} el {rec['max_el_deg']:.1f} az {rec['tca_az_deg']:.0f}",
             f"LOS {rec['los']} az {rec['los_az_deg']:.0f}",
             f"sunlit: {'yes' if rec['sunlit'] else 'no'}, "
             f"visible: {'yes' if rec['visible'] else 'no'}"]
    # A clipped pass's DTSTART/DTEND are the window edges, not a rise or a set: say so.
    if rec.get("aos_clipped"):
        parts.append("already up at the window start (AOS shown is the start)")
    if rec.get("los_clipped"):
        parts.append("still up at the window end, or the elements stopped propagating "
                     "(LOS shown is that time)")
    plan = rec.get("plan")
    if plan:
        parts.append(f"plan: {plan['mode']}, predicted max error {plan['max_error_deg']} deg, "
                     f"pre-position at {plan['preposition']}")
        if plan.get("reason"):
            parts.append(plan["reason"])
    if rec.get("priority") not in (None, ""):
        parts.append(f"priority {rec['priority']}")
    return "\n".join(parts)


def to_ics(records: Sequence[dict], stamp_s: float, name: str = "Satellite passes") -> str:
    """An RFC 5545 calendar with one VEVENT per pass (AOS -> LOS).

    ``stamp_s`` is the DTSTAMP (the run's "as of" time, so the same input gives the same
    file). Escaping, folding and CRLF line ends are the ``icalendar`` library's.
    """
    from icalendar import Calendar, Event

    cal = Calendar()
    cal.add("prodid", "-//rotator-tracker//batch//EN")
    cal.add("version", "2.0")
    cal.add("calscale", "GREGORIAN")
    cal.add("method", "PUBLISH")
    cal.add("x-wr-calname", name)
    for rec in records:
        event = Event()
        event.add("uid", pass_uid(rec))
        event.add("dtstamp", _utc(stamp_s))
        event.add("dtstart", _utc(rec["aos_s"]))
        event.add("dtend", _utc(max(rec["los_s"], rec["aos_s"] + 1)))
        event.add("summary", f"{rec['satellite']} max {rec['max_el_deg']:.0f}°")
        event.add("location", rec["station"])
        event.add("description", _description(rec))
        event.add("transp", "TRANSPARENT")
        cal.add_component(event)
    return cal.to_ical().decode("utf-8")


FORMATS = ("table", "csv", "json", "ics")


def render(fmt: str, records: Sequence[dict], *, meta: dict | None = None,
           errors: Sequence[dict] = (), stamp_s: float = 0.0, name: str = "") -> str:
    if fmt == "table":
        return to_table(records)
    if fmt == "csv":
        return to_csv(records)
    if fmt == "json":
        return to_json(records, meta, errors)
    if fmt == "ics":
        return to_ics(records, stamp_s, name or "Satellite passes")
    raise ConfigError(f"format {fmt!r} is unknown; use one of {', '.join(FORMATS)}")
