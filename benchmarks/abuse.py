"""Throw bad input at every ``tracker`` subcommand, as a user would, and count broken promises.

    python benchmarks/abuse.py            # the full run (about 500 cases, one at a time)
    python benchmarks/abuse.py --quick    # about 60 of them
    python benchmarks/abuse.py --only upload --verbose

The promise checked (the project's rule): bad input -- broken files, special files (FIFOs,
``/dev/zero``, ``/dev/full``), garbage from the port, impossible values (nan, inf, negative,
huge), far dates, unknown names, empty strings -- gets ONE line on stderr starting
``tracker: error: ``, exit status 2, never a traceback, never a hang; nothing the user already
had is overwritten without ``--force``. (``tracker next`` exits 1 with one stdout line when
there is no pass: an answer, not an error.)

Every case runs ``python -m tracker ...`` from this checkout as a subprocess with stdin from
/dev/null, a 20 s timeout (its whole process group is killed then: a "hang"), a temporary
HOME / XDG dirs / ``TRACKER_CONFIG`` / ``TRACKER_CACHE_DIR`` (the user's own config and cache
are never read or written), ``/dev/zero`` cases under RLIMIT_AS 2 GiB, and no network: element
downloads and controllers are served by small servers on 127.0.0.1 inside this script, or
``--port emu://...`` (the tracker's in-process emulator). Times are fixed with ``--at``.

Figures printed: cases tried, and per kind of failure: tracebacks, hangs (timeouts), accepted
bad values (exit 0 where an error was due), wrong exit codes, multi-line / malformed errors,
overwritten files; then every failing case with its command line and the first line it
printed. Outcomes that are defensible either way are listed "to review", not counted as
failures. Exit status 1 if any case failed.
"""

from __future__ import annotations

import argparse
import http.server
import json
import os
import random
import resource
import shlex
import shutil
import signal
import socketserver
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
AT = "2026-08-23T02:00:00Z"          # bundled elements' epoch is about 2026-08-22
TIMEOUT_S = 20.0
GIB = 1024 ** 3

# outcomes a case may expect
ERROR = "error"      # exit 2, exactly one stderr line starting "tracker: error: "
CLEAN = "clean"      # either a success (exit 0) or such an error; never a traceback or hang
APPEND = "append"    # success is fine, but the protected file's old bytes must stay its prefix

KINDS = ("traceback", "hang", "accepted", "exit-code", "multi-line", "overwrote")
KIND_TITLES = {
    "traceback": "tracebacks",
    "hang": "hangs (timeouts)",
    "accepted": "accepted bad values (exit 0, an error was due)",
    "exit-code": "wrong exit codes",
    "multi-line": "multi-line or malformed errors",
    "overwrote": "user files changed without --force",
}
PROTECTED_BYTES = b"precious user data\n"


@dataclass
class Case:
    group: str                   # the subcommand (for --only and the summary)
    what: str                    # what is bad, in a few words
    argv: list[str]
    expect: str = ERROR
    protect: str | None = None   # a placeholder path created with PROTECTED_BYTES first
    memory_limit: bool = False   # RLIMIT_AS 2 GiB
    env: dict[str, str] = field(default_factory=dict)


@dataclass
class Result:
    case: Case
    kind: str                    # "ok", "review" or one of KINDS
    rc: int | None
    seconds: float
    first_line: str
    note: str = ""


# -- fixtures ------------------------------------------------------------------------------------


