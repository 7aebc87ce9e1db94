"""End to end through the CLI: ``tracker emulate`` in one process, ``tracker rotator`` in
another (or in-process), over a real pty and a real TCP socket."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from tracker.cli import main


def start_emulator(*extra: str) -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen([sys.executable, "-m", "tracker", "emulate", "--speed", "100",
                             "--duration", "30", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    url = proc.stdout.readline().strip()
    assert url.startswith(("/dev/pts/", "socket://")), (url, proc.stderr.read())
    return proc, url


def poll_position(url: str, capsys, want: str, timeout_s: float = 10.0) -> str:
    end = time.monotonic() + timeout_s
    out = ""
    while time.monotonic() < end:
        assert main(["rotator", "--port", url, "position"]) == 0
        out = capsys.readouterr().out.strip()
        if out == want:
            break
        time.sleep(0.1)
    return out


@pytest.mark.parametrize("where", [["--pty"], ["--tcp", "0"]], ids=["pty", "tcp"])
def test_emulate_and_rotator_goto_moves_the_antenna(where, capsys):
    proc, url = start_emulator("--protocol", "gs232b", *where)
    try:
        assert main(["rotator", "--port", url, "goto", "270", "30"]) == 0
        assert poll_position(url, capsys, "270 30") == "270 30"
        assert main(["rotator", "--port", url, "park"]) == 0
        assert main(["rotator", "--port", url, "stop"]) == 0
        assert main(["rotator", "--port", url, "raw", "Q"]) == 0
        assert capsys.readouterr().out.strip() == repr(b"?>\r\n")
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
        # not communicate(): it bypasses what readline() already buffered
        out, err = proc.stdout.read(), proc.stderr.read()
    proc.stdout.close()
    proc.stderr.close()
    assert proc.returncode == 0 and "Traceback" not in err, err
    assert "gs232b  az" in out, (out, err)          # plain status lines when stdout is not a TTY


def test_emulate_k3ng_over_tcp(capsys):
    proc, url = start_emulator("--protocol", "k3ng", "--tcp", "0")
    try:
        assert main(["rotator", "--port", url, "--protocol", "k3ng", "goto", "90", "10"]) == 0
        assert poll_position(url, capsys, "90 10") == "90 10"
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()
    assert proc.returncode == 0


@pytest.mark.parametrize(("argv", "message"), [
    (["rotator", "--port", "/dev/does-not-exist", "position"], "cannot open port"),
    (["rotator", "--port", "socket://127.0.0.1:1", "--protocol", "nope", "position"],
     "unknown protocol"),
    (["emulate", "--rotator", "G-9999", "--duration", "0.1"], "unknown rotator"),
    (["emulate", "--protocol", "gs999", "--duration", "0.1"], "unknown GS-232 profile"),
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


def test_goto_out_of_range_sends_nothing(capsys):
    proc, url = start_emulator("--tcp", "0")
    try:
        assert main(["rotator", "--port", url, "goto", "451", "0"]) == 2
        assert "azimuth 451 is outside the limits" in capsys.readouterr().err
        assert main(["rotator", "--port", url, "position"]) == 0
        assert capsys.readouterr().out.strip() == "0 0"
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=10)
        proc.stdout.close()
        proc.stderr.close()


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
