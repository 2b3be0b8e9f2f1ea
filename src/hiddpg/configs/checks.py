"""Validators shared by the configs: each names the class, the field, the bad value and what
is allowed."""

from __future__ import annotations

import math
from typing import Any


def positive(obj: Any, *names: str) -> None:
    for name in names:
        v = getattr(obj, name)
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{type(obj).__name__}.{name}={v!r} must be a finite number > 0")


def unit(obj: Any, *names: str, closed: bool = True) -> None:
    for name in names:
        v = getattr(obj, name)
        ok = isinstance(v, int | float) and (0 <= v <= 1 if closed else 0 < v <= 1)
        if not ok:
            rng = "[0, 1]" if closed else "(0, 1]"
            raise ValueError(f"{type(obj).__name__}.{name}={v!r} must lie in {rng}")


def hidden(obj: Any, name: str = "hidden") -> None:
    h = getattr(obj, name)
    if not h or any(not isinstance(n, int) or n <= 0 for n in h):
        raise ValueError(
            f"{type(obj).__name__}.{name}={h!r} must be a non-empty tuple of positive ints"
        )


def buffer(obj: Any) -> None:
    if obj.batch_size > obj.buffer_size:
        raise ValueError(
            f"{type(obj).__name__}.batch_size={obj.batch_size} is larger than "
            f"buffer_size={obj.buffer_size}; it must be <= buffer_size"
        )


def nonnegative(obj: Any, *names: str, hint: str = "") -> None:
    """Each field a finite number >= 0 (``hint``, if given, ends the message)."""
    for name in names:
        v = getattr(obj, name)
        if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{type(obj).__name__}.{name}={v!r} must be a finite number >= 0"
                             + (f" ({hint})" if hint else ""))
