"""What every argparse-based command shares: one-line usage errors with exit code 2."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence


class UsageError(ValueError):
    """A bad command line or config: reported as one line, exit code 2."""


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
