"""Matrix-multiply FLOPs of one training step, and NumPy's rate on the same shapes.

Used by ``benchmarks/throughput.py`` (its docstring says what is measured and why).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

Trainer = Any  # hiddpg.train.Trainer (not imported: this module must not start JAX's devices)


# -- FLOPs per environment step ------------------------------------------------------------------
#
# Only matrix multiplies are counted (elementwise work, Adam and Polyak updates are O(params),
# <3% here). A dense layer ``in -> out`` on a batch of B rows costs
#
#     f(in, out) = 2 B in out                  forward  (B, in) @ (in, out)
#     f(in, out)                               weight gradient  (in, B) @ (B, out)
#     f(in, out)                               input gradient   (B, out) @ (out, in)
#
# For a network N with layers l = 1..L write F(N) = sum_l f(l) (forward), W(N) = F(N) (weight
# gradients), X(N) = sum_l f(l) (input gradients of every layer) and X1(N) = sum_{l>=2} f(l)
# (input gradients a backward pass to the weights needs: the first layer's is skipped).
# Actor A: d_in -> 300 -> 300 -> d_a (tanh); critic C: d_in -> 300, [h, a] -> 300 -> 1 (the
# action enters the second layer, paper §II-D); model M: [s, a] -> 300 -> 300 -> d_s.
#
# One DDPG block update (hiddpg.agents.block.DDPGBlock.update):
#     target  y = r + g Q'(s', mu'(s'))                       F(A) + F(C)
#     critic  value_and_grad of the TD loss                   F(C) + W(C) + X1(C)
#     actor   mu(s) (vjp), dQ/da (vjp), pullback to theta     F(A) + F(C) + X1(C) + W(A) + X1(A)
#   = 2 F(A) + W(A) + X1(A) + 3 F(C) + W(C) + 2 X1(C)  (= 3 F(A) + X1(A) + 4 F(C) + 2 X1(C))
# One HI-DDPG level update (hiddpg.agents.level.Level.update) adds
#     model-based dQ/da: grad_a V(s + dt M(s, a)), V(x) = Q(x, mu(x)), batched over B:
#                                                   F(M) + F(A) + F(C) + X(M) + X(A) + X(C)
#     model   value_and_grad of the MSE                       F(M) + W(M) + X1(M)
# Acting costs F(A) with B = 1 per actor queried.
#
# Flat DDPG, per env step: one block update (batch 64) + the actor on one observation.
# HI-DDPG, per env step: one low-level update, one high-level update and both actors on one
# observation. The paper preset updates the high level at segment ends only (Alg. 1), counted
# as segments / steps; ``eager_high.every_step`` updates it at every step.
# SB3 DDPG, per env step: its critic takes [s, a] at the input and its actor loss
# -Q(s, mu(s)) backpropagates through the critic's weights too (they are computed and discarded):
#     target F(A) + F(C); critic F(C) + W(C) + X1(C); actor F(A) + F(C) + W(C) + X(C) + W(A) + X1(A)


@dataclass(frozen=True)
class Layer:
    d_in: int
    d_out: int


def mlp(d_in: int, hidden: tuple[int, ...], d_out: int) -> list[Layer]:
    sizes = [d_in, *hidden, d_out]
    return [Layer(a, b) for a, b in zip(sizes[:-1], sizes[1:], strict=True)]


def critic_layers(d_obs: int, d_act: int, hidden: tuple[int, ...]) -> list[Layer]:
    """Our critic: the action joins the output of the first hidden layer."""
    sizes = [d_obs, hidden[0] + d_act, *hidden[1:]]
    outs = [*hidden, 1]
    return [Layer(a, b) for a, b in zip(sizes, outs, strict=True)]


#: a matmul (m, k, n): (m, k) @ (k, n), with how often it is executed per env step
Matmul = tuple[int, int, int]


class Count:
    """Accumulates the matmuls of one env step (shapes and multiplicities)."""

    def __init__(self) -> None:
        self.matmuls: dict[Matmul, int] = {}

    def add(self, shape: Matmul, times: int = 1) -> None:
        self.matmuls[shape] = self.matmuls.get(shape, 0) + times

    def fwd(self, net: list[Layer], b: int, times: int = 1) -> None:  # F(N)
        for layer in net:
            self.add((b, layer.d_in, layer.d_out), times)

    def wgrad(self, net: list[Layer], b: int, times: int = 1) -> None:  # W(N)
        for layer in net:
            self.add((layer.d_in, b, layer.d_out), times)

    def xgrad(self, net: list[Layer], b: int, times: int = 1, first: bool = False) -> None:
        """X(N) with ``first``, else X1(N)."""
        for layer in net if first else net[1:]:
            self.add((b, layer.d_out, layer.d_in), times)

    @property
    def flops(self) -> int:
        return int(sum(2 * m * k * n * t for (m, k, n), t in self.matmuls.items()))


def block_update(c: Count, actor: list[Layer], critic: list[Layer], b: int) -> None:
    """One DDPG block update (see the formula above)."""
    c.fwd(actor, b)
    c.fwd(critic, b)  # target
    c.fwd(critic, b)
    c.wgrad(critic, b)
    c.xgrad(critic, b)  # critic step
    c.fwd(actor, b)
    c.fwd(critic, b)
    c.xgrad(critic, b)
    c.wgrad(actor, b)
    c.xgrad(actor, b)  # actor step


def level_update(c: Count, actor: list[Layer], critic: list[Layer], model: list[Layer], b: int,
                 use_model: bool = True, model_gradient: bool = True) -> None:
    """One HI-DDPG level update: the block update, the model-based dQ/da and the model step."""
    block_update(c, actor, critic, b)
    if model_gradient:
        for net in (model, actor, critic):
            c.fwd(net, b)
            c.xgrad(net, b, first=True)
    if use_model:
        c.fwd(model, b)
        c.wgrad(model, b)
        c.xgrad(model, b)


def flops_per_step(algo: str, trainer: Trainer | None = None, high_updates: float = 1.0
                   ) -> Count:
    """The matmuls one environment step of ``algo`` executes (``"sb3"``: SB3's DDPG);
    HI-DDPG's high level updates ``high_updates`` times per env step (1 with the preset's
    ``eager_high.every_step``, segments / steps with Alg. 1's schedule)."""
    algo = algo.split("@")[0]
    c = Count()
    if algo == "sb3":  # PuckTrajectory2: obs 4, action 2, net_arch 300-300, batch 64
        actor, critic, b = mlp(4, (300, 300), 2), mlp(4 + 2, (300, 300), 1), 64
        c.fwd(actor, b)
        c.fwd(critic, b)
        c.fwd(critic, b)
        c.wgrad(critic, b)
        c.xgrad(critic, b)
        c.fwd(actor, b)
        c.fwd(critic, b)
        c.wgrad(critic, b)
        c.xgrad(critic, b, first=True)
        c.wgrad(actor, b)
        c.xgrad(actor, b)
        c.fwd(actor, 1)
        return c
    assert trainer is not None
    env, cfg = trainer.env, trainer.config.agent
    if algo == "ddpg":
        hidden = tuple(cfg.hidden)
        actor = mlp(env.obs_dim, hidden, env.action_dim)
        critic = critic_layers(env.obs_dim, env.action_dim, hidden)
        block_update(c, actor, critic, cfg.batch_size)
        c.fwd(actor, 1)
        return c
    agent = trainer.agent
    if algo == "h-ddpg":
        # K skill blocks (all updated every step, vmapped over the skill axis) + the DQN meta
        # critic: online forward, target forward, backward for the weights; + acting.
        hidden = tuple(cfg.skill.hidden)
        actor = mlp(env.obs_dim, hidden, agent.patterns.actor_dim)
        critic = critic_layers(env.obs_dim, agent.patterns.actor_dim, hidden)
        for _ in range(agent.n_skills):
            block_update(c, actor, critic, cfg.skill.batch_size)
            c.fwd(actor, 1)
        meta = mlp(env.obs_dim, tuple(cfg.meta.hidden), agent.n_skills)
        c.fwd(meta, cfg.meta.batch_size)
        c.fwd(meta, cfg.meta.batch_size)
        c.wgrad(meta, cfg.meta.batch_size)
        c.fwd(meta, 1)
        return c
    for level, times in ((agent.low, 1.0), (agent.high, high_updates)):
        hidden = tuple(level.config.hidden)
        d_in = level.state_dim + level.context_dim
        actor = mlp(d_in, hidden, level.action_dim)
        critic = critic_layers(d_in, level.action_dim, hidden)
        model = mlp(level.state_dim + level.action_dim, hidden, level.state_dim)
        update = Count()
        level_update(update, actor, critic, model, level.config.batch_size,
                     use_model=level.use_model, model_gradient=level.model_weight > 0)
        for shape, t in update.matmuls.items():
            c.add(shape, t if times == 1.0 else t * times)
        c.fwd(actor, 1)
    return c


def xla_update_flops(algo: str, trainer: Trainer) -> float | None:
    """XLA's cost analysis of one jitted update (all ops, not only matmuls), per env step."""
    try:
        key = jax.random.PRNGKey(0)
        agent = trainer.agent

        def flops(fn, *args) -> float:
            cost = jax.jit(fn).lower(*args).compile().cost_analysis()
            cost = cost[0] if isinstance(cost, list | tuple) else cost
            return float(cost["flops"])

        if algo == "ddpg":
            from hiddpg.agents.transition import example

            block, b = agent.block, trainer.config.agent.batch_size
            one = example(trainer.env.obs_dim, trainer.env.action_dim)
            batch = jax.tree.map(lambda x: jnp.zeros((b, *x.shape), x.dtype), one)
            return flops(block.update, block.init(key), batch)
        if algo == "h-ddpg":
            return None  # no single update function to analyse; the formula stands alone
        episode = jnp.zeros((), jnp.int32)
        return sum(flops(lambda s, k, lv=level: lv.update(s, k, episode=episode),
                         level.init(key), key) for level in (agent.low, agent.high))
    except Exception as err:  # noqa: BLE001 - a cross-check only
        print(f"  (XLA cost analysis unavailable: {err})")
        return None


# -- NumPy matmul rate ---------------------------------------------------------------------------
def numpy_gflops(matmuls: dict[Matmul, int], min_time: float = 0.3, repeats: int = 5) -> float:
    """GFLOP/s of NumPy (float32) executing exactly ``matmuls`` (each shape its number of
    times) back to back, best of ``repeats`` timings of at least ``min_time`` seconds."""
    if not matmuls:
        return float("nan")
    rng = np.random.default_rng(0)
    work = []
    for (m, k, n), t in matmuls.items():
        a = rng.standard_normal((m, k), np.float32)
        b = rng.standard_normal((k, n), np.float32)
        work.append((a, b, np.empty((m, n), np.float32), t))
    flops = sum(2 * a.shape[0] * a.shape[1] * b.shape[1] * t for a, b, _, t in work)

    def once() -> None:
        for a, b, out, t in work:
            for _ in range(t):
                np.matmul(a, b, out=out)

    once()
    n, elapsed = 1, 0.0
    while elapsed < min_time / 4:
        start = time.perf_counter()
        for _ in range(n):
            once()
        elapsed = time.perf_counter() - start
        n *= 2
    n = max(1, int(n / 2 * min_time / elapsed))
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(n):
            once()
        best = min(best, (time.perf_counter() - start) / n)
    return flops / best / 1e9
