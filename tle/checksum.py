"""The TLE mod-10 line checksum (column 69)."""

from __future__ import annotations

# Byte -> what it adds to the checksum: a digit its value, '-' one, anything else nothing.
_WEIGHT = bytearray(256)
for _value, _digit in enumerate(b"0123456789"):
    _WEIGHT[_digit] = _value
_WEIGHT[ord("-")] = 1
_WEIGHTS = bytes(_WEIGHT)


def compute_checksum(line: str) -> int:
    """Checksum of columns 1-68: sum of the digits, each '-' counting 1, modulo 10."""
    # One C-speed translate and sum (every element set read checks two lines); a non-ASCII
    # character becomes '?', which adds nothing, as it must.
    return sum(line[:68].encode("ascii", "replace").translate(_WEIGHTS)) % 10
