"""The claims' verdicts are what an output's sections and artifacts give.

Synthetic outputs of ``hiddpg reproduce``, nothing trained: a ``paper`` output with every
figure (Figs. 4-6 as sections, Figs. 7-8 as sections over artifacts of synthetic run
directories whose gaps between methods are set), a ``quick`` output with Figs. 4 and 6 only
(one trajectory task missing), and an output that does not exist.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from hiddpg import variants
from hiddpg.commands import report as report_cmd
from hiddpg.experiments import claims, comparison
from hiddpg.experiments.artifacts import ARTIFACT_FORMAT, export_run, load_artifact
from hiddpg.experiments.claim_checks import (
    NOT_REPRODUCED,
    NOT_RUN,
    REPRODUCED,
    Output,
    count_text,
    proportion_ci,
    seed_text,
    stage_wins,
)
from hiddpg.experiments.common import Context
from hiddpg.experiments.redraw import write_context
from hiddpg.experiments.report import write_section
from hiddpg.presets import make_config
from hiddpg.runs import Run

TRAJ = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3")
#: (task, algo) -> offset of the evaluation returns: on the puck HI-DDPG = h-DDPG > DDPG and
#: HI-DDPG-wo-model; on the arm HI-DDPG = HI-DDPG-wo-model > h-DDPG and DDPG
OFFSETS = {("PuckObstacle", "hi-ddpg"): 0.0, ("PuckObstacle", "h-ddpg"): 0.0,
           ("PuckObstacle", "hi-ddpg-wo-model"): -20.0, ("PuckObstacle", "ddpg"): -20.0,
           ("ArmObstacle", "hi-ddpg"): 0.0, ("ArmObstacle", "h-ddpg"): -20.0,
           ("ArmObstacle", "hi-ddpg-wo-model"): 0.0, ("ArmObstacle", "ddpg"): -20.0}


def _meta(ctx, algo, task, seeds):
    """An artifact's meta.json alone: the seeds the claims read for Figs. 4-6."""
    path = ctx.artifact_path(algo, task)
    path.mkdir(parents=True, exist_ok=True)
    (path / "meta.json").write_text(json.dumps({"format": ARTIFACT_FORMAT,
                                                "seeds": list(seeds)}))


def _section(ctx, name, numbers):
    write_section(ctx, name, {"title": name, "figures": [], "markdown": "",
                              "numbers": numbers, "wall_s": 0.0})


def _fig4(ctx, bars, runs):
    """Fig. 4's section: per task (goals, switches) counts of ``runs``."""
    numbers = {t: {"bar": {"runs": runs, "goals": g, "switches": s, "both": min(g, s)}}
               for t, (g, s) in bars.items()}
    _section(ctx, "fig4", numbers)
    for task in bars:
        _meta(ctx, "hi-ddpg", task, range(runs))


def _fig6(ctx, success, collision):
    n = len(success)
    _section(ctx, "fig6", {
        "success": success, "collision": collision, "switches": [2.0] * n,
        "final_eval_return": {"mean": -5.0, "std": 1.0, "iqm": -4.9, "ci_low": -5.5,
                              "ci_high": -4.4, "n": n}})
    _meta(ctx, "hi-ddpg", "ArmObstacle", range(n))


