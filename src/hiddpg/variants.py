"""Named variants of the paper: ``paper`` and ``paper+``.

A variant is data: the ``paper`` preset plus a tuple of named changes. Each :class:`Change`
is generic (it names a field of every actor-critic block, or of HI-DDPG's schedule, never a
task) and says in one line what it sets. ``paper`` adds nothing; ``paper+`` adds
only the changes the diagnosis of the exact preset shows are needed (docs/paper-plus.md),
for every algorithm, so the same words describe it on every task.

``hiddpg train ALGO TASK --preset paper+`` builds ``paper+``'s config; :data:`CHANGES` holds
every candidate the diagnosis measured, so a study can ask for one of them by name
(:func:`apply_changes`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hiddpg.configs import EagerHighLevel, HIDDPGConfig
from hiddpg.configs.ddpg import ActorCriticConfig


@dataclass(frozen=True)
class Change:
    """One generic change to the paper: what it sets, why, and how to apply it."""

    name: str
    what: str
    """What it changes, in words (docs, reports, ``hiddpg train --help``)."""
    apply: Callable[[Any], Any]
    """The agent config with the change made; configs it does not concern come back equal."""


def map_blocks(agent: Any, fn: Callable[[ActorCriticConfig], ActorCriticConfig]) -> Any:
    """``agent`` with ``fn`` applied to every actor-critic block in it: flat DDPG itself, both
    HI-DDPG levels, h-DDPG's skills."""
    if isinstance(agent, ActorCriticConfig):
        return fn(agent)
    if not dataclasses.is_dataclass(agent):
        return agent
    changed = {f.name: map_blocks(getattr(agent, f.name), fn) for f in dataclasses.fields(agent)
               if dataclasses.is_dataclass(getattr(agent, f.name))}
    return dataclasses.replace(agent, **changed) if changed else agent


def _blocks(**values: Any) -> Callable[[Any], Any]:
    return lambda agent: map_blocks(agent, lambda b: dataclasses.replace(b, **values))


def _scale_lr(factor: float) -> Callable[[Any], Any]:
    def scale(block: ActorCriticConfig) -> ActorCriticConfig:
        rates = {n: getattr(block, n) * factor for n in ("lr", "actor_lr", "critic_lr")
                 if hasattr(block, n)}
        return dataclasses.replace(block, **rates)

    return lambda agent: map_blocks(agent, scale)


def _set_lr(value: float) -> Callable[[Any], Any]:
    def set_rates(block: ActorCriticConfig) -> ActorCriticConfig:
        rates = {n: value for n in ("lr", "actor_lr", "critic_lr") if hasattr(block, n)}
        return dataclasses.replace(block, **rates)

    return lambda agent: map_blocks(agent, set_rates)


def _eager_high(agent: Any) -> Any:
    if not isinstance(agent, HIDDPGConfig):
        return agent
    return dataclasses.replace(agent, eager_high=EagerHighLevel())


def _low_through_termination(agent: Any) -> Any:
    if not isinstance(agent, HIDDPGConfig):
        return agent
    return dataclasses.replace(agent, low=dataclasses.replace(agent.low, env_terminal=False))


def _episode_end_terminal(agent: Any) -> Any:
    if isinstance(agent, HIDDPGConfig):  # the low level's reward is intrinsic: it keeps its own
        return dataclasses.replace(agent, high=dataclasses.replace(agent.high,
                                                                   end_is_terminal=True))
    return map_blocks(agent, lambda b: dataclasses.replace(b, end_is_terminal=True))


