"""The GS-232 codec and line framer (pure functions, no I/O)."""

from __future__ import annotations

import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tracker.errors import ConfigError, LimitError, ProtocolError
from tracker.protocols.framing import LineFramer
from tracker.protocols.gs232 import (
    PROFILES,
    format_position,
    get_profile,
    is_error_reply,
    parse_elevation,
    parse_position,
    parse_table_status,
)
from tracker.protocols.gs232_codec import encode_goto, encode_table


def test_encode_goto_three_digit_fields():
    assert encode_goto(180, 45) == b"W180 045\r"
    assert encode_goto(5.4, 0.6) == b"W005 001\r"
    assert encode_goto(180.5, 10.5) == b"W180 010\r"     # half to even, as Hamlib's rint
    assert encode_goto(450, 180) == b"W450 180\r"
    assert encode_goto(90) == b"M090\r"


@pytest.mark.parametrize(("az", "el"), [(-0.6, 0), (450.6, 0), (0, 180.6), (0, -1),
                                        (float("nan"), 0), (float("inf"), 0), ("x", 0)])
def test_encode_goto_refuses_out_of_range(az, el):
    with pytest.raises(LimitError, match=r"nothing was sent|not a number"):
        encode_goto(az, el)


def test_encode_goto_honours_360_mode():
    with pytest.raises(LimitError, match=re.escape("0..360")):
        encode_goto(361, 0, az_max_deg=360)


def test_encode_table_forms():
    assert encode_table(10, [90, 180, 270]) == b"M010 090 180 270\r"
    assert encode_table(1, [(10, 5), (20, 10)]) == b"W001 010 005 020 010\r"
    for bad in (0, 1000, 2.5):
        with pytest.raises(LimitError):
            encode_table(bad, [1, 2])
    with pytest.raises(LimitError):
        encode_table(5, [])


def test_table_line_codec_round_trips_and_is_shared():
    from tracker.protocols.gs232_tables import decode_table_line, encode_table_line

    assert encode_table_line("W", 5, [10, 360], [20, 180]) == "W005 010 020 360 180"
    assert encode_table_line("M", 1, [0, 450.0]) == "M001 000 450"
    assert encode_table(5, [(10, 20), (360, 180)]) == b"W005 010 020 360 180\r"
    assert decode_table_line("W005 010 020 360 180") == ("W", 5, [10, 360], [20, 180])
    assert decode_table_line(b"M001 000 450") == ("M", 1, [0, 450], None)
    with pytest.raises(LimitError, match=re.escape("outside the controller range 0..360")):
        encode_table_line("M", 5, [361], az_max_deg=360)
    # A plan file holds exactly the encoder's format; a controller takes 1-3 digits, any blanks.
    for bad in ("W005 010", "W005  010 020", "M05 010", "X005 010", "M005", "M005 010 "):
        with pytest.raises(ValueError):
            decode_table_line(bad)
    assert decode_table_line("M5  10 2", strict=False) == ("M", 5, [10, 2], None)
    # Ranges are checked when the caller gives the controller's limits.
    assert decode_table_line("W001 450 180", az_max_deg=450).az == [450]
    for bad in ("W000 010 020", "W001 451 000", "W001 000 181", "M001 361"):
        with pytest.raises(ValueError):
            decode_table_line(bad, az_max_deg=360 if bad.startswith("M") else 450)


@pytest.mark.parametrize(("line", "want"), [
    (b"AZ=143  EL=001", (143.0, 1.0)),
    (b"AZ=143 EL=001\r\n", (143.0, 1.0)),
    (b"AZ=330EL=000", (330.0, 0.0)),
    (b"AZ=-001  EL=-002", (-1.0, -2.0)),
    (b"AZ=0000EL=000", (0.0, 0.0)),
    (b"AZ=0450EL=180", (450.0, 180.0)),
    (b"AZ=229", (229.0, None)),
    (b"+0179+0001", (179.0, 1.0)),
    (b"+0123-0005", (123.0, -5.0)),
    (b"+0450", (450.0, None)),
])
def test_parse_position_tolerant(line, want):
    assert parse_position(line) == want


