"""``tracker tle update`` against a real HTTP server on 127.0.0.1 that misbehaves: a
shrunken (cut at a set boundary) group, a server that drips bytes, an endless or oversized
body, a redirect loop; and the bad arguments (--timeout, --base-url, non-HTTP URLs, an
unusable cache folder). Each ends with one line and exit 2, and the cached copy is kept."""

from __future__ import annotations

import threading
import time
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import pytest

import tle.store
from tle.store import TleStore
from tracker.cli import main

BUNDLED = Path(tle.store.__file__).parent / "data" / "amateur.txt"


def _sets(text: bytes, n: int) -> bytes:
    """The first ``n`` three-line sets: a body cut cleanly at a set boundary."""
    return b"".join(line + b"\n" for line in text.splitlines()[: 3 * n])


class MisbehavingServer:
    """``how[group]`` picks the answer; "ok" serves ``bodies[group]``."""

    def __init__(self):
        self.how: dict[str, str] = {}
        self.bodies: dict[str, bytes] = {"amateur": BUNDLED.read_bytes()}
        self.stop = threading.Event()
        fake = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.0"

            def log_message(self, *args):
                pass

            def do_GET(self):
                query = urllib.parse.parse_qs(urllib.parse.urlsplit(self.path).query)
                group = query.get("GROUP", ["?"])[0]
                try:
                    fake.answer(self, group, fake.how.get(group, "ok"))
                except OSError:  # the client gave up: expected for the bad cases
                    pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.base_url = f"http://127.0.0.1:{self.server.server_port}/gp.php"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def _drip(self, h, data: bytes) -> None:
        for i in range(len(data)):
            if self.stop.wait(0.2):
                return
            h.wfile.write(data[i:i + 1])
            h.wfile.flush()

    def answer(self, h, group: str, how: str) -> None:
        if how == "drip-headers":  # status line and headers a byte at a time, never done
            self._drip(h, b"HTTP/1.0 200 OK\r\n" + b"X-Padding: " + b"x" * 300)
            return
        if how == "redirect-loop":
            h.send_response(302)
            h.send_header("Location", h.path)
            h.end_headers()
            return
        if how == "huge-length":  # announces 400 MB
            h.send_response(200)
            h.send_header("Content-Length", str(400 * 10**6))
            h.end_headers()
            h.wfile.write(b"1 " * 1000)
            return
        h.send_response(200)
        h.send_header("Content-Type", "text/plain")
        body = self.bodies.get(group, b"")
        if how == "ok":
            h.send_header("Content-Length", str(len(body)))
            h.end_headers()
            h.wfile.write(body)
        elif how == "drip-body":  # headers at once, then one byte every 0.2 s
            h.end_headers()
            self._drip(h, body)
        elif how == "endless":  # no Content-Length, the body never ends
            h.end_headers()
            chunk = body * 4
            while not self.stop.is_set():
                h.wfile.write(chunk)

    def close(self):
        self.stop.set()
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture
def server():
    fake = MisbehavingServer()
    yield fake
    fake.close()


def update(server, *extra: str) -> int:
    return main(["tle", "update", "amateur", "--base-url", server.base_url, "--force", *extra])


def one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("tracker: error: ") and "\n" not in err, err
    assert "Traceback" not in err
    return err


# A group that shrinks: kept unless --force ------------------------------------------------


@pytest.mark.parametrize("keep", [48, 1])
def test_a_shrunken_group_is_refused_without_force(server, cache, capsys, keep):
    full = BUNDLED.read_bytes()
    assert main(["tle", "update", "amateur", "--base-url", server.base_url]) == 0
    assert "96 sets" in capsys.readouterr().out
    server.bodies["amateur"] = _sets(full, keep)
    store = TleStore(cache_dir=cache, base_url=server.base_url, timeout_s=10,
                     min_interval_s=0)
    with pytest.raises(tle.store.TleFetchError, match=rf"holds {keep} element sets where the "
                                                      r"cached amateur has 96"):
        store.update_source(store.resolve("amateur"), force=False)
    assert (cache / "amateur.txt").read_bytes() == full
    meta = (cache / "sources.json").read_text()
    assert '"count": 96' in meta


