"""Code-health checks as tests, so CI enforces them: ruff (style, complexity), import-linter
(the import contracts in pyproject.toml) and mypy (the typed modules in pyproject.toml).

Each runs as a subprocess on this checkout (the repository root above this file), with the
same interpreter as the tests. A check whose tool is not installed is skipped, naming the
package to install (all three are in the ``[test]`` extra).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _run(args: list[str], timeout_s: float = 300.0) -> subprocess.CompletedProcess:
    # The checkout under test first on the path, whatever an editable install points at.
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=timeout_s)


def _need(module: str, package: str) -> None:
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{package} is not installed (pip install -e '.[test]')")


def _assert_clean(result: subprocess.CompletedProcess, tool: str) -> None:
    assert result.returncode == 0, (f"{tool} failed (exit {result.returncode}):\n"
                                    f"{result.stdout}\n{result.stderr}")


def test_ruff_is_clean():
    _need("ruff", "ruff")
    _assert_clean(_run(["-m", "ruff", "check", "--no-cache", "."]), "ruff check .")


def test_import_contracts_hold():
    _need("importlinter", "import-linter")
    # import-linter has no __main__ module; its console script calls this click command.
    code = "from importlinter.cli import lint_imports_command; lint_imports_command()"
    _assert_clean(_run(["-c", code, "--no-cache", "--no-logo"]), "lint-imports")


def test_typed_modules_pass_mypy(tmp_path):
    _need("mypy", "mypy")
    result = _run(["-m", "mypy", "--cache-dir", str(tmp_path / "mypy-cache")])
    _assert_clean(result, "mypy")
