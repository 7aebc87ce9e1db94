"""Alpha-5 catalogue numbers: five columns holding ids 100000-339999.

The first column is a letter A-Z without I and O (which look like 1 and 0): A0000 = 100000,
Z9999 = 339999. Plain five-digit numbers are ids 0-99999.
"""

from __future__ import annotations

ALPHA5_LETTERS = "ABCDEFGHJKLMNPQRSTUVWXYZ"  # 24 letters: I and O are skipped
MAX_ALPHA5_ID = 339_999


def alpha5_to_int(field: str) -> int:
    """Decode a catalogue number field ("25544", " 7530", "A0000") into an int."""
    text = field.strip()
    if not text:
        raise ValueError("empty catalogue number")
    head, tail = text[0], text[1:]
    if head.isdigit():
        if not text.isdigit():
            raise ValueError(f"catalogue number {field!r} is not a number")
        return int(text)
    letter = head.upper()
    if letter not in ALPHA5_LETTERS or len(tail) != 4 or not tail.isdigit():
        raise ValueError(
            f"catalogue number {field!r} is neither 5 digits nor Alpha-5 "
            "(a letter A-Z without I/O followed by 4 digits)")
    return (ALPHA5_LETTERS.index(letter) + 10) * 10_000 + int(tail)


def int_to_alpha5(norad_id: int) -> str:
    """Encode an id 0-339999 in five columns (Alpha-5 above 99999)."""
    if not 0 <= norad_id <= MAX_ALPHA5_ID:
        raise ValueError(f"catalogue number {norad_id} is outside 0..{MAX_ALPHA5_ID}")
    if norad_id < 100_000:
        return f"{norad_id:05d}"
    high, low = divmod(norad_id, 10_000)
    return f"{ALPHA5_LETTERS[high - 10]}{low:04d}"
