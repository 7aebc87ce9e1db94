"""Every command in README.md, run as written (so the README cannot rot).

Each command line of the README's code blocks is one test, named by its line number. How a
command runs is decided here, by rules, never by a list of commands, so a new README line is
tested without anyone adding it:

* ``tracker ...`` runs in-process in a fresh folder, with an empty element cache (the bundled
  snapshot) and no config file. A subcommand that takes ``--at`` gets :data:`AT` unless the
  line gives one, so every run is reproducible. The live demos are replayed on virtual time:
  ``tracker track`` without ``--port`` and the ``tracker upload`` simulation get ``--speed
  max`` (the README's demo takes a minute of real time; the commands, the pass and the
  output are the same). A simulated station day (``tracker station run
  --simulate``) runs on virtual time too (``--speed max``), from :data:`AT` for at most
  :data:`STATION_HOURS` of its hours, its status page (if any) on a free port.
* Ports: ``emu://`` runs as written. ``/dev/pts/N`` (the README's "the pty that ``tracker
  emulate --pty`` printed") gets a real ``tracker emulate --pty`` of the line's protocol, and
  ``socket://127.0.0.1:PORT`` one on TCP when the README starts an emulator on ``--tcp PORT``.
  **Any other port needs hardware** (``/dev/ttyUSB0``, ``COM3``, ``socket://192.168.1.20:4001``,
  ``HOST:PORT`` of a rotctld, ``...``): that line is skipped, with the port named in the skip
  reason (``pytest -rs`` lists them). ``rotctld`` lines start Hamlib on a serial port:
  hardware too.
* ``tracker serve-rotctld`` (a server: it runs until a signal) runs as a real process on a free
  port and must end with exit 0 on SIGTERM; a ``rotctl -r HOST:PORT`` line of the same block
  naming its ``--listen`` address talks to a real one of that line.
* ``tracker tle update`` downloads from a local fake of CelesTrak serving the bundled groups;
  a URL in the README is pointed at it as well.
* A fenced block marked ``text`` shows a command's output: its lines are not commands.
* Files a line reads are made first: ``my.tle`` / ``active.txt`` (the bundled amateur group),
  ``stations.csv`` / ``net.toml`` (two stations), a ``--from`` plan file (by the README's own
  ``--steptable`` line that writes it).
* A line that injects a ``jam`` fault shows the stall report: it must end with exit 2 and
  "did not move ... the rotator was stopped"; every other line must exit 0.
* ``python examples/...`` runs as a process (marked ``slow``, as the ``--dask`` line).
  ``pip install``, the test command itself and system commands (``sudo``, ``groups``) are
  skipped as set-up, with that reason.
"""

from __future__ import annotations

import importlib.util
import re
import shlex
import shutil
import subprocess
import sys
import threading
import urllib.parse
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest
from _paths import DATA
from _rigs import ROTCTL, ServeRotctldProcess, free_port

from tracker.cli import main

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
BUNDLED = ROOT / "tle" / "data"
AT = "2026-08-23T02:00:00Z"   # bundled epochs are 2026-08-22; an ISS pass starts 02:07
STATION_HOURS = 1.0   # from AT: the ISS pass at 02:07 and the next ones
TAKES_AT = {"passes", "next", "plan", "track", "upload", "batch", "schedule", "tle"}
EMULATED_PORT = re.compile(r"^socket://127\.0\.0\.1:(\d+)$")


@dataclass(frozen=True)
class Line:
    """One command of the README: where it is and its words (comments and ``&`` dropped)."""

    line_no: int
    argv: tuple[str, ...]
    block: int   # which code block: an emulator started in a block serves that block

    @property
    def id(self) -> str:
        return f"L{self.line_no}:{' '.join(self.argv)[:60]}"


