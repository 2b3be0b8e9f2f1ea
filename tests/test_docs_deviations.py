"""docs/deviations.md, the reviewer's list of every difference from the paper, names every field
in which the stabilised configuration or the quick preset differs from the paper preset, every
key of the settings ``hiddpg reproduce`` adds, and stays a readable reference (whole tables,
short cells, no history)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from hiddpg import presets
from hiddpg.configs import EagerHighLevel

DOC = Path(__file__).resolve().parents[1] / "docs" / "deviations.md"
TASKS = ("PuckTrajectory2", "ArmObstacle")
#: (paper builder, stabilised builder, quick builder) per algorithm
BUILDERS = (
    (presets.ddpg_paper, presets.ddpg_stable, presets.ddpg_quick),
    (presets.hi_ddpg_paper, presets.hi_ddpg_stable, presets.hi_ddpg_quick),
    (presets.h_ddpg_paper, presets.h_ddpg_stable, presets.h_ddpg_quick),
)
MAX_CELL = 320


@pytest.fixture(scope="module")
def text() -> str:
    return DOC.read_text(encoding="utf-8")


def differing_fields(a, b, path: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """The field paths where two configs differ, recursing through dataclasses of one type (a
    field whose values have different types, e.g. ``ActorChoice`` vs ``HoldChoice``, counts
    as one)."""
    if dataclasses.is_dataclass(a) and type(a) is type(b):
        out: list[tuple[str, ...]] = []
        for f in dataclasses.fields(a):
            out += differing_fields(getattr(a, f.name), getattr(b, f.name), (*path, f.name))
        return out
    return [path] if a != b else []


def named(name: str, text: str) -> bool:
    """``name`` appears as a word inside a code span of ``text``."""
    return re.search(rf"`[^`\n]*(?<![\w-]){re.escape(name)}(?![\w-])[^`\n]*`", text) is not None


@pytest.mark.parametrize("task", TASKS)
@pytest.mark.parametrize("builders", BUILDERS, ids=lambda b: b[0].__name__)
def test_every_stabiliser_and_quick_field_is_named(text: str, task: str, builders) -> None:
    paper, stable, quick = (build(task) for build in builders)
    diffs = differing_fields(paper, stable) + differing_fields(stable, quick)
    assert diffs, "the paper preset and the stabilised/quick configurations cannot be equal"
    missing = sorted({".".join(p) for p in diffs if not named(p[-1], text)})
    assert not missing, f"docs/deviations.md does not name the differing fields {missing}"


@pytest.mark.parametrize("sets", [presets.CRITIC_DURATIONS, presets.ARM_HIGH_CRITIC],
                         ids=["CRITIC_DURATIONS", "ARM_HIGH_CRITIC"])
def test_reproduce_settings_are_named(text: str, sets: tuple[str, ...]) -> None:
    missing = []
    for item in sets:
        key = item.split("=", 1)[0].removeprefix("agent.")
        missing += [f"{part} ({item})" for part in key.split(".")
                    if part not in ("high", "low") and not named(part, text)]
    assert not missing, f"docs/deviations.md does not name {missing}"
    for setting in ("CRITIC_DURATIONS", "ARM_HIGH_CRITIC"):
        assert f"presets.{setting}" in text


def test_eager_high_parts_and_paper_plus_are_named(text: str) -> None:
    for f in dataclasses.fields(EagerHighLevel):
        assert named(f.name, text), f"EagerHighLevel.{f.name} is not named"
    from hiddpg.variants import PAPER_PLUS

    assert "`paper+`" in text and "(diagnosis.md)" in text
    for change in PAPER_PLUS:  # every change of paper+ is a deviation from the paper
        assert f"`{change}`" in text, f"paper+'s change {change} is not named"


def test_tables_are_whole_and_cells_short(text: str) -> None:
    width = None
    for number, line in enumerate(text.splitlines(), 1):
        if not line.startswith("|"):
            width = None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if width is None:
            width = len(cells)  # the header
        assert len(cells) == width, f"line {number}: {len(cells)} cells, header has {width}"
        assert all(cells), f"line {number}: an empty cell"
        long = [c[:40] for c in cells if len(c) > MAX_CELL]
        assert not long, f"line {number}: cells over {MAX_CELL} characters: {long}"


def test_reference_not_history(text: str) -> None:
    assert not re.search(r"\bsessions?\b", text, re.IGNORECASE)
    assert not re.search(r"\b20\d\d-\d\d-\d\d\b", text)
    assert not re.search(r"\bwe tried\b", text, re.IGNORECASE)


SRC = DOC.parents[1] / "src" / "hiddpg"
#: where a ``[decision]`` tag of the code is explained: the deviations or the environments' tables
TAG_DOCS = ("docs/deviations.md", "docs/environments.md")


def tagged_modules() -> list[str]:
    return sorted(
        p.relative_to(SRC).as_posix()
        for p in SRC.rglob("*.py")
        if "[decision" in p.read_text(encoding="utf-8")
    )


def test_some_modules_carry_decision_tags() -> None:
    assert len(tagged_modules()) >= 10  # the configs, presets, agents and environments


@pytest.mark.parametrize("name", tagged_modules())
def test_every_decision_tag_links_to_the_docs(name: str) -> None:
    """A module that tags a value [decision] names the page that lists it, and the page exists."""
    source = (SRC / name).read_text(encoding="utf-8")
    linked = [doc for doc in TAG_DOCS if doc in source]
    assert linked, f"{name} tags a [decision] but names none of {TAG_DOCS}"
    for doc in linked:
        assert (DOC.parents[1] / doc).is_file(), doc