def test_shrink_from_the_command_line_and_force_accepts(server, cache, capsys, monkeypatch):
    full = BUNDLED.read_bytes()
    assert main(["tle", "update", "amateur", "--base-url", server.base_url]) == 0
    capsys.readouterr()
    server.bodies["amateur"] = _sets(full, 48)
    # Two hours later no --force is needed to fetch, and the shrink is refused.
    assert main(["tle", "update", "amateur", "--base-url", server.base_url,
                 "--at", "2100-01-01T00:00Z"]) == 2
    err = one_line(capsys)
    assert "holds 48 element sets where the cached amateur has 96" in err
    assert "--force" in err
    assert (cache / "amateur.txt").read_bytes() == full
    assert update(server) == 0
    assert "48 sets" in capsys.readouterr().out
    assert (cache / "amateur.txt").read_bytes() == _sets(full, 48)


def test_a_small_loss_is_accepted(server, cache, capsys):
    full = BUNDLED.read_bytes()
    assert main(["tle", "update", "amateur", "--base-url", server.base_url]) == 0
    server.bodies["amateur"] = _sets(full, 90)
    store = TleStore(cache_dir=cache, base_url=server.base_url, timeout_s=10,
                     min_interval_s=0)
    assert store.update_source(store.resolve("amateur")).count == 90


# One deadline for the whole request, a bounded body ----------------------------------------


@pytest.mark.parametrize("how", ["drip-headers", "drip-body"])
def test_a_dripping_server_is_cut_off_at_the_deadline(server, cache, capsys, how):
    # 0.2 s between bytes never trips a per-read timeout of 1 s; the old code took minutes.
    server.how["amateur"] = how
    started = time.monotonic()
    assert update(server, "--timeout", "1") == 2
    elapsed_s = time.monotonic() - started
    assert "no complete answer within 1 s" in one_line(capsys)
    assert elapsed_s < 1 + 5, elapsed_s
    assert not cache.exists() or not (cache / "amateur.txt").exists()


def test_an_endless_body_is_bounded(server, cache, capsys, monkeypatch):
    monkeypatch.setattr(tle.store, "MAX_BODY_BYTES", 2**20)
    server.how["amateur"] = "endless"
    assert update(server, "--timeout", "30") == 2
    assert "larger than the 1 MiB limit" in one_line(capsys)


def test_an_announced_400_mb_body_is_refused_before_reading(server, cache, capsys):
    server.how["amateur"] = "huge-length"
    assert update(server) == 2
    assert "announces 381 MiB, more than the 64 MiB limit" in one_line(capsys)


def test_a_redirect_loop_is_one_line(server, cache, capsys):
    server.how["amateur"] = "redirect-loop"
    assert update(server) == 2
    assert "too many redirects (HTTP 302; a redirect loop?)" in one_line(capsys)


def test_the_cached_copy_survives_a_dripping_server(server, cache, capsys):
    assert main(["tle", "update", "amateur", "--base-url", server.base_url]) == 0
    before = (cache / "amateur.txt").read_bytes()
    server.how["amateur"] = "drip-body"
    assert update(server, "--timeout", "1") == 2
    assert (cache / "amateur.txt").read_bytes() == before


# Bad arguments -----------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["-1", "0", "nan", "inf"])
def test_bad_timeout(cache, capsys, value):
    assert main(["tle", "update", "amateur", "--timeout", value]) == 2
    assert "--timeout" in one_line(capsys)


@pytest.mark.parametrize("argv, expect", [
    (["amateur", "--base-url", "garbage"], "base URL 'garbage' is not an http"),
    (["file:///etc/passwd"], "file:///etc/passwd is not an http:// or https:// URL"),
    (["ftp://example.org/x.txt"], "is not an http:// or https:// URL"),
])
def test_not_an_http_url(cache, capsys, argv, expect):
    assert main(["tle", "update", *argv]) == 2
    err = one_line(capsys)
    assert expect in err and "HTTP None" not in err


def test_cache_folder_that_is_a_file(server, tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("keep\n")
    assert main(["tle", "--cache-dir", str(afile), "update", "amateur", "--base-url",
                 server.base_url]) == 2
    err = one_line(capsys)
    assert "must be a folder you can read and write" in err and "delete" not in err
    assert afile.read_text() == "keep\n"


def test_cache_write_failure_is_one_line(server, tmp_path, capsys, monkeypatch):
    # As root a chmod'ed folder stays writable, so the EACCES of the temporary file is
    # injected; the message must name the folder and not advise deleting anything.
    def refuse(*_a, **_k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tle.store.tempfile, "mkstemp", refuse)
    assert main(["tle", "--cache-dir", str(tmp_path / "c"), "update", "amateur",
                 "--base-url", server.base_url]) == 2
    err = one_line(capsys)
    assert "Permission denied" in err and "must be a folder you can write" in err
    assert "delete" not in err