class Fixtures:
    """Every file, folder and server the cases point at, in one temporary folder."""

    def __init__(self, root: Path):
        self.root = root
        self.home = root / "home"
        for sub in ("home", "xdg/config", "xdg/cache", "xdg/data", "xdg/state", "cache",
                    "adir", "outs"):
            (root / sub).mkdir(parents=True, exist_ok=True)
        self.cfg = root / "config.toml"
        self.missing = str(root / "no-such-file.txt")
        self.missing_folder = str(root / "no-such-folder" / "out.txt")
        self.adir = str(root / "adir")
        self.fifo = str(root / "fifo")
        os.mkfifo(self.fifo)
        self.empty = self._write("empty.txt", b"")
        rng = random.Random(2026)
        self.garbage = self._write("garbage.bin", bytes(rng.randrange(256) for _ in range(4096)))
        self.nested_json = self._write("nested.json", b"[" * 100_000)
        self.nested_toml = self._write("nested.toml", b"a = " + b"[" * 100_000)
        self.nested_csv = self._write("nested.csv", b"[" * 100_000)
        self.long_line = self._write("longline.txt", b"1" * 5_000_000)
        tle = (REPO / "tle" / "data" / "stations.txt").read_text().splitlines()
        self.iss = "\n".join(tle[:3]) + "\n"
        l0, l1, l2 = tle[:3]
        self.tle_bad = {
            "bad checksum": f"{l0}\n{l1[:-1]}0\n{l2}\n" if l1[-1] != "0" else
                            f"{l0}\n{l1[:-1]}1\n{l2}\n",
            "truncated line": f"{l0}\n{l1[:40]}\n{l2}\n",
            "only line 1": f"{l0}\n{l1}\n",
            "letters in fields": f"{l0}\n{l1[:20]}ABCDEFGHIJKL{l1[32:]}\n{l2}\n",
            "mean motion 0": _fix_checksum(l0, l1, l2[:52] + " 0.00000000" + l2[63:]),
            "eccentricity 0.9999999": _fix_checksum(l0, l1, l2[:26] + "9999999" + l2[33:]),
        }
        self.tle_files = {k: self._write(f"tle-{i}.txt", v.encode())
                          for i, (k, v) in enumerate(self.tle_bad.items())}
        omm = {"OBJECT_NAME": "ISS (ZARYA)", "NORAD_CAT_ID": 25544, "EPOCH": "2026-08-22T12:00:00",
               "MEAN_MOTION": float("nan"), "ECCENTRICITY": 0.0007, "INCLINATION": 51.6,
               "RA_OF_ASC_NODE": 331.9, "ARG_OF_PERICENTER": 72.6, "MEAN_ANOMALY": 287.5,
               "BSTAR": 0.00017, "MEAN_MOTION_DOT": 0.00009, "MEAN_MOTION_DDOT": 0}
        self.omm_files = {
            "OMM with NaN mean motion": self._write("omm-nan.json", json.dumps([omm]).encode()),
            "OMM empty object": self._write("omm-empty.json", b"[{}]"),
            "OMM epoch 9999": self._write("omm-9999.json", json.dumps(
                [{**omm, "MEAN_MOTION": 15.5, "EPOCH": "9999-12-31T00:00:00"}]).encode()),
            "OMM as a JSON string": self._write("omm-str.json", b'"ISS"'),
        }
        self.masks = {
            "mask el nan": self._write("mask-nan.txt", b"0 nan\n180 5\n"),
            "mask el 1e300": self._write("mask-huge.txt", b"0 1e300\n180 5\n"),
            "mask az 999": self._write("mask-az.txt", b"999 10\n"),
            "mask words": self._write("mask-words.txt", b"north ten\n"),
            "mask one column": self._write("mask-one.txt", b"0\n"),
            "mask el 95": self._write("mask-95.txt", b"0 95\n180 95\n"),
        }
        self.stations = {
            "stations lat nan": self._write("st-nan.csv", b"a,nan,4.4,0\n"),
            "stations lat 91": self._write("st-91.csv", b"a,91,4.4,0\n"),
            "stations alt 1e300": self._write("st-alt.csv", b"a,52,4.4,1e300\n"),
            "stations missing columns": self._write("st-short.csv", b"a,52\n"),
            "stations words": self._write("st-words.csv", b"a,north,east,high\n"),
            "stations TOML lat inf": self._write("st-inf.toml",
                                                 b"[[station]]\nname='a'\nlat_deg=inf\n"
                                                 b"lon_deg=4.4\n"),
            "stations TOML wrong type": self._write("st-type.toml", b"station = 5\n"),
        }
        self.priorities = {
            "priorities no '='": self._write("pr-noeq.txt", b"ISS (ZARYA)\n"),
            "priorities N abc": self._write("pr-abc.txt", b"ISS (ZARYA)=abc\n"),
            "priorities N nan": self._write("pr-nan.txt", b"ISS (ZARYA)=nan\n"),
            "priorities N -1": self._write("pr-neg.txt", b"ISS (ZARYA)=-1\n"),
            "priorities empty name": self._write("pr-empty.txt", b"=3\n"),
        }
        self.schedules = {
            "schedule az nan": self._write("sch-nan.csv", f"{AT},nan,10\n".encode()),
            "schedule az 1e300": self._write("sch-huge.csv", f"{AT},1e300,10\n".encode()),
            "schedule el 91": self._write("sch-el.csv", f"{AT},10,91\n".encode()),
            "schedule time garbage": self._write("sch-time.csv", b"yesterday,10,10\n"),
            "schedule year 0001": self._write("sch-0001.csv",
                                              b"0001-01-01T00:00:00Z,10,10\n"),
            "schedule year 9999": self._write("sch-9999.csv",
                                              b"9999-12-31T00:00:00Z,10,10\n"),
            "schedule no rows": self._write("sch-empty.csv", b"# nothing\n"),
        }
        self.configs = {
            "config lat nan": self._write("c-nan.toml", b"[station]\nlat_deg = nan\n"),
            "config lon inf": self._write("c-inf.toml", b"[station]\nlon_deg = inf\n"),
            "config alt 1e300": self._write("c-alt.toml", b"[station]\nalt_m = 1e300\n"),
            "config lat string": self._write("c-str.toml", b"[station]\nlat_deg = \"abc\"\n"),
            "config station is a number": self._write("c-num.toml", b"station = 5\n"),
            "config unknown rotator preset": self._write(
                "c-rot.toml", b"[tracking]\nrotator = \"nope\"\n[rotator.nope]\n"
                              b"preset = \"NO-SUCH\"\n"),
            "config mask missing": self._write("c-mask.toml",
                                               b"[station]\nmask = \"no-such-mask.txt\"\n"),
            "config broken TOML": self._write("c-broken.toml", b"[station\nlat_deg = \n"),
            "config deadband -5": self._write("c-db.toml", b"[tracking]\ndeadband_deg = -5\n"),
            "config port FIFO": self._write("c-port.toml",
                                            f"[tracking]\nport = \"{self.fifo}\"\n".encode()),
            "config nested arrays": self.nested_toml,
        }
        # written by prepare(), from a plan file the tracker makes
        self.plans = {label: str(root / f"plan-{i}.plan") for i, label in enumerate((
            "plan cut in half", "plan t_utc garbage", "plan t_utc 9999", "plan interval nan",
            "plan W line az 999", "plan W line words", "plan only comments"))}
        self.http = _HttpServer(self.iss.encode())
        self.ports = {mode: _TcpServer(mode) for mode in _TcpHandler.MODES}

    def _write(self, name: str, data: bytes) -> str:
        path = self.root / name
        path.write_bytes(data)
        return str(path)

    def prepare(self) -> None:
        """Things made by the tracker itself: the base config and a good plan file."""
        env = self.env()
        subprocess.run([sys.executable, "-m", "tracker", "config", "init", "--config",
                        str(self.cfg)], env=env, stdin=subprocess.DEVNULL,
                       capture_output=True, timeout=60, check=True)
        plan = self.root / "good.plan"
        subprocess.run([sys.executable, "-m", "tracker", "plan", "ISS", "--at", AT,
                        "--steptable", str(plan)], env=env, stdin=subprocess.DEVNULL,
                       capture_output=True, timeout=60, check=True)
        text = plan.read_text()
        lines = text.splitlines()
        t_line = next(i for i, s in enumerate(lines) if s.startswith("# t_utc:"))
        w_line = next(i for i, s in enumerate(lines) if s.startswith("W"))
        iv_line = next(i for i, s in enumerate(lines) if s.startswith("# interval_s:"))

        def edit(i: int, new: str) -> str:
            return "\n".join([*lines[:i], new, *lines[i + 1:]]) + "\n"

        edits = {
            "plan cut in half": text[:len(text) // 2],
            "plan t_utc garbage": edit(t_line, "# t_utc: soon"),
            "plan t_utc 9999": edit(t_line, "# t_utc: 9999-12-31T00:00:00Z"),
            "plan interval nan": edit(iv_line, "# interval_s: nan"),
            "plan W line az 999": edit(w_line, "W001 999 999"),
            "plan W line words": edit(w_line, "Wabc def"),
            "plan only comments": "# tracker step table\n",
        }
        for label, body in edits.items():
            Path(self.plans[label]).write_text(body)

    def env(self) -> dict[str, str]:
        env = {k: v for k, v in os.environ.items()
               if not k.lower().endswith("_proxy") and not k.startswith(("TRACKER_", "XDG_"))}
        env.update({
            "HOME": str(self.home),
            "XDG_CONFIG_HOME": str(self.root / "xdg/config"),
            "XDG_CACHE_HOME": str(self.root / "xdg/cache"),
            "XDG_DATA_HOME": str(self.root / "xdg/data"),
            "XDG_STATE_HOME": str(self.root / "xdg/state"),
            "TRACKER_CONFIG": str(self.cfg),
            "TRACKER_CACHE_DIR": str(self.root / "cache"),
            "TRACKER_CELESTRAK_URL": "http://127.0.0.1:1/",
            "PYTHONPATH": str(REPO) + os.pathsep + env.get("PYTHONPATH", ""),
            "MPLBACKEND": "Agg",
            "NO_PROXY": "*",
            "no_proxy": "*",
            "COLUMNS": "120",
        })
        return env

    def close(self) -> None:
        self.http.close()
        for server in self.ports.values():
            server.close()


def _tle_checksum(line: str) -> str:
    total = sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68])
    return line[:68] + str(total % 10)


