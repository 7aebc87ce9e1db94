"""A misbehaving peer on a real TCP socket / pty: silence, garbage, partial lines, echoes and
?> become typed errors within the timeout; nothing hangs."""

from __future__ import annotations

import time

import pytest
from _gs232_helpers import RawPeer

from tracker.errors import PortLostError, ProtocolError, RotatorTimeout
from tracker.protocols import open_driver

TIMEOUT_S = 0.3
RETRIES = 2


@pytest.fixture(params=["tcp", "pty"])
def make_peer(request):
    peers = []

    def make(respond):
        p = RawPeer(request.param, respond)
        peers.append(p)
        return p
    yield make
    for p in peers:
        p.close()
        assert not p.thread.is_alive()


def _driver(peer, profile="gs232b"):
    return open_driver(peer.url, profile, timeout_s=TIMEOUT_S, retries=RETRIES)


def _timed(fn):
    t0 = time.monotonic()
    try:
        fn()
    finally:
        elapsed = time.monotonic() - t0
        # every attempt is bounded: (1 + retries) reads of timeout_s, plus slack
        assert elapsed < (1 + RETRIES) * TIMEOUT_S + 1.0


def test_silence_is_a_timeout_after_retries(make_peer):
    peer = make_peer(lambda req: b"")
    d = _driver(peer)
    with pytest.raises(RotatorTimeout, match="no reply to C2"):
        _timed(d.position)
    assert peer.received.count(b"C2\r") == 1 + RETRIES
    d.close()


def test_error_prompt_is_retried_then_protocol_error(make_peer):
    peer = make_peer(lambda req: b"?>\r\n")
    d = _driver(peer)
    with pytest.raises(ProtocolError) as ei:
        _timed(d.position)
    assert ei.value.raw == b"?>"
    assert peer.received.count(b"C2\r") == 1 + RETRIES
    d.close()


def test_error_prompt_then_good_reply_recovers(make_peer):
    answers = iter([b"?>\r\n", b"AZ=123  EL=045\r\n"])
    peer = make_peer(lambda req: next(answers, b""))
    d = _driver(peer)
    assert d.position() == (123.0, 45.0)
    d.close()


def test_garbage_keeps_raw_bytes(make_peer):
    peer = make_peer(lambda req: b"\x00\xffNOISE#\r\n")
    d = _driver(peer)
    with pytest.raises(ProtocolError) as ei:
        _timed(d.position)
    assert ei.value.raw == b"\x00\xffNOISE#"
    assert "received" in str(ei.value)
    d.close()


def test_partial_line_is_a_timeout_naming_the_bytes(make_peer):
    peer = make_peer(lambda req: b"AZ=12")
    d = _driver(peer)
    with pytest.raises(RotatorTimeout, match="partial line"):
        _timed(d.position)
    d.close()


def test_echo_is_reported(make_peer):
    peer = make_peer(lambda req: req + b"AZ=123  EL=045\r\n")
    d = _driver(peer)
    with pytest.raises(ProtocolError, match="echo"):
        _timed(d.position)
    d.close()


def test_stale_bytes_are_flushed_before_a_query(make_peer):
    # A late, unsolicited line after a set command must not be taken as the C2 reply.
    def respond(req):
        return b"AZ=999  EL=999\r\n" if req.startswith(b"W") else b"AZ=010  EL=020\r\n"
    peer = make_peer(respond)
    d = _driver(peer)
    d.goto(10, 20)
    time.sleep(0.1)
    assert d.position() == (10.0, 20.0)
    d.close()


def test_tolerant_reply_formats(make_peer):
    replies = iter([b"AZ=123EL=045\r", b"+0123+0045\r\n", b"AZ=0123 EL=045\n",
                    b"AZ=-001  EL=-002\r\n"])
    peer = make_peer(lambda req: next(replies, b""))
    d = _driver(peer)
    assert [d.position() for _ in range(4)] == [(123.0, 45.0), (123.0, 45.0), (123.0, 45.0),
                                                (-1.0, -2.0)]
    d.close()


def test_peer_closing_tcp_is_port_lost():
    peer = RawPeer("tcp", lambda req: None)
    d = open_driver(peer.url, "gs232b", timeout_s=TIMEOUT_S)
    peer.respond = lambda req: (_ for _ in ()).throw(OSError("gone"))  # peer thread exits
    try:
        with pytest.raises((PortLostError, RotatorTimeout)):
            d.position()
        with pytest.raises(PortLostError):
            d.position()
    finally:
        d.close()
        peer.close()


@pytest.mark.parametrize("reply", [b"AZ=12  EL=045\r\n", b"AZ=1233  EL=045\r\n",
                                   b"AZ=123  EL=04\r\n", b"+01233+0045\r\n"])
def test_reply_with_a_digit_lost_or_doubled_is_refused_not_read(make_peer, reply):
    # No checksum on the wire: a field of the wrong width or out of range is line noise.
    peer = make_peer(lambda req: reply)
    d = _driver(peer)
    with pytest.raises(ProtocolError) as ei:
        _timed(d.position)
    assert ei.value.raw == reply.strip()
    d.close()


def test_a_rotctld_reply_says_to_use_the_rotctld_protocol(make_peer):
    peer = make_peer(lambda req: b"RPRT -1\n")
    d = _driver(peer)
    with pytest.raises(ProtocolError, match=r"a Hamlib rotctld answered C2, not a GS-232 "
                                            r"controller: talk to it with protocol rotctld"):
        _timed(d.position)
    d.close()
