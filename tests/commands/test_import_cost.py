"""What a command loads: ``tracker --help`` stays light (no numpy, no skyfield) and an offline
command loads nothing network-related; a satellite pass listing loads neither the planetary
ephemeris nor the cache's downloader. Checked in a fresh
interpreter, from ``-X importtime``."""

from __future__ import annotations

import os
import subprocess
import sys

from _paths import REPO

NETWORK = {"ssl", "http.client", "urllib.request"}


def _imported(tmp_path, *argv: str) -> set[str]:
    """The modules ``python -m tracker ARGV`` imports, in a fresh interpreter."""
    config = tmp_path / "tracker.toml"
    config.write_text("")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])]),
        TRACKER_CONFIG=str(config), XDG_CACHE_HOME=str(tmp_path / "cache"))
    proc = subprocess.run([sys.executable, "-X", "importtime", "-m", "tracker", *argv],
                          capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return {line.rsplit("|", 1)[1].strip() for line in proc.stderr.splitlines()
            if line.startswith("import time:") and "|" in line}


def _tops(modules: set[str]) -> set[str]:
    return {m.split(".")[0] for m in modules}


def test_help_imports_neither_numpy_nor_skyfield_nor_the_network(tmp_path):
    modules = _imported(tmp_path, "--help")
    assert "tracker.cli" in modules                  # the listing is real
    assert not _tops(modules) & {"numpy", "skyfield", "sgp4", "numba"}
    assert not modules & NETWORK


def test_an_offline_pass_listing_imports_nothing_network_related(tmp_path):
    modules = _imported(tmp_path, "passes", "ISS", "--at", "2026-08-23T00:00Z",
                        "--lat", "52", "--lon", "4.4")
    assert {"tracker.passes", "skyfield.sgp4lib"} <= modules
    assert not modules & NETWORK
    assert "numba" not in _tops(modules)             # only the batch finder's kernels use it
    assert "skyfield.iokit" not in modules           # skyfield's downloader (ssl, urllib)


def test_a_satellite_pass_listing_loads_only_what_it_uses(tmp_path):
    modules = _imported(tmp_path, "passes", "ISS", "--at", "2026-08-23T00:00Z",
                        "--lat", "52", "--lon", "4.4")
    assert "tle.catalog" in modules and "tracker.sun" in modules
    # sunlit/visible come from tracker.sun, not DE421; reading the cache needs no downloader;
    # statistics and difflib serve only other paths (the snapshot's note, suggestions)
    assert not modules & {"tracker.ephemeris", "jplephem.spk", "skyfield_data", "tle.store",
                          "statistics", "difflib"}
