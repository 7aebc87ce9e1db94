"""The element cache: fetch CelesTrak GP groups (or any URL) politely, validate, keep safe.

Rules: a source is fetched at most every 2 hours unless forced; requests are conditional
(If-Modified-Since / If-None-Match, 304 keeps the copy); a body that is HTML, empty, truncated
or has any set that does not parse is rejected; files are written to a temp file and
``os.replace``d, so a failed download never destroys the cached copy. Metadata (url, last check,
Last-Modified, ETag, count) lives in ``sources.json`` beside the element files.
"""

from __future__ import annotations

import json
import math
import os
import re
import socket
import statistics
import tempfile
import threading
import time
import urllib.parse
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tle.cachedir import META_NAME, default_cache_dir, element_paths
from tle.elements import parse_text, sniff_format
from tle.errors import TleError, TleFetchError, with_advice

if TYPE_CHECKING:
    import urllib.request

DEFAULT_BASE_URL = "https://celestrak.org/NORAD/elements/gp.php"
DEFAULT_GROUPS = ("amateur", "weather", "stations", "visual")
FORMATS = ("tle", "json", "csv", "xml")
MIN_INTERVAL_S = 2 * 3600.0
DEFAULT_TIMEOUT_S = 20.0
# The largest CelesTrak group in the largest format is a few tens of MiB; a bigger body is a
# wrong URL (or a hostile server) and must not be read into memory.
MAX_BODY_BYTES = 64 * 2**20
# A new download with fewer than this share of the cached sets is most likely cut short at a
# set boundary (it still parses); it replaces the cache only when forced.
MIN_KEPT_SHARE = 2 / 3
USER_AGENT = "rotator-tracker (+https://github.com/; tle store)"
_GROUP_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
_SUFFIX = {"tle": ".txt", "json": ".json", "csv": ".csv", "xml": ".xml"}


@dataclass(frozen=True)
class FetchResponse:
    """What a fetch function returns: HTTP status, body bytes, lower-case header names."""

    status: int
    body: bytes
    headers: Mapping[str, str] = field(default_factory=dict)


Fetch = Callable[[str, Mapping[str, str], float], FetchResponse]


class _Deadline:
    """One deadline for a whole request (connect, redirects, headers, body): when it passes,
    every socket the request opened is shut down, which ends any read in progress at once
    (a socket timeout alone only bounds each read, and a server dripping a byte a second
    would never trip it)."""

    def __init__(self, seconds: float):
        self.end_s = time.monotonic() + seconds
        self.expired = False
        self._socks: list[socket.socket] = []
        self._lock = threading.Lock()
        self._timer = threading.Timer(seconds, self._fire)
        self._timer.daemon = True

    def remaining_s(self) -> float:
        return max(0.001, self.end_s - time.monotonic())

    def track(self, sock: socket.socket) -> None:
        with self._lock:
            self._socks.append(sock)
            if not self.expired:
                return
        self._shut(sock)

    def _fire(self) -> None:
        with self._lock:
            self.expired = True
            socks = list(self._socks)
        for sock in socks:
            self._shut(sock)

    @staticmethod
    def _shut(sock: socket.socket) -> None:
        try:
            sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass

    def __enter__(self) -> _Deadline:
        self._timer.start()
        return self

    def __exit__(self, *exc) -> None:
        self._timer.cancel()


def _opener(deadline: _Deadline) -> urllib.request.OpenerDirector:
    """A urllib opener whose connections connect within the time left and register their
    socket with ``deadline``."""
    import http.client
    import urllib.request

    def bounded(base):
        class Connection(base):
            def connect(self):
                self.timeout = deadline.remaining_s()
                super().connect()
                deadline.track(self.sock)
        return Connection

    class HTTP(urllib.request.HTTPHandler):
        def http_open(self, req):
            return self.do_open(bounded(http.client.HTTPConnection), req)

    class HTTPS(urllib.request.HTTPSHandler):
        def https_open(self, req):
            return self.do_open(bounded(http.client.HTTPSConnection), req,
                                context=self._context)

    return urllib.request.build_opener(HTTP, HTTPS)