def _code_lines(text: str):
    """(line number, block number, text) of every line in a fenced block or a 4-space
    indented block; a fenced ``text`` block is a command's output, not commands."""
    fenced = False
    output = False
    prev_blank = True
    indented = False
    block = 0
    for n, raw in enumerate(text.splitlines(), 1):
        if raw.startswith("```"):
            fenced = not fenced
            output = fenced and raw[3:].strip() == "text"
            block += 1
            continue
        if fenced:
            if not output:
                yield n, block, raw
            continue
        if raw.startswith("    ") and (prev_blank or indented):
            block += not indented
            indented = True
            yield n, block, raw
        elif raw.strip():
            indented = False
        prev_blank = not raw.strip()


def readme_lines(text: str | None = None) -> list[Line]:
    """Every command of the README; ``\\`` continuations joined, ``&&`` split."""
    text = README.read_text(encoding="utf-8") if text is None else text
    out: list[Line] = []
    pending: tuple[int, str] | None = None
    for n, block, raw in _code_lines(text):
        if pending is not None:
            n, raw = pending[0], pending[1] + " " + raw.strip()
            pending = None
        if raw.rstrip().endswith("\\"):
            pending = (n, raw.rstrip()[:-1])
            continue
        words = shlex.split(raw, comments=True)
        if words and words[-1] == "&":
            words = words[:-1]
        while words:
            cut = words.index("&&") if "&&" in words else len(words)
            out.append(Line(n, tuple(words[:cut]), block))
            words = words[cut + 1:]
    return out


LINES = readme_lines()
# (block, TCP port) -> protocol of a `tracker emulate --tcp PORT` line
EMULATOR_TCP_PORTS = {
    (line.block, line.argv[line.argv.index("--tcp") + 1]):
        line.argv[line.argv.index("--protocol") + 1]
    for line in LINES if line.argv[:2] == ("tracker", "emulate") and "--tcp" in line.argv}


def _serve_rotctld_lines() -> dict[tuple[int, str], tuple[str, ...]]:
    """(block, listen address) -> the words of a ``tracker serve-rotctld`` line that runs
    here: on its built-in emulator (no ``--port``)."""
    return {(line.block, _value(line.argv, "--listen") or "127.0.0.1:4533"): line.argv
            for line in LINES if line.argv[:2] == ("tracker", "serve-rotctld")
            and "--port" not in line.argv}


def _value(argv, flag: str) -> str | None:
    return argv[argv.index(flag) + 1] if flag in argv else None


# (block, listen address) -> words of a `tracker serve-rotctld` line
SERVE_ROTCTLD = _serve_rotctld_lines()


def _emulated_tcp(line: Line, port: str) -> str | None:
    """The protocol of the emulator this line's block starts on ``port``'s TCP port."""
    m = EMULATED_PORT.match(port)
    return EMULATOR_TCP_PORTS.get((line.block, m[1])) if m else None


def skip_reason(line: Line) -> str | None:
    """Why a README line cannot run here, or None: the explicit rules of the module doc."""
    argv = line.argv
    prog = argv[0]
    if prog in ("python3", "python") and argv[1:3] == ("-m", "pip"):
        return "set-up: installs the package (the tests run on this tree)"
    if prog in ("python3", "python") and argv[1:3] == ("-m", "pytest"):
        return "set-up: the test run itself"
    if prog in ("sudo", "groups"):
        return "set-up: a system command"
    if prog == "rotctld":
        return f"needs hardware: Hamlib rotctld on {_value(argv, '-r')}"
    if prog == "rotctl" and ROTCTL is None:
        return "needs Hamlib's rotctl (apt install libhamlib-utils)"
    port = _value(argv, "--port")
    if port is not None and not (port.startswith("emu://") or port == "/dev/pts/N"
                                 or _emulated_tcp(line, port)):
        return f"needs hardware: --port {port}"
    if ("--plot" in argv or "--sky-plots" in argv) and importlib.util.find_spec(
            "matplotlib") is None:
        return "needs the [plot] extra (matplotlib)"
    if "--dask" in argv and importlib.util.find_spec("distributed") is None:
        return "needs the [dask] extra"
    return None


