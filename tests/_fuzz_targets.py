"""Fuzz targets shared by the hypothesis tests (``test_fuzz_*.py``) and ``benchmarks/fuzz.py``.

Each :class:`Target` takes arbitrary bytes and either returns, raises one of its documented
``allowed`` errors, or fails (any other exception, or an AssertionError from a liveness check
such as "the emulator still answers C2"). ``seeds`` are valid inputs that mutations start
from, so most inputs are *near-valid* and reach deep into the parsers.
"""

from __future__ import annotations

import atexit
import os
import random
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from tle.errors import TleError
from tracker.errors import ConfigError, LimitError, PropagationError, ProtocolError

DATA = Path(__file__).parent / "data"
T0 = "2026-08-23T12:00:00+00:00"


@dataclass
class Target:
    name: str
    run: Callable[[bytes], object]
    seeds: list[bytes]
    allowed: tuple[type[BaseException], ...] = ()
    tokens: list[bytes] = field(default_factory=list)


def _text(data: bytes) -> str:
    return data.decode("utf-8", "replace")


# Reply parsers -----------------------------------------------------------------------------


def _gs232_parsers(data: bytes) -> None:
    from tracker.protocols import gs232

    for fn in (gs232.parse_position, gs232.parse_elevation, gs232.parse_table_status):
        try:
            out = fn(data)
        except ProtocolError as e:
            assert e.raw == data
            continue
        assert out is not None
    assert gs232.is_error_reply(data) in (True, False)


def _framer(data: bytes) -> None:
    from tracker.protocols.framing import LineFramer

    # split the input into chunks at bytes < 8 so chunking varies with the data
    f = LineFramer(b"\r\n", ignore=b"\x00", max_line=64)
    whole = LineFramer(b"\r\n", ignore=b"\x00", max_line=1 << 20)
    got: list[bytes] = []
    overrun = False
    chunk = bytearray()
    for b in data:
        chunk.append(b)
        if b < 8:
            try:
                got += f.feed(bytes(chunk))
            except ProtocolError:
                overrun = True
            chunk.clear()
    try:
        got += f.feed(bytes(chunk))
    except ProtocolError:
        overrun = True
    if not overrun:   # chunking never changes the lines
        assert got == whole.feed(data) and f.pending == whole.pending


def _rotorez_parser(data: bytes) -> None:
    from tracker.protocols.rotorez import parse_ai_reply

    for old in (False, True):
        v = parse_ai_reply(data, accept_old=old)
        assert v is None or 0 <= v <= 999


def _rotctld_codes(data: bytes) -> None:
    from tracker.protocols import rotctld

    m = rotctld._RPRT_RE.search(data)
    if m:
        err = rotctld.rprt_error(int(m.group(1)), "fuzz")
        assert isinstance(err, Exception) and str(err)
    try:
        rotctld.rotctld_url(_text(data))
    except ConfigError:
        pass


# Emulators ---------------------------------------------------------------------------------


def _clock():
    from tracker.clock import ManualClock

    return ManualClock(datetime.fromisoformat(T0))


def gs232_emulator_target(profile: str) -> Callable[[bytes], None]:
    from tracker.emulator import Gs232Controller
    from tracker.mount import preset

    def run(data: bytes) -> None:
        clock = _clock()
        ctrl = Gs232Controller(profile, preset("G-5500"), clock, az_deg=100, el_deg=30)
        s = ctrl.open_session()
        # the input in a few chunks with time passing in between
        for i in range(0, len(data), 97):
            s.feed(data[i:i + 97])
            s.poll()
            clock.advance(0.7)
        # leave any dialogue (calibration prompt, F stream, partial line), then ask C2
        s.feed(b"\r\r\r")
        clock.advance(1.0)
        s.poll()
        reply = s.feed(b"C2\r")
        assert b"AZ=" in reply or b"+0" in reply or b"-0" in reply, (profile, reply)
    return run


