"""pyserial URL handlers of this project (``emu://``), found through
``serial.protocol_handler_packages`` once :mod:`tracker.transport` is imported."""