def _fix_checksum(l0: str, l1: str, l2: str) -> str:
    return f"{l0}\n{_tle_checksum(l1)}\n{_tle_checksum(l2)}\n"


class _HttpHandler(http.server.BaseHTTPRequestHandler):
    good: bytes = b""

    def log_message(self, *args) -> None:   # quiet
        pass

    # One branch per kind of bad download the fake server can serve.
    def do_GET(self) -> None:  # noqa: C901
        mode = self.path.strip("/").split("/")[0].split("?")[0]
        port = self.server.server_address[1]
        if mode == "good":
            return self._send(200, self.good)
        if mode == "garbage":
            return self._send(200, bytes(random.Random(7).randrange(256) for _ in range(2048)))
        if mode == "empty":
            return self._send(200, b"")
        if mode == "html":
            return self._send(200, b"<html><body>Service unavailable</body></html>")
        if mode == "nogp":
            return self._send(200, b"No GP data found\n")
        if mode == "nested":
            return self._send(200, b"[" * 100_000)
        if mode == "nanomm":
            return self._send(200, b'[{"OBJECT_NAME": "X", "MEAN_MOTION": NaN}]')
        if mode == "badtle":
            text = self.good.decode().splitlines()
            return self._send(200, f"{text[0]}\n{text[1][:-1]}X\n{text[2]}\n".encode())
        if mode in ("404", "500"):
            return self._send(int(mode), b"no")
        if mode == "loop":
            self.send_response(302)
            self.send_header("Location", f"http://127.0.0.1:{port}/loop")
            self.end_headers()
            return None
        if mode == "away":
            self.send_response(302)
            self.send_header("Location", "http://127.0.0.1:1/")
            self.end_headers()
            return None
        if mode == "slow":   # headers, then a body that trickles for 30 s
            self.send_response(200)
            self.send_header("Content-Length", "100000")
            self.end_headers()
            for _ in range(60):
                try:
                    self.wfile.write(b"x")
                    self.wfile.flush()
                except OSError:
                    return None
                time.sleep(0.5)
            return None
        if mode == "huge":   # 80 MiB of one long line, over the 64 MiB cap
            self.send_response(200)
            self.end_headers()
            chunk = b"1" * (1 << 20)
            try:
                for _ in range(80):
                    self.wfile.write(chunk)
            except OSError:
                pass
            return None
        if mode == "liar":   # Content-Length says more than is sent
            self.send_response(200)
            self.send_header("Content-Length", "1000000")
            self.end_headers()
            self.wfile.write(self.good[:100])
            return None
        return self._send(404, b"unknown mode")

    def _send(self, status: int, body: bytes) -> None:
        self.send_response(status)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        try:
            self.wfile.write(body)
        except OSError:
            pass


class _HttpServer:
    def __init__(self, good: bytes):
        handler = type("H", (_HttpHandler,), {"good": good})
        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self.server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