# What proves a non-GS-232 emulator is still alive after the garbage: (query, reply marker);
# the DCU-1 and the SAK-232 never answer, so for them only "did not raise" is checked.
_ALIVE = {"rotorez": (b"AI1;", b";"), "dcu1": (b"AI1;", b""), "sak232": (b"C\r", b""),
          "gs232b-azaz": (b"C2\r", b"AZ=")}


def other_emulator_target(protocol: str) -> Callable[[bytes], None]:
    from tracker.emulator.factory import make_emulator

    def run(data: bytes) -> None:
        clock = _clock()
        ctrl = make_emulator(protocol, clock)
        s = ctrl.open_session()
        for i in range(0, len(data), 97):
            s.feed(data[i:i + 97])
            s.poll()
            clock.advance(0.7)
        s.feed(b";\r\r")
        clock.advance(1.0)
        s.poll()
        query, marker = _ALIVE[protocol]
        reply = s.feed(query)
        assert marker in reply, (protocol, reply)
        assert ctrl.status_line()
    return run


# Files: TLE, OMM, config, schedule, horizon mask, fault specs ------------------------------


def _tle(data: bytes) -> None:
    from tle.elements import parse_text

    try:
        sets = parse_text(_text(data), "<fuzz>")
    except TleError:
        return
    for es in sets:
        assert es.name is not None


def _tle_skip_bad(data: bytes) -> None:
    import warnings

    from tle.elements import parse_text

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            parse_text(_text(data), "<fuzz>", skip_bad=True, on_warning=lambda m: None)
        except TleError:
            return


# Exceptions known to escape a target (documented bugs) are tolerated here so fuzz runs keep
# looking for *new* problems. Empty: the csv.Error / LookupError / ValueError escapes this
# fuzzing found in tle/omm.py and tle/elements.py are fixed (regressions: test_fuzz_parsers).
KNOWN_ESCAPES: dict[str, tuple[type[BaseException], ...]] = {}


def _omm(kind: str) -> Callable[[bytes], None]:
    def run(data: bytes) -> None:
        from tle import omm

        fn = {"json": omm.parse_omm_json, "csv": omm.parse_omm_csv,
              "xml": omm.parse_omm_xml}[kind]
        fn(_text(data), "<fuzz>")
    return run


# config and mask parsers read files; /dev/shm keeps 100k writes from hitting the disk
_TMP = Path(tempfile.mkdtemp(prefix="tracker-fuzz-",
                             dir="/dev/shm" if Path("/dev/shm").is_dir() else None))
atexit.register(shutil.rmtree, _TMP, True)


def _config(data: bytes) -> None:
    from tracker.config import load_config

    p = _TMP / "config.toml"
    p.write_bytes(data)
    load_config(p)


def _schedule(data: bytes) -> None:
    from tracker.pointing_file import ScheduleTarget

    t = ScheduleTarget.from_text(_text(data))
    assert len(t.t_s) >= 2


def _mask(data: bytes) -> None:
    from tracker.station import HorizonMask

    p = _TMP / "mask.txt"
    p.write_bytes(data)
    m = HorizonMask.load(p)
    assert m.az_deg


def _plan_file(data: bytes) -> None:
    """A step-table plan file (``tracker plan --steptable``), as ``tracker upload`` reads it."""
    from tracker.steptable import read_plan_file

    p = _TMP / "pass.steps"
    p.write_bytes(data)
    plan = read_plan_file(p)
    assert plan.tables and all(t.lines() for t in plan.tables)


def _priorities(data: bytes) -> None:
    """``tracker schedule --priorities FILE`` and ``--priority NAME=N`` items."""
    from tracker.pass_schedule import parse_priorities

    p = _TMP / "priorities.txt"
    p.write_bytes(data)
    out = parse_priorities([], p)
    out.update(parse_priorities(_text(data).splitlines()[:2]))
    assert all(isinstance(v, int) and v >= 0 for v in out.values())