@pytest.mark.parametrize("line", [b"", b"?>", b"AZ=", b"C2", b"AZ=12x EL=1", b"+0aaa+0eee",
                                  b"\x00\xff",
                                  # a digit dropped or doubled by line noise: width or range
                                  b"AZ=12  EL=045", b"AZ=1233  EL=045", b"AZ=123  EL=04",
                                  b"AZ=123  EL=0455", b"AZ=451  EL=045", b"+012+0045",
                                  b"+01233+0045", b"+0123+0181"])
def test_parse_position_rejects_keeping_raw(line):
    with pytest.raises(ProtocolError) as ei:
        parse_position(line)
    assert ei.value.raw == line


def test_elevation_and_table_status_and_error():
    assert parse_elevation(b"EL=045") == 45.0
    assert parse_elevation(b"+0045") == 45.0
    for bad in (b"EL=04", b"EL=0455", b"+045", b"+0045+0010"):
        with pytest.raises(ProtocolError):
            parse_elevation(bad)
    assert parse_table_status(b"+0002+0010") == (2, 10)
    assert parse_table_status(b"=0002=0010") == (2, 10)
    assert parse_table_status(b"3") == (None, 3)
    with pytest.raises(ProtocolError):
        parse_table_status(b"?>")
    assert is_error_reply(b"?>") and is_error_reply(b"? >") and not is_error_reply(b"AZ=1")


@given(st.integers(-1, 450), st.integers(-2, 180), st.sampled_from(sorted(PROFILES)))
def test_format_then_parse_round_trip(az, el, name):
    prof = PROFILES[name]
    assert parse_position(format_position(prof, "C2", az, el)) == (az, el)
    assert parse_position(format_position(prof, "C", az, el))[0] == az


def test_profile_lookup():
    assert get_profile("GS232B").name == "gs232b"
    with pytest.raises(ConfigError, match="known: gs232a"):
        get_profile("yaesu")


# Framer ----------------------------------------------------------------------------------------


@given(st.lists(st.integers(1, 7), min_size=1, max_size=40))
def test_framer_any_chunking_gives_same_lines(cuts):
    stream = b"AZ=143  EL=001\r\n?>\r\n+0180+0045\r\nAZ=0"
    f = LineFramer(b"\r\n", keep_empty=False)
    lines, i, k = [], 0, 0
    while i < len(stream):
        n = cuts[k % len(cuts)]
        lines += f.feed(stream[i:i + n])
        i, k = i + n, k + 1
    assert lines == [b"AZ=143  EL=001", b"?>", b"+0180+0045"]
    assert f.pending == b"AZ=0"


def test_framer_one_byte_at_a_time_and_two_in_one_chunk():
    f = LineFramer(b"\r", ignore=b"\n")
    out = []
    for b in b"C2\r\n":
        out += f.feed(bytes([b]))
    assert out == [b"C2"]
    assert f.feed(b"C2\rW180 045\r\r") == [b"C2", b"W180 045", b""]


def test_framer_line_limit():
    f = LineFramer(b"\r", max_line=16)
    with pytest.raises(ProtocolError, match="longer than 16"):
        f.feed(b"x" * 17)
    assert f.feed(b"ok\r") == [b"ok"]   # usable again after the error
    big = LineFramer(b"\r")
    assert big.feed(b"M" + b"1" * 20000 + b"\r") == [b"M" + b"1" * 20000]


# Commands, both directions (tracker.protocols.gs232_codec) -------------------------------------

def _host_messages():
    from tracker.protocols import gs232_codec as codec
    from tracker.protocols.gs232_tables import TableLine

    fixed = [codec.Query("C"), codec.Query("C2"), codec.Query("B"), codec.Stop("all"),
             codec.Stop("az"), codec.Stop("el"), *(codec.Turn(d) for d in
                                                   ("cw", "ccw", "up", "down")),
             *(codec.Speed(n) for n in range(1, 5)), codec.SetMode450(True),
             codec.SetMode450(False), codec.ToggleCentre(), codec.Calibrate("O"),
             codec.Calibrate("O2"), codec.FullScale("F"), codec.FullScale("F2"),
             codec.Help(""), codec.Help("2"), codec.Help("3"), codec.StartTable(),
             codec.TableStatus(), codec.Goto(0), codec.Goto(450), codec.Goto(5, 180),
             codec.Table(TableLine("M", 5, [10, 20], None)),
             codec.Table(TableLine("W", 999, [450, 0], [0, 180]))]
    azaz = [codec.Sync(0), codec.Sync(45), codec.Sync(360), codec.Unsync(), codec.GotoB(360),
            codec.TableB(TableLine("M", 1, [0, 360], None)),
            *(codec.SpeedB(n) for n in range(1, 5)), codec.ToggleCentreB(),
            codec.SetMode450B(True), codec.SetMode450B(False), codec.StartTableB(),
            codec.TableStatusB()]
    return fixed, azaz


