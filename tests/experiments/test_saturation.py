"""The low level's saturation probe (hiddpg.experiments.saturation)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from hiddpg.experiments.saturation import low_saturation, saturation_table
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys


@functools.cache
def _trained(chunk: int = 3):
    config = make_config("hi-ddpg", "PuckTrajectory1", "quick",
                         ["agent.high.hidden=[16,16]", "agent.low.hidden=[16,16]"])
    trainer = make_trainer(config)
    state = trainer.init_seeds(seed_keys([0, 1]))
    state, *_ = trainer.run_chunk_seeds(state, chunk)
    return trainer, state

def _with_output_bias(state, value):
    low = state.agent.low
    actor = low.block.actor
    out = actor["params"]["out"]
    moved = {"params": dict(actor["params"], out=dict(out, bias=out["bias"] + value))}
    low = low.replace(block=low.block.replace(actor=moved))
    return state.replace(agent=state.agent.replace(low=low))

def test_a_fresh_low_level_depends_on_its_goals_and_a_saturated_one_does_not():
    """A briefly trained low level is inside its bounds and moves with the goal; the same
    actor with its output bias pushed far out gives ±1 everywhere: share 1, no goal effect,
    no spread."""
    trainer, state = _trained()
    out = low_saturation(trainer, state, samples=200)
    assert out["bound_share"].shape == (2,)
    assert np.all(out["bound_share"] < 0.5) and np.all(out["goal_effect"] > 1e-5)
    assert np.all(out["spread"] > 1e-5) and np.all(out["stored"] == 3 * 30)
    pushed = low_saturation(trainer, _with_output_bias(state, 1e3), samples=200)
    np.testing.assert_array_equal(pushed["bound_share"], 1.0)
    np.testing.assert_allclose(pushed["mean_abs"], 1.0)
    np.testing.assert_array_equal(pushed["goal_effect"], 0.0)
    np.testing.assert_array_equal(pushed["spread"], 0.0)

def test_the_table_has_a_row_per_seed_and_bad_input_is_named():
    trainer, state = _trained()
    out = low_saturation(trainer, state, samples=50)
    record = {"runs": [{"run": "x", "episodes": 3, "seeds": {
        str(s): {k: v[i].item() for k, v in out.items()} for i, s in enumerate([0, 1])}}]}
    table = saturation_table(record).splitlines()
    assert len(table) == 4 and table[2].startswith("| x | 3 | 0 | 90 |")
    with pytest.raises(ValueError, match="samples must be at least 2, not 1"):
        low_saturation(trainer, state, samples=1)
    empty = trainer.init_seeds(seed_keys([0, 1]))
    with pytest.raises(ValueError, match="buffer holds 0 transitions"):
        low_saturation(trainer, empty)
    ddpg = make_trainer(make_config("ddpg", "PuckTrajectory1", "quick"))
    with pytest.raises(ValueError, match="low_saturation probes HI-DDPG runs, not DDPG"):
        low_saturation(ddpg, state)
