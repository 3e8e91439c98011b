"""The ``morphkit`` command line.

Each subcommand lives in ``morphkit.commands.<name>`` and exposes ``add_parser(subparsers)`` and
``run(args) -> int``. This module is the only place that turns a :class:`MorphkitError` into
``error: <file>:<line>: <message>`` on stderr and exit code 2, and prints each Python warning as
one line ``warning: <message>`` (the messages name the user's file and line; the library's own
source line would only confuse).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from typing import Any, TextIO

from morphkit._version import __version__
from morphkit.errors import MorphkitError

__all__ = ["main", "run_command"]

COMMANDS = [
    "info",
    "convert",
    "bench",
    "render",
    "map",
    "synth",
    "generate",
    "train",
    "retarget",
    "contacts",
    "evaluate",
]
"""Subcommand modules under ``morphkit.commands``, in help order."""


class _Parser(argparse.ArgumentParser):
    # argparse exits with 2 on usage errors already; keep its message on one line, no traceback. A bad value of
    # a named argument ("argument --fps: expected a number from 1 to 1000 fps, got 'inf'") is that one line
    # alone, as every other bad input; so is an unknown flag ("unrecognized arguments: --prior", e.g. an ACE flag
    # given to `train nkn`: argparse reports it from the top parser, whose usage would not help); a missing
    # argument comes with the usage of the (sub)command that needs it.
    def error(self, message: str) -> None:  # type: ignore[override]
        if message.startswith("argument "):
            message = message.removeprefix("argument ")
        elif not message.startswith("unrecognized arguments: "):
            self.print_usage(sys.stderr)
        sys.stderr.write(f"error: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand registered."""
    parser = _Parser(prog="morphkit", description="Differentiable kinematics for creatures of any morphology.")
    parser.add_argument("--version", action="version", version=f"morphkit {__version__}")
    parser.add_argument("--allow-outside", action="store_true",
                        help="read asset files (meshes, MJCF includes) outside a description's folder and package "
                        "(accepted anywhere on the command line)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"morphkit.commands.{name}").add_parser(sub)
    return parser


def _show_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int, file: TextIO | None = None,
    line: str | None = None, **_: Any,
) -> None:
    text = " ".join(part.strip() for part in str(message).splitlines() if part.strip())
    try:
        (file or sys.stderr).write(f"warning: {text}\n")
    except OSError:  # stderr gone (a closed pipe): nothing useful to do with a warning
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 success, 2 bad input)."""
    from morphkit.io.asset_paths import allow_outside

    argv = list(sys.argv[1:] if argv is None else argv)
    # A global flag that may follow the subcommand too: taken out before the subcommand's parser sees it.
    outside = "--allow-outside" in argv
    argv = [a for a in argv if a != "--allow-outside"]
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # a bad flag (2, its line already written) or --help/--version (0): the exit code
        return exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 2
    with allow_outside(outside):
        return run_command(args.run, args)


def run_command(command: Callable[[argparse.Namespace], int | None], args: argparse.Namespace) -> int:
    """Run ``command(args)`` as every morphkit command runs (the CLI's subcommands, the examples).

    Warp's module-load lines are silenced, a warning is one ``warning:`` line, and bad input (a
    :class:`~morphkit.errors.MorphkitError`, an unreadable or unwritable path) is one ``error:``
    line on stderr and exit code 2, with no traceback.

    Returns:
        The exit code: ``command``'s (0 for ``None``), 2 for bad input, 130 when interrupted.
    """
    os.environ.setdefault("MORPHKIT_QUIET_WARP", "1")
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        return _run(command, args)


def _run(command: Callable[[argparse.Namespace], int | None], args: argparse.Namespace) -> int:
    try:
        return int(command(args) or 0)
    except MorphkitError as exc:
        sys.stderr.write(f"error: {exc}\n")
        return 2
    except BrokenPipeError:
        return 0
    except OSError as exc:
        # Unreadable or unwritable paths, a full disk: bad input too, one line naming the file, no traceback.
        where = f"{exc.filename}: " if exc.filename else ""
        sys.stderr.write(f"error: {where}{exc.strerror or exc}\n")
        return 2
    except MemoryError as exc:
        # An allocation that cannot be served (a size the bounds let through on a small machine): one line.
        detail = f" ({exc})" if str(exc) else ""
        sys.stderr.write(f"error: out of memory{detail}; try a smaller preset, fewer or shorter clips\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