def _stations(data: bytes) -> None:
    """``tracker batch --stations FILE``: CSV or TOML, the format chosen by the content."""
    from tracker.batch import load_stations

    for suffix in (".csv", ".toml"):
        p = _TMP / f"stations{suffix}"
        p.write_bytes(data)
        try:
            stations = load_stations(p)
        except ConfigError:
            continue
        assert all(-90 <= s.lat_deg <= 90 for s in stations)


def _plan_seed() -> bytes:
    from tracker.geometry import MountPath
    from tracker.mount import preset
    from tracker.steptable import compile_program, format_plan_file
    from tracker.testing import synthetic_pass

    spec = preset("G-5500")
    track = synthetic_pass(40.0, 100.0, 300.0, pad_s=10.0)
    prog = compile_program(MountPath.from_track(track, spec), spec, "gs232b", interval_s=10)
    return format_plan_file(prog).encode()


def _station():
    from tracker.station import Station

    return Station("fuzz", 52.0, 4.4, 10.0)


def _omm_propagate(data: bytes) -> None:
    """OMM JSON through to propagation: whatever numbers parse (extremes included) must
    propagate near the epoch and over a pass search, or be refused with a typed error."""
    from tle import omm
    from tracker.passes import find_passes
    from tracker.targets import SatelliteTarget

    for es in omm.parse_omm_json(_text(data), "<fuzz>")[:2]:
        target = SatelliteTarget(es)
        epoch_s = es.epoch.timestamp()
        track = target.observe(_station(), epoch_s + np.array([0.0, 600.0, 86_400.0]))
        assert track.el_deg.shape == (3,)
        find_passes(target, _station(), epoch_s, epoch_s + 3 * 3600.0)


def _far_epoch(data: bytes) -> None:
    """A satellite asked about any time at all (from an ``--at`` text or raw seconds): passes
    near its epoch, a typed refusal far from it, and never minutes of work."""
    import struct
    import time

    from tracker.commands._common import parse_utc
    from tracker.passes import find_passes

    target = _iss()
    text = _text(data)
    try:
        start_s = parse_utc(text).timestamp()
    except ConfigError:
        raw = struct.unpack("<d", data[:8].ljust(8, b"\0"))[0]
        start_s = target.epoch_s + raw
    end_s = start_s + 2 * 3600.0
    t0 = time.perf_counter()
    try:
        find_passes(target, _station(), start_s, end_s)
    except ValueError:  # an empty window (inf, nan, or 2 h lost in rounding): the caller's bug
        if end_s > start_s:
            raise
    assert time.perf_counter() - t0 < 30.0, "a pass search ran for minutes"


def _iss():
    from tle.elements import load_file
    from tracker.targets import SatelliteTarget

    global _ISS
    if _ISS is None:
        es = next(e for e in load_file(DATA / "passes_sats.tle") if e.norad_id == 25544)
        _ISS = SatelliteTarget(es)
    return _ISS


_ISS = None

# Special files every file reader must refuse at once (never block, never read for ever).
_SPECIAL = ("fifo", "dev-zero", "dev-null", "directory", "link-to-fifo", "oversized",
            "regular")


def _special_file(data: bytes) -> Path:
    kind = _SPECIAL[data[0] % len(_SPECIAL)] if data else "regular"
    base = _TMP / f"special-{kind}"
    if base.is_symlink() or base.is_file():
        base.unlink()
    if kind == "fifo":
        if not base.exists():
            os.mkfifo(base)
    elif kind == "dev-zero":
        return Path("/dev/zero")
    elif kind == "dev-null":
        return Path("/dev/null")
    elif kind == "directory":
        base.mkdir(exist_ok=True)
    elif kind == "link-to-fifo":
        fifo = _TMP / "special-fifo"
        if not fifo.exists():
            os.mkfifo(fifo)
        base.symlink_to(fifo)
    elif kind == "oversized":
        with open(base, "wb") as f:   # sparse: 5 MiB of size, nothing written
            f.truncate(5 << 20)
    else:
        base.write_bytes(data[1:])
    return base


