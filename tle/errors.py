"""Errors of the ``tle`` package."""

from __future__ import annotations


class TleError(ValueError):
    """Root of every element-set problem; the CLI prints it on one line and exits 2."""


class TleFormatError(TleError):
    """A broken element set; the message names ``source:line``, the fault and the layout.

    ``source``, ``line_no`` and ``line`` keep the offending place so callers can report or
    skip it without parsing the message.
    """

    def __init__(self, message: str, source: str = "<string>", line_no: int = 0,
                 line: str | None = None):
        super().__init__(message)
        self.source = source
        self.line_no = line_no
        self.line = line


class UnknownSatelliteError(TleError, LookupError):
    """No element set matches the query; ``suggestions`` lists close names."""

    def __init__(self, message: str, suggestions: tuple[str, ...] = ()):
        super().__init__(message)
        self.suggestions = tuple(suggestions)


class AmbiguousSatelliteError(TleError, LookupError):
    """Several element sets match the query; ``candidates`` lists their names."""

    def __init__(self, message: str, candidates: tuple[str, ...] = ()):
        super().__init__(message)
        self.candidates = tuple(candidates)
        self.suggestions = self.candidates


class TleFetchError(TleError):
    """A download failed or brought back something that is not element sets.

    The cached copy (if any) is always kept when this is raised.
    """


class TleWarning(UserWarning):
    """A broken element set that was skipped (``skip_bad=True``), or old elements."""