#: Every change the diagnosis measures, by name.
CHANGES: dict[str, Change] = {c.name: c for c in (
    Change("lr-x5", "learning rates ×5 at every level", _scale_lr(5.0)),
    Change("lr-x25", "learning rates ×25 at every level", _scale_lr(25.0)),
    Change("lr-1e-3", "learning rate 1e-3 for every actor and critic", _set_lr(1e-3)),
    Change("tau-0.01", "target networks follow at τ = 0.01 (paper: silent; spec 0.001)",
           _blocks(tau=0.01)),
    Change("invert-gradients", "inverted gradients at the action bounds in every actor's "
           "update", _blocks(invert_gradients=True)),
    Change("action-l2", "an action penalty |a|² (weight 1) in every actor's loss",
           _blocks(action_l2=1.0)),
    Change("linear-output", "linear actor outputs (the paper's §II-D), clipped where the "
           "action is used", _blocks(actor_output="linear")),
    Change("high-every-step", "HI-DDPG's high level learns at every step instead of once per "
           "segment end (Alg. 1), and D_H also keeps the low level's pre-training segments "
           "(where there is a pre-training: the arm)", _eager_high),
    Change("low-through-termination", "HI-DDPG's low level, whose reward is intrinsic, "
           "bootstraps through the environment's termination (the high level does not)",
           _low_through_termination),
    Change("episode-end-terminal", "the value of every level that earns the environment's "
           "reward ends with the episode, at the time limit too (spec §3 bootstraps there; "
           "the paper's arm rule, §III-B, read for every episode's final step)",
           _episode_end_terminal),
)}

#: The changes of ``paper+``, in the order they are applied: the smallest set that learns both
#: PuckTrajectory2 and ArmObstacle, each change needed on at least one of them
#: (docs/paper-plus.md, "How `paper+` is chosen"), and ``episode-end-terminal``, which removes
#: the arm's late collisions without a loss in score (docs/paper-plus-arm.md, "Why `paper+` collides
#: late on the arm").
PAPER_PLUS: tuple[str, ...] = ("high-every-step", "lr-1e-3", "invert-gradients", "action-l2",
                               "low-through-termination", "episode-end-terminal")

#: variant name -> its changes.
VARIANTS: dict[str, tuple[str, ...]] = {"paper": (), "paper+": PAPER_PLUS}


def apply_changes(agent: Any, names: tuple[str, ...] | list[str]) -> Any:
    """``agent`` with the named changes made in order; an unknown name is an error naming the
    known ones."""
    for name in names:
        if name not in CHANGES:
            raise ValueError(f"unknown change {name!r}; choose from {sorted(CHANGES)}")
        agent = CHANGES[name].apply(agent)
    return agent


def same_as(variant: str) -> str | None:
    """The variant ``variant`` trains exactly, when it adds no change to it (``paper+`` while
    :data:`PAPER_PLUS` is empty: ``"paper"``); else None. Such a variant has no runs of its
    own: ``hiddpg reproduce`` trains nothing for it and ``hiddpg claims`` reads the other's."""
    if variant in VARIANTS and variant != "paper" and not VARIANTS[variant]:
        return "paper"
    return None


def describe(variant: str) -> str:
    """One line naming what ``variant`` is (figures, reports)."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; choose one of {list(VARIANTS)}")
    changes = VARIANTS[variant]
    if variant == "paper":
        return "paper: the paper as written"
    if not changes:
        return (f"{variant}: the paper as written; no generic change is shown to be needed "
                "yet (docs/diagnosis.md)")
    return f"{variant}: the paper plus " + "; ".join(CHANGES[c].what for c in changes)


def ddpg_paper_plus(task: str) -> Any:
    from hiddpg.presets import ddpg_paper

    return apply_changes(ddpg_paper(task), PAPER_PLUS)


def hi_ddpg_paper_plus(task: str) -> Any:
    from hiddpg.presets import hi_ddpg_paper

    return apply_changes(hi_ddpg_paper(task), PAPER_PLUS)


def hi_ddpg_wo_model_paper_plus(task: str) -> Any:
    from hiddpg.presets import hi_ddpg_wo_model_paper

    return apply_changes(hi_ddpg_wo_model_paper(task), PAPER_PLUS)


def h_ddpg_paper_plus(task: str) -> Any:
    from hiddpg.presets import h_ddpg_paper

    return apply_changes(h_ddpg_paper(task), PAPER_PLUS)