def _file_readers(data: bytes) -> None:
    """Every reader of a user-named file on FIFOs, devices, directories, links, huge files."""
    from tle.elements import load_file
    from tracker.batch import load_stations
    from tracker.config import load_config
    from tracker.pass_schedule import parse_priorities
    from tracker.pointing_file import ScheduleTarget
    from tracker.station import HorizonMask
    from tracker.steptable import read_plan_file

    path = _special_file(data)
    readers = (load_file, HorizonMask.load, load_config, lambda p: parse_priorities([], p),
               read_plan_file, load_stations, ScheduleTarget.load)
    for read in readers:
        try:
            read(path)
        except (ConfigError, TleError, LimitError):
            pass


def _fault_spec(data: bytes) -> None:
    from tracker.emulator.faults import parse_fault

    parse_fault(_text(data))


def _encoders(data: bytes) -> None:
    """Random numbers into the GS-232 encoders: bytes out or LimitError, nothing else."""
    import struct

    from tracker.protocols.gs232_codec import encode_goto, encode_table

    vals = [struct.unpack("<d", data[i:i + 8].ljust(8, b"\0"))[0]
            for i in range(0, max(len(data), 1), 8)][:8]
    try:
        out = encode_goto(vals[0], vals[1] if len(vals) > 1 else None)
        assert out.endswith(b"\r")
    except LimitError:
        pass
    try:
        encode_table(int(vals[0]) if abs(vals[0]) < 1e6 else 1, vals[1:] or [0.0])
    except (LimitError, ValueError, OverflowError):
        pass


# Seeds -------------------------------------------------------------------------------------


def _read(p: Path) -> bytes:
    return p.read_bytes() if p.exists() else b""


def _transcript_bytes(name: str) -> list[bytes]:
    out = []
    for line in _read(DATA / "transcripts" / name).decode().splitlines():
        if line.startswith((">>", "<<")):
            import codecs

            out.append(codecs.escape_decode(line[3:].encode())[0])
    return [b for b in out if b]


def _seeds_replies() -> list[bytes]:
    return [b"AZ=123  EL=045", b"AZ=123 EL=045", b"AZ=123EL=045", b"+0123+0045", b"+0123",
            b"AZ=-001  EL=-002", b"EL=045", b"+0001+0020", b"=0001=0020", b"20", b"?>",
            b"AI1;", b";123", b"123;", b"RPRT -8\n", b"RPRT 0\n", b"127.0.0.1:4533"]


def _tle_seed() -> bytes:
    lines = _read(DATA / "tle" / "amateur5.txt").splitlines()
    return b"\n".join(lines[:9]) + b"\n"


def _json_seed() -> bytes:
    import json

    records = json.loads(_read(DATA / "tle" / "amateur5.json") or b"[]")
    return json.dumps(records[:2], indent=1).encode()


def _config_seed() -> bytes:
    from tracker.config import template_text

    return template_text().encode()


TOKENS = [b"\r", b"\n", b" ", b"0", b"9", b"-", b"+", b".", b"e", b"=", b",", b";", b"#",
          b"nan", b"inf", b"999", b"-1", b"1e308", b"AZ=", b"EL=", b"W", b"M", b"C2", b"T",
          b"N", b"O", b"F", b"Y", b"[", b"]", b"{", b"}", b'"', b"<", b">", b"\x00", b"\xff",
          b"\xc3\xa9", b"\t", b"1 ", b"2 ", b"  "]


# Numbers at the edges of what parsers accept, and nesting deeper than json recurses.
NUMBER_TOKENS = [b"1e300", b"-1e300", b"1e-300", b"inf", b"-inf", b"NaN", b"0.0", b"17.9",
                 b"9999-12-31T00:00:00", b"0001-01-01T00:00:00", b"1900-01-01T00:00:00",
                 b"2099-12-31T23:59:59", b"4294967296", b"12345678901234567890"]
NESTING_TOKENS = [b"[" * 5000, b'{"a":' * 3000, b"[{" * 2000]


