"""Where the element cache lives and which of its files hold element sets.

Apart from :mod:`tle.store` (which fetches and writes the cache) because reading the cache,
as every offline command does through ``Catalog.default``, needs only these few lines and
none of the network machinery.
"""

from __future__ import annotations

import os
from pathlib import Path

META_NAME = "sources.json"
ELEMENT_SUFFIXES = (".txt", ".tle", ".json", ".csv", ".xml")


def default_cache_dir() -> Path:
    """``$TRACKER_CACHE_DIR/tle`` if set (tests, CI), else the platformdirs user cache."""
    env = os.environ.get("TRACKER_CACHE_DIR")
    if env:
        return Path(env) / "tle"
    import platformdirs

    return Path(platformdirs.user_cache_dir("tracker")) / "tle"


def element_paths(cache_dir: Path) -> list[Path]:
    """The element files in ``cache_dir`` (the downloads plus any element file dropped in
    it), sorted; none if the directory does not exist."""
    if not cache_dir.is_dir():
        return []
    return sorted(p for p in cache_dir.iterdir()
                  if p.suffix in ELEMENT_SUFFIXES and p.name != META_NAME
                  and not p.name.startswith(".") and p.is_file())