def _comparison(ctx, name, task, seeds=15, episodes=40, every=4):
    """Fig. 7/8: an artifact per method from a synthetic run directory (evaluation returns
    at ``OFFSETS``, noise 1), and the section the figure writes from them."""
    rng = np.random.default_rng(len(task))
    for algo in comparison.COMPARED:
        config = make_config(algo, task, "quick", [f"episodes={episodes}",
                                                   f"eval_every={every}"])
        run = Run.create(ctx.run_path(algo, task), config, list(range(seeds)))
        ep = np.tile(np.arange(1, episodes + 1), (seeds, 1))
        ev = ep[:, every - 1::every]
        score = OFFSETS[(task, algo)] + rng.normal(0, 1, ev.shape)
        run.append_metrics({"episode": ep, "length": np.full(ep.shape, 50),
                            "return": np.zeros(ep.shape),
                            "switches": np.zeros(ep.shape)},
                           {"episode": ev, "return": score, "env_return": score})
        run.write_progress(episodes, 1.0, "finished")
        export_run(run.path, ctx.artifact_path(algo, task))
    runs = {}
    for algo in comparison.COMPARED:
        data = load_artifact(ctx.artifact_path(algo, task))
        runs[data.label] = data
    _section(ctx, name, comparison.summary_numbers(comparison.compare(runs)))


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """Four outputs; ``paper+`` made to add nothing, so that its column is read from
    ``paper``'s (what :func:`hiddpg.variants.same_as` gives a variant without changes)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(variants.VARIANTS, "paper+", ())
        yield _outputs(tmp_path_factory)


def _outputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("claims")
    paper = Context(root / "paper" / "paper", scale="paper", variant="paper")
    write_context(paper)
    _fig4(paper, {"PuckTrajectory1": (15, 15), "PuckTrajectory2": (12, 15),
                  "PuckTrajectory3": (3, 12)}, runs=15)
    _section(paper, "fig5", {t: {"rms_x": 0.1, "rms_y": 0.15, "ilqr_converged": True,
                                 "drawn_seed": 4} for t in TRAJ})
    _fig6(paper, [True] * 12 + [False] * 3, [False] * 14 + [True])
    _comparison(paper, "fig7", "PuckObstacle")
    _comparison(paper, "fig8", "ArmObstacle")
    quick = Context(root / "quick" / "quick", scale="quick", variant="quick")
    _fig4(quick, {"PuckTrajectory1": (3, 3), "PuckTrajectory2": (3, 1)}, runs=3)
    _fig6(quick, [True, False, False], [False, False, True])
    dirs = [paper.out, quick.out, root / "paper" / "extended", root / "paper" / "paper+"]
    return dirs, claims.assess(dirs)


def test_verdicts_are_what_the_numbers_give(outputs):
    dirs, assessment = outputs
    assert assessment.outputs == ["paper (paper scale)", "quick (quick scale)",
                                  "extended (paper scale)",
                                  "paper+ (= paper (paper scale): no change)"]
    verdicts = assessment.verdicts()
    for rows in verdicts.values():  # paper+ adds nothing to paper: its column is paper's
        assert rows.pop("paper+ (= paper (paper scale): no change)") == rows["paper (paper scale)"]
    assert assessment.paths[3] == str(dirs[0])
    assert verdicts == {
        1: {"paper (paper scale)": NOT_REPRODUCED, "quick (quick scale)": NOT_RUN,
            "extended (paper scale)": NOT_RUN},  # PT3 3/15; quick: PT3 missing, the rest pass
        2: {"paper (paper scale)": REPRODUCED, "quick (quick scale)": NOT_REPRODUCED,
            "extended (paper scale)": NOT_RUN},  # 12/15 is the bar; quick PT2 1/3
        3: {"paper (paper scale)": REPRODUCED, "quick (quick scale)": NOT_RUN,
            "extended (paper scale)": NOT_RUN},
        4: {"paper (paper scale)": REPRODUCED, "quick (quick scale)": NOT_REPRODUCED,
            "extended (paper scale)": NOT_RUN},
        5: {"paper (paper scale)": REPRODUCED, "quick (quick scale)": NOT_RUN,
            "extended (paper scale)": NOT_RUN},
        6: {"paper (paper scale)": REPRODUCED, "quick (quick scale)": NOT_RUN,
            "extended (paper scale)": NOT_RUN},
        7: {"paper (paper scale)": NOT_REPRODUCED, "quick (quick scale)": NOT_RUN,
            "extended (paper scale)": NOT_RUN},  # the arm: HI-DDPG = HI-DDPG-wo-model
    }


def test_cells_carry_the_counts_intervals_and_seeds(outputs):
    _, assessment = outputs
    paper = {n: rows[0] for n, rows in assessment.outcomes.items()}
    quick = {n: rows[1] for n, rows in assessment.outcomes.items()}
    assert paper[1].cell() == ("**not reproduced**: PT1 15/15 (78-100%), PT2 12/15 (52-96%), "
                               "PT3 3/15 (4-48%); seeds 0-14")
    assert paper[1].numbers["PuckTrajectory2"]["ci95"] == pytest.approx((0.519, 0.957),
                                                                         abs=1e-3)
    assert quick[1].cell() == ("not run yet: PT1 3/3 (29-100%), PT2 3/3 (29-100%); PT3 not "
                               "run; seeds 0-2")
    assert paper[3].cell().startswith("**reproduced**: RMS x/y, median run: PT1 0.10/0.15 "
                                      "(seed 4)")
    assert paper[4].cell().startswith("**reproduced**: success 12/15 (52-96%), collisions 1/15,"
                                      " return IQM -4.90 [-5.50, -4.40]")
    assert paper[4].seeds == list(range(15)) and quick[4].numbers["success"] == 1
    assert paper[6].numbers["hi_beats_h"] == 5 and paper[6].numbers["stages"] == 5
    assert paper[5].numbers["hi_vs_h_differ"] == 0 and paper[5].numbers["hi_beats_ddpg"] == 5
    assert paper[7].numbers["PuckObstacle"]["hi_beats_wo_model"] == 10
    assert paper[7].numbers["ArmObstacle"]["hi_beats_wo_model"] == 0
    assert paper[6].seeds == list(range(15)) and "episodes 24-40" in paper[6].text
    for rows in assessment.outcomes.values():
        assert rows[2].cell() == "not run yet" and rows[3] == rows[0]
        assert all(len(r.cell()) < 250 for r in rows), [r.cell() for r in rows]


def test_stage_counts_agree_with_the_figure_section(outputs):
    """The per-stage tests recomputed from the artifacts are the figure's: its last-stage p."""
    dirs, _ = outputs
    out = Output(dirs[0])
    comp = out.comparison("fig8")
    pairs = {(p["a"], p["b"]): p for p in out.sections["fig8"]["numbers"]["pairs"]}
    w = comp.welch
    i, j = w.methods.index("HI-DDPG"), w.methods.index("h-DDPG")
    assert w.p_holm[i, j, -1] == pytest.approx(pairs[("HI-DDPG", "h-DDPG")]["p_holm"])
    wins, losses, late = stage_wins(comp, "HI-DDPG", "h-DDPG", late=False)
    assert (late, losses) == (10, 0) and wins == pairs[("HI-DDPG", "h-DDPG")]["stages_a_better"]