def targets() -> list[Target]:
    sched = _read(DATA / "schedule_sweep.csv") or (
        b"time_utc, az_deg, el_deg\n2026-08-22T18:00:00Z, 10, 20\n"
        b"2026-08-22T18:01:00Z, 20, 30\n")
    gs_cmds = [b"C2\r", b"W180 045\r", b"M005 010 020 030\r", b"T\r", b"N\r", b"O\rY\r",
               b"F\r\r", b"H\r", b"P45\r", b"Z\r", b"X3\r", b"R\rL\rS\r",
               b"W002 010 020 030 040\rT\r"]
    gs_cmds += [b for b in _transcript_bytes("gs232b.txt") if not b.startswith((b"AZ", b"+"))]
    rz_cmds = [b"AI1;", b"AP1180\r", b"AP1090;AM1;", b";", b"S;"]
    rz_cmds += _transcript_bytes("rotorez.transcript")
    ts = [
        Target("gs232.parse_*", _gs232_parsers, _seeds_replies(), (), TOKENS),
        Target("framing.LineFramer", _framer, [b"AZ=1\r\nEL=2\r", b"\x01ab\r\x02c\n"], (),
               TOKENS),
        Target("rotorez.parse_ai_reply", _rotorez_parser, [b"AI1;", b";123", b"123;",
                                                           b"\xe0Rotor-EZ;123"], (), TOKENS),
        Target("rotctld.replies", _rotctld_codes, [b"RPRT -8\n", b"RPRT 0\n",
                                                   b"127.0.0.1:4533"], (), TOKENS),
        Target("encode_goto/table", _encoders, [b"\x00" * 16, bytes(range(32))], (), []),
    ]
    for prof in ("gs232a", "gs23", "gs232b", "gs232b-manual", "k3ng"):
        ts.append(Target(f"emulator.{prof}", gs232_emulator_target(prof), gs_cmds, (), TOKENS))
    for proto in _ALIVE:
        seeds = rz_cmds if proto in ("rotorez", "dcu1") else _transcript_bytes(
            "sak232.transcript" if proto == "sak232" else "azaz.transcript")
        ts.append(Target(f"emulator.{proto}", other_emulator_target(proto), seeds or rz_cmds,
                         (), TOKENS))
    ts += [
        Target("tle.parse_text", _tle, [_tle_seed()], (TleError,), TOKENS),
        Target("tle.parse_text(skip_bad)", _tle_skip_bad, [_tle_seed()], (TleError,), TOKENS),
        Target("omm.json", _omm("json"), [_json_seed()], (TleError,),
               [*TOKENS, *NUMBER_TOKENS, *NESTING_TOKENS]),
        Target("omm.csv", _omm("csv"), [b"\n".join(
            _read(DATA / "tle" / "amateur5.csv").splitlines()[:3])],
               (TleError, *KNOWN_ESCAPES.get("omm.csv", ())), TOKENS),
        Target("omm.xml", _omm("xml"), [_read(DATA / "tle" / "amateur5.xml")],
               (TleError, *KNOWN_ESCAPES.get("omm.xml", ())), TOKENS),
        Target("config.load_config", _config, [_config_seed()], (ConfigError,), TOKENS),
        Target("schedule.parse", _schedule, [sched], (ConfigError,), TOKENS),
        Target("station.HorizonMask.load", _mask, [b"0 5\n90 10\n180, 3 # x\n270 0\n"],
               (ConfigError,), TOKENS),
        # LimitError: a table angle outside what the controller accepts (e.g. el 936)
        Target("steptable.read_plan_file", _plan_file, [_plan_seed()],
               (ConfigError, LimitError),
               [*TOKENS, b"# table 1/1 ", b"upload_utc=", b"t_utc=", b"W010 ", b"M010 ",
                b"\nT\n", b"2026-08-22T11:57:25.000Z"]),
        Target("schedule.parse_priorities", _priorities,
               [b"ISS=5\nAO-91=2\nAO-7, 1 # fm\n\"SO-50\"=0\n"], (ConfigError,), TOKENS),
        Target("batch.load_stations", _stations,
               [b"name,lat,lon,alt\nJO22,52.0,4.4,10\nFN42,42.4,-71.1,50\n",
                b'[[station]]\nname = "JO22"\nlat = 52.0\nlon = 4.4\nalt = 10\n'],
               (), TOKENS),
        Target("omm.json->propagation", _omm_propagate, [_json_seed()],
               (TleError, PropagationError), [*TOKENS, *NUMBER_TOKENS, *NESTING_TOKENS]),
        Target("far epochs", _far_epoch,
               [b"2026-08-23T00:00Z", b"1900-01-01", b"0001-01-01", b"9999-12-31T23:59Z",
                b"2028-08-23", b"2024-08-21T12:00Z", b"", b"\x00" * 8],
               (ConfigError, PropagationError), [*TOKENS, *NUMBER_TOKENS]),
        Target("file readers on special files", _file_readers,
               [bytes([i]) + b"0 5\n90 10\n" for i in range(len(_SPECIAL))], (), TOKENS),
        Target("faults.parse_fault", _fault_spec, [b"drop=0.01", b"silent=30@120",
                                                   b"jam=el:30@60", b"drift=-0.5%"],
               (ConfigError,), TOKENS),
    ]
    return ts


