"""Errors of the ``tle`` package."""

from __future__ import annotations

from typing import TypeVar


class AdvisedError(Exception):
    """An error whose message may end in advice worded for a Python caller.

    ``problem`` is then the message without that advice and ``advice`` the advice (naming
    parameters and functions), so a front end can put its own after the problem (the CLI's
    flags: :meth:`advise`). Both are empty when the whole message is the problem. The root of
    ``tle``'s errors and of ``tracker``'s (:class:`tracker.errors.TrackerError`).
    """

    problem: str = ""
    advice: str = ""

    def advise(self, advice: str) -> AdvisedError:
        """This error with its advice replaced by ``advice``; one without advice is kept."""
        if self.problem:
            self.advice = advice
            self.args = (self.problem + advice,)
        return self


E = TypeVar("E", bound=AdvisedError)


def with_advice(error_type: type[E], problem: str, advice: str) -> E:
    """``error_type(problem + advice)`` that remembers both (see :class:`AdvisedError`)."""
    error = error_type(problem + advice)
    error.problem = problem
    error.advice = advice
    return error


class TleError(AdvisedError, ValueError):
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
