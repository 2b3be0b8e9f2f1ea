"""What could a run's high level reach with its own low level? A diagnostic, run by hand.

For each seed of a trained HI-DDPG run, search two-goal plans ``(g1 for T1 steps, then g2)``
by grid, driving the run's learned low level without noise, and compare the best plan's return
with the learned high level's (its noise-free evaluation). A large gap means the high level's
optimisation is what fails, not the low level.

* ``PuckTrajectory2``: a coarse-to-fine grid around the reference goals, ``T1`` in 11..19; it
  also reports the return of the reference goals themselves, how far the best goals lie
  from them, and the best plan with both goals within 0.3 of the reference's: where that is
  more than 0.1 below the best, a high level that finds the best plan misses the
  reproduction's goal bar (the low level, not the high level, is what keeps it off).
* ``ArmObstacle``: ``g1`` on a 10-degree grid over the workspace, ``T1`` in 10..40, ``g2`` on a
  5-degree grid around the target; it reports the fraction of plans that collide or succeed.

Usage::

    python scripts/best_plans.py RUN_DIR
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.runs import Run, make_trainer
from hiddpg.train import eval_keys


def plan_rollouts(trainer):
    """``(low_state, g1, T1, g2) -> (return, alive at the end, final info distance)`` over a
    batch of plans (goals are the goal space's entries)."""
    agent, env, params = trainer.agent, trainer.env, trainer.env_params
    space, horizon = env.goal_space, env.max_steps(params)

    def one(low_state, g1, t1, g2):
        obs, state = env.reset(jax.random.PRNGKey(0), params)

        def body(carry, t):
            obs, state, alive, ret = carry
            goal = space.embed(jnp.where(t < t1, g1, g2), env.obs_dim)
            unit = agent.low.act(low_state, obs, goal)
            res = env.step(jax.random.PRNGKey(0), state, agent.env_action(unit), params)
            ret = ret + jnp.where(alive, res.reward, 0.0)
            alive = alive & ~res.terminated
            return (res.obs, res.state, alive, ret), res.info.get("distance", jnp.zeros(()))

        (_, _, alive, ret), dist = jax.lax.scan(
            body, (obs, state, jnp.array(True), jnp.zeros(())), jnp.arange(horizon))
        return ret, alive, dist[-1]

    return jax.jit(jax.vmap(one, in_axes=(None, 0, 0, 0)))


def _pairs(c1, c2, span: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    offsets = np.arange(-span, span + 1e-9, step)
    g1 = np.array([(c1[0] + x, c1[1] + y) for x in offsets for y in offsets], np.float32)
    g2 = np.array([(c2[0] + x, c2[1] + y) for x in offsets for y in offsets], np.float32)
    return np.repeat(g1, len(g2), 0), np.tile(g2, (len(g1), 1))


def puck(roll, low, params) -> str:
    ref = np.asarray(params.goals, np.float32)
    switch = int(np.asarray(params.switch_steps)[0])
    r_ref = float(roll(low, ref[:1], np.array([switch], np.float32), ref[1:2])[0][0])
    best = (ref[0], ref[1], switch, r_ref)
    for span, step in ((1.0, 0.2), (0.3, 0.05)):
        centre = best
        for t1 in range(11, 20):
            g1, g2 = _pairs(centre[0], centre[1], span, step)
            ret = np.asarray(roll(low, g1, np.full(len(g1), t1, np.float32), g2)[0])
            k = int(ret.argmax())
            if ret[k] > best[3]:
                best = (g1[k], g2[k], t1, float(ret[k]))
    near = _best_near(roll, low, ref)
    return (f"reference goals {r_ref:.2f}; best plan {best[3]:.2f}: g1 {best[0].round(2)} "
            f"({np.linalg.norm(best[0] - ref[0]):.2f} off) for {best[2]} steps, "
            f"g2 {best[1].round(2)} ({np.linalg.norm(best[1] - ref[1]):.2f} off); best with "
            f"both goals within {NEAR} of the reference's {near:.2f} "
            f"({'meets' if near >= best[3] - TIE else 'misses'} the bar's goals)")


NEAR = 0.3
"""The reproduction's goal radius (``experiments.trajectory.GOAL_RADIUS``)."""
TIE = 0.1
"""A plan near the reference within this much of the best counts as a tie."""


def _best_near(roll, low, ref: np.ndarray) -> float:
    """The best return of plans whose two goals lie within :data:`NEAR` of the reference's
    (a 0.05 grid over both discs, ``T1`` in 11..19)."""
    offsets = np.arange(-NEAR, NEAR + 1e-9, 0.05)
    disc = np.array([(x, y) for x in offsets for y in offsets if np.hypot(x, y) < NEAR],
                    np.float32)
    g1 = np.repeat(ref[0] + disc, len(disc), 0)
    g2 = np.tile(ref[1] + disc, (len(disc), 1))
    return max(float(np.asarray(roll(low, g1, np.full(len(g1), t1, np.float32), g2)[0]).max())
               for t1 in range(11, 20))


def arm(roll, low, params) -> str:
    deg = np.deg2rad
    g1s = [(a, b) for a in range(30, 131, 10) for b in range(60, 161, 10)]
    g2s = [(a, b) for a in range(80, 101, 5) for b in range(45, 76, 5)]
    plans = np.array([(*g1, t, *g2) for g1 in g1s for t in range(10, 41, 5) for g2 in g2s],
                     np.float32)
    ret, alive, dist = map(np.asarray, roll(low, deg(plans[:, :2]), plans[:, 2],
                                            deg(plans[:, 3:])))
    ok = alive & (dist < float(params.success_radius))
    k = int(ret.argmax())
    return (f"{ok.mean():.1%} of {len(plans)} plans succeed, {1 - alive.mean():.1%} collide; "
            f"best plan {ret[k]:.2f} (success {bool(ok[k])}): g1 {plans[k, :2].astype(int)} deg "
            f"for {int(plans[k, 2])} steps, g2 {plans[k, 3:].astype(int)} deg")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="a HI-DDPG run directory on PuckTrajectory2 or ArmObstacle")
    args = parser.parse_args()
    run = Run.open(args.run)
    task = run.config.task
    if not run.config.algo.startswith("hi-ddpg") or task not in ("PuckTrajectory2",
                                                                 "ArmObstacle"):
        parser.error(f"{args.run}: {run.config.algo} on {task}; need hi-ddpg or "
                     "hi-ddpg-wo-model on PuckTrajectory2 or ArmObstacle")
    trainer = make_trainer(run.config)
    state, done = run.load_checkpoint(trainer)
    learned, _ = trainer.evaluate_seeds(state, eval_keys(0, run.seeds))
    roll = plan_rollouts(trainer)
    search = puck if task == "PuckTrajectory2" else arm
    print(f"{run.config.algo} on {task} after {done} episodes")
    for i, seed in enumerate(run.seeds):
        low = jax.tree.map(lambda x, i=i: x[i], state.agent.low)
        print(f"seed {seed}: learned high level {float(learned['env_return'][i]):.2f}; "
              + search(roll, low, trainer.env_params))


if __name__ == "__main__":
    main()
