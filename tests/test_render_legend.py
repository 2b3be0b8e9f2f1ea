"""The frames' legend: one entry per mark drawn and no other, the same for every frame of a
rollout, a strip below the view; the running number is named ``env_return`` as in ``hiddpg
eval``'s table; ``eval --gif`` names HI-DDPG's learned goals and h-DDPG's skill changes."""

from __future__ import annotations

from types import SimpleNamespace

import jax
import numpy as np
import pytest

from hiddpg import make, render
from hiddpg.commands import envs as envs_cmd
from hiddpg.commands import eval as eval_cmd
from hiddpg.render_style import SWATCHES


def labels(items):
    return [item.label for item in items]


@pytest.mark.parametrize("task, static", [
    ("PuckTrajectory2", ["reference path", "reference goals g1, g2"]),
    ("PuckTrajectory1", ["reference path", "reference goal g1"]),
    ("PuckObstacle", ["obstacle", "target"]),
    ("ArmObstacle", ["obstacle", "collision distance", "target (hand)"]),
    ("ArmReach", []),  # the target is drawn per episode: none without one
])
def test_static_entries_follow_the_task(task, static):
    core, params = make(task)
    scene = render.Scene(core, params)
    body = ["puck"] if task.startswith("Puck") else ["hand"]
    assert labels(scene.legend_items()) == static + body
    action = ["force (action)"] if task.startswith("Puck") else ["muscles (red: active)"]
    assert labels(scene.legend_items(action=True)) == static + body + action
    assert all(item.swatch in SWATCHES for item in scene.legend_items(action=True))


def test_arm_target_given_to_the_scene_is_named():
    core, params = make("ArmReach")
    scene = render.Scene(core, params, target=np.array([1.0, 1.5]))
    assert "target (hand)" in labels(scene.legend_items())


def test_overlay_entries_only_for_what_is_drawn():
    core, params = make("PuckObstacle")
    scene = render.Scene(core, params)
    empty = labels(scene.legend_items(render.Overlay()))
    assert not {"trail", "goal", "goal switch"} & set(empty)
    one = render.Overlay(goals=[(1.0, 0.5)], active_goal=0, trail=[(0, 0), (0.1, 0.1)],
                         goal_label="learned goal")
    assert labels(scene.legend_items(one)) == [
        "obstacle", "target", "trail", "learned goal", "puck"]
    two = render.Overlay(goals=[(1.0, 0.5), (2.0, 0.0)], active_goal=1,
                         switch_points=[(1.0, 0.4)], switch_label="skill change")
    assert labels(scene.legend_items(two))[2:] == [
        "goal", "earlier goal", "skill change", "puck"]


def test_legend_strip_is_below_the_view_and_leaves_it_unchanged():
    core, params = make("PuckTrajectory2")
    _, state = core.reset(jax.random.PRNGKey(0), params)
    scene = render.Scene(core, params)
    overlay = render.Overlay(trail=[(0, 0), (0.5, -0.5)], text=["step 1"])
    plain = scene.frame(state, overlay=overlay)
    overlay.legend = scene.legend_items(overlay)
    framed = scene.frame(state, overlay=overlay)
    assert framed.shape[1] == plain.shape[1] and framed.shape[0] > plain.shape[0]
    np.testing.assert_array_equal(framed[:plain.shape[0]], plain)
    strip = framed[plain.shape[0]:]
    assert len(np.unique(strip.reshape(-1, 3), axis=0)) > 5  # swatches and text drawn
    many = scene.legend_strip(list(overlay.legend) * 3)  # wraps into more rows, same width
    assert many.size[0] == strip.shape[1] and many.size[1] > strip.shape[0]


def test_rollout_shares_one_legend_and_names_env_return():
    run = envs_cmd.demo_rollout("PuckTrajectory2", max_steps=20)
    scene = render.Scene(run["core"], run["params"])
    overlays = render.rollout_overlays(scene, run["states"], run["actions"], run["rewards"],
                                       goals=run["goals"], title="demo",
                                       goal_label="scripted goal")
    assert len(overlays) == 21
    assert all(o.legend == overlays[0].legend for o in overlays)
    assert labels(overlays[0].legend) == [
        "reference path", "reference goals g1, g2", "trail", "scripted goal",
        "earlier scripted goal", "goal switch", "puck", "force (action)"]
    last = overlays[-1].text[-1]
    assert last.startswith("step  20   env_return") and "   return" not in last
    assert float(last.split()[-1]) == pytest.approx(float(np.sum(run["rewards"])), abs=0.01)
    bare = render.rollout_overlays(scene, run["states"][:1], legend=False)
    assert bare[0].legend == () and bare[0].text == ["step   0"]
    frames = render.render_rollout(run["core"], run["params"], run["states"][:3],
                                   run["actions"][:2], run["rewards"][:2], run["goals"][:2])
    assert frames[0].shape[0] > scene.size[1]  # the legend strip is in every frame
    assert len({f.shape for f in frames}) == 1


def _capture_overlays(monkeypatch):
    seen = []
    frame = render.Scene.frame

    def recording(self, x, action=None, overlay=None):
        seen.append(overlay)
        return frame(self, x, action, overlay)

    monkeypatch.setattr(render.Scene, "frame", recording)
    return seen


def _episode(task, n=12):
    run = envs_cmd.demo_rollout(task, max_steps=n)
    core, params = run["core"], run["params"]
    obs = np.concatenate([run["states"][:-1], np.zeros((n, core.obs_dim - core.state_dim))], 1)
    trainer = SimpleNamespace(env=core, env_params=params)
    traj = {"alive": np.ones(n), "obs": obs, "action": run["actions"], "reward": run["rewards"]}
    return trainer, traj, run


def test_eval_gif_names_learned_goals_and_switches(tmp_path, monkeypatch):
    trainer, traj, run = _episode("PuckTrajectory2")
    switch = np.zeros(12, bool)
    switch[[0, 6]] = True
    traj.update(goal=run["goals"], switch=switch)
    seen = _capture_overlays(monkeypatch)
    path = eval_cmd.write_episode_gif(trainer, traj, str(tmp_path / "hi.gif"), "hi-ddpg")
    assert path.is_file() and len(seen) == 12
    names = labels(seen[0].legend)
    assert {"learned goal", "earlier learned goal", "goal switch", "trail"} <= set(names)
    assert seen[-1].text[0] == "hi-ddpg" and "env_return" in seen[-1].text[1]
    assert len(seen[-1].switch_points) == 1


def test_eval_gif_names_skill_changes(tmp_path, monkeypatch):
    trainer, traj, _ = _episode("PuckObstacle")
    traj["skill"] = np.array([0] * 5 + [2] * 7)
    seen = _capture_overlays(monkeypatch)
    eval_cmd.write_episode_gif(trainer, traj, str(tmp_path / "h.gif"), "h-ddpg")
    names = labels(seen[0].legend)
    assert "skill change" in names and not {"goal", "learned goal"} & set(names)
    assert seen[4].text[1].endswith("skill 0") and seen[5].text[1].endswith("skill 2")
    assert len(seen[-1].switch_points) == 1 and not seen[-1].goals
