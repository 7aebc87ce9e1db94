"""pyserial handler for ``emu://``: an emulated controller in this process, on its clock.

``serial.serial_for_url("emu://gs232b?rotator=G-5500", clock=clock)`` (or
:func:`tracker.transport.open_port`) returns a port-like object whose peer is the project's
emulator; see :mod:`tracker.emulator.virtual` for the URL syntax and the waiting rules.
"""

from __future__ import annotations

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from tracker.emulator.virtual import attach


class Serial(SerialBase):
    """An emulated controller as a serial port (no pty, no socket, no thread)."""

    def __init__(self, *args, clock=None, **kwargs):
        self._clock_arg = clock
        self._link = None
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        try:
            self._link = attach(self.portstr, self._clock_arg)
        except (ValueError, LookupError) as e:
            raise SerialException(f"could not open port {self.portstr!r}: {e}") from e
        self.is_open = True

    def _reconfigure_port(self) -> None:
        pass    # an emulator has no baud rate or framing to set

    def close(self) -> None:
        if self._link is not None:
            self._link.close()
        self.is_open = False

    @property
    def clock(self):
        """The clock this port's time is measured on (its emulator's clock)."""
        return self._need().bench.clock

    @property
    def bench(self):
        return self._need().bench

    def _need(self):
        if not self.is_open or self._link is None:
            raise PortNotOpenError()
        return self._link

    @property
    def in_waiting(self) -> int:
        return self._need().in_waiting()

    def read(self, size: int = 1) -> bytes:
        return self._need().read(size, self._timeout)

    def write(self, data) -> int:
        return self._need().write(bytes(data))

    def flush(self) -> None:
        self._need()

    def reset_input_buffer(self) -> None:
        self._need().reset_input()

    def reset_output_buffer(self) -> None:
        self._need()

    @property
    def out_waiting(self) -> int:
        return 0

    def send_break(self, duration: float = 0.25) -> None:
        self._need()

    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
