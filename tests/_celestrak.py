"""A fake CelesTrak GP endpoint on a real http.server at 127.0.0.1 (no mocked network), for
the element-cache tests and station mode's element keeper."""

from __future__ import annotations

import threading
import time
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from _paths import DATA

TLE_DATA = DATA / "tle"
LAST_MODIFIED = "Sat, 22 Aug 2026 16:00:00 GMT"
HTML = b"<!DOCTYPE html><html><head><title>503</title></head><body>busy</body></html>"


class FakeCelestrak:
    """A GP endpoint: ``behaviour[group]`` says what to answer; requests are recorded."""

    def __init__(self):
        self.behaviour: dict[str, str] = {}
        self.requests: list[tuple[str, dict[str, str]]] = []
        self.body = (TLE_DATA / "amateur5.txt").read_bytes()
        self.etag = '"v1"'  # change it with the body: a new version of the group
        fake = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):  # keep pytest output clean
                pass

            def do_GET(self):
                query = urllib.parse.parse_qs(urllib.parse.urlsplit(self.path).query)
                group = query.get("GROUP", ["?"])[0]
                fake.requests.append((group, {k.lower(): v for k, v in self.headers.items()}))
                fake.answer(self, group, fake.behaviour.get(group, "ok"))

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.base_url = f"http://127.0.0.1:{self.server.server_port}/NORAD/elements/gp.php"
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def answer(self, h: BaseHTTPRequestHandler, group: str, how: str) -> None:
        body, status, length = self.body, 200, None
        etag = self.etag
        if how == "ok" and h.headers.get("If-None-Match") == etag:
            h.send_response(304)
            h.send_header("ETag", etag)
            h.end_headers()
            return
        if how == "404":
            body, status = b"not found", 404
        elif how == "slow":
            time.sleep(1.5)
        elif how == "html":
            body = HTML
        elif how == "empty":
            body = b""
        elif how == "nodata":
            body = b"No GP data found"
        elif how == "cut":  # the connection ends early: Content-Length promises more
            length = len(body)
            body = body[: len(body) // 2]
        elif how == "cut-clean":  # a body cut mid-set, with a matching length
            body = body[:-40]
        elif how == "json":
            body = (TLE_DATA / "amateur5.json").read_bytes()
        h.send_response(status)
        h.send_header("Content-Type", "text/plain")
        h.send_header("Content-Length", str(length if length is not None else len(body)))
        h.send_header("Last-Modified", LAST_MODIFIED)
        h.send_header("ETag", etag)
        h.end_headers()
        try:
            h.wfile.write(body)
        except (BrokenPipeError, ConnectionResetError):
            pass
        if how == "cut":
            h.close_connection = True

    def close(self):
        self.server.shutdown()
        self.server.server_close()
