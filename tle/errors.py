"""Errors of the ``tle`` package."""

from __future__ import annotations


class TleError(ValueError):
    """Root of every element-set problem; the CLI prints it on one line and exits 2."""