class _TcpHandler(socketserver.BaseRequestHandler):
    """A 'controller' on a TCP port that answers badly, by mode."""

    MODES = ("garbage", "silent", "endless", "close", "nan", "huge", "words")

    def handle(self) -> None:
        mode = self.server.mode
        sock = self.request
        sock.settimeout(30)
        rng = random.Random(11)
        try:
            if mode == "close":
                return
            if mode == "endless":   # bytes without a line end, up to 200 MiB
                chunk = b"AZ=1" * 16384
                for _ in range(200 * (1 << 20) // len(chunk)):
                    sock.sendall(chunk)
                return
            while True:
                data = sock.recv(4096)
                if not data:
                    return
                if mode == "silent":
                    continue
                reply = {"garbage": bytes(rng.randrange(256) for _ in range(64)),
                         "nan": b"AZ=nan  EL=nan\r",
                         "huge": b"AZ=99999999999  EL=-9999999999\r",
                         "words": b"?>\r\nERROR north\r\n"}[mode]
                sock.sendall(reply)
        except OSError:
            return


class _TcpServer:
    def __init__(self, mode: str):
        self.server = socketserver.ThreadingTCPServer(("127.0.0.1", 0), _TcpHandler)
        self.server.daemon_threads = True
        self.server.mode = mode
        self.port = self.server.server_address[1]
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


# -- cases -----------------------------------------------------------------------------------------

NUM_BAD = ("nan", "inf", "1e300", "abc", "")


# The case table: one block per subcommand and option, read top to bottom.
def build_cases(fx: Fixtures) -> list[Case]:  # noqa: C901
    cases: list[Case] = []

    def add(group: str, what: str, argv: list[str], **kw) -> None:
        cases.append(Case(group, what, list(argv), **kw))

    base = {
        "next": ["next", "ISS", "--at", AT],
        "passes": ["passes", "ISS", "--at", AT],
        "plan": ["plan", "ISS", "--at", AT],
        "batch": ["batch", "stations", "--at", AT, "--days", "0.1"],
        "schedule": ["schedule", "stations", "--at", AT, "--days", "0.1"],
        "track": ["track", "ISS", "--port", "emu://gs232b", "--at", AT, "--plain"],
        "upload": ["upload", "ISS", "--at", AT, "--dry-run"],
        "rotator": ["rotator", "--port", "emu://gs232b", "--timeout", "1"],
        "emulate": ["emulate", "--tcp", "0", "--duration", "1"],
        "tle show": ["tle", "show", "ISS", "--at", AT],
        "tle update": ["tle", "update", "--force", "--base-url", f"{fx.http.url}/good/gp.php",
                       "--timeout", "5", "--at", AT, "amateur"],
        "config show": ["config", "show"],
    }

    parse_errors_seen: set[tuple[str, str]] = set()

    def numeric(group: str, opt: str, values, tail=("position",), grp=None) -> None:
        argv0 = base[group]
        for v in values:
            if v in ("abc", "1.5"):   # argparse's own refusals: one per subcommand is enough
                if (group, v) in parse_errors_seen:
                    continue
                parse_errors_seen.add((group, v))
            argv = [*argv0, opt, v]
            if group == "rotator":
                argv += list(tail)
            add(grp or group.split()[0], f"{opt} {v!r}", argv)

    # -- 1. impossible / malformed numbers, per numeric option --------------------------------
    station_opts = {"--lat": ("91", "-91"), "--lon": ("181", "-361"), "--alt": ("-1e6",),
                    "--min-el": ("-90", "91")}
    for opt, extra in station_opts.items():
        numeric("next", opt, (*NUM_BAD, *extra))
        numeric("config show", opt, ("nan", "inf", *extra))
        for group in ("plan", "batch", "track", "upload", "rotator"):
            if opt == "--lat" or group in ("plan", "batch"):
                numeric(group, opt, ("nan",))
    numeric("next", "--days", ("-1", "0", "nan", "inf", "1e300"))
    numeric("passes", "--hours", ("-1", "0", "nan", "1e300"))
    numeric("plan", "--hours", ("-1", "0", "nan", "inf", "1e300"))
    numeric("batch", "--days", ("-1", "0", "nan", "inf", "1e300"))
    numeric("upload", "--days", ("-1", "0", "nan", "1e300"))
    numeric("plan", "--pass", ("0", "-1", "abc", "99999"))
    numeric("upload", "--pass", ("0", "99999"))
    numeric("plan", "--threshold", ("nan", "inf", "-1", "abc", ""))
    for v in (("nan", "0"), ("0", "inf"), ("1e300", "0"), ("-1", "0"), ("0", "-95")):
        add("plan", f"--current {' '.join(v)}", [*base["plan"], "--current", *v])
    numeric("plan", "--mains-hz", ("55",))
    numeric("plan", "--format", ("xml",))
    numeric("plan", "--rotator", ("NO-SUCH-ROTATOR", ""))
    for group in ("batch", "schedule"):
        numeric(group, "--min-max-el", ("nan", "1e300"))
        numeric(group, "--step", ("-1", "0", "nan", "inf"))
        numeric(group, "--workers", ("-1", "0", "1.5"))
        numeric(group, "--rotator", ("NO-SUCH-ROTATOR",))
        numeric(group, "--format", ("xml",))
    numeric("schedule", "--settle", ("-1", "nan", "inf", "1e300"))
    numeric("schedule", "--default-priority", ("-1", "nan", "inf", "abc"))
    for v in ("ISS (ZARYA)", "ISS (ZARYA)=abc", "ISS (ZARYA)=nan", "ISS (ZARYA)=-1", "=3"):
        add("schedule", f"--priority {v!r}", [*base["schedule"], "--priority", v])
    numeric("track", "--passes", ("-1", "nan", "1e300"))
    numeric("track", "--speed", ("0", "-1", "nan", "inf"))
    numeric("track", "--deadband", ("-1", "nan", "inf", "1e300"))
    numeric("track", "--cycle", ("0", "-1", "nan", "inf", "1e300"))
    numeric("track", "--baud", ("0", "-1", "abc"))
    numeric("track", "--protocol", ("no-such-protocol",))
    numeric("track", "--rotator", ("NO-SUCH-ROTATOR", ""))
    add("track", "--target2 without an AZ/AZ protocol",
        [*base["track"], "--target2", "Sun"])
    add("track", "--target2 unknown",
        ["track", "ISS", "--protocol", "gs232b-azaz", "--port", "emu://gs232b-azaz", "--at", AT,
         "--plain", "--rotator", "G-400", "--target2", "NO SUCH SAT"])
    add("track", "--rotator2 unknown",
        ["track", "ISS", "--protocol", "gs232b-azaz", "--port", "emu://gs232b-azaz", "--at", AT,
         "--plain", "--rotator", "G-400", "--target2", "Sun", "--rotator2", "NO-SUCH"])
    add("track", "az-only protocol with an az/el rotator",
        ["track", "ISS", "--protocol", "gs232b-azaz", "--port", "emu://gs232b-azaz", "--at", AT,
         "--plain", "--rotator", "G-5500"])
    numeric("upload", "--interval", ("0", "-1", "1000", "1.5", "abc"))
    numeric("upload", "--max-error", ("0", "-1", "nan", "inf", "1e300"))
    numeric("upload", "--baud", ("0", "-1"))
    numeric("upload", "--protocol", ("rotorez", "no-such-protocol", ""))
    numeric("upload", "--rotator", ("NO-SUCH-ROTATOR",))
    for v in ("0", "-1", "nan", "inf"):   # the simulation itself, no --dry-run
        add("upload", f"--speed {v!r}", ["upload", "ISS", "--at", AT, "--speed", v])
    numeric("rotator", "--timeout", ("0", "-1", "nan", "inf", "1e300"))
    numeric("rotator", "--baud", ("0", "-1", "1e300"))
    numeric("rotator", "--protocol", ("no-such-protocol", ""))
    numeric("rotator", "--rotator", ("NO-SUCH-ROTATOR",))
    numeric("rotator", "--park-az", ("nan", "inf", "-1", "1e300"), tail=("park",))
    numeric("rotator", "--park-el", ("nan", "-95", "1e300"), tail=("park",))
    for v in ("nan", "inf", "-1", "1e300", "999", ""):
        add("rotator", f"goto {v!r}", [*base["rotator"], "goto", v])
    for v in ("nan", "inf", "-95", "1e300"):
        add("rotator", f"goto 90 {v!r}", [*base["rotator"], "goto", "90", v])
    for v in ("nan", "-1", "361", "1e300", "abc", "1.5"):
        add("rotator", f"sync {v!r}", ["rotator", "--port", "emu://gs232b-azaz", "--protocol",
                                       "gs232b-azaz", "--rotator", "G-400", "--timeout", "1",
                                       "sync", v])
    add("rotator", "sync on a plain GS-232B", [*base["rotator"], "sync", "90"])
    add("rotator", "raw without --ignore-limits", [*base["rotator"], "raw", "M090"])
    add("rotator", "unknown action", [*base["rotator"], "spin"])
    numeric("emulate", "--tcp", ("-1", "70000", "abc"))
    numeric("emulate", "--speed", ("0", "-1", "nan", "inf", "1e300"))
    numeric("emulate", "--az", ("-1", "999", "nan", "inf"))
    numeric("emulate", "--el", ("-1", "181", "nan", "inf"))   # a G-5500's el is 0-180
    numeric("emulate", "--duration", ("-1", "nan", "inf", "1e300"))
    numeric("emulate", "--fault-seed", ("nan", "1.5"))
    numeric("emulate", "--protocol", ("no-such-protocol",))
    numeric("emulate", "--rotator", ("NO-SUCH-ROTATOR",))
    numeric("emulate", "--bind", ("999.1.1.1", ""))
    numeric("emulate", "--mains", ("55",))
    for spec in ("bogus", "drop=2", "delay=inf", "silent=nan@1", "powercycle@-5", ""):
        add("emulate", f"--fault {spec!r}", [*base["emulate"], "--fault", spec])
    numeric("tle update", "--timeout", ("0", "-1", "nan", "inf", "1e300"), grp="tle")
    numeric("tle update", "--format", ("yaml", ""), grp="tle")

    # -- 2. far dates and garbage times ---------------------------------------------------------
    times = ("0001-01-01", "9999-12-31", "1899-12-31T23:59:59Z", "2101-01-01T00:00:00Z",
             "2026-13-45", "2026-08-23T25:00:00Z", "nan", "1e300", "yesterday", "")
    for group, argv0 in (("next", ["next", "ISS"]), ("passes", ["passes", "ISS"]),
                         ("plan", ["plan", "ISS"]), ("batch", ["batch", "stations", "--days",
                                                               "0.1"]),
                         ("schedule", ["schedule", "stations", "--days", "0.1"]),
                         ("track", ["track", "ISS", "--port", "emu://gs232b", "--plain"]),
                         ("upload", ["upload", "ISS", "--dry-run"]),
                         ("tle", ["tle", "show", "ISS"])):
        for t in (times if group == "next" else times[:5]):
            add(group, f"{' '.join(argv0[:2])} --at {t!r}", [*argv0, "--at", t])
    add("tle", "tle update --at 9999-12-31",
        ["tle", "update", "--base-url", f"{fx.http.url}/good/gp.php", "--at", "9999-12-31",
         "amateur"])
    add("next", "elements 20 years old (--at 2046)", ["next", "ISS", "--at", "2046-08-23"],
        expect=CLEAN)

    # -- 3. unknown names and empty strings -----------------------------------------------------
    names = ("NO SUCH SATELLITE", "", "   ", "99999999999", "-1", "radec:abc",
             "radec:83.6,99", "radec:nan,nan", "schedule:" + fx.missing,
             "ISS\nsecond line", "\x1b[31mred\x1b[0m", "\udcff")
    for group, argv0 in (("next", ["next"]), ("passes", ["passes"]), ("plan", ["plan"]),
                         ("track", ["track"]), ("upload", ["upload"])):
        post = ["--at", AT, *{"track": ["--port", "emu://gs232b", "--plain"],
                               "upload": ["--dry-run"]}.get(group, [])]
        for n in (names if group == "next" else names[:3] + names[-4:-2]):
            add(group, f"target {n!r}", [*argv0, n, *post])
    for n in ("NO SUCH SATELLITE", "", "99999999999", "ISS\nsecond line"):
        add("tle", f"tle show {n!r}", ["tle", "show", n, "--at", AT])
    for group in ("next", "plan"):
        add(group, "--group unknown", [*base[group], "--group", "no-such-group"])
        add(group, "--group ''", [*base[group], "--group", ""])
        add(group, "--station unknown", [*base[group], "--station", "nowhere"])
        add(group, "--station ''", [*base[group], "--station", ""])
    add("passes", "--group with nothing else", ["passes", "--group", "nope", "--at", AT])
    add("batch", "catalogue group unknown", ["batch", "no-such-group", "--at", AT])
    add("batch", "catalogue ''", ["batch", "", "--at", AT])
    add("schedule", "catalogue group unknown", ["schedule", "no-such-group", "--at", AT])
    add("track", "--station unknown", [*base["track"], "--station", "nowhere"])
    add("rotator", "--station unknown", [*base["rotator"], "--station", "nowhere", "position"])
    add("config", "config show --station unknown", ["config", "show", "--station", "nowhere"])
    add("main", "unknown subcommand", ["fly"])
    add("main", "no subcommand", [])
    add("main", "empty subcommand", [""])
    add("config", "config unknown action", ["config", "burn"])
    add("tle", "tle unknown action", ["tle", "eat"])

    # -- 4. broken input files, per file option -----------------------------------------------
    special = [("missing file", fx.missing, False), ("a directory", fx.adir, False),
               ("a FIFO", fx.fifo, False), ("/dev/zero", "/dev/zero", True),
               ("empty file", fx.empty, False), ("binary garbage", fx.garbage, False),
               ("nested JSON [*100000", fx.nested_json, False),
               ("5 MB single line", fx.long_line, False)]
    file_opts = [
        ("next", [*base["next"], "--tle"]),
        ("tle", ["tle", "show", "ISS", "--at", AT, "--tle"]),
        ("next", [*base["next"], "--mask"]),
        ("batch", [*base["batch"], "--stations"]),
        ("schedule", [*base["schedule"], "--priorities"]),
        ("batch", ["batch", "--at", AT, "--days", "0.1", "--"]),
        ("upload", ["upload", "--dry-run", "--from"]),
        ("upload", ["upload", "--from"]),
        ("next", [*base["next"], "--config"]),
        ("config", ["config", "show", "--config"]),
        ("main", ["--config"]),       # the global --config, then a subcommand
    ]
    for group, argv0 in file_opts:
        opt = argv0[-1] if argv0[-1].startswith("--") and argv0[-1] != "--" else "CATALOG"
        for label, path, limit in special:
            if label.startswith("nested") and opt not in ("--tle", "--config", "--from",
                                                          "CATALOG"):
                continue
            if label == "empty file" and opt in ("--config", "--mask", "--priorities"):
                continue   # an empty config / mask / priorities file is a valid "none"
            if label.startswith("5 MB") and opt not in ("--tle", "--mask"):
                continue
            if opt == "--from" and "--dry-run" not in argv0 and label not in (
                    "a FIFO", "/dev/zero", "missing file"):
                continue
            argv = [*argv0, path] if group != "main" else ["--config", path, *base["next"]]
            add(group, f"{opt} {label}", argv, memory_limit=limit)
    add("tle", "--cache-dir a file", ["tle", "--cache-dir", fx.garbage, "list"])
    add("tle", "--cache-dir /dev/zero", ["tle", "--cache-dir", "/dev/zero", "list"],
        memory_limit=True)
    add("tle", "--cache-dir a FIFO", ["tle", "--cache-dir", fx.fifo, "list"])
    add("tle", "--cache-dir ''", ["tle", "--cache-dir", "", "list"])
    bad_cache = fx.root / "bad-cache"
    (bad_cache / "tle").mkdir(parents=True)
    (bad_cache / "tle" / "sources.json").write_bytes(b"[" * 100_000)
    (bad_cache / "tle" / "amateur.txt").write_bytes(Path(fx.garbage).read_bytes())
    os.mkfifo(bad_cache / "tle" / "weather.txt")
    add("tle", "cache: nested sources.json, garbage + FIFO element files",
        ["tle", "list", "--at", AT], env={"TRACKER_CACHE_DIR": str(bad_cache)}, expect=CLEAN)
    add("next", "cache: nested sources.json, garbage + FIFO element files",
        ["next", "ISS", "--at", AT], env={"TRACKER_CACHE_DIR": str(bad_cache)}, expect=CLEAN)
    add("main", "TRACKER_CONFIG is a FIFO", base["next"], env={"TRACKER_CONFIG": fx.fifo})
    add("main", "TRACKER_CONFIG is /dev/zero", base["next"],
        env={"TRACKER_CONFIG": "/dev/zero"}, memory_limit=True)
    add("main", "TRACKER_EPHEMERIS is garbage", ["next", "Sun", "--at", AT],
        env={"TRACKER_EPHEMERIS": fx.garbage})
    add("main", "TRACKER_EPHEMERIS is a FIFO", ["next", "Sun", "--at", AT],
        env={"TRACKER_EPHEMERIS": fx.fifo})

    # element files with bad contents
    for label, path in {**fx.tle_files, **fx.omm_files}.items():
        expect = CLEAN if label.startswith(("mean motion", "eccentricity")) else ERROR
        add("next", f"--tle {label}", ["next", "ISS", "--at", AT, "--tle", path], expect=expect)
    for label, path in fx.masks.items():
        add("next", label, [*base["next"], "--mask", path])
        if label in ("mask el nan", "mask el 95"):
            add("rotator", label, [*base["rotator"], "--mask", path, "goto", "90", "10"])
    for label, path in fx.stations.items():
        add("batch", label, [*base["batch"], "--stations", path])
    for label, path in fx.priorities.items():
        add("schedule", label, [*base["schedule"], "--priorities", path])
    for label, path in fx.schedules.items():
        add("next", f"target {label}", ["next", f"schedule:{path}", "--at", AT])
        if label in ("schedule az nan", "schedule year 9999"):
            add("plan", f"target {label}", ["plan", path, "--at", AT])
    for label, path in fx.configs.items():
        if label not in ("config deadband -5", "config port FIFO",
                         "config unknown rotator preset"):   # next uses none of these
            add("next", label, ["next", "ISS", "--at", AT, "--config", path])
        if label in ("config lat nan", "config nested arrays", "config mask missing"):
            add("config", label, ["config", "show", "--config", path])
        if label in ("config deadband -5", "config port FIFO", "config unknown rotator preset"):
            add("track", label, ["track", "ISS", "--at", AT, "--plain", "--speed", "max",
                                 "--config", path])
    for label, path in fx.plans.items():
        add("upload", f"--from {label}", ["upload", "--dry-run", "--from", path])

    # -- 5. output files: existing (kept unless --force), folder, missing folder, devices --------
    outputs = [
        ("batch", [*base["batch"], "--out"]),
        ("schedule", [*base["schedule"], "--out"]),
        ("batch", [*base["batch"], "--plot"]),
        ("schedule", [*base["schedule"], "--plot"]),
        ("plan", [*base["plan"], "--steptable"]),
        ("plan", [*base["plan"], "--plot"]),
        ("config", ["config", "init", "--config"]),
    ]
    for group, argv0 in outputs:
        opt = argv0[-1]
        suffix = ".png" if opt == "--plot" else ".txt"
        add(group, f"{opt} existing file", [*argv0, "{protect}" + suffix],
            protect="{protect}" + suffix)
        add(group, f"{opt} a directory", [*argv0, fx.adir])
        add(group, f"{opt} in a missing folder", [*argv0, fx.missing_folder])
        add(group, f"{opt} /dev/full", [*argv0, "/dev/full"])
        add(group, f"{opt} a FIFO", [*argv0, fx.fifo])
        if group == "plan":
            add(group, f"{opt} ''", [*argv0, ""])
    add("config", "config init over TRACKER_CONFIG", ["config", "init"],
        protect="{protect}.toml", env={"TRACKER_CONFIG": "{protect}.toml"})
    add("batch", "--sky-plots is a file", [*base["batch"], "--rotator", "G-5500", "--sky-plots",
                                           "{protect}.txt"], protect="{protect}.txt")
    add("batch", "--sky-plots /dev/full", [*base["batch"], "--rotator", "G-5500", "--sky-plots",
                                           "/dev/full"])
    add("track", "--log existing file (appends)", [*base["track"], "--log", "{protect}.jsonl"],
        protect="{protect}.jsonl", expect=APPEND)
    add("track", "--log a directory", [*base["track"], "--log", fx.adir])
    add("track", "--log in a missing folder", [*base["track"], "--log", fx.missing_folder])
    add("track", "--log /dev/full", [*base["track"], "--log", "/dev/full"])
    add("track", "--log a FIFO", [*base["track"], "--log", fx.fifo])
    add("emulate", "--link over an existing file", ["emulate", "--duration", "1", "--link",
                                                     "{protect}.txt"], protect="{protect}.txt")
    add("emulate", "--link a directory", ["emulate", "--duration", "1", "--link", fx.adir])
    add("emulate", "--link in a missing folder", ["emulate", "--duration", "1", "--link",
                                                   fx.missing_folder])

    # -- 6. garbage from the port ---------------------------------------------------------------
    ports = {mode: f"socket://127.0.0.1:{srv.port}" for mode, srv in fx.ports.items()}
    for mode, url in ports.items():
        for action in (["position"], ["goto", "90", "10"]):
            # GS-232B set commands get no reply: a goto cannot tell a bad controller
            add("rotator", f"controller '{mode}' / {action[0]}",
                ["rotator", "--port", url, "--timeout", "1", *action],
                memory_limit=(mode == "endless"), expect=CLEAN if action[0] == "goto" else ERROR)
        if mode not in ("garbage", "silent", "endless"):
            continue
        add("rotator", f"rotctld '{mode}' / position",
            ["rotator", "--protocol", "rotctld", "--port", url.removeprefix("socket://"),
             "--timeout", "1", "position"], memory_limit=(mode == "endless"))
        add("upload", f"controller '{mode}' / upload",
            # just before the upload time: the controller is spoken to within seconds
            ["upload", "ISS", "--at", "2026-08-23T02:06:58Z", "--port", url, "--detach"],
            memory_limit=(mode == "endless"))
    for label, port in (("refused socket", "socket://127.0.0.1:1"),
                        ("socket port abc", "socket://127.0.0.1:abc"),
                        ("no such device", "/dev/ttyNOSUCH"), ("a directory", fx.adir),
                        ("a FIFO", fx.fifo), ("/dev/zero", "/dev/zero"),
                        ("/dev/null", "/dev/null"), ("a plain file", fx.empty), ("''", ""),
                        ("emu://no-such-protocol", "emu://no-such-protocol"),
                        ("emu az=nan", "emu://gs232b?az=nan"),
                        ("emu az=1e300", "emu://gs232b?az=1e300"),
                        ("emu unknown rotator", "emu://gs232b?rotator=NOPE"),
                        ("emu fault bogus", "emu://gs232b?fault=bogus"),
                        ("emu unknown option", "emu://gs232b?flux=1"),
                        ("emu silent", "emu://gs232b?fault=silent=600@0"),
                        ("emu all bytes dropped", "emu://gs232b?fault=drop=1"),
                        ("emu deaf", "emu://gs232b?fault=deaf=600@0")):
        add("rotator", f"--port {label}", ["rotator", "--port", port, "--timeout", "1",
                                           "position"], memory_limit=(port == "/dev/zero"))
    for label, port in (("emu fault bogus", "emu://gs232b?fault=bogus"),
                        ("emu az=nan", "emu://gs232b?az=nan"),
                        ("no such device", "/dev/ttyNOSUCH"), ("''", "")):
        add("track", f"--port {label}", ["track", "ISS", "--port", port, "--at", AT, "--plain"])
    for label, spec in (("garbled 50%", "garble=0.5"), ("duplicated 50%", "duplicate=0.5")):
        add("rotator", f"emu {label} / position",
            ["rotator", "--port", f"emu://gs232b?fault={spec}", "--timeout", "1", "position"],
            expect=CLEAN)
        add("track", f"emu {label}", ["track", "ISS", "--port", f"emu://gs232b?fault={spec}",
                                      "--at", AT, "--plain"], expect=CLEAN)

    # -- 7. element downloads: bad bodies, bad URLs (127.0.0.1 only) ----------------------------
    for mode in ("garbage", "empty", "html", "nogp", "nested", "nanomm", "badtle", "404", "500",
                 "loop", "away", "slow", "huge", "liar"):
        add("tle", f"tle update: server sends {mode}",
            ["tle", "update", "--force", "--timeout", "3", f"{fx.http.url}/{mode}/x.txt"],
            memory_limit=(mode == "huge"))
    for fmt in ("json", "csv", "xml"):
        add("tle", f"tle update --format {fmt}: garbage",
            ["tle", "update", "--force", "--timeout", "3", "--format", fmt, "--base-url",
             f"{fx.http.url}/garbage/gp.php", "amateur"])
    for label, url in (("refused", "http://127.0.0.1:1/"), ("ftp URL", "ftp://127.0.0.1/x"),
                       ("no host", "http:///x"), ("file URL", "file:///etc/passwd"),
                       ("garbage base URL", "::::"), ("empty base URL", "")):
        add("tle", f"tle update --base-url {label}",
            ["tle", "update", "--force", "--timeout", "3", "--base-url", url, "amateur"])
    for spec in ("no such group!", "", "../../etc", "ftp://127.0.0.1/x", "http://127.0.0.1:1/x",
                 "http://[::1"):
        add("tle", f"tle update {spec!r}", ["tle", "update", "--force", "--timeout", "3", spec])
    return cases


def quick_subset(cases: list[Case], n: int = 60) -> list[Case]:
    """A spread of about ``n`` cases: every k-th, plus the first of each kind of special file."""
    k = max(1, len(cases) // n)
    return cases[::k]


# -- running ---------------------------------------------------------------------------------------


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (2 * GIB, 2 * GIB))


def run_case(case: Case, fx: Fixtures, index: int) -> Result:
    protect = None
    subst = {}
    if case.protect or any("{protect}" in a for a in case.argv) or any(
            "{protect}" in v for v in case.env.values()):
        subst["{protect}"] = str(fx.root / "outs" / f"user-file-{index}")
    argv = [_subst(a, subst) for a in case.argv]
    env = fx.env()
    env.update({k: _subst(v, subst) for k, v in case.env.items()})
    if case.protect:
        protect = Path(_subst(case.protect, subst))
        protect.write_bytes(PROTECTED_BYTES)
    cmd = [sys.executable, "-m", "tracker", *argv]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env, cwd=fx.root,
                            start_new_session=True,
                            preexec_fn=_limit_memory if case.memory_limit else None)
    try:
        out, err = proc.communicate(timeout=TIMEOUT_S)
        rc = proc.returncode
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        out, err = proc.communicate()
        rc = None
    dt = time.perf_counter() - t0
    stdout = out.decode("utf-8", "replace")
    stderr = err.decode("utf-8", "replace")
    kind, note = classify(case, rc, stdout, stderr, protect)
    lines = [s for s in stderr.splitlines() if s.strip()] or stdout.splitlines() or [""]
    first = lines[0]
    if kind == "traceback":
        tail = [s for s in stderr.splitlines() if s.strip()]
        first = f"{first}  ...  {tail[-1] if tail else ''}"
    return Result(case, kind, rc, dt, first[:300], note)