def test_markdown_has_a_row_per_claim_and_a_column_per_output(outputs):
    _, assessment = outputs
    table = claims.markdown(assessment).splitlines()
    assert table[0] == ("| claim | paper (paper scale) | quick (quick scale) | "
                        "extended (paper scale) | paper+ (= paper (paper scale): no change) |")
    assert len(table) == 2 + len(claims.CLAIMS)
    assert all(line.count("|") == 6 for line in table)
    definitions = claims.definitions_markdown().splitlines()
    assert len(definitions) == 2 + len(claims.CLAIMS)
    assert all(len(cell) < 250 for line in definitions for cell in line.split("|"))


def test_the_claims_command_prints_writes_and_exports(outputs, tmp_path, capsys):
    dirs, assessment = outputs
    out = tmp_path / "claims.md"
    assert report_cmd.claims([*map(str, dirs), "--bars", "--out", str(out)]) == 0
    printed = capsys.readouterr()
    assert printed.out.strip() == out.read_text().strip()
    assert claims.markdown(assessment) in printed.out
    assert claims.definitions_markdown() in printed.out
    assert "extended does not exist" in printed.err
    assert "paper+ adds no change to paper: read from" in printed.err
    assert report_cmd.claims([str(dirs[0]), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [c["outcomes"]["paper (paper scale)"]["verdict"] for c in data["claims"]] == [
        NOT_REPRODUCED, REPRODUCED, REPRODUCED, REPRODUCED, REPRODUCED, REPRODUCED,
        NOT_REPRODUCED]


def test_seed_ranges_and_exact_intervals():
    assert seed_text([0, 1, 2, 5, 7, 8]) == "0-2, 5, 7-8" and seed_text([3]) == "3"
    assert proportion_ci(0, 15)[0] == 0 and proportion_ci(15, 15)[1] == 1
    assert count_text(12, 15) == "12/15 (52-96%)"


def test_figure_blocks_give_each_output_s_section_once(outputs, tmp_path):
    dirs, assessment = outputs
    section = json.loads((dirs[0] / "sections" / "fig6.json").read_text())
    section.update(figures=["figures/fig6.png", "figures/fig6.pdf"], markdown="| a |\n|---|\n")
    (dirs[0] / "sections" / "fig6.json").write_text(json.dumps(section))
    block = claims.figure_markdown(assessment, "fig6")
    paper, quick = assessment.outputs[0], assessment.outputs[1]
    assert block.startswith(f"**{paper}** (`{dirs[0]}`):\n\n![fig6, {paper}](../{dirs[0]}/"
                            "figures/fig6.png)\n\n| a |\n|---|")
    assert f"**{quick}** (`{dirs[1]}`)" in block
    assert block.count(str(dirs[0])) == 2  # paper+ is read from paper's output: not again
    assert claims.figure_markdown(assessment, "fig3") == "No output has drawn fig3 yet."


def test_update_page_rewrites_only_the_generated_blocks(outputs):
    _, assessment = outputs
    page = ("# title\n\n<!-- hiddpg claims: verdicts -->\nold table\n<!-- end -->\n\nprose "
            "kept\n\n<!-- hiddpg claims: fig3 -->\nold\n<!-- end -->\n")
    new = claims.update_page(page, assessment)
    assert new == ("# title\n\n<!-- hiddpg claims: verdicts -->\n"
                   f"{claims.markdown(assessment)}\n<!-- end -->\n\nprose kept\n\n"
                   "<!-- hiddpg claims: fig3 -->\nNo output has drawn fig3 yet.\n<!-- end -->\n")
    assert claims.update_page(new, assessment) == new
    with pytest.raises(ValueError, match="generated block 'fig9' is not one of"):
        claims.update_page("<!-- hiddpg claims: fig9 -->\n<!-- end -->", assessment)


def test_claims_update_rewrites_a_page_and_refuses_a_missing_one(outputs, tmp_path, capsys):
    dirs, _ = outputs
    page = tmp_path / "page.md"
    page.write_text("intro\n<!-- hiddpg claims: fig3 -->\nstale\n<!-- end -->\n")
    argv = [str(d) for d in dirs]
    assert report_cmd.claims([*argv, "--figures", "--update", str(page)]) == 0
    out = capsys.readouterr()
    assert "## fig6\n\n**paper (paper scale)**" in out.out and "updated" in out.err
    assert page.read_text() == ("intro\n<!-- hiddpg claims: fig3 -->\nNo output has drawn fig3 "
                                "yet.\n<!-- end -->\n")
    assert report_cmd.claims([*argv, "--update", str(tmp_path / "missing.md")]) == 2
    err = capsys.readouterr().err
    assert "--update" in err and "missing.md" in err and "Traceback" not in err


def test_the_summary_groups_each_output_s_claims_by_verdict(outputs):
    """The README's short list: per output, the claims by verdict (from the verdicts above)."""
    _, assessment = outputs
    assert claims.summary_markdown(assessment).splitlines() == [
        "- `paper (paper scale)`: claims reproduced: 2-6; not reproduced: 1, 7; not run yet: "
        "none.",
        "- `quick (quick scale)`: claims reproduced: none; not reproduced: 2, 4; not run yet: "
        "1, 3, 5-7.",
        "- `extended (paper scale)`: claims reproduced: none; not reproduced: none; not run "
        "yet: 1-7.",
        "- `paper+ (= paper (paper scale): no change)`: claims reproduced: 2-6; not "
        "reproduced: 1, 7; not run yet: none.",
    ]
    # a verdict on fewer seeds than the output plans is flagged
    outcome = assessment.outcomes[2][0]
    saved = outcome.planned
    try:
        outcome.planned = 20
        assert claims.summary_markdown(assessment).splitlines()[0].endswith(
            "; some verdicts on part of the planned seeds so far.")
    finally:
        outcome.planned = saved
    page = "<!-- hiddpg claims: summary -->\nold\n<!-- end -->"
    assert claims.update_page(page, assessment) == (
        f"<!-- hiddpg claims: summary -->\n{claims.summary_markdown(assessment)}\n<!-- end -->")
