"""The batch finder's own behaviour: chunking, stations, masks, decayed elements, bad input."""

from __future__ import annotations

from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from _paths import TESTS
from sgp4.api import Satrec, jday

from tracker.batch import find_passes_batch, iter_passes_batch, load_stations, pass_track
from tracker.errors import ConfigError
from tracker.station import HorizonMask, Station

START = datetime(2026, 8, 22, 13, 45, tzinfo=timezone.utc)
DELFT = Station("Delft", 52.0, 4.37, 10.0)
QUITO = Station("Quito", -0.2, -78.5, 2850.0, 5.0)


def read_sets(path: Path):
    lines = [x.strip() for x in path.read_text().splitlines() if x.strip()]
    return [(lines[i], lines[i + 1], lines[i + 2]) for i in range(0, len(lines) - 2, 3)]


@pytest.fixture(scope="module")
def amateur():
    sets = read_sets(TESTS.parent / "tle" / "data" / "amateur.txt")
    return [Satrec.twoline2rv(a, b) for _, a, b in sets], [n for n, _, _ in sets]


def run(amateur, stations=(DELFT,), days=1.0, **kw):
    satrecs, names = amateur
    return find_passes_batch(satrecs, names, list(stations), START, START + timedelta(days=days),
                             **kw)


def same(a, b, tol_s=0.0):
    """Same passes; AOS/LOS within ``tol_s``, TCA (flatter, so looser) within 0.1 s."""
    assert len(a) == len(b)
    for key in ("sat", "station", "aos_clipped", "los_clipped"):
        assert np.array_equal(a[key], b[key]), key
    for key, tol in (("aos_s", tol_s), ("tca_s", tol_s and 0.1), ("los_s", tol_s)):
        assert np.max(np.abs(a[key] - b[key]), initial=0) <= tol, key


def test_screening_skips_most_of_the_window(amateur):
    table = run(amateur)
    st = table.stats
    assert st["candidate_intervals"] < 0.5 * st["intervals"]
    # Fewer SGP4 evaluations than a plain 60 s grid of the whole window would need.
    total = st["sgp4_coarse"] + st["sgp4_fine"] + st["sgp4_refine"]
    assert total < len(amateur[0]) * 1440 / 3
    p = table.passes
    assert len(p) > 500 and np.all(p["aos_s"] <= p["tca_s"]) and np.all(p["tca_s"] <= p["los_s"])
    assert np.all((p["max_el_deg"] >= 0) & (p["max_el_deg"] <= 90))


def sgp4_elevation_deg(satrec, station: Station, t_s) -> np.ndarray:
    """SGP4's own elevation at POSIX times, in the finder's frames (GMST on UT1)."""
    from tracker.batch import geometry as geo

    t_s = np.atleast_1d(np.asarray(t_s, dtype=float))
    jd0, fr0 = jday(1970, 1, 1, 0, 0, 0.0)
    fr = fr0 + t_s / 86400.0
    err, r, v = satrec.sgp4_array(np.full(len(t_s), jd0), fr)
    assert np.all(err == 0)
    theta = geo.gmst_rad(jd0, fr + geo.dut1_s(START) / 86400.0)
    r_ecef, v_ecef = geo.teme_to_ecef(r, v, theta)
    frames = geo.StationFrames.from_stations([station])
    return geo.look_angles(r_ecef, v_ecef, frames, 0)[0]


def test_events_are_finished_on_sgp4_with_about_one_evaluation_each(amateur):
    """AOS/TCA/LOS come from the interpolant corrected by SGP4 at the root: by SGP4's own
    elevation AOS/LOS sit on the horizon and TCA is a maximum, at about one SGP4 evaluation
    per event."""
    table = run(amateur)
    st = table.stats
    events = st["brackets_tca"] + st["brackets_cross"]
    assert events > 1000 and st["sgp4_refine"] <= 1.2 * events
    satrecs, _names = amateur
    p = table.passes[~table.passes["aos_clipped"] & ~table.passes["los_clipped"]]
    for row in p[::10]:
        sr = satrecs[row["sat"]]
        el = sgp4_elevation_deg(sr, DELFT, [row["aos_s"], row["los_s"]])
        assert np.all(np.abs(el - DELFT.min_el_deg) < 1e-4), (row, el)
        around = sgp4_elevation_deg(sr, DELFT, row["tca_s"] + np.array([-1, -0.1, 0, 0.1, 1]))
        # The corrected cubic is good to centimetres: 1e-5 deg even at 2000 km range.
        assert around[2] == pytest.approx(row["max_el_deg"], abs=1e-5)
        assert np.all(around <= row["max_el_deg"] + 1e-5), (row, around)