def _subst(text: str, subst: dict[str, str]) -> str:
    for k, v in subst.items():
        text = text.replace(k, v)
    return text


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=3)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


# One check per promise (traceback, hang, exit code, one line, files kept), in that order.
def classify(case: Case, rc: int | None, stdout: str, stderr: str,  # noqa: C901
             protect: Path | None) -> tuple[str, str]:
    """One of "ok", "review" or KINDS, with a note."""
    if rc is None:
        return "hang", f"no exit within {TIMEOUT_S:g} s"
    if "Traceback (most recent call last)" in stderr:
        return "traceback", ""
    if protect is not None:
        now = protect.read_bytes() if protect.is_file() else None
        if case.expect == APPEND:
            if now is None or not now.startswith(PROTECTED_BYTES):
                return "overwrote", "the log's earlier bytes are gone"
        elif now != PROTECTED_BYTES:
            return "overwrote", "the existing file changed"
    err_lines = [s for s in stderr.splitlines() if s.strip()]
    one_error = len(err_lines) == 1 and err_lines[0].startswith("tracker: error: ")
    if case.expect in (CLEAN, APPEND):
        if rc == 0 or (rc == 2 and one_error):
            return "ok", ""
        if rc == 2:
            return _multi(err_lines)
        return "review", f"exit {rc}"
    # ERROR expected
    if rc == 0:
        return "accepted", "exit 0"
    if rc == 1 and case.argv and case.argv[0] == "next" and len(stdout.splitlines()) == 1:
        return "review", "next: exit 1 'no pass' (the bad value was taken as a search)"
    if rc != 2:
        return "exit-code", f"exit {rc}"
    if not one_error:
        return _multi(err_lines)
    return "ok", ""


