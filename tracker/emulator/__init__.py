"""Virtual rotator controllers served on a real pty or TCP socket (see ``serve.py``)."""

from __future__ import annotations

from tracker.emulator.gs232_controller import EmulatorOptions, Faults, Gs232Controller
from tracker.emulator.serve import PtyServer, TcpServer, serve_pty, serve_tcp

__all__ = ["EmulatorOptions", "Faults", "Gs232Controller", "PtyServer", "TcpServer",
           "serve_pty", "serve_tcp"]
