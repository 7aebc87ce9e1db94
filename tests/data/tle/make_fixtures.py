"""Regenerate the fixtures in this directory from amateur5.txt (a verbatim excerpt of the
bundled tle/data/amateur.txt, CRLF kept). Run: python tests/data/tle/make_fixtures.py

OMM fields are derived from the TLE columns the way CelesTrak publishes them, so the OMM
fixtures must propagate to the same positions as the TLEs.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from tle.checksum import compute_checksum
from tle.elements import parse_tle_text

HERE = Path(__file__).parent
FIELDS = ["OBJECT_NAME", "OBJECT_ID", "EPOCH", "MEAN_MOTION", "ECCENTRICITY", "INCLINATION",
          "RA_OF_ASC_NODE", "ARG_OF_PERICENTER", "MEAN_ANOMALY", "EPHEMERIS_TYPE",
          "CLASSIFICATION_TYPE", "NORAD_CAT_ID", "ELEMENT_SET_NO", "REV_AT_EPOCH", "BSTAR",
          "MEAN_MOTION_DOT", "MEAN_MOTION_DDOT"]


def exp_field(text: str) -> float:
    """TLE implied-decimal exponent field ' 17025-3' -> 0.17025e-3."""
    text = text.strip()
    sign = -1.0 if text.startswith("-") else 1.0
    text = text.lstrip("+-")
    return sign * float(f"0.{text[:-2]}e{text[-2:]}")


def omm_record(es) -> dict:
    l1, l2 = es.line1, es.line2
    return {
        "OBJECT_NAME": es.name, "OBJECT_ID": es.intl_designator,
        "EPOCH": es.epoch.strftime("%Y-%m-%dT%H:%M:%S.%f"),
        "MEAN_MOTION": float(l2[52:63]), "ECCENTRICITY": float("0." + l2[26:33]),
        "INCLINATION": float(l2[8:16]), "RA_OF_ASC_NODE": float(l2[17:25]),
        "ARG_OF_PERICENTER": float(l2[34:42]), "MEAN_ANOMALY": float(l2[43:51]),
        "EPHEMERIS_TYPE": int(l1[62]), "CLASSIFICATION_TYPE": l1[7],
        "NORAD_CAT_ID": es.norad_id, "ELEMENT_SET_NO": int(l1[64:68]),
        "REV_AT_EPOCH": int(l2[63:68]), "BSTAR": exp_field(l1[53:61]),
        "MEAN_MOTION_DOT": float(l1[33:43]), "MEAN_MOTION_DDOT": exp_field(l1[44:52]),
    }


def with_checksum(line: str) -> str:
    return line[:68] + str(compute_checksum(line))


def main() -> None:
    text = (HERE / "amateur5.txt").read_text()
    sets = parse_tle_text(text)
    records = [omm_record(es) for es in sets]
    (HERE / "amateur5.json").write_text(json.dumps(records, indent=1) + "\n")
    out = io.StringIO()
    writer = csv.DictWriter(out, FIELDS, lineterminator="\r\n")
    writer.writeheader()
    writer.writerows(records)
    (HERE / "amateur5.csv").write_text(out.getvalue(), newline="")
    segments = []
    for r in records:
        meta = "".join(f"<{k}>{r[k]}</{k}>" for k in ("OBJECT_NAME", "OBJECT_ID"))
        mean = "".join(f"<{k}>{r[k]}</{k}>" for k in (
            "EPOCH", "MEAN_MOTION", "ECCENTRICITY", "INCLINATION", "RA_OF_ASC_NODE",
            "ARG_OF_PERICENTER", "MEAN_ANOMALY"))
        tlep = "".join(f"<{k}>{r[k]}</{k}>" for k in (
            "EPHEMERIS_TYPE", "CLASSIFICATION_TYPE", "NORAD_CAT_ID", "ELEMENT_SET_NO",
            "REV_AT_EPOCH", "BSTAR", "MEAN_MOTION_DOT", "MEAN_MOTION_DDOT"))
        segments.append(
            f"<segment><metadata>{meta}<CENTER_NAME>EARTH</CENTER_NAME>"
            f"<REF_FRAME>TEME</REF_FRAME><TIME_SYSTEM>UTC</TIME_SYSTEM>"
            f"<MEAN_ELEMENT_THEORY>SGP4</MEAN_ELEMENT_THEORY></metadata>"
            f"<data><meanElements>{mean}</meanElements>"
            f"<tleParameters>{tlep}</tleParameters></data></segment>")
    xml = ('<?xml version="1.0" encoding="UTF-8"?>\n<ndm xmlns:xsi="http://www.w3.org/2001/'
           'XMLSchema-instance" xsi:noNamespaceSchemaLocation="https://sanaregistry.org/r/ndmxml'
           '_unqualified/ndmxml-2.0.0-master-2.0.xsd">\n'
           + "".join(f'<omm id="CCSDS_OMM_VERS" version="2.0"><header><CREATION_DATE/>'
                     f"<ORIGINATOR/></header><body>{s}</body></omm>\n" for s in segments)
           + "</ndm>\n")
    (HERE / "amateur5.xml").write_text(xml)

    lines = text.splitlines()  # 15 lines: 5 sets of name, line 1, line 2
    # Messy but valid: LF, blank lines, '0 ' names, trailing blanks, one 2-line set.
    messy = ["", "0 " + lines[0].rstrip(), lines[1] + "   ", lines[2], "", "",
             lines[4], lines[5],  # AO-10 without its name line
             "0 ISS (ZARYA)", lines[7], lines[8] + "\t", "", lines[9], lines[10], lines[11],
             lines[12], lines[13], lines[14], ""]
    (HERE / "messy.txt").write_text("\n".join(messy), newline="")
    # Broken copies: each one bad set (ISS) between good ones.
    iss1, iss2 = lines[7], lines[8]
    bad = {
        "bad_checksum.txt": (iss1[:68] + "3", iss2),  # expected 7
        "shifted_column.txt": (iss1[:18] + " " + iss1[18:63] + iss1[64:], iss2),
        "truncated_line2.txt": (iss1, iss2[:50]),
        "mismatched_ids.txt": (iss1, with_checksum(iss2[:2] + "25545" + iss2[7:])),
    }
    for name, (l1, l2) in bad.items():
        body = [*lines[0:3], "ISS (ZARYA)", l1, l2, *lines[12:15]]
        (HERE / name).write_text("\r\n".join(body) + "\r\n", newline="")
    # Alpha-5: the ISS and AO-7 elements renumbered A0000 (100000) and Z9999 (339999).
    alpha = ["ALPHA FIVE LOW", with_checksum(iss1[:2] + "A0000" + iss1[7:]),
             with_checksum(iss2[:2] + "A0000" + iss2[7:]),
             "ALPHA FIVE HIGH", with_checksum(lines[1][:2] + "Z9999" + lines[1][7:]),
             with_checksum(lines[2][:2] + "Z9999" + lines[2][7:])]
    (HERE / "alpha5.txt").write_text("\n".join(alpha) + "\n")


if __name__ == "__main__":
    main()