def mutate(rng: random.Random, seed: bytes, tokens: list[bytes], max_ops: int = 8) -> bytes:
    """A near-valid input: ``seed`` with a few random edits (flip, insert, delete, splice)."""
    b = bytearray(seed)
    for _ in range(rng.randint(1, max_ops)):
        op = rng.random()
        pos = rng.randint(0, len(b))
        if op < 0.25 and b:
            b[min(pos, len(b) - 1)] = rng.randrange(256)
        elif op < 0.45 and tokens:
            b[pos:pos] = rng.choice(tokens)
        elif op < 0.6 and b:
            del b[pos:pos + rng.randint(1, 8)]
        elif op < 0.7 and b:
            seg = b[pos:pos + rng.randint(1, 16)]
            b[pos:pos] = seg * rng.randint(1, 4)
        elif op < 0.8:
            b[pos:pos] = bytes(rng.randrange(48, 58) for _ in range(rng.randint(1, 6)))
        else:
            b[pos:pos] = bytes(rng.randrange(32, 127) for _ in range(rng.randint(1, 4)))
    return bytes(b)


def random_input(rng: random.Random, target: Target) -> bytes:
    """Half near-valid mutations of a seed, a quarter random bytes, a quarter token soup."""
    r = rng.random()
    if r < 0.5 and target.seeds:
        return mutate(rng, rng.choice(target.seeds), target.tokens)
    if r < 0.75 or not target.tokens:
        return bytes(rng.randrange(256) for _ in range(rng.randint(0, 64)))
    return b"".join(rng.choice(target.tokens) for _ in range(rng.randint(0, 24)))


def check(target: Target, data: bytes) -> BaseException | None:
    """Run one input; None if it passed or raised an allowed error, else the exception."""
    try:
        target.run(data)
    except target.allowed:
        return None
    except Exception as e:
        return e
    return None


def hypothesis_inputs(target: Target):
    """The hypothesis strategy the CI tests and ``benchmarks/fuzz.py --engine hypothesis``
    draw from: near-valid mutations of a seed (hypothesis picks the edit script), raw bytes,
    and a soup of protocol tokens."""
    from hypothesis import strategies as st

    pick = st.tuples(st.integers(0, 10**6), st.integers(0, 10**6))
    near = pick.map(lambda sr: mutate(random.Random(sr[1]),
                                      target.seeds[sr[0] % len(target.seeds)],
                                      target.tokens))
    soup = st.lists(st.sampled_from(target.tokens or TOKENS), max_size=24).map(b"".join)
    return st.one_of(near, st.binary(max_size=200), soup) if target.seeds else \
        st.one_of(st.binary(max_size=200), soup)