def test_memory_chunks_and_worker_processes_give_identical_results(amateur):
    base = run(amateur).passes
    same(base, run(amateur, memory_mb=0.5).passes)  # 32-satellite chunks
    same(base, run(amateur, workers=2).passes)


def test_time_blocks_join_passes_cut_at_the_block_edge(amateur):
    base = run(amateur, days=2.0).passes
    blocked = run(amateur, days=2.0, block_days=0.3).passes
    # Fine grids are aligned to each block's start, so refinement differs by < tolerance.
    same(base, blocked, tol_s=0.05)


def test_stations_are_independent_of_each_other(amateur):
    both = run(amateur, stations=(DELFT, QUITO)).passes
    for k, st in enumerate((DELFT, QUITO)):
        alone = run(amateur, stations=(st,)).passes
        mine = both[both["station"] == k]
        alone = alone.copy()
        alone["station"] = k
        same(mine, alone)


def test_coarser_fine_step_still_finds_the_same_passes(amateur):
    """Near-miss maxima: with 10-minute steps grazing passes fall inside one step."""
    fine = run(amateur, step_s=60.0).passes
    coarse = run(amateur, step_s=600.0).passes
    same(fine, coarse, tol_s=0.05)


def test_min_el_and_horizon_mask(amateur):
    mask = HorizonMask((0.0, 90.0, 180.0, 270.0), (20.0, 2.0, 2.0, 2.0))
    station = Station("Masked", 52.0, 4.37, 10.0, 1.0, mask)
    table = run(amateur, stations=(station,))
    p = table.passes[~table.passes["aos_clipped"] & ~table.passes["los_clipped"]]
    satrecs, _names = amateur
    for row in p[::15]:
        for key, az_key in (("aos_s", "aos_az_deg"), ("los_s", "los_az_deg")):
            track = pass_track(satrecs[row["sat"]], station, row[key], row[key] + 1.0, 1.0)
            assert track.el_deg[0] == pytest.approx(station.horizon_at(row[az_key]), abs=0.02)
    plain = run(amateur, min_el_deg=10.0).passes
    assert np.all(plain["max_el_deg"] >= 10.0)
    assert len(plain) < len(run(amateur).passes)


def test_decayed_elements_are_reported_not_fatal(amateur):
    decayed = read_sets(TESTS / "data" / "passes_decayed.tle")
    satrecs = [Satrec.twoline2rv(a, b) for _, a, b in decayed] + amateur[0][:5]
    names = [n for n, _, _ in decayed] + amateur[1][:5]
    start = datetime(2026, 8, 22, 12, 0, tzinfo=timezone.utc)
    table = find_passes_batch(satrecs, names, [DELFT], start, start + timedelta(days=20))
    assert [e.name for e in table.errors] == ["DECAYSAT"]
    err = table.errors[0]
    assert "decayed" in err.message and start.timestamp() < err.first_s
    assert set(table.passes["sat"].tolist()) >= {1, 2, 3, 4, 5}
    dead = table.passes[table.passes["sat"] == 0]
    assert np.all(dead["los_s"] <= err.first_s)


def test_sunlit_and_visible_flags(amateur):
    p = run(amateur).passes
    assert p["sunlit"].any() and (~p["sunlit"]).any()
    assert np.all(p["sunlit"][p["visible"]])  # visible implies sunlit


