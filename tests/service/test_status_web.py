"""``tracker.service.web``: the status page's JSON API (Flask's test client) and its server
on a real socket; the page's files are the package's, so an installed copy serves them too."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import urllib.error
import urllib.request

import pytest
from _paths import REPO

from tracker.clock import ManualClock, utc
from tracker.errors import ConfigError
from tracker.service.board import StatusBoard
from tracker.service.web import STATIC_DIR, StatusServer, make_app
from tracker.transport import is_loopback

PASS = {"key": "ISS@2026-08-22T12:00:00Z", "target": "ISS (ZARYA)",
        "aos_utc": "2026-08-22T12:00:00Z", "los_utc": "2026-08-22T12:10:00Z",
        "max_el_deg": 45.0, "priority": 1, "mode": "normal", "state": "planned", "reason": ""}


def board() -> StatusBoard:
    b = StatusBoard(ManualClock(utc(2026, 8, 22, 11, 50)), station={"name": "Delft"},
                    rotator={"name": "G-5500"}, simulated=True)
    b.set_schedule([PASS])
    b.set_antenna(123.456, 10.0)
    b.set_target("ISS (ZARYA)", 200.0, 5.0, 1.25)
    b.add_pass({"key": "k", "target": "ISS (ZARYA)", "measured_max_error_deg": float("nan"),
                "predicted_max_error_deg": 1.5})
    return b


@pytest.fixture
def client():
    b = board()
    return b, make_app(b).test_client()


def test_json_routes_are_the_boards_readers(client):
    b, c = client
    for path, reader in (("/api/status", b.status), ("/api/schedule", b.schedule)):
        r = c.get(path)
        assert r.status_code == 200 and r.mimetype == "application/json"
        assert r.headers["Cache-Control"] == "no-store"
        assert r.get_json() == reader()
    st = c.get("/api/status").get_json()
    assert st["simulated"] is True and st["antenna"]["az_deg"] == 123.46
    assert st["next_pass"]["key"] == PASS["key"]
    assert set(st) >= {"station", "rotator", "state", "detail", "target", "current_pass",
                       "control_port", "elements", "faults", "counts", "now_utc"}


def test_a_nan_in_a_record_is_null_not_invalid_json(client):
    _b, c = client
    r = c.get("/api/passes")
    rec = json.loads(r.get_data(as_text=True))[0]   # strict parse: NaN would not parse in JS
    assert "NaN" not in r.get_data(as_text=True)
    assert rec["measured_max_error_deg"] is None and rec["predicted_max_error_deg"] == 1.5


def test_health_is_503_while_the_station_is_in_fault(client):
    b, c = client
    r = c.get("/api/health")
    assert r.status_code == 200 and r.get_json()["ok"] is True
    b.set_state("fault", "stall")
    r = c.get("/api/health")
    assert r.status_code == 503 and r.get_json() == {
        "ok": False, "state": "fault", "now_utc": "2026-08-22T11:50:00Z", "version": b.version}


def test_unknown_routes_and_methods(client):
    _b, c = client
    r = c.get("/api/nothing")
    assert r.status_code == 404 and r.mimetype == "application/json"
    assert "no such resource" in r.get_json()["error"]
    assert c.get("/nothing").status_code == 404
    r = c.post("/api/status")
    assert r.status_code == 405 and "read-only" in r.get_json()["error"]
    r = c.options("/api/status")
    assert r.status_code == 405 and "OPTIONS is not allowed" in r.get_json()["error"]


def test_page_and_its_files_load_nothing_from_elsewhere(client):
    _b, c = client
    r = c.get("/")
    html = r.get_data(as_text=True)
    assert r.status_code == 200 and r.mimetype == "text/html"
    assert "default-src 'self'" in r.headers["Content-Security-Policy"]
    assert 'id="sky"' in html and 'id="sim-banner"' in html
    for name in ("app.js", "app.css"):
        f = c.get(f"/static/{name}")
        assert f.status_code == 200 and len(f.get_data()) > 1000
        f.close()
    for text in (html, c.get("/static/app.js").get_data(as_text=True),
                 c.get("/static/app.css").get_data(as_text=True)):
        assert "http://" not in text and "https://" not in text and "//cdn" not in text


def test_the_page_is_package_data():
    assert os.path.isfile(os.path.join(STATIC_DIR, "index.html"))
    toml = (REPO / "pyproject.toml").read_text()
    assert '"tracker.service" = ["static/*"]' in toml


@pytest.mark.parametrize("host,loop", [
    ("127.0.0.1", True), ("127.3.4.5", True), ("::1", True), ("[::1]", True),
    ("localhost", True), ("LOCALHOST", True), ("0.0.0.0", False), ("", False), ("::", False),
    ("192.168.1.10", False), ("station.example.org", False)])
def test_is_loopback(host, loop):
    assert is_loopback(host) is loop


def _get(url: str):
    with urllib.request.urlopen(url, timeout=10) as r:
        return r.status, r.headers.get_content_type(), r.read()


def test_server_on_a_real_socket_serves_and_closes():
    b = board()
    srv = StatusServer(b, port=0).start()
    try:
        assert srv.port > 0 and srv.url == f"http://127.0.0.1:{srv.port}/"
        status, ctype, body = _get(srv.url + "api/status")
        assert (status, ctype) == (200, "application/json")
        assert json.loads(body)["antenna"]["az_deg"] == 123.46
        b.set_antenna(42.0, 1.0)
        assert json.loads(_get(srv.url + "api/status")[2])["antenna"]["az_deg"] == 42.0
        status, ctype, body = _get(srv.url)
        assert (status, ctype) == (200, "text/html") and b'id="sky"' in body
        with pytest.raises(urllib.error.HTTPError) as e:
            _get(srv.url + "api/none")
        assert e.value.code == 404
        # a second server on the same port is refused with the reason
        with pytest.raises(ConfigError, match=f"cannot listen on 127.0.0.1:{srv.port}"):
            StatusServer(b, port=srv.port).start()
        with pytest.raises(ConfigError, match=r"cannot listen on garbage!!:0 \(not an address"):
            StatusServer(b, host="garbage!!", port=0).start()
    finally:
        srv.close()
    assert srv._thread is not None and not srv._thread.is_alive()
    with pytest.raises(urllib.error.URLError):
        _get(srv.url + "api/status")


def test_without_flask_the_import_says_what_to_install():
    code = ("import sys; sys.modules['flask'] = None\n"
            "try:\n    import tracker.service.web\n"
            "except ImportError as e:\n    print(e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=REPO, timeout=60, env={**os.environ, "PYTHONPATH": str(REPO)})
    lines = out.stdout.strip().splitlines()
    assert len(lines) == 1 and "pip install 'rotator-tracker[station]'" in lines[0], out
