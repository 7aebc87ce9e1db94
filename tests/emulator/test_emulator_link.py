"""``tracker emulate --pty --link PATH`` never deletes what the user has at PATH: only a
symlink to a pty (one the emulator made) is replaced; the temporary link name is unique."""

from __future__ import annotations

import os
from datetime import datetime

import pytest
from _gs232_helpers import T0

from tracker.cli import main
from tracker.clock import SimClock
from tracker.emulator import Gs232Controller, serve_pty
from tracker.errors import ConfigError
from tracker.mount import preset


def _controller() -> Gs232Controller:
    return Gs232Controller("gs232b", preset("G-5500"), SimClock(datetime.fromisoformat(T0)))


def _one_line_exit_2(capsys, link: str) -> str:
    assert main(["emulate", "--pty", "--link", link, "--duration", "0.1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tracker: error: --link") and "\n" not in err, err
    return err


def test_existing_file_is_refused_and_kept(tmp_path, capsys):
    path = tmp_path / "ttyEMU0"
    path.write_text("the user's file\n")
    assert "an existing file" in _one_line_exit_2(capsys, str(path))
    assert path.read_text() == "the user's file\n"


def test_directory_and_missing_folder_are_refused(tmp_path, capsys):
    folder = tmp_path / "dir"
    folder.mkdir()
    (folder / "keep").write_text("x")
    assert "is a directory" in _one_line_exit_2(capsys, str(folder))
    assert (folder / "keep").read_text() == "x"
    assert "does not exist" in _one_line_exit_2(capsys, str(tmp_path / "no" / "ttyEMU0"))
    (tmp_path / "afile").write_text("keep")
    assert "is not a folder" in _one_line_exit_2(capsys, str(tmp_path / "afile" / "tty"))
    assert (tmp_path / "afile").read_text() == "keep"


def test_link_to_a_user_file_is_refused(tmp_path, capsys):
    target = tmp_path / "notes.txt"
    target.write_text("mine\n")
    link = tmp_path / "ttyEMU0"
    link.symlink_to(target)
    assert "not a pty link" in _one_line_exit_2(capsys, str(link))
    assert os.readlink(link) == str(target) and target.read_text() == "mine\n"


def test_stale_pty_link_is_replaced_and_user_new_file_untouched(tmp_path):
    link = tmp_path / "ttyEMU0"
    link.symlink_to("/dev/pts/9999")          # left by an emulator that was killed
    new = tmp_path / "ttyEMU0.new"
    new.write_text("the user's own .new file\n")
    server = serve_pty(_controller(), link=str(link))
    try:
        assert os.readlink(link) == server.device and server.url == str(link)
        assert new.read_text() == "the user's own .new file\n"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["ttyEMU0", "ttyEMU0.new"]
    finally:
        server.close()
    assert not os.path.lexists(link)            # its own link goes with it
    assert new.read_text() == "the user's own .new file\n"


def test_close_leaves_a_link_that_is_no_longer_its_own(tmp_path):
    link = tmp_path / "ttyEMU0"
    server = serve_pty(_controller(), link=str(link))
    try:
        os.unlink(link)
        link.symlink_to(tmp_path / "elsewhere")  # someone else's link now
    finally:
        server.close()
    assert os.readlink(link) == str(tmp_path / "elsewhere")


def test_library_refuses_too(tmp_path):
    path = tmp_path / "f"
    path.write_text("x")
    with pytest.raises(ConfigError, match="not replacing it"):
        serve_pty(_controller(), link=str(path))
    assert path.read_text() == "x"
