"""Serve an emulated controller on a real pseudo-terminal or a real TCP socket.

``serve_pty(controller)`` returns a server whose ``url`` is ``/dev/pts/N``: any program opens
it like a serial port (rotctl, pyserial, minicom). ``serve_tcp(controller)`` listens on
127.0.0.1 and its ``url`` is ``socket://127.0.0.1:N`` for pyserial. Both run one background
thread with a selector; ``close()`` stops it and closes every descriptor (``closed`` tells
whether that happened, for leak checks). Writes are non-blocking with an output queue, so a
client that stops reading never wedges the server.
"""

from __future__ import annotations

import os
import re
import secrets
import selectors
import socket
import threading
import tty

from tracker.emulator.gs232_controller import Gs232Controller, Session
from tracker.errors import ConfigError

POLL_S = 0.02
MAX_QUEUED_OUTPUT = 1 << 20


class _Conn:
    def __init__(self, fd_or_sock, session: Session, is_socket: bool):
        self.obj = fd_or_sock
        self.session = session
        self.is_socket = is_socket
        self.out = bytearray()

    def fileno(self) -> int:
        return self.obj.fileno() if self.is_socket else self.obj

    def read(self) -> bytes:
        return self.obj.recv(65536) if self.is_socket else os.read(self.obj, 65536)

    def write(self, data: bytes) -> int:
        return self.obj.send(data) if self.is_socket else os.write(self.obj, data)

    def close(self) -> None:
        if self.is_socket:
            self.obj.close()
        else:
            os.close(self.obj)


