"""The project's error hierarchy.

Every error a user can cause or meet (bad config, unknown target, a controller that stops
answering) is a ``TrackerError``; the CLI prints its message on one line and exits 2. The
``tle`` package has its own root, :class:`tle.errors.TleError`, which the CLI treats alike.
"""

from __future__ import annotations

# The advice mechanism is shared with ``tle`` (which cannot import ``tracker``).
from tle.errors import AdvisedError
from tle.errors import with_advice as with_advice


class TrackerError(AdvisedError):
    """Root of every error the tracker raises on purpose.

    A message may end in advice worded for a Python caller (``problem`` and ``advice``, see
    :class:`~tle.errors.AdvisedError`): the CLI replaces that advice with its flags.
    """


class ConfigError(TrackerError, ValueError):
    """A config file, flag or rotator spec is invalid; the message names the key and range."""


class TargetError(TrackerError, LookupError):
    """A target name is unknown or ambiguous; ``suggestions`` lists close matches."""

    def __init__(self, message: str, suggestions: tuple[str, ...] = ()):
        super().__init__(message)
        self.suggestions = tuple(suggestions)


class PropagationError(TrackerError):
    """Elements that cannot be propagated (decayed, SGP4 error) for the named satellite."""


class OutputExistsError(ConfigError):
    """An output file exists and overwriting it was not asked for (``force``)."""


class LimitError(TrackerError, ValueError):
    """A position outside the configured rotator limits or below the horizon mask."""


class RotatorIOError(TrackerError, OSError):
    """Any controller I/O problem: the port vanished, a write failed."""


class PortLostError(RotatorIOError):
    """The port disappeared (USB unplug, TCP peer closed)."""


class RotatorTimeout(RotatorIOError, TimeoutError):
    """No complete reply within the timeout."""


class ProtocolError(RotatorIOError):
    """A malformed or unexpected reply; ``raw`` keeps the bytes that were received."""

    def __init__(self, message: str, raw: bytes = b""):
        super().__init__(f"{message} (received {raw!r})" if raw else message)
        self.raw = bytes(raw)


class StallError(RotatorIOError):
    """A commanded axis did not move: the rotator was stopped and is reported jammed."""


class ReadbackError(TrackerError):
    """The controller's read-back stayed untrustworthy (well-formed positions that contradict
    each other and every command) for longer than the loop may wait: the rotator was
    stopped rather than steered blind."""

