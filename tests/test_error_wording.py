"""Library errors describe the problem; only the CLI (tracker/cli.py, tracker/commands/)
names command-line flags. A library message ending in advice words it in Python terms
(parameters, functions) with ``with_advice``; the command that called it puts the flags in."""

from __future__ import annotations

import ast
import re

import pytest
from _paths import REPO

from tle.errors import AdvisedError, TleError
from tracker.errors import ConfigError, with_advice

FLAG = re.compile(r"(?:^|[\s(`'\"])--[a-z]")
CLI_PARTS = ("tracker/cli.py", "tracker/commands/")


def _library_modules(root):
    for package in ("tracker", "tle"):
        for path in sorted((root / package).rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            if not rel.startswith(CLI_PARTS):
                yield rel, path


def _message_calls(tree: ast.AST):
    """Calls that build an error message: whatever a ``raise`` raises, every ``with_advice``
    and every ``...Error(...)`` (an error built to be returned and raised elsewhere)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Raise) and node.exc is not None:
            yield node.exc
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else getattr(func, "attr", "")
            if name == "with_advice" or name.endswith("Error"):
                yield node


def _strings(node: ast.AST):
    for sub in ast.walk(node):
        if isinstance(sub, ast.Constant) and isinstance(sub.value, str):
            yield sub


def flags_in_library_errors(root=REPO) -> list[str]:
    found = set()
    for rel, path in _library_modules(root):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=rel)
        for call in _message_calls(tree):
            for const in _strings(call):
                if FLAG.search(const.value):
                    found.add(f"{rel}:{const.lineno}: {const.value.strip()!r}")
    return sorted(found)


def test_library_errors_name_no_flags():
    found = flags_in_library_errors()
    assert not found, ("library error messages name command-line flags (word the advice "
                       "in parameters with with_advice; let the command add the flag):\n"
                       + "\n".join(found))


def test_the_scan_finds_a_flag(tmp_path):
    # the scan must be able to fail: a module raising with a flag in its message is named
    fake = tmp_path / "tracker"
    fake.mkdir()
    (fake / "bad.py").write_text('def f(x):\n'
                                 '    raise ValueError(f"{x} is wrong; use --port URL")\n')
    (fake / "cli.py").write_text('raise SystemExit("see --help")\n')
    (tmp_path / "tle").mkdir()
    (fake / "commands").mkdir()
    (fake / "commands" / "c.py").write_text('raise ValueError("give --lat")\n')
    assert flags_in_library_errors(tmp_path) == ["tracker/bad.py:2: 'is wrong; use --port URL'"]


def test_advise_replaces_only_the_advice():
    e = with_advice(ConfigError, "file x: no tables", "; write one with write_plan_file()")
    assert str(e) == "file x: no tables; write one with write_plan_file()"
    assert e.problem == "file x: no tables" and isinstance(e, AdvisedError)
    assert str(e.advise("; run `tracker plan`")) == "file x: no tables; run `tracker plan`"
    plain = ConfigError("the whole message")
    assert str(plain.advise("; never added")) == "the whole message"
    tle_error = with_advice(TleError, "cache unreadable", " (see cache_dir)")
    assert tle_error.advice == " (see cache_dir)" and isinstance(tle_error, ValueError)


@pytest.mark.parametrize("flag_first_args, message, expected", [
    (("link", "--link"), "link /tmp/x is a directory", "--link /tmp/x is a directory"),
    (("link", "--link"), "linking failed", "linking failed"),
])
def test_flag_first(flag_first_args, message, expected):
    from tracker.commands._common import flag_first

    assert str(flag_first(ConfigError(message), *flag_first_args)) == expected


def test_the_cli_puts_its_flags_into_the_advice(tmp_path, capsys):
    from tracker.cli import main

    missing = tmp_path / "missing.toml"
    assert main(["config", "show", "--config", str(missing)]) == 2
    err = capsys.readouterr().err
    assert err == (f"tracker: error: config file {missing} does not exist; create it with "
                   f"`tracker config init --config {missing}`\n")