class _Server:
    """Selector loop shared by the pty and TCP servers."""

    kind = "server"

    def __init__(self, controller: Gs232Controller):
        self.controller = controller
        self._sel = selectors.DefaultSelector()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._sel.register(self._wake_r, selectors.EVENT_READ, None)
        self._conns: list[_Conn] = []
        self._stop = threading.Event()
        self._pending: list = []          # callables run in the loop thread
        self._lock = threading.Lock()
        self._fds: list[int] = []         # every descriptor we own, for the leak check
        self.thread = threading.Thread(target=self._run, name=f"emulator-{self.kind}",
                                       daemon=True)
        self.closed = False
        self.url = ""
        self.errors: list[str] = []       # responder exceptions survived (should stay empty)

    def _start(self) -> None:
        self.thread.start()

    def _call_in_loop(self, fn) -> None:
        with self._lock:
            self._pending.append(fn)
        self._wake()

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"x")
        except OSError:
            pass

    def _add_conn(self, conn: _Conn) -> None:
        self._conns.append(conn)
        self._sel.register(conn.fileno(), selectors.EVENT_READ, conn)

    def _drop_conn(self, conn: _Conn) -> None:
        if conn in self._conns:
            self._conns.remove(conn)
            self._sel.unregister(conn.fileno())
            conn.close()
            self._forget(conn)

    def _forget(self, conn: _Conn) -> None:
        # Replies held back for a client that is gone must not reach the next one (session
        # ids are reused) nor pile up over a long run of reconnects.
        inj = getattr(self.controller.faults, "injector", None)
        if inj is not None:
            inj.forget(conn.session)

    def _on_accept(self) -> None:  # TCP only
        raise NotImplementedError

    def _on_eof(self, conn: _Conn) -> None:
        self._drop_conn(conn)

    def _run(self) -> None:
        while not self._stop.is_set():
            for key, events in self._sel.select(self._poll_s()):
                if key.data is None:
                    try:
                        self._wake_r.recv(4096)
                    except BlockingIOError:
                        pass
                    continue
                if key.data == "listen":
                    self._on_accept()
                    continue
                conn: _Conn = key.data
                if conn in self._conns and events & selectors.EVENT_READ:
                    self._read(conn)
            with self._lock:
                pending, self._pending = self._pending, []
            for fn in pending:
                fn()
            injector = getattr(self.controller.faults, "injector", None)
            if injector is not None:      # timed faults fire even with no client attached
                injector.tick(self)
            for conn in list(self._conns):
                conn.out += self._poll(conn)
                self._flush_out(conn)
        for conn in list(self._conns):
            self._drop_conn(conn)

    def _read(self, conn: _Conn) -> None:
        """Feed what ``conn`` has to the controller; drop it at EOF or on a responder bug."""
        try:
            data = conn.read()
        except BlockingIOError:
            data = None
        except OSError:
            data = b""
        if data == b"":
            self._on_eof(conn)
            return
        if data:
            try:
                conn.out += self._feed(conn, data)
            except Exception as e:
                # A bug in a responder must not kill the emulator: record it,
                # drop that connection, keep serving (leak/fuzz tests check it).
                self.errors.append(f"{type(e).__name__}: {e}")
                self._on_eof(conn)

    def _poll_s(self) -> float:
        """Select timeout: POLL_S, shorter when a delayed reply is due sooner (real s)."""
        inj = getattr(self.controller.faults, "injector", None)
        due = inj.next_release_in_s() if inj is not None else None
        if due is None:
            return POLL_S
        speed = getattr(self.controller.clock, "speed", 1.0)
        return min(POLL_S, max(0.0005, due / speed)) if speed != float("inf") else 0.0005

    def _feed(self, conn: _Conn, data: bytes) -> bytes:
        return feed_session(self.controller, conn.session, data)

    def _poll(self, conn: _Conn) -> bytes:
        return poll_session(self.controller, conn.session)

    def _flush_out(self, conn: _Conn) -> None:
        if not conn.out:
            return
        try:
            n = conn.write(bytes(conn.out[:65536]))
            del conn.out[:n]
        except BlockingIOError:
            pass
        except OSError:
            self._on_eof(conn)
            return
        if len(conn.out) > MAX_QUEUED_OUTPUT:   # client stopped reading: behave like an
            conn.out.clear()                     # overrun UART rather than grow forever

    def close(self) -> None:
        """Stop the thread and close every descriptor. Idempotent."""
        if self.closed:
            return
        self._stop.set()
        self._wake()
        if self.thread.is_alive():
            self.thread.join(timeout=5.0)
        self._sel.close()
        self._wake_r.close()
        self._wake_w.close()
        self._close_own()
        self.closed = True

    def _close_own(self) -> None:
        pass

    def _in_loop(self, fn) -> None:
        """Run ``fn`` now if called from the server thread, else queue it for the loop."""
        if threading.current_thread() is self.thread:
            fn()
        else:
            self._call_in_loop(fn)

    def fault_disconnect(self) -> None:
        """Fault: the port goes away (overridden per transport)."""

    def fault_reconnect(self) -> None:
        """Fault: the port comes back (overridden per transport)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __str__(self) -> str:
        return self.url

    @property
    def connections(self) -> int:
        return len(self._conns)


class PtyServer(_Server):
    """The controller on the master side of a pseudo-terminal; ``url`` is the slave path."""

    kind = "pty"

    def __init__(self, controller: Gs232Controller, link: str | None = None):
        super().__init__(controller)
        # ``link``: a stable symlink to the current /dev/pts/N, so a "reopened" device (fault
        # disconnect) is found again at the same path, like /dev/ttyUSB0 after a replug.
        self.link = link
        if link:
            check_link_path(link)
        self._open_pty()
        self.url = link if link else os.ttyname(self._slave)
        self._start()

    def _open_pty(self) -> None:
        master, slave = os.openpty()
        # Raw slave: no echo, no CR/LF translation; we hold the slave open so the master does
        # not see EIO between clients (like a UART that is always there).
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self._fds = [master, slave]
        self.device = os.ttyname(slave)
        if self.link:
            try:
                place_link(self.link, self.device)
            except ConfigError:
                _close_fd(master)
                _close_fd(slave)
                self._fds = []
                raise
        self._conn = _Conn(master, self.controller.open_session(), is_socket=False)
        self._add_conn(self._conn)

    def _on_eof(self, conn: _Conn) -> None:
        # On a pty a read error means no client right now; keep serving.
        pass

    def _drop_conn(self, conn: _Conn) -> None:
        if conn in self._conns:
            self._conns.remove(conn)
            self._sel.unregister(conn.fileno())
            self._forget(conn)
            # the master is closed in _close_own (or by hangup)

    def hangup(self) -> None:
        """Fault: the device disappears (USB unplug); clients get an I/O error."""
        self._call_in_loop(self._vanish)

    def _vanish(self) -> None:
        self._drop_conn(self._conn)
        fds, self._fds = self._fds, []
        for fd in fds:
            _close_fd(fd)
        # The link goes too, like /dev/ttyUSB0 on unplug: left dangling it would point at a
        # /dev/pts/N number the kernel hands to the next pty opened by any process, and a
        # client retrying the link would write into that stranger's session.
        self._remove_own_link()

    def _remove_own_link(self) -> None:
        # Only the link to this server's pty: whatever else is there now is not ours.
        if self.link and os.path.islink(self.link) and os.readlink(self.link) == self.device:
            try:
                os.unlink(self.link)
            except OSError:
                pass

    def _close_own(self) -> None:
        for fd in self._fds:
            _close_fd(fd)
        self._remove_own_link()

    def fault_disconnect(self) -> None:
        """Fault: the device vanishes (as :meth:`hangup`); :meth:`fault_reconnect` brings a
        new pty back at ``link``."""
        self._in_loop(self._vanish)

    def fault_reconnect(self) -> None:
        def do() -> None:
            if not self._fds:
                try:
                    self._open_pty()
                except ConfigError:
                    # Something else took the link path while the device was away: leave
                    # it alone; the device stays gone (clients see no port).
                    pass
        self._in_loop(do)


class TcpServer(_Server):
    """The controller on a TCP port; every client gets its own session on the same box."""

    kind = "tcp"

    def __init__(self, controller: Gs232Controller, port: int = 0, bind: str = "127.0.0.1"):
        super().__init__(controller)
        self._listen: socket.socket | None = None
        self.bind = bind
        self._listen_on(bind, port)
        host, self.port = self._listen.getsockname()[:2]
        self.url = f"socket://{host}:{self.port}"
        self._start()

    def _on_accept(self) -> None:
        try:
            sock, _addr = self._listen.accept()
        except BlockingIOError:
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._add_conn(_Conn(sock, self.controller.open_session(), is_socket=True))

    def _listen_on(self, bind: str, port: int) -> None:
        self._listen = socket.create_server((bind, port))
        self._listen.setblocking(False)
        self._sel.register(self._listen, selectors.EVENT_READ, "listen")

    def fault_disconnect(self) -> None:
        """Fault: every client is cut off and the port refuses connections until
        :meth:`fault_reconnect` listens on the same port again."""
        def do() -> None:
            for c in list(self._conns):
                self._drop_conn(c)
            if self._listen is not None:
                self._sel.unregister(self._listen)
                self._listen.close()
                self._listen = None
        self._in_loop(do)

    def fault_reconnect(self) -> None:
        def do() -> None:
            if self._listen is None:
                self._listen_on(self.bind, self.port)
        self._in_loop(do)

    def drop_connections(self) -> None:
        """Fault: close every client connection (the listener stays, clients may reconnect)."""
        self._call_in_loop(lambda: [self._drop_conn(c) for c in list(self._conns)])

    def _close_own(self) -> None:
        if self._listen is not None:
            self._listen.close()


# What a link made by this emulator points at: a pseudo-terminal slave (Linux, macOS).
_PTY_DEVICE = re.compile(r"^/dev/(pts/\d+|ttys\d+)$")


def check_link_path(link: str) -> None:
    """``--link PATH`` may be a new name or a symlink to a pty (one this emulator made, maybe
    left by a run that was killed); anything else the user has there is refused."""
    if os.path.islink(link):
        target = os.readlink(link)
        if _PTY_DEVICE.match(target):
            return
        raise ConfigError(f"link {link} is a symlink to {target}, not a pty link made by "
                          "tracker emulate; not replacing it (choose another path)")
    if os.path.lexists(link):
        kind = "a directory" if os.path.isdir(link) else "an existing file"
        raise ConfigError(f"link {link} is {kind}; not replacing it (give a new path for "
                          "the link)")
    folder = os.path.dirname(link) or "."
    if not os.path.isdir(folder):
        what = "is not a folder" if os.path.exists(folder) else "does not exist"
        raise ConfigError(f"link {link}: folder {folder} {what}; create it or choose "
                          "another path")


def place_link(link: str, device: str) -> None:
    """Point ``link`` at ``device`` atomically, through a uniquely named temporary link in the
    same folder (so no user file is ever unlinked or clobbered)."""
    check_link_path(link)
    folder, name = os.path.split(link)
    for _ in range(100):
        tmp = os.path.join(folder, f".{name}.{secrets.token_hex(6)}.tmp")
        try:
            os.symlink(device, tmp)
            break
        except FileExistsError:
            continue
        except OSError as e:
            raise ConfigError(f"link {link}: cannot create a link in {folder or '.'} "
                              f"({e.strerror}); choose a writable folder") from None
    else:
        raise ConfigError(f"link {link}: no free temporary name in {folder or '.'}")
    try:
        os.replace(tmp, link)
    except OSError as e:
        os.unlink(tmp)
        raise ConfigError(f"link {link}: cannot place the link ({e.strerror})") from None

def feed_session(controller, session, data: bytes) -> bytes:
    """Bytes from a client into ``session`` -> the reply bytes, faults applied once."""
    inj = getattr(controller.faults, "injector", None)
    if inj is None or getattr(session, "applies_faults", False):
        return session.feed(data)
    # Sessions that do not run the injector themselves get it here, on the wire.
    data = inj.on_input(data)
    return inj.on_output(session, session.feed(data)) if data else b""


def poll_session(controller, session) -> bytes:
    """Unsolicited bytes (and delayed replies) due now for ``session``, faults applied once."""
    inj = getattr(controller.faults, "injector", None)
    if inj is None or getattr(session, "applies_faults", False):
        return session.poll()
    out = session.poll()
    return (inj.on_output(session, out) if out else b"") + inj.release(session)


def _close_fd(fd: int) -> None:
    try:
        os.close(fd)
    except OSError:
        pass


def serve_pty(controller: Gs232Controller, link: str | None = None) -> PtyServer:
    """Serve ``controller`` on a new pseudo-terminal; ``.url`` is ``/dev/pts/N`` (or ``link``,
    a symlink kept pointing at the current pty)."""
    return PtyServer(controller, link)


def serve_tcp(controller: Gs232Controller, port: int = 0, bind: str = "127.0.0.1") -> TcpServer:
    """Serve ``controller`` on TCP; ``.url`` is ``socket://127.0.0.1:N`` (port 0 = any)."""
    return TcpServer(controller, port, bind)