@pytest.mark.parametrize("kwargs,match", [
    (dict(start=datetime(2026, 8, 22)), "timezone"),
    (dict(end=START), "after its start"),
    (dict(names=["one"]), "names"),
    (dict(step_s=1.0), "step_s"),
    (dict(stations=[]), "no stations"),
])
def test_bad_input_is_one_clear_error(amateur, kwargs, match):
    args = dict(satrecs=amateur[0], names=amateur[1], stations=[DELFT], start=START,
                end=START + timedelta(days=1))
    args.update(kwargs)
    with pytest.raises(ConfigError, match=match):
        find_passes_batch(**args)


def test_stations_file_csv_and_toml(tmp_path):
    csv_file = tmp_path / "st.csv"
    csv_file.write_text("# network\nname,lat,lon,alt,min_el\nDelft,52.0,4.37,10,5\n"
                        "\"Quito, EC\",-0.2,-78.5,2850\n")
    st = load_stations(csv_file)
    assert [s.name for s in st] == ["Delft", "Quito, EC"]
    assert st[0].min_el_deg == 5.0 and st[1].alt_m == 2850.0
    toml_file = tmp_path / "st.toml"
    toml_file.write_text('[[station]]\nname = "A"\nlat = 10\nlon = 20\nalt = 5\n\n'
                         '[[station]]\nname = "B"\nlat = -10\nlon = 30\nmin_el = 3\n')
    assert [(s.name, s.min_el_deg) for s in load_stations(toml_file)] == [("A", 0.0),
                                                                        ("B", 3.0)]


def test_stations_file_takes_the_config_schema(tmp_path):
    # The config's field names (and a horizon mask file next to the stations file) work in
    # both forms, and give the same stations as the short spelling.
    (tmp_path / "roof.txt").write_text("0 10\n180 20\n")
    csv_file = tmp_path / "st.csv"
    csv_file.write_text("name,lat_deg,lon_deg,alt_m,min_el_deg,mask\n"
                        "Delft,52.0,4.37,10,5,roof.txt\n")
    toml_file = tmp_path / "st.toml"
    toml_file.write_text('[[station]]\nname = "Delft"\nlat_deg = 52.0\nlon_deg = 4.37\n'
                         'alt_m = 10\nmin_el_deg = 5\nmask = "roof.txt"\n')
    short = tmp_path / "short.csv"
    short.write_text("Delft,52.0,4.37,10,5\n")
    from_csv, from_toml = load_stations(csv_file)[0], load_stations(toml_file)[0]
    assert from_csv == from_toml
    assert from_csv.mask is not None and from_csv.mask.min_el_deg == (10.0, 20.0)
    plain = load_stations(short)[0]
    assert (plain.name, plain.lat_deg, plain.lon_deg, plain.alt_m, plain.min_el_deg) == (
        from_csv.name, from_csv.lat_deg, from_csv.lon_deg, from_csv.alt_m,
        from_csv.min_el_deg)


@pytest.mark.parametrize("text,match", [
    ("Delft,52.0\n", r"st\.csv:1: expected 'name,lat_deg,lon_deg"),
    ("Delft,52.0,4.37\nBad,95,4,0\n", r"st\.csv:2: .*lat_deg = 95"),
    ("Delft,north,4.37\n", r'st\.csv:1: lat_deg = "north" is invalid; allowed: a number'),
    ("name,lat,lon\nDelft,inf,4.37\n", r"st\.csv:2: lat = Infinity is invalid"),
    ("Delft,52,4.37,10,5,x\n", r"st\.csv:1: expected"),
    ("Delft,1,2\nDelft,3,4\n", "appears twice"),
    ("# nothing\n", "no stations"),
])
def test_stations_file_errors_name_the_line(tmp_path, text, match):
    path = tmp_path / "st.csv"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match):
        load_stations(path)


def test_stations_toml_errors(tmp_path):
    path = tmp_path / "st.toml"
    path.write_text('[[station]]\nname = "A"\nlat = 10\n\n[[station]]\nname = "B"\nlat = 1\n'
                    'lon = 2\nheight = 3\n')
    with pytest.raises(ConfigError, match=r"st\.toml:1: lon_deg is missing"):
        load_stations(path)
    path.write_text('[[station]]\nname = "B"\nlat = 1\nlon = 2\nheight = 3\n')
    with pytest.raises(ConfigError, match=r"st\.toml:1: unknown key 'height'; allowed keys: "
                                          r"name, lat_deg, lon_deg, alt_m, min_el_deg, "
                                          r"locator, mask"):
        load_stations(path)
    path.write_text("[[station]\n")
    with pytest.raises(ConfigError, match=r"st\.toml"):
        load_stations(path)


