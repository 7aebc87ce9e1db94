"""The station's status page: a small local web server over a :class:`StatusBoard`.

:func:`make_app` is a Flask app with the page (``/``, its files under ``/static/``) and the
JSON API, each route exactly one reader of the board:

- ``/api/status``: :meth:`StatusBoard.status`
- ``/api/schedule``: :meth:`StatusBoard.schedule`
- ``/api/passes``: :meth:`StatusBoard.passes`
- ``/api/health``: ``{"ok", "state", "now_utc", "version"}``; HTTP 503 while the station is in
  ``fault`` or ``stopped``, so a plain uptime checker sees it

:class:`StatusServer` serves the app with waitress on a background thread and closes it
cleanly. Flask and waitress are the ``station`` extra. The page is read-only: nothing here
writes to the board. It listens on loopback by default; :func:`is_loopback` tells a caller
when to warn that another address exposes the page to the network.
"""

from __future__ import annotations

import json
import math
import threading
from importlib import resources
from typing import Any

try:
    from flask import Flask, Response, abort, request, send_from_directory
    from waitress import create_server
except ImportError as _e:   # pragma: no cover - exercised in a subprocess by the tests
    raise ImportError(f"the station's status page needs Flask and waitress ({_e.name} is not "
                      f"installed): pip install 'rotator-tracker[station]'") from None

from tracker.errors import ConfigError
from tracker.service.board import StatusBoard

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8073
STATIC_DIR = str(resources.files("tracker.service") / "static")

# Served with every answer: the page loads nothing from elsewhere, and nothing may frame it.
_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data:; "
                               "frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}


def _finite(value: Any) -> Any:
    """``value`` with NaN and infinities as None: JSON has no NaN, and a browser's
    ``JSON.parse`` rejects the whole answer over one (a pass with no error measured)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _json(value: Any, status: int = 200) -> Response:
    body = json.dumps(_finite(value), default=str, allow_nan=False)
    resp = Response(body, status=status, mimetype="application/json")
    resp.headers["Cache-Control"] = "no-store"
    return resp


def make_app(board: StatusBoard) -> Flask:
    """The Flask app of the status page and its JSON API over ``board`` (read-only)."""
    app = Flask(__name__, static_folder=STATIC_DIR, static_url_path="/static")

    @app.get("/")
    def page():
        return send_from_directory(STATIC_DIR, "index.html", max_age=0)

    @app.get("/api/status")
    def api_status():
        return _json(board.status())

    @app.get("/api/schedule")
    def api_schedule():
        return _json(board.schedule())

    @app.get("/api/passes")
    def api_passes():
        return _json(board.passes())

    @app.get("/api/health")
    def api_health():
        st = board.status()
        ok = st["state"] not in ("fault", "stopped")
        return _json({"ok": ok, "state": st["state"], "now_utc": st["now_utc"],
                      "version": board.version}, 200 if ok else 503)

    @app.before_request
    def read_only():
        # Flask answers OPTIONS itself (200, the methods allowed); nothing but GET is served.
        if request.method not in ("GET", "HEAD"):
            abort(405)

    @app.errorhandler(404)
    def not_found(_e):
        if request.path.startswith("/api/"):
            return _json({"error": f"no such resource: {request.path}"}, 404)
        return Response("not found\n", status=404, mimetype="text/plain")

    @app.errorhandler(405)
    def not_allowed(_e):
        return _json({"error": f"{request.method} is not allowed here; the page is "
                               f"read-only"}, 405)

    @app.after_request
    def headers(resp: Response) -> Response:
        resp.headers.update(_HEADERS)
        return resp

    return app


class StatusServer:
    """The status page served by waitress on a background thread.

    ``port`` 0 picks a free port (see :attr:`url` after :meth:`start`). Use as a context
    manager or call :meth:`start` and :meth:`close`. A host or port that cannot be bound is
    a :class:`~tracker.errors.ConfigError`.
    """

    def __init__(self, board: StatusBoard, host: str = DEFAULT_HOST,
                 port: int = DEFAULT_PORT, *, threads: int = 4):
        self.board = board
        self.host = host
        self.port = port
        self.threads = threads
        self._server: Any = None
        self._thread: threading.Thread | None = None

    def start(self) -> StatusServer:
        if self._server is not None:
            return self
        try:
            server = create_server(make_app(self.board), host=self.host, port=self.port,
                                   threads=self.threads, ident="tracker-station")
        except OSError as e:
            raise ConfigError(f"status page: cannot listen on {self.host}:{self.port} "
                              f"({e.strerror or e})") from None
        except ValueError:    # waitress: a host it cannot resolve
            raise ConfigError(f"status page: cannot listen on {self.host}:{self.port} (not "
                              f"an address of this machine)") from None
        self._server = server
        # a name such as "localhost" may bind several sockets (a MultiSocketServer)
        self.port = int(getattr(server, "effective_port", None)
                        or server.effective_listen[0][1])
        self._thread = threading.Thread(target=server.run, name="status-page", daemon=True)
        self._thread.start()
        return self

    @property
    def url(self) -> str:
        """Where to open the page from this machine."""
        host = self.host.strip("[]")
        if host in ("", "0.0.0.0"):
            host = "127.0.0.1"
        elif host == "::":
            host = "::1"
        if ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop listening, drop open connections and end the thread."""
        server, self._server = self._server, None
        if server is None:
            return
        # Closing every socket from inside the server's own loop (a thunk its trigger runs)
        # instead of from this thread: the loop never polls a socket closed under it, and
        # ends once its map is empty, open keep-alive connections included.
        from waitress import wasyncore

        trigger = getattr(server, "trigger", None)
        if trigger is None:
            server.close()      # a MultiSocketServer closes its sockets itself
        else:
            trigger.pull_trigger(lambda: wasyncore.close_all(server._map))
        if self._thread is not None:
            self._thread.join(timeout_s)
        server.task_dispatcher.shutdown()

    def __enter__(self) -> StatusServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
