"""docs/results.md's claims tables are what the outputs committed under ``results/`` give
(``hiddpg claims --bars`` run from the repository root), and the page stays a reference: no
work log, short cells, only figures that are committed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hiddpg.experiments import claims

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "results.md"
MAX_CELL = 250
MAX_PROSE_LINES = 170  # the page's own text; the generated blocks grow with the outputs
GENERATED = re.compile(r"<!-- hiddpg claims: \w+ -->.*?<!-- end -->", re.S)


@pytest.fixture(scope="module")
def text() -> str:
    return DOC.read_text(encoding="utf-8")


def test_every_committed_output_is_a_column():
    """An output of ``hiddpg reproduce`` under results/ that the table leaves out would go
    unreported: it must be one of the outputs ``hiddpg claims`` reads by default."""
    outputs = {p.parent.relative_to(ROOT).as_posix()
               for p in ROOT.glob("results/*/*/sections")}
    assert outputs <= set(claims.DEFAULT_DIRS), sorted(outputs - set(claims.DEFAULT_DIRS))


def test_the_verdicts_are_what_the_committed_outputs_give(text, monkeypatch):
    monkeypatch.chdir(ROOT)
    table = claims.markdown(claims.assess(claims.DEFAULT_DIRS))
    assert table in text, ("the claims table in docs/results.md is stale; paste the output of "
                           "`hiddpg claims` (run from the repository root)")


def test_each_figure_s_numbers_are_what_the_committed_outputs_give(text, monkeypatch):
    """Under each figure's heading: every output's figure and numbers, as `hiddpg claims
    --figures` prints them from the committed sections."""
    from hiddpg.commands.reproduce import FIGURES

    monkeypatch.chdir(ROOT)
    assessment = claims.assess(claims.DEFAULT_DIRS)
    for name in FIGURES:
        block = claims.figure_markdown(assessment, name)
        assert block in text, (f"{name}'s numbers in docs/results.md are stale; paste its "
                               "block of `hiddpg claims --figures`")


def test_the_claims_and_bars_are_the_code_s(text):
    assert claims.definitions_markdown() in text, (
        "the claims' bars in docs/results.md differ from hiddpg.experiments.claims.CLAIMS; "
        "paste `hiddpg claims --bars`")


def test_the_page_is_a_short_reference(text):
    prose = GENERATED.sub("", text)
    assert len(prose.splitlines()) <= MAX_PROSE_LINES, (
        "docs/results.md's own text has grown: move what is not about the claims elsewhere")
    assert not re.search(r"\bsessions?\b|\b20\d\d-\d\d-\d\d\b", text, re.IGNORECASE)
    cells = [c.strip() for line in text.splitlines() if line.startswith("|")
             for c in line.strip("|").split("|")]
    long = [c[:60] for c in cells if len(c) > MAX_CELL]
    assert not long, f"table cells over {MAX_CELL} characters: {long}"


def test_every_linked_image_is_committed(text):
    for target in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert (DOC.parent / target).is_file(), target


def test_the_readme_says_what_the_results_page_says(monkeypatch):
    """The README's list of which claims hold is the generated one, from the same outputs."""
    monkeypatch.chdir(ROOT)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    block = claims.summary_markdown(claims.assess(claims.DEFAULT_DIRS))
    assert f"<!-- hiddpg claims: summary -->\n{block}\n<!-- end -->" in readme, (
        "the README's list of claims is stale; run `hiddpg claims --update README.md`")