def test_memory_is_bounded_by_chunking_not_by_catalogue_size():
    """The working set follows ``memory_mb``: four times the catalogue adds only the result
    rows (and the merge's copies of them), not four times the sample arrays."""
    import tracemalloc

    sets = read_sets(TESTS / "data" / "batch_active_sample.txt")
    satrecs = [Satrec.twoline2rv(a, b) for _, a, b in sets]
    names = [n for n, _, _ in sets]
    start = datetime(2026, 3, 19, 4, 51, tzinfo=timezone.utc)
    end = start + timedelta(days=2)
    station = [Station("Boulder", 40.0, -105.3, 1650.0)]
    find_passes_batch(satrecs[:3], names[:3], station, start, end)  # load skyfield data first
    budget_mb = 8.0
    peaks_mb, tables = [], []
    for k in (1, 4):
        tracemalloc.start()
        try:
            tables.append(find_passes_batch(satrecs * k, names * k, station, start, end,
                                            memory_mb=budget_mb))
            peaks_mb.append(tracemalloc.get_traced_memory()[1] / 2**20)
        finally:
            tracemalloc.stop()
    one, four = tables
    assert len(four) == 4 * len(one) > 2000
    result_mb = four.passes.nbytes / 2**20
    assert peaks_mb[1] < 3 * budget_mb, peaks_mb
    assert peaks_mb[1] - peaks_mb[0] < 4 * result_mb + 2.0, (peaks_mb, result_mb)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_subarc_screen_matches_a_dense_sweep_of_the_arc(dtype):
    """The closed-form screen of a fine step's sub-arc agrees with the largest projection of
    the station found by sweeping the arc densely, wherever the two are not within rounding
    of the cone's edge."""
    from tracker.batch.kernels import subarc_within

    rng = np.random.default_rng(7)
    m = 4000
    r_in = np.sqrt(rng.random(m))
    beta = rng.random(m) * 2 * np.pi
    a1 = rng.random(m) * 2 * np.pi
    a2 = a1 + rng.random(m) * (2 * np.pi - a1)
    cos_lim = rng.uniform(-0.3, 1.0, m)
    sweep = np.linspace(0.0, 1.0, 4001)
    alpha = a1[:, None] + (a2 - a1)[:, None] * sweep
    best = (r_in[:, None] * np.cos(alpha - beta[:, None])).max(1)
    got = subarc_within(*(x.astype(dtype) for x in (r_in * np.cos(beta), r_in * np.sin(beta),
                                                     a1, a2, cos_lim)))
    clear = np.abs(best - cos_lim) > 1e-4
    assert clear.sum() > 0.95 * m
    assert np.array_equal(got[clear], (best >= cos_lim)[clear])


def test_worker_shares_split_large_grid_classes_and_keep_small_ones_whole(amateur):
    from tracker.batch.finder import MIN_SPLIT_SATS, _GridClasses, _worker_shares

    satrecs, _names = amateur
    grid = _GridClasses.of(satrecs, 480.0)
    shares = _worker_shares(grid, 2)
    assert len(shares) == 2
    every = np.sort(np.concatenate(shares))
    assert np.array_equal(every, np.arange(len(satrecs)))  # each satellite exactly once
    for ids in grid.groups():
        held = [np.isin(ids, s).sum() for s in shares]
        if len(ids) >= 2 * MIN_SPLIT_SATS:
            assert abs(held[0] - held[1]) <= 1, held  # dealt out evenly
        else:
            assert sorted(held) == [0, len(ids)], held  # whole to one worker


def identical(a, b):
    """Every field of every pass bit for bit the same."""
    assert len(a) == len(b)
    for key in a.dtype.names:
        assert np.array_equal(a[key], b[key]), key


