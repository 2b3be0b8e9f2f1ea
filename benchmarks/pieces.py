"""Where the time of one training step goes: each part timed as a jitted ``lax.scan``.

Run through ``benchmarks/throughput.py --pieces``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp

from hiddpg.configs import TrainConfig
from hiddpg.train import Trainer


def pieces(ours_config: Callable[[str, int, int], TrainConfig], n: int = 300,
           episodes: int = 10) -> list[tuple[str, float, float]]:
    """Milliseconds per env step of the parts of one seed's training step, each a jitted
    ``lax.scan`` without ``vmap`` (best of 3): ``(label, wall ms, cpu ms)``. ``ours_config``
    is the benchmark's ``(algo, episodes, repeats) -> config``."""
    from hiddpg.agents import buffer as replay

    key = jax.random.PRNGKey(0)
    keys = jax.random.split(key, n)
    out = []

    def clock(label: str, fn, arg, per: int) -> None:
        fn = jax.jit(fn)
        jax.block_until_ready(fn(arg))
        wall = cpu = float("inf")
        for _ in range(3):
            start, start_cpu = time.perf_counter(), time.process_time()
            jax.block_until_ready(fn(arg))
            wall = min(wall, time.perf_counter() - start)
            cpu = min(cpu, time.process_time() - start_cpu)
        out.append((label, 1e3 * wall / per, 1e3 * cpu / per))
        print(f"  {label:58s} {1e3 * wall / per:7.3f} ms/step (cpu {1e3 * cpu / per:.3f})",
              flush=True)

    def scan(body):
        return lambda s: jax.lax.scan(lambda c, k: (body(c, k), None), s, keys)[0]

    def episodes_of(trainer, vmapped: bool):
        agent, params = trainer.agent, trainer.env_params
        run = lambda s: jax.lax.scan(  # noqa: E731
            lambda c, k: agent.train_episode(k, c, params), s,
            jax.random.split(key, episodes))[0]
        return jax.vmap(run) if vmapped else run

    def one(algo: str) -> None:
        trainer = Trainer(ours_config(algo, episodes, 1))
        agent, state = trainer.agent, trainer.agent.init(key, trainer.env_params)
        single = jax.tree.map(lambda x: x[None], state)
        per_ep = episodes * trainer.env.max_steps(trainer.env_params)
        clock(f"{algo}: train_episode, vmap over 1 seed (unnamed axis)",
              episodes_of(trainer, True), single, per_ep)
        clock(f"{algo}: train_episode, no vmap (as Trainer: lax.cond branches)",
              episodes_of(trainer, False), state, per_ep)
        idle = Trainer(dataclasses.replace(trainer.config, agent=dataclasses.replace(
            trainer.config.agent, learning_starts=10**9)))
        clock(f"{algo}: train_episode, no vmap, no update (env, acting, replay)",
              episodes_of(idle, False), state, per_ep)
        if algo == "ddpg":
            block, b = agent.block, trainer.config.agent.batch_size

            def sample(buf, k, b=b):
                return replay.sample(buf, k, b)

            buf = state.buffer
            clock("ddpg: block.update (critic + actor + targets)",
                  scan(lambda s, k: block.update(s, sample(buf, k))[0]), state.block, n)
            clock("ddpg:   critic_update", scan(
                lambda s, k: block.critic_update(s, sample(buf, k))[0]), state.block, n)
            clock("ddpg:   actor_update", scan(
                lambda s, k: block.actor_update(s, sample(buf, k)["obs"])[0]), state.block, n)
            clock("ddpg: replay add + sample (100k)", scan(
                lambda s, k: replay.add(s, jax.tree.map(lambda x: x[0], sample(s, k, 1)))),
                  buf, n)
        else:
            for name in ("low", "high"):
                level, ls = getattr(agent, name), getattr(state, name)
                clock(f"hi-ddpg: {name} Level.update (block + model grad + model)",
                      scan(lambda s, k, lv=level: lv.update(s, k)[0]), ls, n)
                blk = level.block

                def block_only(s, k, lv=level, blk=blk):
                    tr = replay.sample(s.buffer, k, lv.config.batch_size)
                    inp = jnp.concatenate([tr["s"], tr["c"]], -1)
                    batch = {"obs": inp, "action": tr["a"], "reward": tr["r"],
                             "next_obs": jnp.concatenate([tr["s2"], tr["c"]], -1),
                             "terminated": tr["terminated"]}
                    return s.replace(block=blk.update(s.block, batch)[0])

                clock(f"hi-ddpg:   {name} block update alone", scan(block_only), ls, n)

    for algo in ("ddpg", "hi-ddpg"):
        one(algo)
    return out
