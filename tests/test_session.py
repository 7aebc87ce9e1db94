"""The controller session on its own: signals take the Ctrl-C path, the all-stop is the last
word, a failed all-stop never hides the error that ended the session, handlers come back."""

from __future__ import annotations

import os
import signal

import pytest

from tracker.errors import RotatorIOError
from tracker.session import ControllerSession, Interrupted


@pytest.fixture(autouse=True)
def normal_signals():
    """Each test starts as a process in a terminal does: the suite itself may run with
    SIGINT or SIGHUP ignored (a background job, nohup), which the session must respect, and
    which the test that is about it sets up itself."""
    old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
    yield
    for sig, handler in old.items():
        signal.signal(sig, handler)


class Recorder:
    """An all-stop that records calls and can fail."""

    def __init__(self, fail: bool = False, reached: bool = True):
        self.calls = 0
        self.fail = fail
        self.reached = reached

    def __call__(self):
        self.calls += 1
        if self.fail:
            raise RotatorIOError("port lost")
        return self.reached


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP],
                         ids=lambda s: signal.Signals(s).name)
def test_signal_raises_interrupted_and_stops(sig):
    stop = Recorder()
    with pytest.raises(Interrupted) as info:
        with ControllerSession(stop, stop_at_end=False) as session:
            os.kill(os.getpid(), sig)
            for _ in range(1000):       # the handler runs between bytecodes
                pass
    assert info.value.signame == signal.Signals(sig).name
    assert isinstance(info.value, KeyboardInterrupt)
    assert stop.calls == 1 and session.stopped and session.signal == info.value.signame


def test_old_handlers_come_back():
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    with ControllerSession(Recorder(), stop_at_end=False):
        assert signal.getsignal(signal.SIGHUP) is not before[signal.SIGHUP]
    assert {s: signal.getsignal(s) for s in before} == before


def test_an_ignored_signal_stays_ignored():
    """nohup (SIGHUP ignored) keeps working: the session does not take the signal over."""
    old = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        stop = Recorder()
        with ControllerSession(stop, stop_at_end=False):
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)
        assert stop.calls == 0
    finally:
        signal.signal(signal.SIGHUP, old)


def test_a_second_signal_does_not_cut_the_all_stop_short():
    calls = []

    def stop_interrupted_by_a_second_signal():
        os.kill(os.getpid(), signal.SIGTERM)   # arrives while the all-stop is under way
        for _ in range(1000):
            pass
        calls.append("S")
        return True

    with pytest.raises(Interrupted):
        with ControllerSession(stop_interrupted_by_a_second_signal, stop_at_end=False):
            os.kill(os.getpid(), signal.SIGHUP)
            for _ in range(1000):
                pass
    assert calls == ["S"]


def test_an_exception_stops_and_a_failed_stop_does_not_mask_it():
    stop, heard = Recorder(fail=True), []
    with pytest.raises(ValueError, match="the real problem"):
        with ControllerSession(stop, stop_at_end=False, on_stop_failed=heard.append):
            raise ValueError("the real problem")
    assert stop.calls == 1 and heard == ["port lost"]


def test_a_stop_that_did_not_reach_is_reported_but_does_not_mask_the_error():
    heard = []
    with pytest.raises(ValueError):
        with ControllerSession(Recorder(reached=False), stop_at_end=False,
                               on_stop_failed=heard.append):
            raise ValueError("x")
    assert heard == ["all-stop did not reach the controller"]


def test_normal_end_stops_only_when_asked():
    stop = Recorder()
    with ControllerSession(stop, stop_at_end=False):
        pass
    assert stop.calls == 0
    with ControllerSession(stop):
        pass
    assert stop.calls == 1


def test_normal_end_with_a_failed_stop_is_an_error():
    with pytest.raises(RotatorIOError, match="port lost"):
        with ControllerSession(Recorder(fail=True)):
            pass
    with pytest.raises(RotatorIOError, match="did not reach"):
        with ControllerSession(Recorder(reached=False)):
            pass
