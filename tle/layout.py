"""The fixed column layout of TLE lines 1 and 2, and a checker that names the bad column.

Templates follow the ones sgp4 prints in its own errors: ``N`` a digit (leading blanks allowed),
``C`` the classification letter, ``A`` the international designator, ``+`` a sign or blank,
``-`` an exponent sign; every space, ``.``, and the leading ``1``/``2`` is literal.
"""

from __future__ import annotations

import re

TLE_LINE_LENGTH = 69
LINE1_TEMPLATE = "1 NNNNNC NNNNNAAA NNNNN.NNNNNNNN +.NNNNNNNN +NNNNN-N +NNNNN-N N NNNNN"
LINE2_TEMPLATE = "2 NNNNN NNN.NNNN NNN.NNNN NNNNNNN NNN.NNNN NNN.NNNN NN.NNNNNNNNNNNNNN"
TEMPLATES = {1: LINE1_TEMPLATE, 2: LINE2_TEMPLATE}

# Columns 3-7 hold the catalogue number, which may be Alpha-5 (a letter first): checked by
# alpha5_to_int, not by the digit rule. Column 69 is the checksum and must be a digit.
_CATALOGUE_COLUMNS = range(2, 7)
_CHECKSUM_INDEX = TLE_LINE_LENGTH - 1

_ALLOWED = {
    "N": ("0123456789 ", "a digit"),
    "+": ("+- ", "'+', '-' or a blank"),
    "-": ("+-", "'+' or '-'"),
    " ": (" ", "a blank"),
    ".": (".", "'.'"),
}


def _template_regex(template: str) -> re.Pattern[str]:
    parts = [re.escape(template[0])]
    for index, want in enumerate(template[1:], start=1):
        if index in _CATALOGUE_COLUMNS or want in "CA":
            parts.append(".")
        elif index == _CHECKSUM_INDEX:
            parts.append("[0-9]")
        else:
            parts.append(f"[{re.escape(_ALLOWED[want][0])}]")
    return re.compile("".join(parts))


# One C-speed regex match for the common (valid) line; the column walk only names the fault.
_LINE_RE = {number: _template_regex(template) for number, template in TEMPLATES.items()}


def layout_fault(line: str, line_number: int) -> str | None:
    """Describe the first column of ``line`` that breaks the layout, or None if it fits.

    ``line_number`` is 1 or 2. The length is checked by the caller (it has the better message).
    """
    if _LINE_RE[line_number].fullmatch(line):
        return None
    template = TEMPLATES[line_number]
    if not line.startswith(str(line_number)):
        return f"column 1 should be '{line_number}', found {line[:1]!r}"
    for index, (want, got) in enumerate(zip(template, line, strict=False)):
        if index == 0 or index in _CATALOGUE_COLUMNS or want in "CA":
            continue
        if index == _CHECKSUM_INDEX:
            if not got.isdigit():
                return f"column 69 should be the checksum digit, found {got!r}"
            continue
        allowed, description = _ALLOWED[want]
        if got not in allowed:
            return f"column {index + 1} should be {description}, found {got!r}"
    return None

