"""The budgets and variants of ``hiddpg reproduce``: how many seeds and episodes a run gets at
each scale, and what each variant trains (a preset, plus ``--set`` overrides of its HI-DDPG
runs and episode counts per task group)."""

from __future__ import annotations

from dataclasses import dataclass

from hiddpg.presets import ARM_HIGH_CRITIC, CRITIC_DURATIONS

SCALES = ("quick", "paper")


@dataclass(frozen=True)
class Budget:
    """The training budget of one run at one scale (what it trains is the variant's)."""

    seeds: int
    episodes: int | None
    """Episodes per run; ``None``: the preset's (the paper's budget)."""
    eval_every: int
    chunk_episodes: int


#: (scale, task group: ``budget_group``) -> budget. ``quick``: minutes, 3 seeds; ``paper``:
#: the paper's 15 runs per method on the preset's episodes.
BUDGETS: dict[tuple[str, str], Budget] = {
    ("quick", "puck"): Budget(seeds=3, episodes=1500, eval_every=50, chunk_episodes=250),
    ("quick", "arm"): Budget(seeds=3, episodes=1500, eval_every=50, chunk_episodes=250),
    ("paper", "puck"): Budget(seeds=15, episodes=None, eval_every=20, chunk_episodes=250),
    ("paper", "arm"): Budget(seeds=15, episodes=None, eval_every=20, chunk_episodes=250),
}


@dataclass(frozen=True)
class Variant:
    """What ``hiddpg reproduce --variant NAME`` trains: a preset, plus ``--set`` overrides of
    its HI-DDPG runs and episode counts per task group (at paper scale)."""

    name: str
    preset: str
    summary: str
    hi_ddpg_sets: tuple[tuple[str, tuple[str, ...]], ...] = ()
    """(task group, ``--set`` list) of the HI-DDPG runs (``hi-ddpg``, ``hi-ddpg-wo-model``)."""
    paper_episodes: tuple[tuple[str, int], ...] = ()
    """(task group, episodes) at paper scale, where they differ from the preset's."""

    def sets_for(self, group: str) -> tuple[str, ...]:
        return dict(self.hi_ddpg_sets).get(group, ())

    def describe(self) -> str:
        """One line: the variant and what it adds (figures, report)."""
        if self.name in ("paper", "paper+"):
            from hiddpg.variants import describe

            return describe(self.name)
        return f"{self.name}: {self.summary}"


REPRODUCE_VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant("quick", "quick", "the quick preset (the stabilised configuration with small "
            "networks; docs/hyperparameters.md)"),
    Variant("paper", "paper", "the paper as written"),
    Variant("paper+", "paper+", "the paper plus the changes of docs/paper-plus.md"),
    Variant("extended", "quick",
            "the quick preset plus, for HI-DDPG, the critic-chosen durations, hindsight goals "
            "and a rest term without the model-based gradient on the trajectory tasks (6000 "
            "episodes) and hindsight actions and a Huber loss for the high critic on "
            "ArmObstacle",
            hi_ddpg_sets=(("trajectory", CRITIC_DURATIONS), ("arm", ARM_HIGH_CRITIC)),
            paper_episodes=(("trajectory", 6000), ("puck", 3000), ("arm", 3000))),
)}
#: The variant of each scale when ``--variant`` is not given.
DEFAULT_VARIANT = {"quick": "quick", "paper": "paper"}


def budget_group(task: str) -> str:
    """The task's group: ``"trajectory"`` (PuckTrajectory*), else its family (``"puck"``,
    ``"arm"``); budgets fall back from ``trajectory`` to ``puck``."""
    from hiddpg.envs import task_name
    from hiddpg.presets import SWITCHING_TASKS, task_family

    return "trajectory" if task_name(task) in SWITCHING_TASKS else task_family(task)


def budget_table() -> str:
    """The budgets as a markdown table (``--help``, report)."""
    rows = ["| scale | tasks | seeds | episodes | eval every | chunk |",
            "|---|---|---:|---:|---:|---:|"]
    for (scale, group), b in BUDGETS.items():
        episodes = b.episodes or "the preset's"
        rows.append(f"| {scale} | {group} | {b.seeds} | {episodes} | {b.eval_every} | "
                    f"{b.chunk_episodes} |")
    return "\n".join(rows)


def variant_table() -> str:
    """The variants as a markdown table (``--help``, report)."""
    rows = ["| variant | preset | HI-DDPG adds | episodes at paper scale |", "|---|---|---|---|"]
    for v in REPRODUCE_VARIANTS.values():
        sets = "; ".join(f"{g}: " + " ".join(f"`{s}`" for s in ss) for g, ss in v.hi_ddpg_sets)
        episodes = ", ".join(f"{g} {n}" for g, n in v.paper_episodes) or "the preset's"
        rows.append(f"| {v.name} | {v.preset} | {sets or '-'} | {episodes} |")
    return "\n".join(rows)