def test_stations_refined_together_match_each_alone(amateur):
    """All stations' brackets are refined and assembled in one pass (in groups sized by the
    memory budget): each station's passes are those of a run with it alone, bit for bit,
    with and without a horizon mask."""
    mask = HorizonMask((0.0, 90.0, 180.0, 270.0), (20.0, 2.0, 2.0, 2.0))
    stations = (DELFT, Station("Masked", 60.2, 24.9, 20.0, 1.0, mask), QUITO,
                Station("Dunedin", -45.9, 170.5, 0.0))
    alone = [run(amateur, stations=(st,)).passes for st in stations]
    for memory_mb in (256.0, 0.2):  # all stations in one group; one group per station
        many = run(amateur, stations=stations, memory_mb=memory_mb).passes
        for k, mine in enumerate(alone):
            mine = mine.copy()
            mine["station"] = k
            identical(many[many["station"] == k], mine)
        assert len(many) == sum(map(len, alone))


def test_streamed_parts_are_the_whole_table(amateur):
    """iter_passes_batch with a tiny memory budget (passes wait in temporary files per span
    of AOS times; passes cut at the 0.3-day block edges joined as blocks finish) gives the
    whole table in order, with its errors and statistics on every part; so does the forked
    path (statistics alike but for the number of chunks)."""
    satrecs, names = amateur
    stations = [DELFT, QUITO]
    end = START + timedelta(days=2.0)
    kw = dict(block_days=0.3, memory_mb=0.1)
    whole = find_passes_batch(satrecs, names, stations, START, end, **kw)
    spans = (whole.passes["los_s"] - whole.passes["aos_s"]) / 86400.0
    assert spans.max() > 0.6  # a pass joined across more than one block edge
    for workers in (1, 2):
        parts = list(iter_passes_batch(satrecs, names, stations, START, end,
                                       workers=workers, **kw))
        assert len(parts) > 3
        identical(np.concatenate([p.passes for p in parts]), whole.passes)
        for p in parts:  # the forked path splits the satellites into more chunks
            assert p.errors == whole.errors
            assert {**p.stats, "chunks": 0} == {**whole.stats, "chunks": 0}
            assert (p.start, p.end, p.names) == (whole.start, whole.end, whole.names)


@pytest.mark.parametrize("memory_mb", [0.0, -1.0, float("nan"), float("inf")])
def test_an_impossible_memory_budget_is_a_clear_error(amateur, memory_mb):
    for finder in (find_passes_batch, lambda *a, **k: list(iter_passes_batch(*a, **k))):
        with pytest.raises(ConfigError, match=r"memory_mb .* is invalid"):
            finder(amateur[0][:2], amateur[1][:2], [DELFT], START, START + timedelta(hours=6),
                   memory_mb=memory_mb)


def test_compiled_kernels_memory_counts_against_the_budget(amateur, monkeypatch):
    """The kernels' own resident memory leaves less of ``memory_mb`` for the arrays: more,
    smaller chunks, the same passes."""
    from tracker.batch import kernels

    monkeypatch.setattr(kernels, "runtime_mb", lambda: 0.0)
    plain = run(amateur, memory_mb=2.0)
    monkeypatch.setattr(kernels, "runtime_mb", lambda: 1.5)
    counted = run(amateur, memory_mb=2.0)
    assert counted.stats["chunks"] > plain.stats["chunks"]
    assert np.array_equal(counted.passes, plain.passes)


def test_a_whole_result_is_held_once(amateur):
    """The streamed result comes sorted in the array it was gathered in; concat of one part
    and select_passes keeping every pass add no copy."""
    from tracker.batch import PassTable, select_passes

    args = (*amateur, [DELFT], START, START + timedelta(days=1))
    (part,) = iter_passes_batch(*args)
    order = np.lexsort((part.passes["station"], part.passes["sat"], part.passes["aos_s"]))
    assert np.array_equal(order, np.arange(len(part)))
    assert PassTable.concat([part]) is part
    assert np.shares_memory(select_passes(part).passes, part.passes)
    fewer = select_passes(part, 30.0)
    assert 0 < len(fewer) < len(part) and not np.shares_memory(fewer.passes, part.passes)
    assert np.array_equal(find_passes_batch(*args).passes, part.passes)
