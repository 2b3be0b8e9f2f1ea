"""Comments and docstrings under ``src/hiddpg`` say what a thing is and why, not when or by
whom it was worked on: no dates and no work-log words (results and history go to docs/).

Only comment tokens and docstrings (a string that is a statement of its own) are read, so
code strings such as ``strftime`` formats or messages are never flagged.
"""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parent.parent / "src" / "hiddpg"

#: What a log entry looks like: a calendar date, or words that only a work log uses.
FORBIDDEN = re.compile(
    r"\b(?:19|20)\d\d[-/][01]\d[-/][0-3]\d\b"
    r"|\bsessions?\b"
    r"|\bwe (?:tried|found|measured|saw|observed)\b"
    r"|\bearlier versions?\b"
    r"|\b(?:yesterday|today|last (?:week|month|night))\b",
    re.IGNORECASE,
)

_SKIPPED = {tokenize.NL, tokenize.COMMENT, tokenize.INDENT, tokenize.DEDENT, tokenize.ENCODING}


def prose(source: str) -> list[tuple[int, str]]:
    """``(line, text)`` of every comment and docstring of ``source``."""
    tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    found = []
    for i, tok in enumerate(tokens):
        if tok.type == tokenize.COMMENT:
            found.append((tok.start[0], tok.string))
        elif tok.type == tokenize.STRING:
            before = next((t for t in reversed(tokens[:i]) if t.type not in _SKIPPED), None)
            after = tokens[i + 1] if i + 1 < len(tokens) else None
            starts = before is None or before.type == tokenize.NEWLINE
            ends = after is None or after.type in (tokenize.NEWLINE, tokenize.ENDMARKER)
            if starts and ends:
                found.append((tok.start[0], tok.string))
    return found


def offences(source: str) -> list[str]:
    """``line: text`` of each comment or docstring line that reads like a log entry."""
    out = []
    for start, text in prose(source):
        for k, line in enumerate(text.splitlines()):
            if FORBIDDEN.search(line):
                out.append(f"{start + k}: {line.strip()}")
    return out


def source_files() -> list[str]:
    return sorted(p.relative_to(SRC).as_posix() for p in SRC.rglob("*.py"))


def test_the_checker_catches_a_log_entry() -> None:
    assert offences("x = 1  # measured on 2026-11-24\n")
    assert offences('def f():\n    """Slow in this session."""\n')
    assert not offences('STAMP = "%Y-%m-%d"  # an strftime format\n')
    assert not offences('MESSAGE = "session 2026-11-24"\n')  # a code string, not prose


@pytest.mark.parametrize("name", source_files())
def test_no_log_in_comments_or_docstrings(name: str) -> None:
    assert offences((SRC / name).read_text(encoding="utf-8")) == [], name