def test_the_readme_has_commands_and_exactly_two_set_up_commands():
    text = README.read_text(encoding="utf-8")
    assert len(LINES) > 50
    setup = text.split("## Set up", 1)[1].split("\n## ", 1)[0]
    assert setup.count("```sh") == 2
    assert text.count("<!-- main-command -->") == 1 and text.count("<!-- test-command -->") == 1


def test_the_extractor_reads_continuations_comments_and_chains():
    text = ("x\n\n    tracker a --b 'c d' \\\n        --e   # note\n    tracker f &\n\n"
            "```sh\npython3 -m pip install . && tracker g\n```\n")
    assert [(ln.line_no, ln.block, ln.argv) for ln in readme_lines(text)] == [
        (3, 1, ("tracker", "a", "--b", "c d", "--e")), (5, 1, ("tracker", "f")),
        (8, 2, ("python3", "-m", "pip", "install", ".")), (8, 2, ("tracker", "g"))]


class FakeCelestrak:
    """Serves the bundled groups (any other path: the amateur group; FORMAT=json: OMM)."""

    def __init__(self):
        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_GET(self):
                query = urllib.parse.parse_qs(urllib.parse.urlsplit(self.path).query)
                group = query.get("GROUP", ["amateur"])[0]
                if query.get("FORMAT", ["tle"])[0] == "json":
                    body = (DATA / "tle" / "amateur5.json").read_bytes()
                else:
                    path = BUNDLED / f"{group}.txt"
                    body = (path if path.exists() else BUNDLED / "amateur.txt").read_bytes()
                self.send_response(200)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.server.server_port}"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    for var in ("TRACKER_CONFIG", "TRACKER_CACHE_DIR", "TRACKER_CELESTRAK_URL"):
        monkeypatch.delenv(var, raising=False)
    return tmp_path


def _make_inputs(argv: list[str], folder: Path) -> None:
    """The files a README line reads, made as the README's reader would have them."""
    if "my.tle" in argv or "active.txt" in argv:
        for name in ("my.tle", "active.txt"):
            shutil.copy(BUNDLED / "amateur.txt", folder / name)
    if "stations.csv" in argv:
        (folder / "stations.csv").write_text("name,lat,lon,alt\nDelft,52.0,4.37,0\n"
                                             "Boulder,40.0,-105.3,1600\n")
    if "net.toml" in argv:
        (folder / "net.toml").write_text('[[station]]\nname = "Delft"\nlat = 52.0\n'
                                         'lon = 4.37\n\n[[station]]\nname = "Boulder"\n'
                                         'lat = 40.0\nlon = -105.3\nalt = 1600\n')
    plan_file = _value(argv, "--from")
    if plan_file and not (folder / plan_file).exists():
        (writer,) = [ln.argv for ln in LINES if _value(ln.argv, "--steptable") == plan_file]
        assert main([*writer[1:], "--at", AT]) == 0


def _tracker_argv(argv: list[str]) -> list[str]:
    """The README's words plus what makes the run reproducible and quick (module doc)."""
    command = argv[1]
    if command in TAKES_AT and "--at" not in argv:
        argv = [*argv, "--at", AT]
    demo = "--port" not in argv and "--dry-run" not in argv and "--from" not in argv
    if command == "track" and demo and "--speed" not in argv:
        argv = [*argv, "--speed", "max"]
    if command == "upload" and demo and "--speed" not in argv:
        argv = [*argv, "--speed", "max"]
    if argv[1:3] == ["station", "run"] and "--simulate" in argv:
        hours = min(float(_value(argv, "--hours") or 24.0), STATION_HOURS)
        argv = _with_value(argv, "--speed", "max")
        argv = _with_value(argv, "--hours", f"{hours:g}")
        if "--at" not in argv:
            argv = _with_value(argv, "--at", AT)
        if "--status-port" in argv:
            argv = _with_value(argv, "--status-port", str(free_port()))
    return argv