def _multi(err_lines: list[str]) -> tuple[str, str]:
    errors = [s for s in err_lines if s.startswith("tracker: error: ")]
    if len(errors) == 1 and all(s.startswith(("tracker: warning", "tracker: note"))
                                or s == errors[0]
                                for s in err_lines):
        return "review", f"{len(err_lines)} stderr lines: warning(s) before the error"
    return "multi-line", f"{len(err_lines)} stderr lines"


def command_line(case: Case) -> str:
    env = " ".join(f"{k}={shlex.quote(v)}" for k, v in case.env.items())
    return (env + " " if env else "") + "tracker " + " ".join(shlex.quote(a) for a in case.argv)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="about 60 cases instead of all")
    ap.add_argument("--only", default="", help="cases whose subcommand or command line "
                                               "contains this")
    ap.add_argument("--list", action="store_true", help="print the cases, run nothing")
    ap.add_argument("--verbose", action="store_true", help="one line per case as it runs")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = ap.parse_args(argv)

    root = Path(tempfile.mkdtemp(prefix="tracker-abuse-"))
    fx = Fixtures(root)
    try:
        cases = build_cases(fx)
        if args.only:
            cases = [c for c in cases if args.only in c.group or args.only in command_line(c)]
        if args.quick:
            cases = quick_subset(cases)
        if args.list:
            for c in cases:
                print(f"{c.group:9s} {c.expect:6s} {command_line(c)}")
            print(f"{len(cases)} cases")
            return 0
        fx.prepare()
        print(f"abuse: {len(cases)} cases, one at a time, timeout {TIMEOUT_S:g} s each "
              f"(temp folder {root})", flush=True)
        t_all = time.perf_counter()
        results = []
        for i, case in enumerate(cases):
            r = run_case(case, fx, i)
            results.append(r)
            if args.verbose or r.kind not in ("ok", "review"):
                mark = "ok" if r.kind == "ok" else r.kind.upper()
                print(f"  [{i + 1}/{len(cases)}] {mark:10s} {r.seconds:5.1f}s  "
                      f"{command_line(case)[:150]}", flush=True)
        wall = time.perf_counter() - t_all
        return report(results, wall)
    finally:
        fx.close()
        if args.keep:
            print(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)