def _read_body(reply, url: str, max_bytes: int) -> bytes:
    import http.client

    text = (reply.headers.get("Content-Length") or "").strip()
    length = int(text) if text.isdigit() else None
    if length is not None and length > max_bytes:
        raise TleFetchError(f"{url}: the server announces {length / 2**20:.0f} MiB, more than "
                            f"the {max_bytes / 2**20:.0f} MiB limit for element sets (wrong "
                            "URL?); cached copy kept")
    chunks, size = [], 0
    while True:
        chunk = reply.read(min(1 << 16, max_bytes + 1 - size))
        if not chunk:
            if length is not None and size < length:  # read(n) does not raise IncompleteRead
                raise http.client.IncompleteRead(b"".join(chunks), length - size)
            return b"".join(chunks)
        chunks.append(chunk)
        size += len(chunk)
        if size > max_bytes:
            raise TleFetchError(f"{url}: the body is larger than the {max_bytes / 2**20:.0f} "
                                "MiB limit for element sets (wrong URL?); cached copy kept")


def _no_answer(url: str, timeout_s: float) -> TleFetchError:
    return TleFetchError(f"{url}: no complete answer within {timeout_s:g} s (slow server or no "
                         "network?); cached copy kept")


def urllib_fetch(url: str, headers: Mapping[str, str], timeout_s: float,
                 max_bytes: int | None = None) -> FetchResponse:
    """GET ``url`` with urllib within ``timeout_s`` for the whole request and at most
    ``max_bytes`` of body; 304 is a response, other HTTP errors raise TleFetchError."""
    # The network modules (and ssl under them) load here, when a download happens: an
    # offline command that only reads the cache never imports them.
    import urllib.error
    import urllib.request

    max_bytes = MAX_BODY_BYTES if max_bytes is None else max_bytes
    request = urllib.request.Request(url, headers={"User-Agent": USER_AGENT, **headers})
    with _Deadline(timeout_s) as deadline:
        try:
            with _opener(deadline).open(request, timeout=timeout_s) as reply:
                body = _read_body(reply, url, max_bytes)
                if deadline.expired:  # a body without a length just ends when cut off
                    raise _no_answer(url, timeout_s)
                return FetchResponse(reply.status, body,
                                     {k.lower(): v for k, v in reply.headers.items()})
        except TleFetchError:
            raise
        except urllib.error.HTTPError as e:
            if e.code == 304:
                return FetchResponse(304, b"", {k.lower(): v for k, v in e.headers.items()})
            if 300 <= e.code < 400:
                raise TleFetchError(f"{url}: too many redirects (HTTP {e.code}; a redirect "
                                    "loop?); cached copy kept") from None
            reason = " ".join(str(e.reason).split())
            raise TleFetchError(f"{url}: HTTP {e.code} {reason}; cached copy kept") from None
        except Exception as e:
            if deadline.expired:
                raise _no_answer(url, timeout_s) from None
            raise _fetch_error(url, timeout_s, e) from None


def _fetch_error(url: str, timeout_s: float, e: Exception) -> TleFetchError:
    import http.client
    import urllib.error

    if isinstance(e, http.client.IncompleteRead):
        return TleFetchError(f"{url}: truncated download ({len(e.partial)} bytes arrived, "
                             f"{e.expected} missing); cached copy kept")
    reason = e.reason if isinstance(e, urllib.error.URLError) else e
    if isinstance(reason, TimeoutError):
        return _no_answer(url, timeout_s)
    if isinstance(e, urllib.error.URLError):
        return TleFetchError(f"{url}: cannot connect ({reason}); no network? cached copy kept")
    text = " ".join(str(e).split()) or type(e).__name__
    return TleFetchError(f"{url}: download failed ({text}); no network? cached copy kept")


@dataclass(frozen=True)
class Source:
    """A named download: a CelesTrak group ("amateur") or any URL."""

    name: str
    url: str


@dataclass(frozen=True)
class UpdateResult:
    """The outcome for one source: "updated", "not modified", "fresh" (skipped) or "failed"."""

    source: Source
    status: str
    count: int = 0
    message: str = ""


