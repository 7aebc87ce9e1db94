"""Hypothesis over every reply parser, the emulators' command interpreters and the file
parsers: the only exceptions allowed are the documented typed ones; the emulator always
answers C2 afterwards. CI runs a few examples per target (all fuzz tests < 30 s);
``benchmarks/fuzz.py`` runs 100k per target."""

from __future__ import annotations

import pytest
from _fuzz_targets import check, hypothesis_inputs, targets
from hypothesis import HealthCheck, given, settings

from tle.errors import TleError

TARGETS = {t.name: t for t in targets()}
FAST = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def _inputs(name: str):
    return hypothesis_inputs(TARGETS[name])


def _run(name: str, data: bytes) -> None:
    err = check(TARGETS[name], data)
    if err is not None:
        raise AssertionError(f"{name}: {type(err).__name__}: {err} on input {data[:200]!r}") \
            from err


@pytest.mark.parametrize("name", list(TARGETS))
def test_fuzz_target(name):
    @FAST
    @given(data=_inputs(name))
    def run(data):
        _run(name, data)
    run()


def test_every_seed_is_accepted_where_it_is_valid():
    """The seeds are real, valid inputs: the file parsers must take them without error, so
    the mutations start from the inside of each parser rather than its first check."""
    for name in ("tle.parse_text", "omm.json", "omm.csv", "omm.xml", "config.load_config",
                 "schedule.parse", "station.HorizonMask.load", "faults.parse_fault",
                 "steptable.read_plan_file", "schedule.parse_priorities"):
        t = TARGETS[name]
        for seed in t.seeds:
            t.run(seed)     # raises on a bad seed


# Found by fuzzing: exceptions that escaped the TLE/OMM parsers instead of TleError.
def test_omm_csv_with_a_newline_in_an_unquoted_field_is_a_tle_error():
    from tle.omm import parse_omm_csv

    with pytest.raises(TleError):       # any other exception, or none, fails
        parse_omm_csv("OBJECT_NAME,EPOCH\rX\n", "<fuzz>")


def test_omm_xml_with_an_unknown_encoding_is_a_tle_error():
    from tle.omm import parse_omm_xml

    with pytest.raises(TleError):
        parse_omm_xml('<?xml version="1.0" encoding="UTF-863932"?>\n<ndm/>', "<fuzz>")


def test_tle_with_a_blank_in_the_epoch_is_a_tle_error():
    """Found by ``benchmarks/fuzz.py`` (100k inputs): ``float(line1[20:32])`` unguarded."""
    from tle.checksum import compute_checksum
    from tle.elements import parse_tle_text

    l1 = "1 25544U 98067A   26234.50 53383  .00009133  00000+0  17025-3 0  999"
    l1 += str(compute_checksum(l1))
    l2 = "2 25544  51.6331 331.8814 0007668  72.6488 287.5339 15.49570248582031"
    with pytest.raises(TleError):
        parse_tle_text(f"ISS\n{l1}\n{l2}\n", "<fuzz>")


@pytest.mark.parametrize("loader", ["plan", "priorities", "stations"])
def test_a_binary_file_is_a_config_error_not_a_unicode_error(tmp_path, loader):
    """Found by fuzzing: these readers caught OSError only, so a non-UTF-8 file (a plan or
    stations file saved in another encoding, a binary by mistake) was a traceback."""
    from tracker.batch import load_stations
    from tracker.errors import ConfigError
    from tracker.pass_schedule import parse_priorities
    from tracker.steptable import read_plan_file

    p = tmp_path / "file.txt"
    p.write_bytes(b"ISS=5\n\xff\xfe\xe9=3\n")
    fn = {"plan": read_plan_file, "priorities": lambda f: parse_priorities([], f),
          "stations": load_stations}[loader]
    with pytest.raises(ConfigError, match="not a text file"):
        fn(p)
