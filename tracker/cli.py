"""Command-line entry point: ``tracker SUBCOMMAND ...`` and ``python -m tracker``.

Each subcommand lives in its own module under :mod:`tracker.commands` and exposes
``register(subparsers)``, which adds its parser and sets ``func`` to a callable taking the
parsed arguments and returning an exit code. Modules are discovered, so adding a command never
edits this file. Heavy imports happen inside the command functions so ``--help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence
from typing import NoReturn

import tracker
import tracker.commands
from tracker.errors import OutputExistsError, TrackerError

EXIT_USAGE = 2


class UsageError(Exception):
    """A command line argparse refused; the message is the one line to print."""


class Parser(argparse.ArgumentParser):
    """argparse with the project's error format: one line, and where to read more.

    argparse's own prints the whole usage block first, which buries the line that says what
    is wrong. Subcommand parsers are made of the same class."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"tracker: error: {message} (see '{self.prog} --help')")


def _named_command(argv: Sequence[str]) -> str | None:
    """The command module ``argv`` names (its first word that is not a global option), or None."""
    names = {info.name for info in pkgutil.iter_modules(tracker.commands.__path__)
             if not info.name.startswith("_")}
    words = iter(argv)
    for word in words:
        if word == "--config":
            next(words, None)
        elif not word.startswith("-"):
            word = word.replace("-", "_")     # serve-rotctld is module serve_rotctld
            return word if word in names else None
    return None


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The whole command line; given ``argv`` that names a command, only that command's
    parser is built (each command module imports what it needs: the others need not load)."""
    parser = Parser(
        prog="tracker",
        description="Satellite and celestial pass tracker for GS-232 class antenna rotators.")
    parser.add_argument("--version", action="version", version=f"tracker {tracker.__version__}")
    # Also accepted before the subcommand (``tracker --config F passes``); a subcommand's own
    # --config default would overwrite the same dest, hence a separate one.
    parser.add_argument("--config", metavar="FILE", dest="global_config",
                        help="config file (default: $TRACKER_CONFIG or the user config dir)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    named = _named_command(argv) if argv is not None else None
    for info in sorted(pkgutil.iter_modules(tracker.commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_") or named not in (None, info.name):
            continue
        module = importlib.import_module(f"tracker.commands.{info.name}")
        module.register(sub)
    return parser


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """dest -> its argparse action, over every subcommand (argparse keeps no public list)."""
    found: dict[str, argparse.Action] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                for dest, sub_action in _options(sub).items():
                    found.setdefault(dest, sub_action)
        else:
            found.setdefault(action.dest, action)
    return found


def _refuse_empty_values(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """No option or argument takes an empty string: ``--port ''`` or ``--bind ''`` (which a
    socket reads as every interface) is a script that lost a variable, not a choice. An
    option whose bare form means "" (``--dask`` with no address) is the exception."""
    options: dict[str, argparse.Action] | None = None
    for dest, value in vars(args).items():
        values = value if isinstance(value, list) else [value]
        if not any(isinstance(v, str) and not v.strip() for v in values):
            continue
        options = options or _options(parser)
        action = options.get(dest)
        if action is not None and action.const == "":
            continue
        name = max(action.option_strings, key=len, default=dest) if action else dest
        prog = " ".join(filter(None, ("tracker", getattr(args, "command", None))))
        raise UsageError(f"tracker: error: {name} is empty; give a value (see '{prog} --help')")


# The element store's advice (tle.store) in Python terms -> what the user types instead.
_TLE_FLAG_TERMS = (("call update(force=True)", "run `tracker tle update --force`"),
                   ("force=True", "--force"), ("cache_dir", "--cache-dir"),
                   ("Catalog.load", "--tle FILE"))


def main(argv: Sequence[str] | None = None) -> int:
    from tle.errors import TleError
    from tracker.commands._common import in_flag_terms

    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    try:
        args = parser.parse_args(argv)
        _refuse_empty_values(parser, args)
    except UsageError as e:
        print(e, file=sys.stderr)
        return EXIT_USAGE
    if args.global_config and getattr(args, "config", None) is None:
        args.config = args.global_config
    if not getattr(args, "func", None):
        commands = ", ".join(sorted(name for action in parser._actions
                                    if isinstance(action, argparse._SubParsersAction)
                                    for name in action.choices))
        print(f"tracker: error: give a command: {commands} (see 'tracker --help')",
              file=sys.stderr)
        return EXIT_USAGE
    try:
        return int(args.func(args) or 0)
    except OutputExistsError as e:
        # the library's advice names the parameter; on the command line it is --force
        print(f"tracker: error: {e.problem} (add --force to replace it, or choose another "
              f"name)", file=sys.stderr)
        return EXIT_USAGE
    except TleError as e:
        # the element store's advice names its parameters; on the command line they are these
        print(f"tracker: error: {in_flag_terms(e, _TLE_FLAG_TERMS)}", file=sys.stderr)
        return EXIT_USAGE
    except TrackerError as e:
        print(f"tracker: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt as e:
        # SIGTERM / SIGHUP inside a controller session arrive here as Ctrl-C does (after
        # the session's all-stop), named; the exit code stays the Ctrl-C one.
        name = getattr(e, "signame", None)
        print("tracker: interrupted" + (f" ({name})" if name else ""), file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