@dataclass(frozen=True)
class SourceInfo:
    """One cached source as ``list()`` reports it; ages in seconds/days from the clock."""

    name: str
    url: str
    path: Path
    count: int
    checked_age_s: float | None
    median_epoch_age_days: float | None


def _name_from_url(url: str) -> str:
    parts = urllib.parse.urlsplit(url)
    query = urllib.parse.parse_qs(parts.query)
    for key in ("GROUP", "NAME", "CATNR", "INTDES", "SPECIAL"):
        if query.get(key):
            return re.sub(r"[^A-Za-z0-9_.-]+", "_", query[key][0]).strip("_") or "download"
    stem = Path(urllib.parse.unquote(parts.path)).stem
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", stem).strip("_") or "download"


def resolve_source(spec: str, base_url: str = DEFAULT_BASE_URL, fmt: str = "tle") -> Source:
    """"amateur" → the CelesTrak GP URL for that group; a URL is kept as given."""
    if "://" in spec:
        _check_url(spec, spec)
        return Source(_name_from_url(spec), spec)
    if not _GROUP_RE.match(spec):
        raise TleError(f"{spec!r} is neither a CelesTrak group name (like amateur, weather) "
                       "nor a URL")
    if fmt not in FORMATS:
        raise TleError(f"unknown element format {fmt!r}; choose one of {', '.join(FORMATS)}")
    _check_url(base_url, f"base URL {base_url!r}")
    query = urllib.parse.urlencode({"GROUP": spec, "FORMAT": fmt})
    return Source(spec, f"{base_url}?{query}")


def _check_url(url: str, what: str) -> None:
    """Only http(s) URLs with a host are downloaded (a local file is read with Catalog.load)."""
    try:
        parts = urllib.parse.urlsplit(url)
        parts.port   # noqa: B018  # parsed on access: a bad port or IPv6 literal raises here
    except ValueError as e:
        raise TleError(f"{what} is not a valid URL ({e}); give a CelesTrak-style http:// "
                       "or https:// URL") from None
    if parts.scheme.lower() not in ("http", "https") or not parts.netloc:
        raise with_advice(TleError, f"{what} is not an http:// or https:// URL with a host; "
                          "give a CelesTrak-style URL", " (a local file is read with Catalog.load)")


def _atomic_write(path: Path, data: bytes) -> None:
    # Temp file in the same directory, then os.replace: readers see the old or the new file,
    # never half of one, and a crash leaves the old copy in place.
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".part")
    except OSError as e:
        raise _cache_write_error(path, e) from None
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(e, OSError):
            raise _cache_write_error(path, e) from None
        raise


def _count(entry: Mapping[str, Any]) -> int:
    """The cached set count of a metadata entry (0 when missing or damaged)."""
    try:
        return int(entry.get("count", 0))
    except (TypeError, ValueError):
        return 0


def _cache_write_error(path: Path, e: OSError) -> TleError:
    return with_advice(TleError, f"cannot write {path} ({e.strerror or e}); the element cache "
                       f"{path.parent} must be a folder you can write",
                       " (see cache_dir or $TRACKER_CACHE_DIR); cached copy kept")


class _RealTime:
    """The default clock: real time. ``tle`` sits below ``tracker`` and cannot use
    ``tracker.clock.SystemClock``; the store only needs ``timestamp()``, and callers with a
    simulated timeline pass their own clock."""

    @staticmethod
    def timestamp() -> float:
        return time.time()