def _with_value(argv: list[str], flag: str, value: str) -> list[str]:
    """``argv`` with ``flag`` set to ``value`` (replaced, or added at the end)."""
    if flag in argv:
        i = argv.index(flag)
        return [*argv[:i + 1], value, *argv[i + 2:]]
    return [*argv, flag, value]


def _with_emulator(line: Line, argv: list[str], emulate) -> list[str]:
    """Point ``/dev/pts/N`` or an emulator's TCP port at a real ``tracker emulate``."""
    port_flag = "-r" if argv[0] == "rotctl" else "--port"
    port = _value(argv, port_flag)
    if port is None or port.startswith("emu://"):
        return argv
    if port == "/dev/pts/N":
        box = emulate("--protocol", _value(argv, "--protocol") or "gs232b", "--pty")
    else:
        box = emulate("--protocol", _emulated_tcp(line, port), "--tcp", "0")
    i = argv.index(port_flag) + 1
    return [*argv[:i], box.url, *argv[i + 1:]]


def _run_with_serve_rotctld(line: Line, argv: list[str]) -> None:
    """A server line runs until SIGTERM; a rotctl line talks to its block's server."""
    server_argv = argv if argv[0] == "tracker" else SERVE_ROTCTLD[(line.block,
                                                                   _value(argv, "-r"))]
    server = ServeRotctldProcess(*server_argv[2:])
    try:
        if argv[0] == "rotctl":
            i = argv.index("-r") + 1
            r = subprocess.run([ROTCTL, *argv[1:i], server.where, *argv[i + 1:]],
                               capture_output=True, text=True, timeout=30)
            assert r.returncode == 0, r.stderr[-2000:]
    finally:
        code, _out, err = server.stop()
    assert code == 0, err[-2000:]


def _param(line: Line):
    # a Dask cluster and the example scripts (a week of plans) take seconds each: `slow`
    slow = "--dask" in line.argv or line.argv[:1] == ("python",)
    return pytest.param(line, id=line.id, marks=[pytest.mark.slow] if slow else [])


@pytest.mark.parametrize("line", [_param(ln) for ln in LINES])
def test_readme_command(line, folder, emulate, monkeypatch, capsys, request):
    reason = skip_reason(line)
    if reason:
        pytest.skip(reason)
    argv = list(line.argv)
    _make_inputs(argv, folder)
    if argv[0] == "python":
        # The timeout only guards against a hang: a benchmark's quick look takes seconds of
        # CPU, which a CI run sharing two cores with its other workers can stretch many times.
        r = subprocess.run([sys.executable, str(ROOT / argv[1]), *argv[2:]], cwd=folder,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-2000:]
        return
    if argv[:2] == ["tracker", "serve-rotctld"] or (
            argv[0] == "rotctl" and (line.block, _value(argv, "-r")) in SERVE_ROTCTLD):
        _run_with_serve_rotctld(line, argv)
        return
    argv = _with_emulator(line, argv, emulate)
    if argv[0] == "rotctl":
        r = subprocess.run([ROTCTL, *argv[1:]], capture_output=True, text=True, timeout=30)
        assert r.returncode == 0, r.stderr
        return
    if argv[1] == "emulate":
        i = argv.index("--tcp") + 1 if "--tcp" in argv else None
        box = emulate(*(argv[2:] if i is None else [*argv[2:i], "0", *argv[i + 1:]]))
        assert re.match(r"^(/dev/|socket://)", box.url), box.url
        assert box.stop()[0] == 0
        return
    if argv[1:3] == ["tle", "update"]:
        fake = FakeCelestrak()
        request.addfinalizer(fake.close)
        monkeypatch.setenv("TRACKER_CELESTRAK_URL", fake.url + "/NORAD/elements/gp.php")
        argv = [re.sub(r"^https?://[^/]+", fake.url, a) for a in argv]
    code = main(_tracker_argv(argv)[1:])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if any("fault=jam" in a for a in argv):   # the README's jammed-rotator example
        assert code == 2 and "did not move" in err and "the rotator was stopped" in err
        return
    assert code == 0, f"exit {code}: {err[-2000:]}"