def test_every_host_command_decodes_to_what_was_encoded():
    from tracker.protocols import gs232_codec as codec

    fixed, azaz = _host_messages()
    for msg in fixed:
        assert codec.decode_command(codec.encode(msg)) == msg, msg
        assert codec.decode_command(codec.encode(msg), dialect="azaz") == msg, msg
    for msg in azaz:
        assert codec.decode_command(codec.encode(msg), dialect="azaz") == msg, msg
    assert codec.encode(codec.Stop("all")) == b"S"
    assert codec.encode(codec.Goto(5, 180)) == b"W005 180"
    assert codec.encode(codec.Sync(0)) == b"Y" and codec.encode(codec.Sync(7)) == b"Y007"
    assert codec.encode(codec.TableB(fixed[-2].line)) == b"MB005 010 020"
    for not_sent in (codec.Invalid("Q"), codec.BadTable("M"), codec.InvalidB("FB")):
        with pytest.raises(ValueError):
            codec.encode(not_sent)


@given(st.integers(0, 450), st.one_of(st.none(), st.integers(0, 180)))
def test_goto_round_trips(az, el):
    from tracker.protocols import gs232_codec as codec

    msg = codec.Goto(az, el)
    assert codec.decode_command(codec.encode(msg) + b"\r") == msg


@pytest.mark.parametrize(("line", "kw", "want"), [
    (b" m 090 ", {}, "Goto(az=90, el=None)"),
    (b"W5 7", {}, "Goto(az=5, el=7)"),
    (b"M451", {}, "Invalid(text='M451')"),
    (b"M361", {"az_max_deg": 360}, "Invalid(text='M361')"),
    (b"W360 181", {}, "Invalid(text='W360 181')"),
    (b"W360 360", {"el_max_deg": 360}, "Goto(az=360, el=360)"),
    (b"M0900", {}, "Invalid(text='M0900')"),
    (b"M", {}, "BadTable(text='M')"),
    (b"W123", {}, "BadTable(text='W123')"),
    (b"M005 361", {"az_max_deg": 360}, "BadTable(text='M005 361')"),
    (b"", {}, "Invalid(text='')"),
    (b"X5", {}, "Invalid(text='X5')"),
    (b"H4", {}, "Invalid(text='H4')"),
    (b"Y", {}, "Invalid(text='Y')"),
    (b"MB090", {}, "Invalid(text='MB090')"),
    (b"\xff", {}, "Invalid(text='\ufffd')"),
    (b"Y", {"dialect": "azaz"}, "Sync(offset_deg=0)"),
    (b"Y361", {"dialect": "azaz"}, "Invalid(text='Y361')"),
    (b"Y12", {"dialect": "azaz"}, "Invalid(text='Y12')"),
    (b"MB90", {"dialect": "azaz"}, "InvalidB(text='MB90')"),
    (b"MB361", {"dialect": "azaz"}, "InvalidB(text='MB361')"),
    (b"MB", {"dialect": "azaz"}, "BadTableB(text='MB')"),
    (b"XB5", {"dialect": "azaz"}, "InvalidB(text='XB5')"),
    (b"FB2", {"dialect": "azaz"}, "InvalidB(text='FB2')"),
])
def test_decode_command_reads_what_a_controller_reads(line, kw, want):
    from tracker.protocols import gs232_codec as codec

    assert repr(codec.decode_command(line, **kw)).removeprefix("codec.") == want


def test_every_decoded_message_has_an_emulator_handler():
    """The emulators dispatch through a table: a message type without a handler would fail."""
    import typing

    from tracker.emulator.azaz_controller import AzAzController
    from tracker.emulator.gs232_controller import Gs232Controller
    from tracker.protocols import gs232_codec as codec

    every = set(typing.get_args(codec.Command))
    assert set(AzAzController()._handlers) == every
    assert set(Gs232Controller()._handlers) == {m for m in every if m.__name__[-1] != "B"
                                                and m not in (codec.Sync, codec.Unsync)}
