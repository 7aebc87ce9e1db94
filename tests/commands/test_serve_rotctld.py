"""``tracker serve-rotctld`` end to end: a real process in front of an emulator served on TCP,
driven by Hamlib's ``rotctl -m 2``, ended with SIGTERM (all-stop last, exit 0)."""

from __future__ import annotations

from _rigs import EmulatedRig, ServeRotctldProcess, require_rotctl, rotctl

from tracker.cli import main

require_rotctl()


def _serve(*args: str) -> ServeRotctldProcess:
    return ServeRotctldProcess("--lat", "52", "--lon", "4.4", *args)


def test_serve_rotctld_drives_a_controller_and_stops_it_on_sigterm():
    rig = EmulatedRig("gs232b", "tcp")
    try:
        proc = _serve("--port", rig.url, "--protocol", "gs232b", "--min-el", "10")
        where = proc.where
        try:
            rotctl("2", where, "P", "100", "30")
            assert rig.seen(b"W100 030")
            r = rotctl("2", where, "P", "100", "5", ok=False)       # below --min-el
            assert r.returncode != 0
        finally:
            code, out, err = proc.stop()
        assert code == 0, err
        assert rig.tail_is(b"S")                     # all-stop was the last command
        assert b"W100 005" not in rig.lines()
        assert "refused" in out and "all-stop sent" in out and "SIGTERM" in out
    finally:
        rig.close()


def test_serve_rotctld_without_port_serves_the_emulator_and_says_so():
    proc = _serve("--protocol", "sak232")
    where = proc.where
    try:
        rotctl("2", where, "P", "45", "0")
        assert len(rotctl("2", where, "p").stdout.split()) == 2
    finally:
        code, _out, err = proc.stop()
    assert code == 0, err
    assert proc.head[0].startswith("SIMULATION: built-in sak232 emulator with a Zelpro-RAU "
                                   "on the real clock")


def test_bad_input_is_one_line_and_exit_2(capsys):
    assert main(["serve-rotctld", "--listen", "127.0.0.1:http"]) == 2
    assert main(["serve-rotctld", "--protocol", "rotctld"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "HOST:PORT" in err[0] and "needs --port" in err[1]


def test_a_non_loopback_address_warns(capsys, monkeypatch):
    from tracker.service import rotctld_server

    class Stop(Exception):
        pass

    def refuse(*_a, **_k):
        raise Stop
    monkeypatch.setattr(rotctld_server.RotctldServer, "start", refuse)
    try:
        main(["serve-rotctld", "--listen", "0.0.0.0:0", "--protocol", "gs232b"])
    except Stop:
        pass
    assert "anyone on that network can move the antenna" in capsys.readouterr().err
