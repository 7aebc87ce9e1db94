"""Fixtures for the command-line tests."""

from __future__ import annotations

import pytest


@pytest.fixture
def isolated_home(tmp_path, monkeypatch):
    """A user with nothing yet: empty cache and config folders under ``tmp_path``, no
    ``TRACKER_CONFIG`` or ``TRACKER_CACHE_DIR``, and UTC as the local time zone (so printed
    local times are stable)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    monkeypatch.delenv("TRACKER_CONFIG", raising=False)
    monkeypatch.delenv("TRACKER_CACHE_DIR", raising=False)
    monkeypatch.setenv("TZ", "UTC")
    return tmp_path
