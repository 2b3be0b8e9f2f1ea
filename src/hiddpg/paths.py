"""The commands' path arguments, checked before anything is computed.

Each check returns the path as a :class:`~pathlib.Path` or raises :class:`PathError`, a
:class:`~hiddpg.commands.common.UsageError` that the commands print as one line naming the
option, the value and what is allowed (exit code 2).

An output file's missing parent directories are created when the file is written
(:func:`hiddpg.render.write_gif`, :func:`hiddpg.experiments.report.save_figure`); the check
only makes sure they can be: the nearest existing ancestor must be a writable directory.
"""

from __future__ import annotations

import os
from pathlib import Path

from hiddpg.commands.common import UsageError

#: How many candidate directories a "did you mean" names at most.
MAX_SUGGESTIONS = 3


class PathError(UsageError):
    """A path argument that cannot be used: one line, exit code 2."""


def _nonempty(value: str | os.PathLike, flag: str) -> Path:
    if not str(value).strip():
        raise PathError(f"{flag} is empty; give a path")
    return Path(value).expanduser()


def _check_parent(path: Path, value: str | os.PathLike, flag: str) -> None:
    """The nearest existing ancestor of ``path`` is a writable directory."""
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise PathError(f"{flag} {str(value)!r}: {ancestor} is a file, not a directory")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise PathError(f"{flag} {str(value)!r}: the directory {ancestor} is not writable")


def output_file(value: str | os.PathLike, flag: str, suffix: str | None = None,
                what: str = "file") -> Path:
    """An output file: not an existing directory, its directory creatable, and ending in
    ``suffix`` (case-insensitive) when one is given, since the format follows the name."""
    path = _nonempty(value, flag)
    if suffix is not None and path.suffix.lower() != suffix:
        ok = path.name not in ("", ".", "..")
        example = path.with_name(path.stem + suffix) if ok else Path("FILE" + suffix)
        raise PathError(f"{flag} {str(value)!r} must end in {suffix} (it is written as "
                        f"{what}), e.g. {flag} {example}")
    if path.is_dir():
        raise PathError(f"{flag} {str(value)!r} is a directory; give a file name"
                        + (f" ending in {suffix}" if suffix else ""))
    _check_parent(path, value, flag)
    return path


def gif_path(value: str | os.PathLike, flag: str = "--gif") -> Path:
    """An animated GIF to write: a name ending in ``.gif``, see :func:`output_file`."""
    return output_file(value, flag, ".gif", "an animated GIF")


def png_path(value: str | os.PathLike, flag: str) -> Path:
    """A PNG picture to write: a name ending in ``.png``, see :func:`output_file`."""
    return output_file(value, flag, ".png", "a PNG picture")


def figure_stem(value: str | os.PathLike, flag: str = "--out",
                suffixes: tuple[str, ...] = (".png", ".pdf")) -> Path:
    """A figure's file name without extension (``STEM.png`` and ``STEM.pdf`` are written); a
    value ending in one of ``suffixes`` names the same stem. Neither it nor the files written
    may be existing directories."""
    path = _nonempty(value, flag)
    if path.suffix.lower() in suffixes:
        path = path.with_suffix("")
    written = [path.with_name(path.name + s) for s in suffixes]
    allowed = (f"give a file name without extension "
               f"({' and '.join('NAME' + s for s in suffixes)} are written)")
    if path.is_dir():
        raise PathError(f"{flag} {str(value)!r} is a directory; {allowed}")
    for p in written:
        if p.is_dir():
            raise PathError(f"{flag} {str(value)!r}: {p} is a directory; {allowed}")
    _check_parent(path, value, flag)
    return path


def output_dir(value: str | os.PathLike, flag: str) -> Path:
    """A directory to write into: an existing directory or one that can be created; not an
    existing file."""
    path = _nonempty(value, flag)
    if path.exists() and not path.is_dir():
        raise PathError(f"{flag} {str(value)!r} is a file; give a directory")
    _check_parent(path, value, flag)
    return path


def similar_dirs(path: Path) -> list[Path]:
    """Directories next to ``path`` whose name starts with its name (run directories carry a
    timestamp suffix), newest name last."""
    parent = path.parent if str(path.parent) else Path(".")
    if not path.name or not parent.is_dir():
        return []
    return sorted(p for p in parent.iterdir() if p.is_dir() and p.name.startswith(path.name))


def existing_dir(value: str | os.PathLike, what: str) -> Path:
    """An existing directory ``what`` (e.g. ``"RUN_DIR"``); when it does not exist, the message
    suggests the directories next to it whose names start with the value."""
    path = _nonempty(value, what)
    if path.is_dir():
        return path
    if path.exists():
        raise PathError(f"{what} {str(value)!r} is a file, not a directory")
    message = f"{what} {str(value)!r} does not exist"
    found = similar_dirs(path)
    if len(found) == 1:
        message += f"; did you mean {found[0]}?"
    elif found:
        shown = ", ".join(map(str, found[-MAX_SUGGESTIONS:]))
        more = (f" (the newest {MAX_SUGGESTIONS} of {len(found)})"
                if len(found) > MAX_SUGGESTIONS else "")
        message += f"; did you mean one of {shown}{more}?"
    raise PathError(message)
