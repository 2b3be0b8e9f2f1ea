"""docs/gym-demo.md's tables are what the records committed under ``results/gym-demo/`` give:
the final-return table of every environment (``benchmarks/_demo_summary.py``), the committed
``table.md`` beside them, and the low-level saturation probes; every figure and GIF the page
shows is committed."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from hiddpg.experiments.saturation import saturation_table

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "gym-demo.md"
DEMO = ROOT / "results" / "gym-demo"
sys.path.insert(0, str(ROOT / "benchmarks"))
from _demo_summary import ALL, curves, table  # noqa: E402

OUTPUTS = sorted(p.parent for p in DEMO.glob("*/records"))


@pytest.fixture(scope="module")
def text() -> str:
    return DOC.read_text(encoding="utf-8")


def test_there_is_an_output_to_check():
    assert OUTPUTS, f"no records under {DEMO}"


@pytest.mark.parametrize("out", OUTPUTS, ids=lambda p: p.name)
def test_the_table_is_the_records_table(out: Path, text: str):
    found = curves(out, list(ALL))
    if not found:  # nothing finished yet: nothing to report, and no table claims otherwise
        assert not (out / "table.md").exists(), f"{out / 'table.md'} without a finished record"
        return
    computed = table(found)
    assert (out / "table.md").read_text() == computed, (
        f"{out / 'table.md'} is stale: python benchmarks/_demo_summary.py {out}")
    assert computed in text, f"docs/gym-demo.md's table for {out.name} is stale; paste\n{computed}"


@pytest.mark.parametrize("record", sorted(DEMO.glob("*/low-saturation.json")),
                         ids=lambda p: p.parent.name)
def test_the_saturation_tables_are_the_probes(record: Path, text: str):
    shown = saturation_table(json.loads(record.read_text()))
    assert shown in text, f"docs/gym-demo.md's saturation table is stale; paste\n{shown}"


def test_every_linked_file_is_committed(text: str):
    links = re.findall(r"\]\((\.\./[^)#]+)\)", text)
    assert any(link.endswith(".gif") for link in links), "the page shows no GIF"
    missing = [link for link in links if not (DOC.parent / link).resolve().is_file()]
    assert not missing, missing


def section(text: str, env: str) -> str:
    """The part of the page under the ``## ENV`` heading, up to the next ``## `` heading."""
    parts = re.split(r"^## ", text, flags=re.M)
    found = [p for p in parts if p.startswith(env)]
    assert len(found) == 1, f"docs/gym-demo.md has {len(found)} sections for {env}"
    return found[0]


def test_a_section_ends_at_the_next_heading():
    page = "intro\n## A-v0\nseed 1 −2.0 with 3\n## B-v0 (x)\nseed 1 4.0 with 5\n"
    assert section(page, "A-v0") == "A-v0\nseed 1 −2.0 with 3\n"
    assert section(page, "B-v0") == "B-v0 (x)\nseed 1 4.0 with 5\n"


@pytest.mark.parametrize("eval_table", sorted(DEMO.glob("*/hi-ddpg-eval.txt")),
                         ids=lambda p: p.parent.name)
def test_the_gif_episodes_quoted_are_the_eval_table(eval_table: Path, text: str):
    """``seed S R with K`` in the environment's section of the page (R signed, ``−`` for a
    negative return): seed S's env_return and switches in ``hiddpg eval``'s table of the run,
    as committed."""
    rows = {int(r[0]): (float(r[2]), int(r[3])) for r in
            (line.split() for line in eval_table.read_text().splitlines())
            if len(r) == 5 and r[0].isdigit()}
    part = section(text, eval_table.parent.name)
    quoted = re.findall(r"seed (\d+)\s+(−?)(\d+\.\d) with (\d+)", part)
    assert quoted, f"the {eval_table.parent.name} section quotes no evaluation episode"
    for seed, minus, ret, switches in quoted:
        value = -float(ret) if minus else float(ret)
        assert rows[int(seed)] == (pytest.approx(value, abs=0.05), int(switches)), seed