class TleStore:
    """A directory of downloaded element files plus their metadata."""

    def __init__(self, cache_dir: str | Path | None = None, fetch: Fetch | None = None,
                 clock=None, base_url: str | None = None,
                 timeout_s: float = DEFAULT_TIMEOUT_S, min_interval_s: float = MIN_INTERVAL_S):
        self.cache_dir = Path(cache_dir) if cache_dir is not None else default_cache_dir()
        self.fetch = fetch or urllib_fetch
        self.clock = clock if clock is not None else _RealTime()
        self.base_url = (base_url or os.environ.get("TRACKER_CELESTRAK_URL")
                         or DEFAULT_BASE_URL)
        if not (isinstance(timeout_s, (int, float)) and math.isfinite(timeout_s)
                and timeout_s > 0):
            raise TleError(f"timeout {timeout_s!r} is invalid; give a number of seconds > 0")
        self.timeout_s = timeout_s
        self.min_interval_s = min_interval_s

    # -- metadata ------------------------------------------------------------------------
    @property
    def meta_path(self) -> Path:
        return self.cache_dir / META_NAME

    def _read_meta(self) -> dict[str, dict[str, Any]]:
        try:
            data = json.loads(self.meta_path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return {}
        except OSError as e:  # the folder itself is the problem, not the file's content
            raise with_advice(TleError, f"cannot read {self.meta_path} ({e.strerror}); the "
                              f"element cache {self.cache_dir} must be a folder you can read "
                              "and write", " (see cache_dir or $TRACKER_CACHE_DIR)") from None
        except (ValueError, RecursionError) as e:
            raise with_advice(TleError, f"{self.meta_path}: unreadable cache metadata ({e})",
                              "; delete it and call update(force=True)") from None
        return data if isinstance(data, dict) else {}

    def _write_meta(self, meta: Mapping[str, Any]) -> None:
        text = json.dumps(meta, indent=2, sort_keys=True) + "\n"
        _atomic_write(self.meta_path, text.encode("utf-8"))

    # -- queries -------------------------------------------------------------------------
    def paths(self) -> list[Path]:
        """Cached element files (the downloads plus any element file dropped in the dir)."""
        return element_paths(self.cache_dir)

    def list(self) -> list[SourceInfo]:
        """Each cached source with its count, time since the last check, and element age."""
        meta = self._read_meta()
        now_s = self.clock.timestamp()
        infos = []
        known = set()
        for name, entry in sorted(meta.items()):
            path = self.cache_dir / entry.get("file", "")
            if not entry.get("file") or not path.is_file():
                continue
            known.add(path)
            checked = entry.get("last_check")
            median = entry.get("median_epoch")
            infos.append(SourceInfo(
                name, entry.get("url", ""), path, int(entry.get("count", 0)),
                None if checked is None else now_s - checked,
                None if median is None else (now_s - median) / 86400.0))
        for path in self.paths():
            if path not in known:
                infos.append(SourceInfo(path.stem, "", path, -1, None, None))
        return infos

    # -- updating ------------------------------------------------------------------------
    def resolve(self, spec: str, fmt: str = "tle") -> Source:
        return resolve_source(spec, self.base_url, fmt)

    def update(self, sources: Iterable[str | Source] = DEFAULT_GROUPS, force: bool = False,
               fmt: str = "tle",
               on_result: Callable[[UpdateResult], None] | None = None) -> list[UpdateResult]:
        """Update every source; report each through ``on_result``.

        Failures do not stop the other sources; afterwards one TleFetchError names them all
        (the cached copies are kept).
        """
        results = []
        first: TleError | None = None
        for spec in sources:
            source = spec if isinstance(spec, Source) else self.resolve(spec, fmt)
            try:
                result = self.update_source(source, force=force)
            except TleError as e:
                first = first or e
                result = UpdateResult(source, "failed", 0, str(e))
            results.append(result)
            if on_result is not None:
                on_result(result)
        failed = [r for r in results if r.status == "failed"]
        if failed:
            assert first is not None
            names = ", ".join(r.source.name for r in failed)
            summary = ("" if len(failed) == 1 else f"{len(failed)} of {len(results)} sources "
                       f"failed ({names}), cached copies kept; first: ")
            # the first failure's advice stays advice, for a front end to reword
            if first.advice:
                raise with_advice(TleFetchError, summary + first.problem, first.advice)
            raise TleFetchError(summary + str(first))
        return results

    def update_source(self, source: Source, force: bool = False) -> UpdateResult:
        """Fetch one source if due; raise TleFetchError when it fails (copy kept)."""
        meta = self._read_meta()
        entry = dict(meta.get(source.name, {}))
        if entry.get("url") not in (None, source.url):
            entry = {}  # same name, different URL: the old validators do not apply
        old_path = self.cache_dir / entry["file"] if entry.get("file") else None
        have_copy = old_path is not None and old_path.is_file()
        now_s = self.clock.timestamp()
        last_check = entry.get("last_check")
        if (have_copy and not force and last_check is not None
                and now_s - last_check < self.min_interval_s):
            wait_min = (self.min_interval_s - (now_s - last_check)) / 60.0
            return UpdateResult(source, "fresh", int(entry.get("count", 0)),
                                f"checked {(now_s - last_check) / 60.0:.0f} min ago; next "
                                f"check allowed in {wait_min:.0f} min (--force to override)")
        headers = {}
        if have_copy:
            if entry.get("etag"):
                headers["If-None-Match"] = entry["etag"]
            if entry.get("last_modified"):
                headers["If-Modified-Since"] = entry["last_modified"]
        response = self.fetch(source.url, headers, self.timeout_s)
        if response.status == 304 and have_copy:
            entry["last_check"] = now_s
            self._save_entry(source.name, entry)
            return UpdateResult(source, "not modified", int(entry.get("count", 0)),
                                "server copy unchanged; cached copy kept")
        if response.status != 200:
            raise TleFetchError(f"{source.url}: HTTP {response.status}; cached copy kept")
        sets, kind = self._validate(source, response.body)
        self._check_shrink(source, len(sets), _count(entry) if have_copy else 0, force)
        new_path = self.cache_dir / f"{source.name}{_SUFFIX[kind]}"
        _atomic_write(new_path, response.body)
        if old_path is not None and old_path != new_path and old_path.is_file():
            old_path.unlink(missing_ok=True)
        entry.update(
            url=source.url, file=new_path.name, last_check=now_s, count=len(sets),
            last_modified=response.headers.get("last-modified"),
            etag=response.headers.get("etag"),
            median_epoch=statistics.median(es.epoch.timestamp() for es in sets))
        self._save_entry(source.name, entry)
        return UpdateResult(source, "updated", len(sets), f"{len(sets)} element sets")

    @staticmethod
    def _check_shrink(source: Source, new_count: int, old_count: int, force: bool) -> None:
        # A body cut at a set boundary (with a matching Content-Length) parses fine; only the
        # count against the cached copy gives it away.
        if force or old_count <= 0 or new_count >= MIN_KEPT_SHARE * old_count:
            return
        raise with_advice(TleFetchError, f"download from {source.url} holds {new_count} element "
                          f"sets where the cached {source.name} has {old_count}; a group "
                          f"shrinking that much is most likely a cut-short download, so it "
                          f"was rejected and the cached copy kept",
                          " (use force=True to accept it)")

    def _save_entry(self, name: str, entry: Mapping[str, Any]) -> None:
        meta = self._read_meta()
        meta[name] = dict(entry)
        self._write_meta(meta)

    def _validate(self, source: Source, body: bytes):
        where = f"download from {source.url}"
        try:
            text = body.decode("utf-8-sig")
        except UnicodeDecodeError:
            raise TleFetchError(f"{where} is not text; rejected, cached copy kept") from None
        if not text.strip():
            raise TleFetchError(f"{where} is empty; rejected, cached copy kept")
        kind = sniff_format(text)
        if kind == "html":
            raise TleFetchError(f"{where} is an HTML page, not element sets (wrong URL or an "
                                "error page); rejected, cached copy kept")
        first_line = text.strip().splitlines()[0]
        if len(text.strip().splitlines()) == 1 and kind == "tle":
            # CelesTrak answers unknown groups with one line of text ("No GP data found").
            raise TleFetchError(f"{where}: the server says {first_line[:120]!r}; rejected, "
                                "cached copy kept")
        try:
            sets = parse_text(text, source=f"{source.name} (downloaded)")
        except TleError as e:
            raise TleFetchError(f"{where} does not parse (truncated or damaged?): {e}; "
                                "rejected, cached copy kept") from None
        if not sets:
            raise TleFetchError(f"{where} holds no element sets; rejected, cached copy kept")
        return sets, kind
