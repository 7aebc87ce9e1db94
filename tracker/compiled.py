"""Compiled loops where numba is installed (the ``fast`` extra), numpy otherwise.

A module with a hot loop keeps two implementations of the same arithmetic: numpy, the
reference that always runs, and a plain Python loop that numba compiles (a :class:`Loops` of
the module). It asks :func:`backend` which one to run.

numba is imported on the first compile only, never by importing this module: loading it costs
about 0.7 s CPU and 150 MB, which only a big job pays back. So the automatic choice is numpy
until numba is already loaded in the process or the caller says the job is big enough.
``TRACKER_NUMBA=0`` in the environment, or :func:`use`, selects numpy.
"""

from __future__ import annotations

import functools
import os
import sys
import threading
from collections.abc import Callable, Iterable, MutableMapping
from typing import Any

IMPLEMENTATIONS = ("numba", "numpy")

_choice: str | None = None  # chosen by use(); None: automatic (see backend())


@functools.cache
def usable() -> bool:
    """numba imports: installed, and built for the numpy installed beside it (numba refuses
    a numpy newer than it knows). Otherwise the numpy implementations run: same results,
    slower."""
    try:
        import numba  # noqa: F401
    except Exception:  # ImportError, or an install broken in any other way
        return False
    return True


def enabled() -> bool:
    """numba is usable and not switched off by ``TRACKER_NUMBA=0``."""
    return os.environ.get("TRACKER_NUMBA", "1") != "0" and usable()


def backend(worth_loading: bool = False) -> str:
    """The implementation to run: the one chosen by :func:`use`, else "numba" when it is
    enabled and either already loaded or ``worth_loading`` (the caller's job pays for loading
    it), else "numpy"."""
    if _choice is not None:
        return _choice
    if (worth_loading or "numba" in sys.modules) and enabled():
        return "numba"
    return "numpy"


def best() -> str:
    """The faster implementation that runs here: "numba" when it is enabled, else "numpy"
    (for a job known to be big, such as a benchmark)."""
    return "numba" if enabled() else "numpy"


def use(name: str | None) -> str | None:
    """Select the implementation every module runs ("numba", "numpy", or None: the automatic
    choice of :func:`backend`); returns the previous choice."""
    global _choice
    if name is not None and name not in IMPLEMENTATIONS:
        raise ValueError(f"unknown kernel implementation {name!r}; known: "
                         f"{', '.join(IMPLEMENTATIONS)}")
    previous, _choice = _choice, name
    return previous


class Loops:
    """The compiled loops of one module: ``loops("_name")`` is the module's function
    ``_name`` compiled (on first use, once even when threads ask at the same time, cached on
    disk). The ``helpers`` (functions the loops call) are compiled first, in place in the
    module's namespace, which only the loops use them from. error_model "numpy": a division by
    zero gives inf or nan, as in numpy."""

    def __init__(self, namespace: MutableMapping[str, Any], helpers: Iterable[str] = ()):
        self._namespace = namespace
        self._helpers = tuple(helpers)
        self._lock = threading.Lock()
        self.compiled: dict[str, Callable[..., Any]] = {}

    def __call__(self, name: str) -> Callable[..., Any]:
        fn = self.compiled.get(name)
        if fn is None:
            with self._lock:
                fn = self.compiled.get(name)
                if fn is None:
                    import numba

                    options = dict(cache=True, error_model="numpy")
                    for helper in self._helpers:
                        if not hasattr(self._namespace[helper], "py_func"):  # not yet compiled
                            self._namespace[helper] = numba.njit(**options)(
                                self._namespace[helper])
                    fn = self.compiled[name] = numba.njit(**options)(self._namespace[name])
        return fn
