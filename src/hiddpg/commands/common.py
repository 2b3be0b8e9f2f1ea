"""What every argparse-based command shares: one-line usage errors with exit code 2."""

from __future__ import annotations

import argparse


class UsageError(ValueError):
    """A bad command line or config: reported as one line, exit code 2."""


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` that raises :class:`UsageError` instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(message)
