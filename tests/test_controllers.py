"""The controller registry: every entry resolves, and its facts agree with the code they name."""

from __future__ import annotations

from datetime import datetime, timezone

import pytest

from tracker.clock import ManualClock
from tracker.controllers import CONTROLLERS, controller, find, names, with_emulator
from tracker.emulator.factory import make_emulator
from tracker.errors import ConfigError
from tracker.mount import preset
from tracker.steptable import PROFILES, table_profile

T0 = datetime(2026, 8, 23, tzinfo=timezone.utc)
ENTRIES = {e.name: e for e in CONTROLLERS}


def test_names_are_unique_and_lower_case():
    every = names()
    assert len(every) == len(set(every))
    assert all(n == n.lower() for n in every)


@pytest.mark.parametrize("name", list(ENTRIES))
def test_entry_resolves_inside_its_layer(name):
    e = ENTRIES[name]
    # drivers live in the wire layer, emulators in the emulator package: the registry's
    # lazy imports must not reach past them
    assert e.driver.startswith("tracker.protocols.")
    assert callable(e.driver_factory())
    if e.emulator is not None:
        assert e.emulator.startswith("tracker.emulator.")
        assert callable(e.emulator_factory())
        assert e.default_rotator is not None
    if e.default_rotator is not None:
        assert preset(e.default_rotator).has_elevation == e.has_elevation
    if e.step_tables is not None:
        assert e.step_tables in PROFILES
        assert all(table_profile(n).name == e.step_tables for n in e.names)
    if e.emulator is None:
        assert e.port_hint


@pytest.mark.parametrize("name", [n for e in with_emulator() for n in e.names])
def test_every_emulated_name_makes_a_box_on_its_default_rotator(name):
    e = find(name)
    box = make_emulator(name.upper(), ManualClock(T0))
    assert box.spec.name == preset(e.default_rotator).name


def test_unknown_protocol_lists_the_known_ones():
    with pytest.raises(ConfigError, match=r"unknown protocol 'nope'; known: .*sak232"):
        controller("nope")
    with pytest.raises(ConfigError, match=r"no emulator for 'rotctld'; known: .*gs232b"):
        make_emulator("rotctld", ManualClock(T0))


def test_lookup_ignores_letter_case():
    assert controller("GS232B-Manual") is ENTRIES["gs232b-manual"]
    assert controller("gs232b-azaz2") is ENTRIES["gs232b-azaz"]
