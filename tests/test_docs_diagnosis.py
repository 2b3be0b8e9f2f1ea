"""The diagnosis pages' tables (docs/diagnosis.md and the pages it lists) are what the
committed study records give (``python -m hiddpg.experiments.diagnosis
results/diagnosis/FILE.json``), and every change ``paper+`` adds is one they measure."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hiddpg.experiments import diagnosis
from hiddpg.variants import CHANGES, PAPER_PLUS

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["diagnosis.md", "diagnosis-puck.md", "diagnosis-arm.md", "paper-plus.md",
         "paper-plus-arm.md"]
TEXT = "\n".join((ROOT / "docs" / page).read_text() for page in PAGES)
RECORDS = sorted(set(re.findall(r"results/diagnosis/[\w.-]+\.json", TEXT)))


def test_the_index_page_links_every_page():
    index = (ROOT / "docs" / "diagnosis.md").read_text()
    for page in PAGES[1:]:
        assert f"]({page})" in index, f"docs/diagnosis.md should link {page}"


def test_the_page_names_its_records_and_they_are_committed():
    assert RECORDS, "the diagnosis pages name no results/diagnosis/*.json"
    for record in RECORDS:
        assert (ROOT / record).is_file(), f"{record} is named in the diagnosis pages but missing"


@pytest.mark.parametrize("record", RECORDS)
def test_each_table_is_what_its_records_give(record):
    table = diagnosis.markdown(diagnosis.summarize([str(ROOT / record)]))
    assert table in TEXT, f"the table of {record} in the diagnosis pages is stale"


PROBES = sorted(set(re.findall(r"results/diagnosis/probes/[\w.-]+\.json", TEXT)))


@pytest.mark.parametrize("record", PROBES)
def test_each_probe_table_is_what_its_record_gives(record):
    import json

    from hiddpg.experiments.probes import end_value_table
    from hiddpg.experiments.saturation import saturation_table

    assert (ROOT / record).is_file(), f"{record} is named in the diagnosis pages but missing"
    data = json.loads((ROOT / record).read_text())
    first = next(iter(data["runs"][0]["seeds"].values()))
    table = (saturation_table if "bound_share" in first else end_value_table)(data)
    assert table in TEXT, f"the table of {record} in the diagnosis pages is stale"


def test_every_change_of_paper_plus_is_a_measured_candidate():
    for name in PAPER_PLUS:
        assert name in CHANGES and f"`{name}`" in TEXT


FLOORS = [("PuckTrajectory2", "rest"), ("PuckTrajectory2", "random"),
          ("ArmObstacle", "rest"), ("ArmObstacle", "random")]


@pytest.mark.parametrize("task,policy", FLOORS)
def test_the_floors_quoted_are_what_the_policies_score(task, policy):
    """The reference points "zero action" and "random policy" (1000 episodes each)."""
    from hiddpg.experiments.floors import floor_returns
    from hiddpg.experiments.report import fmt

    mean, _ = floor_returns(task, policy)
    quoted = f"`floor_returns(\"{task}\", \"{policy}\")` {fmt(mean)}"
    assert quoted in TEXT, f"the diagnosis pages should quote {quoted}"
