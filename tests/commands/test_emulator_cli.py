"""End to end through the CLI: ``tracker emulate`` in one process, ``tracker rotator`` in
another (or in-process), over a real pty and a real TCP socket."""

from __future__ import annotations

import signal
import time

import pytest

from tracker.cli import main


def start_emulator(emulate, *extra: str):
    p = emulate("--speed", "100", *extra)
    assert p.url.startswith(("/dev/pts/", "socket://")), (p.url, p.stop())
    return p


def poll_position(url: str, capsys, want: str, timeout_s: float = 10.0) -> str:
    end = time.monotonic() + timeout_s
    out = ""
    while time.monotonic() < end:
        assert main(["rotator", "--port", url, "position"]) == 0
        out = capsys.readouterr().out.strip()
        if out == want:
            break
        time.sleep(0.02)
    return out


@pytest.mark.parametrize("where", [["--pty"], ["--tcp", "0"]], ids=["pty", "tcp"])
def test_emulate_and_rotator_goto_moves_the_antenna(where, emulate, capsys):
    p = start_emulator(emulate, "--protocol", "gs232b", *where)
    url = p.url
    assert main(["rotator", "--port", url, "goto", "270", "30"]) == 0
    assert poll_position(url, capsys, "270 30") == "270 30"
    assert main(["rotator", "--port", url, "park"]) == 0
    assert main(["rotator", "--port", url, "stop"]) == 0
    assert main(["rotator", "--port", url, "--ignore-limits", "raw", "Q"]) == 0
    assert capsys.readouterr().out.strip() == repr(b"?>\r\n")
    rc, out, err = p.stop()
    assert rc == 0 and "Traceback" not in err, err
    assert "gs232b  az" in out, (out, err)          # plain status lines when stdout is not a TTY


def test_emulate_k3ng_over_tcp(emulate, capsys):
    url = start_emulator(emulate, "--protocol", "k3ng", "--tcp", "0").url
    assert main(["rotator", "--port", url, "--protocol", "k3ng", "goto", "90", "10"]) == 0
    assert poll_position(url, capsys, "90 10") == "90 10"


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_emulate_ends_cleanly_on_sigterm_and_sighup_even_with_sigint_ignored(emulate, sig):
    # started as from the background of a non-interactive shell: SIGINT inherited as ignored
    p = emulate("--tcp", "0", "--fault", "jam=az@0",
                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    assert p.url.startswith("socket://127.0.0.1:"), p.url
    assert "gs232b  az" in p.readline()           # serving: the first status line
    p.proc.send_signal(signal.SIGINT)               # ignored, as in such a shell
    rc, out, err = p.stop(sig)
    assert rc == 0 and err == "", err
    assert "faults: " in out and "jam_events 1" in out   # the summary of a clean end


def test_emulate_under_nohup_keeps_running_through_sighup(emulate, capsys):
    # nohup: SIGHUP inherited as ignored, and it must stay ignored
    p = emulate("--tcp", "0", preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    assert "cmds 0" in p.readline()
    p.proc.send_signal(signal.SIGHUP)
    assert main(["rotator", "--port", p.url, "position"]) == 0
    # still serving after the hang-up: its status loop reports the query it answered
    line = p.readline()
    assert "cmds 1" in line, (line, p.stop())
    rc, _out, err = p.stop(signal.SIGTERM)
    assert rc == 0 and err == "", err


@pytest.mark.parametrize(("argv", "message"), [
    (["rotator", "--port", "/dev/does-not-exist", "position"], "cannot open port"),
    (["rotator", "--port", "socket://127.0.0.1:1", "--protocol", "nope", "position"],
     "unknown protocol"),
    (["emulate", "--rotator", "G-9999", "--duration", "0.1"], "unknown rotator"),
    (["emulate", "--protocol", "gs999", "--duration", "0.1"], "unknown protocol"),
    (["emulate", "--tcp", "99999", "--duration", "0.1"], "--tcp 99999 is invalid"),
    (["emulate", "--tcp", "-5", "--duration", "0.1"], "--tcp -5 is invalid"),
    (["emulate", "--speed", "inf", "--duration", "0.1"], "--speed inf is invalid"),
    (["emulate", "--az", "451", "--duration", "0.1"], "outside the G-5500 travel 0..450"),
    (["emulate", "--el", "-1", "--duration", "0.1"], "outside the G-5500 travel 0..180"),
    (["emulate", "--rotator", "G-1000DXA", "--el", "10", "--duration", "0.1"],
     "no elevation axis"),
    (["rotator", "--port", "socket://127.0.0.1:1", "--timeout", "nan", "position"],
     "--timeout nan is invalid"),
    (["rotator", "--port", "socket://127.0.0.1:1", "--baud", "0", "position"],
     "--baud 0 is invalid"),
])
def test_cli_errors_are_one_line_exit_2(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_goto_out_of_range_sends_nothing(emulate, capsys):
    url = start_emulator(emulate, "--tcp", "0").url
    assert main(["rotator", "--port", url, "goto", "451", "0"]) == 2
    assert "azimuth 451 is outside the limits" in capsys.readouterr().err
    assert main(["rotator", "--port", url, "position"]) == 0
    assert capsys.readouterr().out.strip() == "0 0"


def test_rotator_timeout_is_reported(capsys):
    import socket
    srv = socket.create_server(("127.0.0.1", 0))    # accepts, never answers
    try:
        port = srv.getsockname()[1]
        t0 = time.monotonic()
        assert main(["rotator", "--port", f"socket://127.0.0.1:{port}", "--timeout", "0.2",
                     "position"]) == 2
        assert time.monotonic() - t0 < 3
        assert "no reply to C2" in capsys.readouterr().err
    finally:
        srv.close()
