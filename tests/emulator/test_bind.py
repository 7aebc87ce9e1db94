"""Every socket the project listens on binds to 127.0.0.1 unless the user asks otherwise.

An audit (every listening call in the package and in the test helpers is a reviewed site) and
real checks of each listener's address: the emulator's TCP server (also after a fault
disconnect re-listens), ``tracker emulate --tcp``, and the Dask LocalCluster of ``batch --dask``.
"""

from __future__ import annotations

import re
import socket
from datetime import datetime

import pytest
from _gs232_helpers import T0, wait_until
from _paths import REPO

from tracker.clock import SimClock
from tracker.emulator import Gs232Controller, serve_tcp
from tracker.emulator.faults import install

LISTEN_RE = re.compile(r"create_server\(|\.bind\(|\.listen\(|HTTPServer\(|TCPServer\b|"
                       r"start_server\(|LocalCluster\(|serve_forever\(|run_server\(")

# Package files with a listening call, each reviewed: how many calls, and why they are safe.
REVIEWED = {
    "tracker/emulator/serve.py": 1,        # TcpServer._listen_on: bind defaults to 127.0.0.1
    "tracker/batch/distributed.py": 1,  # LocalCluster: host None -> 127.0.0.1, no dashboard
    "tracker/service/web.py": 1,        # StatusServer: host defaults to 127.0.0.1
    "tracker/service/rotctld_server.py": 2,   # RotctldServer: host defaults to 127.0.0.1
}


def _listening_lines(top: str):
    for p in sorted((REPO / top).rglob("*.py")):
        rel = p.relative_to(REPO).as_posix()
        if rel == "tests/emulator/test_bind.py":
            continue
        for no, line in enumerate(p.read_text(errors="replace").splitlines(), 1):
            if LISTEN_RE.search(line):
                yield rel, no, line.strip()


def test_audit_package_listeners_are_the_reviewed_sites():
    found: dict[str, int] = {}
    for rel, _no, _line in [*_listening_lines("tracker"), *_listening_lines("tle")]:
        found[rel] = found.get(rel, 0) + 1
    assert found == REVIEWED, (f"listening sockets in the package changed: {found}; bind new "
                               f"ones to 127.0.0.1 by default, test them here, update REVIEWED")


def test_audit_tests_benchmarks_and_examples_listen_on_loopback_literally():
    loose = [f"{rel}:{no}: {line}" for top in ("tests", "benchmarks", "examples")
             for rel, no, line in _listening_lines(top)
             if "127.0.0.1" not in line and "localhost" not in line
             and 'protocol="inproc://"' not in line]       # in-process: no socket at all
    assert not loose, "listening without an explicit 127.0.0.1:\n" + "\n".join(loose)


def _other_local_address() -> str | None:
    """A non-loopback address of this machine (no packet is sent), or None."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.connect(("10.255.255.255", 1))
        addr = s.getsockname()[0]
    except OSError:
        return None
    finally:
        s.close()
    return None if addr.startswith("127.") else addr


def test_emulator_tcp_server_listens_on_loopback_only():
    ctrl = Gs232Controller("gs232b")
    server = serve_tcp(ctrl)
    try:
        assert server.url.startswith("socket://127.0.0.1:")
        assert server._listen.getsockname()[0] == "127.0.0.1"
        other = _other_local_address()
        if other is not None:   # the port is not reachable on the machine's LAN address
            with pytest.raises(OSError):
                socket.create_connection((other, server.port), timeout=1).close()
        socket.create_connection(("127.0.0.1", server.port), timeout=1).close()
    finally:
        server.close()


def test_reopened_listener_after_a_disconnect_fault_is_still_loopback():
    clock = SimClock(datetime.fromisoformat(T0), speed=1.0)
    ctrl = Gs232Controller("gs232b", clock=clock)
    inj = install(ctrl, ["disconnect=0.2@0.1"])
    server = serve_tcp(ctrl)
    try:
        assert wait_until(lambda: inj.elapsed_s() > 0.4 and server._listen is not None, 3)
        assert server._listen.getsockname()[:2] == ("127.0.0.1", server.port)
    finally:
        server.close()


def test_emulate_cli_binds_loopback_unless_told(emulate):
    def first_line(*extra):
        p = emulate("--tcp", "0", *extra)
        assert p.stop()[0] == 0
        return p.url
    assert first_line().startswith("socket://127.0.0.1:")
    assert first_line("--bind", "0.0.0.0").startswith("socket://0.0.0.0:")   # user's choice


@pytest.mark.slow
def test_dask_local_cluster_binds_loopback():
    pytest.importorskip("dask.distributed")
    from tracker.batch.distributed import _client

    client, cluster = _client(None, 1, True, 30.0)
    try:
        addrs = [cluster.scheduler_address, *client.scheduler_info()["workers"]]
        assert all(a.startswith("tcp://127.0.0.1:") for a in addrs), addrs
        assert cluster.dashboard_link in ("", None) or "127.0.0.1" in cluster.dashboard_link
    finally:
        client.close()
        cluster.close()


def test_the_status_page_and_the_control_port_listen_on_loopback_by_default():
    pytest.importorskip("flask")
    from tracker.clock import ManualClock
    from tracker.mount import preset
    from tracker.service.board import StatusBoard
    from tracker.service.rotctld_server import RotctldServer
    from tracker.service.web import StatusServer

    clock = ManualClock(datetime.fromisoformat(T0))
    page = StatusServer(StatusBoard(clock), port=0)
    port = RotctldServer(lambda: None, preset("G-5500"), clock=clock, port=0)
    page.start()
    port.start()
    try:
        assert page.url.startswith("http://127.0.0.1:")
        assert port.address[0] == "127.0.0.1"
        other = _other_local_address()
        if other is not None:
            for p in (int(page.url.rsplit(":", 1)[1].strip("/")), port.address[1]):
                with pytest.raises(OSError):
                    socket.create_connection((other, p), timeout=1).close()
    finally:
        page.close()
        port.close()
