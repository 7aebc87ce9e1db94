"""Easycomm codec: what the driver encodes the emulator decodes, and back, byte for byte as
Hamlib's easycomm backend writes and reads them."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tracker.errors import LimitError, ProtocolError
from tracker.protocols import easycomm_codec as codec
from tracker.protocols.easycomm_codec import Move, Query, SetAxis, StopAxis, Unknown, Version


def test_hamlib_bytes():
    # Hamlib rotators/easycomm/easycomm.c: "AZ%.1f EL%.1f\n", "AZ EL \n", "SA SE \n"
    assert codec.encode_goto(120, 30) == b"AZ120.0 EL30.0\n"
    assert codec.encode_goto(359.96, 0.04) == b"AZ360.0 EL0.0\n"
    assert codec.QUERY == b"AZ EL \n" and codec.STOP == b"SA SE \n"
    assert codec.encode_goto(90) == b"AZ90.0\n"


@given(st.floats(0, 360), st.floats(0, 180))
def test_goto_round_trip(az, el):
    cmds = codec.decode_line(codec.encode_goto(az, el))
    assert cmds == [SetAxis("az", float(f"{az:.1f}")), SetAxis("el", float(f"{el:.1f}"))]


@given(st.floats(0, 360), st.floats(0, 180))
def test_position_reply_round_trip(az, el):
    reply = codec.format_reply([codec.format_value("az", az), codec.format_value("el", el)])
    assert reply.endswith(b"\n") and reply.count(b"\n") == 1
    assert codec.parse_position(reply) == (float(f"{az:.1f}"), float(f"{el:.1f}"))


def test_query_and_stop_decode():
    assert codec.decode_line(codec.QUERY) == [Query("az"), Query("el")]
    assert codec.decode_line(codec.STOP) == [StopAxis("az"), StopAxis("el")]
    assert codec.decode_line(b"ml mr MU MD VE") == [Move("ccw"), Move("cw"), Move("up"),
                                                     Move("down"), Version()]
    assert codec.decode_line(b"VR4900") == [Move("cw", 4900.0)]
    assert codec.decode_line(b"AZabc XYZ UP145800000") == [Unknown(b"AZabc"), Unknown(b"XYZ"),
                                                            Unknown(b"UP145800000")]


@pytest.mark.parametrize("reply", [b"AZ120.0 EL30.0", b"AZ120 EL30\r", b"AZ 120.0 EL 30.0",
                                   b"junk AZ120.0  EL30.0\n"])
def test_parse_accepts_what_sscanf_accepts(reply):
    assert codec.parse_position(reply) == (120.0, 30.0)


@pytest.mark.parametrize("reply", [b"", b"AZ120.0", b"VEsatnogs", b"?"])
def test_parse_refuses_other_lines(reply):
    with pytest.raises(ProtocolError):
        codec.parse_position(reply)


@pytest.mark.parametrize("az, el", [(-0.1, 0), (360.1, 0), (0, 180.1), (0, -1),
                                    (float("nan"), 0), (0, float("nan")), ("x", 0)])
def test_out_of_range_is_refused(az, el):
    with pytest.raises(LimitError):
        codec.encode_goto(az, el)
