"""The one reader of user-named text files, and the library checks behind the bad-input table
(``test_bad_input.py`` runs them as ``tracker ...``)."""

from __future__ import annotations

import os
import threading

import pytest
from _paths import DATA

from tle.errors import TleFormatError, UnknownSatelliteError
from tle.textfile import read_text_file
from tracker.errors import ConfigError, PropagationError


def _read_in_thread(path, **kw):
    """read_text_file in a thread with a deadline, so a regression that blocks fails."""
    out: dict = {}

    def run():
        try:
            out["text"] = read_text_file(path, "test file", ConfigError, **kw)
        except ConfigError as e:
            out["error"] = str(e)
    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(30.0)
    assert not t.is_alive(), "read_text_file blocked"
    return out


def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    assert "is a FIFO (named pipe), not a regular file" in _read_in_thread(fifo)["error"]


def test_a_symlink_to_a_fifo_is_refused_too(tmp_path):
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "link").symlink_to(tmp_path / "pipe")
    assert "FIFO" in _read_in_thread(tmp_path / "link")["error"]


def test_devices_and_directories_are_refused_and_dev_null_is_empty(tmp_path):
    assert "character device" in _read_in_thread("/dev/zero")["error"]
    assert "is a directory" in _read_in_thread(tmp_path)["error"]
    assert _read_in_thread("/dev/null")["text"] == ""


def test_size_is_capped_per_use(tmp_path):
    p = tmp_path / "big.txt"
    p.write_text("x" * 2000)
    assert "more than the" in _read_in_thread(p, max_bytes=1000)["error"]
    assert _read_in_thread(p, max_bytes=2000)["text"] == "x" * 2000


def test_bom_is_dropped_and_binary_refused_with_the_hint(tmp_path):
    p = tmp_path / "c.toml"
    p.write_bytes(b"\xef\xbb\xbfa = 1\n")
    assert _read_in_thread(p)["text"] == "a = 1\n"
    p.write_bytes(b"\xff\xfe\x00a")
    err = _read_in_thread(p, hint="a TOML file")["error"]
    assert "not a text file (byte 0 is not UTF-8); a TOML file" in err


def test_the_callers_error_type_is_raised(tmp_path):
    with pytest.raises(TleFormatError, match="no/such: No such file"):
        read_text_file(tmp_path / "no/such", "element file", TleFormatError)


def test_a_bom_config_from_notepad_loads(tmp_path):
    from tracker.config import load_config

    p = tmp_path / "bom.toml"
    p.write_bytes(b'\xef\xbb\xbf[station]\nname = "N"\nlat_deg = 10.0\nlon_deg = 20.0\n')
    assert load_config(p).station_named(None).lat_deg == 10.0


def _iss():

    from tle.elements import load_file
    from tracker.targets import SatelliteTarget

    data = DATA / "passes_sats.tle"
    return SatelliteTarget(next(e for e in load_file(data) if e.norad_id == 25544))


def test_propagation_far_from_the_epoch_is_refused_before_any_work():
    from tracker.passes import find_passes
    from tracker.station import Station
    from tracker.targets import MAX_PROPAGATION_DAYS

    iss, here = _iss(), Station("x", 52.0, 4.4, 10.0)
    day_s = 86400.0
    near = iss.epoch_s + (MAX_PROPAGATION_DAYS - 2) * day_s
    assert find_passes(iss, here, near, near + day_s)          # still answers near the bound
    for far in (iss.epoch_s + (MAX_PROPAGATION_DAYS + 1) * day_s,
                iss.epoch_s - (MAX_PROPAGATION_DAYS + 1) * day_s, -2.2e9):
        with pytest.raises(PropagationError, match=r"days (after|before) the elements' epoch"):
            find_passes(iss, here, far, far + day_s)
        with pytest.raises(PropagationError):
            iss.observe(here, [far])


def test_a_number_is_a_norad_id_never_part_of_a_name():
    from tle.catalog import Catalog
    from tle.elements import parse_text

    sets = parse_text(
        "TIANQI (1)\n"
        "1 25544U 98067A   26234.50053383  .00009133  00000+0  17025-3 0  9997\n"
        "2 25544  51.6331 331.8814 0007668  72.6488 287.5339 15.49570248582031\n")
    catalog = Catalog(sets)
    assert catalog.find("25544").name == "TIANQI (1)"
    with pytest.raises(UnknownSatelliteError, match="no satellite with NORAD id 1 "):
        catalog.find("1")


@pytest.mark.parametrize(("url", "says"), [
    ("socket://127.0.0.1:99999", "port 99999 is not a TCP port"),
    ("socket://127.0.0.1", "names no port"),
    ("rfc2217://:4000", "names no host"),
    ("socket://h:x", "port x is not a TCP port"),
])
def test_network_urls_are_checked_before_pyserial(url, says):
    from tracker.transport import open_port

    with pytest.raises(ConfigError, match=says):
        open_port(url)


@pytest.mark.parametrize("baud", [0, -1, 49, 4_000_001, 2**32, True, 9600.0])
def test_impossible_baud_rates_are_refused_where_ports_open(baud):
    from tracker.transport import check_baud, open_port

    with pytest.raises(ConfigError, match="is invalid"):
        check_baud(baud)
    with pytest.raises(ConfigError, match="is invalid"):
        open_port("/dev/null-not-opened", baudrate=baud)