def report(results: list[Result], wall: float) -> int:
    counts = Counter(r.kind for r in results)
    failing = [r for r in results if r.kind in KINDS]
    review = [r for r in results if r.kind == "review"]
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    print()
    print(f"cases tried                {len(results):5d}")
    print(f"passed                     {counts['ok']:5d}")
    for kind in KINDS:
        print(f"{KIND_TITLES[kind]:48s} {counts[kind]:5d}")
    print(f"to review                  {counts['review']:5d}")
    print(f"failing cases              {len(failing):5d}")
    cpu = children.ru_utime + children.ru_stime
    print(f"wall {wall:.0f} s; CPU of the tracker runs {cpu:.0f} s")
    by_group = Counter(r.case.group for r in failing)
    if by_group:
        print("failing by subcommand: " + ", ".join(f"{g} {n}" for g, n in by_group.most_common()))
    if failing:
        print("\nFAILING CASES")
        for r in failing:
            note = f", {r.note}" if r.note else ""
            print(f"- [{r.kind}] {r.case.what}  (exit {r.rc}, {r.seconds:.1f} s{note})")
            print(f"    $ {command_line(r.case)}")
            print(f"    > {r.first_line}")
    if review:
        print("\nTO REVIEW (defensible either way; not counted as failures)")
        for r in review:
            print(f"- {r.case.what}  (exit {r.rc}; {r.note})")
            print(f"    $ {command_line(r.case)}")
            print(f"    > {r.first_line}")
    return 1 if failing else 0


if __name__ == "__main__":
    sys.exit(main())
