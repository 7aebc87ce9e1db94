"""Memory figures the long-running benchmarks (``soak.py``, ``station.py``) print: resident set
size and the Python heap as tracemalloc sees it."""

from __future__ import annotations

import tracemalloc
from pathlib import Path


def rss_mib() -> float:
    """The process's resident set size (MiB); the peak where /proc is missing."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def heap_mib() -> float:
    """The Python heap traced by tracemalloc (MiB; 0 while it is not tracing)."""
    return tracemalloc.get_traced_memory()[0] / 2**20
