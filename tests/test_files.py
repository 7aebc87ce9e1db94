"""The one output writer (tracker.files) and every command that writes a file through it:
links written through, special files refused, no overwrite without --force, unique temporary
names, nothing left behind on failure."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import tempfile

import pytest
from _paths import REPO

from tracker.cli import main
from tracker.errors import ConfigError
from tracker.files import check_output, write_atomic

TLE = str(REPO / "tests" / "data" / "steptable_iss.tle")
AT = ["--at", "2026-08-23T02:00:00Z"]
WHERE = ["--lat", "52", "--lon", "4.5"]


def _one_line_exit_2(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tracker: error: ") and "\n" not in err, err
    return err


# The writer -------------------------------------------------------------------------------


def test_symlink_is_written_through_and_kept(tmp_path):
    target = tmp_path / "real.csv"
    target.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    write_atomic(link, "new\n", force=True)
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new\n"
    # A dangling link creates its target.
    dangling = tmp_path / "dangling.csv"
    dangling.symlink_to(tmp_path / "made.csv")
    write_atomic(dangling, "x\n")
    assert dangling.is_symlink() and (tmp_path / "made.csv").read_text() == "x\n"


def test_existing_file_needs_force(tmp_path):
    out = tmp_path / "passes.csv"
    out.write_text("mine\n")
    with pytest.raises(ConfigError, match=r"already exists.*force=True"):
        write_atomic(out, "new\n")
    assert out.read_text() == "mine\n"
    link = tmp_path / "link.csv"
    link.symlink_to(out)
    with pytest.raises(ConfigError, match="already exists"):
        write_atomic(link, "new\n")
    assert out.read_text() == "mine\n" and sorted(p.name for p in tmp_path.iterdir()) == [
        "link.csv", "passes.csv"]


@pytest.mark.parametrize("make, kind", [
    (lambda p: p.mkdir(), "a directory"),
    (lambda p: os.mkfifo(p), "a FIFO"),
])
def test_special_files_are_refused_even_with_force(tmp_path, make, kind):
    dest = tmp_path / "out"
    make(dest)
    for force in (False, True):
        with pytest.raises(ConfigError, match=f"is {kind}"):
            write_atomic(dest, "x\n", force=force)
    mode = os.lstat(dest).st_mode
    assert stat.S_ISDIR(mode) or stat.S_ISFIFO(mode)
    # A link to the special file is refused the same way.
    link = tmp_path / "link"
    link.symlink_to(dest)
    with pytest.raises(ConfigError, match=f"is {kind}"):
        write_atomic(link, "x\n", force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "out"]


def test_character_device_is_refused():
    with pytest.raises(ConfigError, match="is a character device"):
        check_output("/dev/null", force=True)


def test_missing_folder_and_file_as_folder(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        write_atomic(tmp_path / "nope" / "x.csv", "x")
    afile = tmp_path / "afile"
    afile.write_text("keep\n")
    with pytest.raises(ConfigError, match=r"is a file, not a folder|is not a folder"):
        write_atomic(afile / "x.csv", "x")
    assert afile.read_text() == "keep\n"


def test_temporary_name_is_unique_and_a_user_tmp_file_is_untouched(tmp_path):
    out = tmp_path / "plan.steps"
    (tmp_path / "plan.steps.tmp").write_text("the user's own\n")
    write_atomic(out, "x\n")
    assert (tmp_path / "plan.steps.tmp").read_text() == "the user's own\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.steps", "plan.steps.tmp"]


def test_unwritable_folder_is_one_clear_error(tmp_path, monkeypatch):
    # As root a chmod'ed folder stays writable, so the EACCES from creating the temporary file
    # is injected; the test below covers the real permission check when not root.
    def refuse(*_a, **_k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(ConfigError, match=r"cannot write in folder .*Permission denied"):
        write_atomic(tmp_path / "x.csv", "x")


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write in any folder")
def test_unwritable_folder_for_a_user(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        with pytest.raises(ConfigError, match="Permission denied"):
            write_atomic(folder / "x.csv", "x")
    finally:
        folder.chmod(0o755)


def test_a_write_that_fails_midway_keeps_the_old_file_and_no_temp(tmp_path):
    # A file size limit (like a full disk) makes the write fail after the temporary file was
    # created: the old output stays whole and the temporary file is removed.
    out = tmp_path / "big.csv"
    out.write_text("old\n")
    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))\n"
            "from tracker.files import write_atomic\n"
            "from tracker.errors import ConfigError\n"
            "try:\n"
            "    write_atomic(sys.argv[1], 'x' * 100000, force=True)\n"
            "except ConfigError as e:\n"
            "    print(e)\n")
    r = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=60)
    assert "cannot write (File too large)" in r.stdout, r.stdout + r.stderr
    assert out.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["big.csv"]


# The commands -----------------------------------------------------------------------------


def test_batch_out_refuses_existing_file_and_force_replaces(tmp_path, capsys):
    out = tmp_path / "passes.csv"
    out.write_text("mine\n")
    argv = ["batch", TLE, *WHERE, *AT, "--days", "0.1",
            "--format", "csv", "--out", str(out)]
    err = _one_line_exit_2(capsys, argv)
    assert "already exists" in err and "--force" in err and out.read_text() == "mine\n"
    assert main([*argv, "--force"]) == 0
    assert out.read_text().startswith("target,")


def test_batch_out_to_a_fifo_or_directory_is_refused(tmp_path, capsys):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    err = _one_line_exit_2(capsys, ["batch", TLE, *WHERE, *AT,
                                    "--out", str(fifo), "--force"])
    assert "FIFO" in err and stat.S_ISFIFO(os.lstat(fifo).st_mode)
    err = _one_line_exit_2(capsys, ["schedule", TLE, *WHERE, *AT,
                                    "--out", str(tmp_path), "--force"])
    assert "is a directory" in err


def test_batch_out_writes_through_a_symlink(tmp_path, capsys):
    real = tmp_path / "real.csv"
    real.write_text("old\n")
    link = tmp_path / "link.csv"
    link.symlink_to(real)
    assert main(["batch", TLE, *WHERE, *AT, "--days", "0.1",
                 "--format", "csv", "--out", str(link), "--force"]) == 0
    assert link.is_symlink() and real.read_text().startswith("target,")


@pytest.mark.parametrize("where, expect", [
    ("missing/iss.steps", "does not exist"),
    (".", "is a directory"),
    ("afile/iss.steps", "not a folder"),
    ("exists.steps", "already exists"),
])
def test_plan_steptable_bad_paths(tmp_path, capsys, where, expect):
    (tmp_path / "afile").write_text("keep\n")
    (tmp_path / "exists.steps").write_text("keep\n")
    err = _one_line_exit_2(capsys, ["plan", "ISS", "--tle", TLE, *WHERE, *AT, "--steptable",
                                    str(tmp_path / where)])
    assert expect in err
    assert (tmp_path / "exists.steps").read_text() == "keep\n"


def test_plan_steptable_force_and_no_fixed_tmp_name(tmp_path, capsys):
    f = tmp_path / "iss.steps"
    f.write_text("old\n")
    (tmp_path / "iss.steps.tmp").write_text("the user's own\n")
    assert main(["plan", "ISS", "--tle", TLE, *WHERE, *AT, "--steptable", str(f), "--force"]) == 0
    assert f.read_text().startswith("# tracker step table")
    assert (tmp_path / "iss.steps.tmp").read_text() == "the user's own\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["iss.steps", "iss.steps.tmp"]


def test_config_init_paths(tmp_path, capsys):
    (tmp_path / "afile").write_text("keep\n")
    err = _one_line_exit_2(capsys, ["config", "init", "--config",
                                    str(tmp_path / "afile" / "c.toml")])
    assert "cannot create folder" in err or "not a folder" in err
    err = _one_line_exit_2(capsys, ["config", "init", "--config", str(tmp_path)])
    assert "is a directory" in err
    cfg = tmp_path / "c.toml"
    (tmp_path / "c.toml.tmp").write_text("the user's own\n")
    assert main(["config", "init", "--config", str(cfg)]) == 0
    assert (tmp_path / "c.toml.tmp").read_text() == "the user's own\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "c.toml", "c.toml.tmp"]


def test_config_init_in_a_folder_it_may_not_write(tmp_path, capsys, monkeypatch):
    # `config init --config /root/c.toml` as a user: creating the temporary file fails with
    # EACCES (injected here, since root may write anywhere).
    def refuse(*_a, **_k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    err = _one_line_exit_2(capsys, ["config", "init", "--config", str(tmp_path / "c.toml")])
    assert "cannot write in folder" in err and "Permission denied" in err
    assert list(tmp_path.iterdir()) == []


def test_outputs_are_checked_before_the_work(tmp_path, capsys):
    # An existing --plot is refused before the plan is computed or printed.
    png = tmp_path / "sky.png"
    png.write_bytes(b"mine")
    assert main(["plan", "ISS", "--tle", TLE, *WHERE, *AT, "--plot", str(png)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "--plot" in captured.err and "already exists" in captured.err
    assert png.read_bytes() == b"mine"
    err = _one_line_exit_2(capsys, ["batch", TLE, *WHERE, *AT, "--plot", str(png)])
    assert "already exists" in err and png.read_bytes() == b"mine"
