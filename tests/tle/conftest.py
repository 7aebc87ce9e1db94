"""Fixtures of the element-cache tests: a fake CelesTrak on 127.0.0.1 and an empty cache."""

from __future__ import annotations

import pytest


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty element cache for the CLI (``$TRACKER_CACHE_DIR``), default download URL."""
    monkeypatch.setenv("TRACKER_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("TRACKER_CELESTRAK_URL", raising=False)
    return tmp_path / "tle"
