"""The pass record and its exports: CSV, JSON (schema in docs/pass-schema.md), iCalendar.

``tracker passes``, ``tracker batch`` and ``tracker schedule`` all write one record per pass
with the fields :data:`PASS_FIELDS`, whatever found the pass: :func:`pass_records` turns a
batch :class:`~tracker.batch.PassTable` or a list of single-target
:class:`~tracker.passes.Pass` values into a :class:`PassRecords`, a set of columns (numpy
arrays), so CSV and JSON are written column-wise without a Python object per cell. Files are
written by :func:`tracker.files.write_atomic`.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

import numpy as np

from tracker.errors import ConfigError
from tracker.skytrack import COMPASS_POINTS, compass_index
from tracker.timescale import iso_utc, iso_utc_array, to_datetime

JSON_SCHEMA_ID = "rotator-tracker/passes/2"

# The pass record: the JSON keys, in this order (meanings: docs/pass-schema.md).
PASS_FIELDS = (
    "target", "kind", "station", "aos", "tca", "los", "aos_s", "tca_s", "los_s",
    "duration_s", "max_el_deg", "aos_az_deg", "tca_az_deg", "los_az_deg", "aos_compass",
    "los_compass", "sunlit", "visible", "in_progress_at_start", "aos_known", "los_known",
    "always_up", "plan_mode", "plan_max_error_deg", "plan_preposition", "plan_reason",
    "priority", "chosen", "conflicts_with",
)
# CSV leaves out the POSIX seconds (the ISO columns say the same to the second).
CSV_FIELDS = tuple(k for k in PASS_FIELDS if k not in ("aos_s", "tca_s", "los_s"))
_FLAGS = ("sunlit", "visible", "in_progress_at_start", "aos_known", "los_known", "always_up")
# Decimals kept per number field (times in *_s keep full precision).
_DECIMALS = {"duration_s": 1, "max_el_deg": 2, "aos_az_deg": 1, "tca_az_deg": 1,
             "los_az_deg": 1}
# Filled by the planner (--rotator) and the schedule; None (CSV: empty) otherwise.
_OPTIONAL = ("plan_mode", "plan_max_error_deg", "plan_preposition", "plan_reason",
             "priority", "chosen", "conflicts_with")


@dataclass
class PassRecords:
    """Pass records as columns: ``columns[field]`` is an array with one entry per pass, for
    every field of :data:`PASS_FIELDS` (object arrays holding None where a field is unset).

    ``categories[field]`` = ``(column, codes, values)`` says that ``column`` (the field's
    column when it was built) is ``values[codes]``: CSV then formats each of the few values
    once (a catalogue's names, the compass points) instead of every cell. It is ignored
    once ``columns[field]`` is another array.
    """

    columns: dict[str, np.ndarray]
    categories: dict[str, tuple[np.ndarray, np.ndarray, Sequence]] = field(
        default_factory=dict)

    def __len__(self) -> int:
        return len(self.columns["aos_s"])

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def take(self, index) -> PassRecords:
        """The records at ``index`` (indices or a boolean mask), in that order."""
        index = np.asarray(index)
        if index.dtype != bool:
            index = index.astype(np.intp)
        columns = {k: v[index] for k, v in self.columns.items()}
        return PassRecords(columns, {k: (_frozen(columns[k]), codes[index], values)
                                     for k, (column, codes, values) in self.categories.items()
                                     if self.columns.get(k) is column})

    def set(self, name: str, values: Iterable) -> None:
        """Fill an optional field (``priority``, ``chosen``, ...) for every record."""
        if name not in _OPTIONAL:
            raise KeyError(f"{name!r} is not an optional pass field")
        column = np.empty(len(self), dtype=object)
        column[:] = list(values)
        self.columns[name] = column

    @classmethod
    def concat(cls, parts: Sequence[PassRecords]) -> PassRecords:
        """The records of ``parts`` one after the other."""
        if len(parts) == 1:
            return parts[0]
        return cls({k: np.concatenate([p.columns[k] for p in parts]) for k in PASS_FIELDS})

    def rows(self) -> list[dict[str, Any]]:
        """One dict per pass with plain Python values (the JSON objects)."""
        cols = [self.columns[k].tolist() for k in PASS_FIELDS]
        return [dict(zip(PASS_FIELDS, values, strict=True))
                for values in zip(*cols, strict=True)]


def _none(n: int) -> np.ndarray:
    return np.full(n, None, dtype=object)


def _records(target, kind, station, t_s: dict[str, np.ndarray], angles: dict[str, np.ndarray],
             flags: dict[str, np.ndarray], plans: Sequence[dict | None] | None,
             codes: dict[str, tuple[np.ndarray, Sequence]] | None = None) -> PassRecords:
    """The one builder of the record, from arrays (``t_s``: aos/tca/los; ``angles``: max_el_deg,
    aos/tca/los_az_deg; ``flags``: :data:`_FLAGS`; ``codes``: (codes, values) of the fields
    given as categories, see :class:`PassRecords`)."""
    n = len(t_s["aos"])
    cols: dict[str, np.ndarray] = {"target": target, "kind": kind, "station": station}
    codes = dict(codes or {})
    for key in ("aos", "tca", "los"):
        cols[key] = iso_utc_array(t_s[key])
    for key in ("aos", "tca", "los"):
        cols[f"{key}_s"] = np.asarray(t_s[key], dtype=float)
    cols["duration_s"] = np.round(cols["los_s"] - cols["aos_s"], _DECIMALS["duration_s"])
    for key, value in angles.items():
        cols[key] = np.round(np.asarray(value, dtype=float), _DECIMALS[key])
    points = np.array(COMPASS_POINTS, dtype=object)
    for key in ("aos", "los"):
        index = compass_index(angles[f"{key}_az_deg"])
        cols[f"{key}_compass"] = points[index]
        codes[f"{key}_compass"] = (index, COMPASS_POINTS)
    for key in _FLAGS:
        cols[key] = np.asarray(flags[key], dtype=bool)
    unset = np.zeros(n, np.intp)
    for key in _OPTIONAL:
        cols[key] = _none(n)
        codes[key] = (unset, (None,))
    if plans is not None:
        for key in ("plan_mode", "plan_max_error_deg", "plan_preposition", "plan_reason"):
            del codes[key]
        for i, plan in enumerate(plans):
            if plan:
                cols["plan_mode"][i] = plan["mode"]
                cols["plan_max_error_deg"][i] = plan["max_error_deg"]
                cols["plan_preposition"][i] = iso_utc(plan["preposition_s"])
                cols["plan_reason"][i] = plan.get("reason", "")
    return PassRecords(cols, {k: (_frozen(cols[k]), c, values) for k, (c, values) in codes.items()})


def _frozen(column: np.ndarray) -> np.ndarray:
    """``column`` made read-only: a category's cells are formatted from its codes, so an edit
    in place would not show; a field is changed by giving it a new column (``set``)."""
    column.flags.writeable = False
    return column


def pass_records(passes, plans: Sequence[dict | None] | None = None) -> PassRecords:
    """The pass records of a batch :class:`~tracker.batch.PassTable` or of a sequence of
    :class:`~tracker.passes.Pass`, with the planner summaries ``plans`` (same order, None for
    a pass without one) when given.

    A PassTable's ``aos_clipped``/``los_clipped`` become ``aos_known``/``los_known`` false
    (and ``in_progress_at_start`` / ``always_up``), the meanings :class:`Pass` has.
    """
    table = getattr(passes, "passes", None)
    if isinstance(table, np.ndarray):
        n = len(table)
        sat = table["sat"].astype(np.intp)
        st = table["station"].astype(np.intp)
        aos_clipped = table["aos_clipped"].astype(bool)
        los_clipped = table["los_clipped"].astype(bool)
        stations = [s.name for s in passes.stations]
        return _records(
            np.array(passes.names, dtype=object)[sat], np.full(n, "satellite", dtype=object),
            np.array(stations, dtype=object)[st],
            {k: table[f"{k}_s"] for k in ("aos", "tca", "los")},
            {k: table[k] for k in ("max_el_deg", "aos_az_deg", "tca_az_deg", "los_az_deg")},
            {"sunlit": table["sunlit"], "visible": table["visible"],
             "in_progress_at_start": aos_clipped, "aos_known": ~aos_clipped,
             "los_known": ~los_clipped, "always_up": aos_clipped & los_clipped},
            plans, {"target": (sat, passes.names), "kind": (np.zeros(n, np.intp), ("satellite",)),
                    "station": (st, stations)})
    passes = list(passes)

    def column(get, dtype=object) -> np.ndarray:
        out = np.empty(len(passes), dtype=dtype)
        out[:] = [get(p) for p in passes]
        return out

    return _records(
        column(lambda p: p.target_name), column(lambda p: p.kind),
        column(lambda p: p.station.name if p.station is not None else ""),
        {k: column(lambda p, k=k: getattr(p, k).timestamp(), float)
         for k in ("aos", "tca", "los")},
        {k: column(lambda p, k=k: getattr(p, k), float)
         for k in ("max_el_deg", "aos_az_deg", "tca_az_deg", "los_az_deg")},
        {k: column(lambda p, k=k: getattr(p, k), bool) for k in _FLAGS},
        plans)


def error_records(errors: Iterable) -> list[dict]:
    """The ``errors`` entries of the JSON document (and Parquet metadata) for a batch
    table's :class:`~tracker.batch.SatError` list."""
    return [{"target": e.name, "code": e.code, "message": e.message,
             "from": iso_utc(e.first_s)} for e in errors]


def station_meta(station) -> dict:
    """A station as the ``meta.stations`` entries of the JSON document."""
    return {"name": station.name, "lat_deg": station.lat_deg, "lon_deg": station.lon_deg,
            "alt_m": station.alt_m, "min_el_deg": station.min_el_deg,
            "mask": station.mask is not None}


def _csv_text(value: Any) -> str:
    """One CSV cell as the csv module writes it (minimal quoting), flags as true/false."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    text = value if isinstance(value, str) else repr(value)
    if any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


def _rounded_distinct(col: np.ndarray, decimals: int) -> tuple[list[str], np.ndarray] | None:
    """``(repr of each distinct value, each row's index into them)`` of a column rounded to
    ``decimals`` (as :func:`_records` rounds); None when the column is not such a column."""
    scale = 10.0 ** decimals
    steps = np.rint(col * scale)
    if not (np.all(np.isfinite(steps)) and np.all(np.abs(steps) < 2.0**52)
            and np.array_equal(steps / scale, col) and not np.any(np.signbit(col) & (col == 0))):
        return None
    values, index = np.unique(steps, return_inverse=True)
    # steps / scale is bit for bit the column value, so its repr is the cell.
    return list(map(repr, (values / scale).tolist())), index.ravel()


def _rounded_cells(col: np.ndarray, decimals: int) -> list[str] | None:
    """``repr`` of each value of a rounded column (:func:`_rounded_distinct`), each distinct
    value formatted once; None when the column is not such a column."""
    found = _rounded_distinct(col, decimals)
    if found is None:
        return None
    text, index = found
    return np.array(text, dtype=object)[index].tolist()


def _csv_column(col: np.ndarray, decimals: int | None = None) -> list[str]:
    """The cells of one column, formatted column-wise (the batch table has 10^5 rows);
    ``decimals``: the float column is rounded to that many (formats faster)."""
    if col.dtype == bool:
        return np.where(col, "true", "false").tolist()
    if col.dtype.kind == "f":
        cells = None if decimals is None else _rounded_cells(col, decimals)
        return list(map(repr, col.tolist())) if cells is None else cells
    if col.dtype.kind == "U":  # ISO times: never need quoting
        return col.tolist()
    values = col.tolist()
    # Object columns hold few distinct values (names, modes, None): format each once.
    keys = list(map(_distinct_key, values))
    text = {k: _csv_text(v) for k, v in zip(keys, values, strict=True)}
    return list(map(text.__getitem__, keys))


def _csv_constant(col: np.ndarray) -> str | None:
    """The cell of an object column holding one value throughout (kind, the unset optional
    fields), else None."""
    if col.dtype != object or not len(col):
        return None
    first = col[0]
    same = np.equal(col, None) if first is None else col == first
    return _csv_text(first) if isinstance(same, np.ndarray) and same.all() else None


def _csv_rows_by_cell(records: PassRecords) -> str:
    """The CSV rows of ``records`` joined cell by cell in Python (for text holding NUL, which
    :func:`_csv_rows` cannot carry); runs of constant columns are joined once, not per row."""
    cols: list[Iterable[str]] = []
    run: list[str] = []
    for key in CSV_FIELDS:
        cell = _csv_constant(records[key])
        if cell is not None:
            run.append(cell)
            continue
        if run:
            cols.append(itertools.repeat(",".join(run)))
            run = []
        cols.append(_csv_column(records[key], _DECIMALS.get(key)))
    if run:
        cols.append(itertools.repeat(",".join(run)))
    return "\n".join(map(",".join, zip(*cols, strict=False))) + "\n"  # repeat: endless


class _CategoryText:
    """The cells (UTF-8 bytes) of categories' values in one format (``text``: a value's
    cell), each value list formatted once per document (the same list of names comes with
    every part of a table)."""

    def __init__(self, text: Callable[[Any], str]) -> None:
        self.text = text
        self.known: dict[int, tuple[Sequence, np.ndarray | None]] = {}

    def __call__(self, values: Sequence) -> np.ndarray | None:
        hit = self.known.get(id(values))
        if hit is not None and hit[0] is values:
            return hit[1]
        cells = _utf8_cells([self.text(v) for v in values])
        self.known[id(values)] = (values, cells)  # the reference keeps the id valid
        return cells


def _utf8_cells(texts: list[str]) -> np.ndarray | None:
    """``texts`` as a numpy ``S`` array of UTF-8 bytes, or None when one holds NUL (the ``S``
    type would strip it at the end, and :func:`_joined_rows` takes NUL for padding)."""
    if any("\0" in t for t in texts):
        return None
    cells = _ascii(np.array(texts, dtype=str))
    return cells if cells is not None else np.array([t.encode() for t in texts], dtype=bytes)


def _ascii(text: np.ndarray) -> np.ndarray | None:
    """A numpy ``U`` array of ASCII text as the ``S`` array of the same text, else None.
    (Through the code points as integers: numpy's own U to S cast costs about 1 us a cell.)"""
    points = np.ascontiguousarray(text).view(np.uint32)
    if points.size and points.max() >= 128:
        return None
    return points.astype(np.uint8).view(f"S{max(text.dtype.itemsize // 4, 1)}")


def _needs_escape(cells: np.ndarray) -> bool:
    """Does ASCII text (an ``S`` array) hold a byte CSV quotes or JSON escapes (a comma, a
    double quote, a backslash or a control character)?"""
    b = cells.view(np.uint8)
    return bool(np.any((b == ord(",")) | (b == ord('"')) | (b == ord("\\"))
                       | ((b > 0) & (b < 32))))


def _float_text(col: np.ndarray, decimals: int | None, text: Callable[[Any], str]
                ) -> np.ndarray | None:
    """The cells of a float column: a rounded column (:func:`_rounded_text`) formats each
    distinct value once; otherwise ``repr`` of each value (what ``text`` gives for a finite
    float), or ``text`` of each where one is not finite."""
    cells = None if decimals is None else _rounded_text(col, decimals)
    if cells is not None:
        return cells
    values = col.tolist()
    return _utf8_cells(list(map(repr if np.isfinite(col).all() else text, values)))


def _column_cells(records: PassRecords, key: str, category_text: _CategoryText
                  ) -> np.ndarray | None:
    """The cells of one column in ``category_text``'s format as UTF-8 bytes (a numpy ``S``
    array, one per row), or None for text holding NUL (the ``S`` type strips it at the
    end). Flags are ``true``/``false`` and floats their ``repr`` in both CSV and JSON."""
    col = records[key]
    cat = records.categories.get(key)
    if cat is not None and cat[0] is col:
        cells = category_text(cat[2])
        return None if cells is None else cells[cat[1]]
    if col.dtype == bool:
        return np.where(col, b"true", b"false")
    if col.dtype.kind == "f":
        return _float_text(col, _DECIMALS.get(key), category_text.text)
    if col.dtype.kind == "U":  # ISO times: plain ASCII, written as they are (JSON: quoted)
        cells = _ascii(col)
        if cells is None or _needs_escape(cells):
            return _utf8_cells(list(map(category_text.text, col.tolist())))
        return cells if category_text.text is _csv_text else np.char.add(
            np.char.add(b'"', cells), b'"')
    # Each distinct value of an object column formatted once.
    values = col.tolist()
    keys = list(map(_distinct_key, values))
    index: dict = {}
    distinct = []
    for key, value in zip(keys, values, strict=True):
        if key not in index:
            index[key] = len(distinct)
            distinct.append(value)
    text = _utf8_cells([category_text.text(v) for v in distinct])
    if text is None:
        return None
    return text[np.fromiter(map(index.__getitem__, keys), np.intp, len(keys))]


def _distinct_key(value: Any) -> Any:
    """A key equal only for values written alike: 1, 1.0 and True are equal in Python, and so
    are 0.0 and -0.0, but each is written differently."""
    if isinstance(value, float):
        return (float, value, math.copysign(1.0, value))
    return (type(value), value)


def _rounded_text(col: np.ndarray, decimals: int) -> np.ndarray | None:
    """:func:`_rounded_cells` as UTF-8 bytes (a numpy ``S`` array)."""
    found = _rounded_distinct(col, decimals)
    if found is None:
        return None
    text = _ascii(np.array(found[0], dtype=str))
    return None if text is None else text[found[1]]


def _joined_rows(records: PassRecords, fields: Sequence[str], category_text: _CategoryText,
                 glue: Callable[[int], bytes]) -> bytes | None:
    """Every row of ``records`` as ``glue(0)``, the cell of ``fields[0]``, ``glue(1)``, ...,
    the cell of the last field, ``glue(len(fields))``, assembled as bytes column by column:
    each column's cells are copied into a row-major byte matrix (padded with NUL to the
    column's widest cell) and the padding is dropped. No Python object per row. None when a
    cell holds NUL."""
    n = len(records)
    pieces = [np.frombuffer(glue(0), np.uint8).reshape(1, -1)]
    for i, key in enumerate(fields):
        cells = _column_cells(records, key, category_text)
        if cells is None:
            return None
        pieces += [cells.view(np.uint8).reshape(n, -1),
                   np.frombuffer(glue(i + 1), np.uint8).reshape(1, -1)]
    matrix = np.zeros((n, sum(p.shape[1] for p in pieces)), np.uint8)
    at = 0
    for p in pieces:
        matrix[:, at:at + p.shape[1]] = p
        at += p.shape[1]
    return matrix[matrix != 0].tobytes()


def _csv_glue(i: int) -> bytes:
    return b"" if i == 0 else b"\n" if i == len(CSV_FIELDS) else b","


def _csv_rows(records: PassRecords, category_text: _CategoryText | None = None) -> str:
    """The CSV rows of ``records`` (:func:`_joined_rows`; text holding NUL cell by cell)."""
    rows = _joined_rows(records, CSV_FIELDS, category_text or _CategoryText(_csv_text),
                        _csv_glue) if len(records) else b""
    return _csv_rows_by_cell(records) if rows is None else rows.decode("utf-8")


def _csv_chunks(chunks: Iterable[PassRecords]) -> Iterator[str]:
    yield ",".join(CSV_FIELDS) + "\n"
    category_text = _CategoryText(_csv_text)
    for records in chunks:
        if len(records):
            yield _csv_rows(records, category_text)


def to_csv(records: PassRecords) -> str:
    """CSV with a header row (columns :data:`CSV_FIELDS`; times ISO-8601 UTC, flags
    ``true``/``false``, unset fields empty)."""
    return "".join(_csv_chunks([records]))


# json.dumps of one pass record (its dict, default separators), between the cells.
_JSON_GLUE = [("{" if i == 0 else ", ") + json.dumps(k) + ": " for i, k in
              enumerate(PASS_FIELDS)]
_JSON_ROW_SEP = ",\n  "


def _json_glue(i: int) -> bytes:
    return (_JSON_GLUE[i] if i < len(PASS_FIELDS) else "}" + _JSON_ROW_SEP).encode()


def _json_rows(records: PassRecords, category_text: _CategoryText) -> str:
    """``json.dumps`` of each pass record's dict, joined by :data:`_JSON_ROW_SEP`, built
    column-wise (:func:`_joined_rows`)."""
    rows = _joined_rows(records, PASS_FIELDS, category_text, _json_glue)
    if rows is None:
        return _JSON_ROW_SEP.join(map(json.dumps, records.rows()))
    return rows[:-len(_JSON_ROW_SEP)].decode("ascii")


def _json_chunks(chunks: Iterable[PassRecords], meta: dict | None,
                 errors: Sequence[dict]) -> Iterator[str]:
    def block(value: Any) -> str:
        return json.dumps(value, indent=1).replace("\n", "\n ")

    yield (f'{{\n "schema": {json.dumps(JSON_SCHEMA_ID)},\n "meta": {block(dict(meta or {}))},'
           f'\n "passes": ')
    sep = "[\n  "
    category_text = _CategoryText(json.dumps)
    for records in chunks:
        if len(records):
            yield sep + _json_rows(records, category_text)
            sep = _JSON_ROW_SEP
    yield ("[]" if sep == "[\n  " else "\n ]") + f',\n "errors": {block(list(errors))}\n}}\n'


def to_json(records: PassRecords, meta: dict | None = None,
            errors: Sequence[dict] = ()) -> str:
    """The documented JSON document: ``{"schema", "meta", "passes", "errors"}``, one pass
    object per line."""
    return "".join(_json_chunks([records], meta, errors))


def _table_chunks(chunks: Iterable[PassRecords]) -> Iterator[str]:
    head = (f"{'satellite':<24} {'station':<12} {'AOS (UTC)':<20} {'LOS':>8} {'max el':>6} "
            f"{'az AOS>LOS':>11} {'lit':>3} {'plan':<8} {'err':>5}")
    yield head + "\n" + "-" * len(head) + "\n"
    for records in chunks:
        if len(records):
            yield "\n".join(_table_lines(records)) + "\n"


def _table_lines(records: PassRecords) -> list[str]:
    lines = []
    for r in records.rows():
        err = r["plan_max_error_deg"]
        lines.append(
            f"{r['target'][:24]:<24} {r['station'][:12]:<12} "
            f"{r['aos'].replace('T', ' ')[:19]:<20} {r['los'][11:19]:>8} "
            f"{r['max_el_deg']:>6.1f} {r['aos_az_deg']:>5.0f}>{r['los_az_deg']:<5.0f} "
            f"{'yes' if r['sunlit'] else 'no':>3} {r['plan_mode'] or '-':<8} "
            f"{'-' if err is None else f'{err:.1f}':>5}")
    return lines


def to_table(records: PassRecords) -> str:
    """A fixed-width text table for the terminal."""
    return "".join(_table_chunks([records]))


# iCalendar (RFC 5545) ---------------------------------------------------------------------


def _utc(t_s: float) -> datetime:
    return to_datetime(round(float(t_s)))


def pass_uid(rec: dict) -> str:
    """A UID stable across runs: target, station and the TCA minute."""
    key = f"{rec['target']}|{rec['station']}|{round(rec['tca_s'] / 60.0)}"
    return hashlib.sha1(key.encode()).hexdigest()[:20] + "@rotator-tracker"


def _description(rec: dict) -> str:
    parts = [f"{rec['target']} from {rec['station']}",
             f"AOS {rec['aos']} az {rec['aos_az_deg']:.0f}",
             f"TCA {rec['tca']} el {rec['max_el_deg']:.1f} az {rec['tca_az_deg']:.0f}",
             f"LOS {rec['los']} az {rec['los_az_deg']:.0f}",
             f"sunlit: {'yes' if rec['sunlit'] else 'no'}, "
             f"visible: {'yes' if rec['visible'] else 'no'}"]
    # A clipped pass's DTSTART/DTEND are the window edges, not a rise or a set: say so.
    if not rec["aos_known"]:
        parts.append("already up at the window start (AOS shown is the start)")
    if not rec["los_known"]:
        parts.append("still up at the window end, or the elements stopped propagating "
                     "(LOS shown is that time)")
    if rec["plan_mode"]:
        parts.append(f"plan: {rec['plan_mode']}, predicted max error "
                     f"{rec['plan_max_error_deg']} deg, pre-position at "
                     f"{rec['plan_preposition']}")
        if rec["plan_reason"]:
            parts.append(rec["plan_reason"])
    if rec["priority"] is not None:
        parts.append(f"priority {rec['priority']}")
    return "\n".join(parts)


def to_ics(records: PassRecords, stamp_s: float, name: str = "Satellite passes") -> str:
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
    for rec in records.rows():
        event = Event()
        event.add("uid", pass_uid(rec))
        event.add("dtstamp", _utc(stamp_s))
        event.add("dtstart", _utc(rec["aos_s"]))
        event.add("dtend", _utc(max(rec["los_s"], rec["aos_s"] + 1)))
        event.add("summary", f"{rec['target']} max {rec['max_el_deg']:.0f}°")
        event.add("location", rec["station"])
        event.add("description", _description(rec))
        event.add("transp", "TRANSPARENT")
        cal.add_component(event)
    return cal.to_ical().decode("utf-8")


FORMATS = ("table", "csv", "json", "ics")
PARQUET_EXTRA = "pip install 'rotator-tracker[parquet]'"


def render_chunks(fmt: str, chunks: Iterable[PassRecords], *, meta: dict | None = None,
                  errors: Sequence[dict] = (), stamp_s: float = 0.0,
                  name: str = "") -> Iterator[str]:
    """:func:`render` for records given in consecutive parts: the same text, in pieces,
    so a large result is written without holding all of it as text (iCalendar joins the
    parts first)."""
    if fmt == "table":
        return _table_chunks(chunks)
    if fmt == "csv":
        return _csv_chunks(chunks)
    if fmt == "json":
        return _json_chunks(chunks, meta, errors)
    if fmt == "ics":
        return iter([to_ics(PassRecords.concat(list(chunks)), stamp_s,
                            name or "Satellite passes")])
    raise ConfigError(f"format {fmt!r} is unknown; use one of {', '.join(FORMATS)}")


def render(fmt: str, records: PassRecords, *, meta: dict | None = None,
           errors: Sequence[dict] = (), stamp_s: float = 0.0, name: str = "") -> str:
    return "".join(render_chunks(fmt, [records], meta=meta, errors=errors, stamp_s=stamp_s,
                                 name=name))


# Parquet (optional: pyarrow) --------------------------------------------------------------


def require_pyarrow():
    """The ``pyarrow`` module, or a ConfigError naming the extra that installs it."""
    try:
        import pyarrow
        import pyarrow.parquet  # the writer lives in the submodule
    except ImportError:
        raise ConfigError(f"Parquet output needs pyarrow, which is not installed: "
                          f"{PARQUET_EXTRA}") from None
    return pyarrow


def arrow_schema(pa, meta: dict | None, errors: Sequence[dict]):
    """The Parquet schema of the pass record, with ``{"schema", "meta", "errors"}`` as
    key-value metadata under ``rotator-tracker``."""
    types = {"aos_s": pa.float64(), "tca_s": pa.float64(), "los_s": pa.float64(),
             "plan_max_error_deg": pa.float64(), "priority": pa.int64(),
             "chosen": pa.bool_()}
    for key in _DECIMALS:
        types[key] = pa.float64()
    for key in _FLAGS:
        types[key] = pa.bool_()
    fields = [pa.field(k, types.get(k, pa.string()), nullable=k in _OPTIONAL)
              for k in PASS_FIELDS]
    doc = {"schema": JSON_SCHEMA_ID, "meta": dict(meta or {}), "errors": list(errors)}
    return pa.schema(fields, metadata={"rotator-tracker": json.dumps(doc)})


def write_parquet(chunks: Iterable[PassRecords], sink, *, meta: dict | None = None,
                  errors: Sequence[dict] = ()) -> int:
    """Write the records to ``sink`` (a path or binary file) as Parquet, one row group per
    part; returns the number of records. Columns: :data:`PASS_FIELDS` (the JSON record's
    fields and types; unset fields null); ``meta`` and ``errors`` go into the file's
    key-value metadata under ``rotator-tracker`` as the JSON document has them."""
    pa = require_pyarrow()
    import pyarrow.parquet as pq

    schema = arrow_schema(pa, meta, errors)
    n = 0
    with pq.ParquetWriter(sink, schema) as writer:
        for records in chunks:
            arrays = [pa.array(records[f.name], type=f.type) for f in schema]
            writer.write_table(pa.Table.from_arrays(arrays, schema=schema))
            n += len(records)
    return n
