"""What every command shares: one-line usage errors with exit code 2, and the ``-h`` / parse /
prepare / run sequence of an argparse command and the error handling of a tyro one."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

T = TypeVar("T")


class UsageError(ValueError):
    """A bad command line or config: reported as one line, exit code 2."""


#: The errors an argparse command reports as a usage error unless it names its own.
USAGE_ERRORS: tuple[type[BaseException], ...] = (UsageError, ValueError)


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` that raises :class:`UsageError` instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(message)


def argv_or_help(argv: Sequence[str] | None,
                 build_parser: Callable[[], argparse.ArgumentParser]) -> list[str] | None:
    """The command line as a list (``sys.argv[1:]`` when ``argv`` is None), or None after
    printing the command's help when it asks for it (``-h`` / ``--help``)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if {"-h", "--help"} & set(args):
        build_parser().print_help()
        return None
    return args


def report_error(prog: str, error: object, code: int = 2) -> int:
    """Print ``PROG: error: ERROR`` on stderr; returns the exit code ``code``."""
    print(f"{prog}: error: {error}", file=sys.stderr)
    return code


def run_command(prog: str, argv: Sequence[str] | None,
                build_parser: Callable[[], argparse.ArgumentParser],
                prepare: Callable[[argparse.Namespace], T],
                run: Callable[[argparse.Namespace, T], int],
                errors: tuple[type[BaseException], ...] = USAGE_ERRORS) -> int:
    """An argparse command: its help on ``-h`` / ``--help`` (exit code 0); else the parsed
    arguments and ``prepare(args)``, where one of ``errors`` is a usage error (one line, exit
    code 2); then ``run(args, prepared)``, whose exit code is returned."""
    args_list = argv_or_help(argv, build_parser)
    if args_list is None:
        return 0
    try:
        args = build_parser().parse_args(args_list)
        prepared = prepare(args)
    except errors as err:
        return report_error(prog, err)
    return run(args, prepared)


def run_tyro(prog: str, argv: Sequence[str] | None, cli: Callable[[list[str]], Any],
             errors: tuple[type[BaseException], ...]) -> int:
    """A tyro command: ``cli(args)``'s exit code, with tyro's ``--help`` (0) and usage errors
    (2) as exit codes, and one of ``errors`` reported by its first line with exit code 2."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        return cli(args)
    except SystemExit as e:  # tyro's --help (0) and its usage errors (2)
        return e.code if isinstance(e.code, int) else 2
    except errors as e:
        message = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        return report_error(prog, message)
