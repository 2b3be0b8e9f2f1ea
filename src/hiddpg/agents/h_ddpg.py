"""h-DDPG: a meta-critic choosing among K DDPG skills every step (paper §III-C; spec §4).

The paper's baseline, after Yang et al. (2018), as the paper adapts it:

* ``K = 4`` basic skills, each a :class:`~hiddpg.agents.block.DDPGBlock` whose unit output is
  turned into an environment action by its built-in movement pattern
  (:mod:`hiddpg.agents.skills`: velocity along ±x/±y on PuckWorld, agonist activations on the
  arm). No high-level actor.
* A meta-critic ``Q_meta(s) ∈ R^K`` (an MLP) picks the skill **every step** ε-greedily, ε
  falling linearly from ``epsilon_start`` to ``epsilon_end`` over ``epsilon_decay_episodes``
  episodes (:func:`epsilon_schedule`). It is trained like a DQN on the environment reward:
  replay of ``(s, k, r, s', terminated)``, target ``r + γ (1 − terminated) max_k' Q'(s', k')``
  with a Polyak-averaged target network, squared error [decision: MSE as the DDPG critics].
* Each skill is trained by DDPG (critic eq. 3, actor eq. 2) on the environment reward [paper:
  "the basic reward in h-DDPG directly came from the environment"], from its own replay of the
  transitions in which it was chosen (masked inserts).

Decisions. The skills' parameters, optimiser states and replays are stacked along a leading
skill axis and updated with ``vmap`` (one compiled DDPG update for all skills). **Every skill
whose replay holds at least a batch is updated at every environment step**, not only the chosen
one: under ``vmap`` both cost the same, and a skill keeps learning from its data while it is not
chosen, so rarely chosen skills are not left behind. The actors share one output size (the
largest skill's); a skill with fewer agonists ignores its extra outputs (the critic sees them
and learns that they do not matter). One OU process, reset every episode, perturbs the acting
skill's unit output. The first ``skill.learning_starts`` environment steps use uniformly random
skills and unit outputs; nothing learns before. Learning rates of the skills decay by
``skill.lr_decay`` every ``skill.lr_decay_every`` episodes; the meta-critic's stays constant.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import optax
from flax import struct

from hiddpg.agents import buffer as replay
from hiddpg.agents import noise
from hiddpg.agents.block import BlockState, DDPGBlock, value_terminal
from hiddpg.agents.episode import EpisodeMetrics, run_episode, select
from hiddpg.agents.gate import gated
from hiddpg.agents.networks import FINAL_INIT_SCALE, MLP
from hiddpg.agents.skills import SkillPatterns, skill_patterns
from hiddpg.agents.streams import split_named
from hiddpg.agents.transition import Transition, example
from hiddpg.configs import HDDPGConfig
from hiddpg.envs.base import Environment


# -- the pieces that tests check on their own ---------------------------------------------------
def epsilon_schedule(episode: jax.Array, start: float, end: float, decay_episodes: int):
    """ε of episode ``episode`` (0-based): linear from ``start`` (episode 0) to ``end`` (episode
    ``decay_episodes`` and after) [spec §4]."""
    frac = jnp.clip(jnp.asarray(episode, jnp.float32) / decay_episodes, 0.0, 1.0)
    return start + (end - start) * frac


def epsilon_greedy(key: jax.Array, q: jax.Array, epsilon: jax.Array) -> jax.Array:
    """With probability ``epsilon`` a uniformly random skill, otherwise ``argmax q`` (int32)."""
    k_explore, k_skill = jax.random.split(key)
    random_skill = jax.random.randint(k_skill, (), 0, q.shape[-1])
    explore = jax.random.uniform(k_explore) < epsilon
    return jnp.where(explore, random_skill, jnp.argmax(q, axis=-1)).astype(jnp.int32)


def count_switches(skill: jax.Array, alive: jax.Array) -> jax.Array:
    """Skill changes between consecutive steps of the episode (``alive`` masks the steps after
    its end): comparable to HI-DDPG's goal switches (goals after the first)."""
    alive = jnp.asarray(alive, bool)
    changed = (skill[1:] != skill[:-1]) & alive[1:] & alive[:-1]
    return jnp.sum(changed).astype(jnp.int32)


@struct.dataclass
class MetaState:
    """The meta-critic: online and target parameters and the Adam state."""

    params: Any
    target: Any
    opt: Any


@struct.dataclass
class HDDPGState:
    """Everything h-DDPG carries between episodes.

    Attributes:
        skills: the K skills' :class:`BlockState`, every leaf with a leading skill axis.
        skill_buffers: the K skills' replays (leading skill axis; keys ``obs, action, reward,
            next_obs, terminated``, ``action`` the skill's unit output).
        meta: the meta-critic.
        meta_buffer: replay of ``obs, skill, reward, next_obs, terminated``.
        env_steps: int32 environment steps of the run; episodes: int32 episodes finished.
    """

    skills: BlockState
    skill_buffers: replay.ReplayBuffer
    meta: MetaState
    meta_buffer: replay.ReplayBuffer
    env_steps: jax.Array
    episodes: jax.Array


#: per-episode sums: the return, then what :meth:`HDDPG._learn` adds up, in its order.
_SUMS = ("ret", "meta_loss", "skill_critic_loss", "skill_actor_loss", "meta_updates",
         "skill_updates")

#: one step's random streams
STREAMS = ("skill", "noise", "random", "env", "learn")


@dataclasses.dataclass(frozen=True)
class HDDPG:
    """h-DDPG on one environment (an :class:`~hiddpg.agents.base.Agent`; see module docstring).
    Build with :func:`make_hddpg`."""

    config: HDDPGConfig
    env: Environment
    patterns: SkillPatterns
    block: DDPGBlock = dataclasses.field(init=False, repr=False, compare=False)
    meta_net: MLP = dataclasses.field(init=False, repr=False, compare=False)
    meta_tx: optax.GradientTransformation = dataclasses.field(init=False, repr=False,
                                                              compare=False)

    def __post_init__(self) -> None:
        c, s = self.config, self.config.skill
        setattr_ = object.__setattr__
        setattr_(self, "block", DDPGBlock(
            obs_dim=self.env.obs_dim, action_dim=self.patterns.actor_dim, hidden=s.hidden,
            actor_lr=s.actor_lr, critic_lr=s.critic_lr, gamma=s.gamma, tau=s.tau,
            invert_gradients=s.invert_gradients, action_l2=s.action_l2,
            actor_output=s.actor_output))
        setattr_(self, "meta_net", MLP(c.meta.hidden, self.n_skills, FINAL_INIT_SCALE))
        setattr_(self, "meta_tx", optax.adam(c.meta.lr))

    @property
    def n_skills(self) -> int:
        return self.patterns.n_skills

    # -- meta-critic (DQN) ------------------------------------------------------------------
    def meta_q(self, params: Any, obs: jax.Array) -> jax.Array:
        """``Q_meta(s) ∈ R^K`` (any leading batch shape)."""
        return self.meta_net.apply(params, obs)

    def epsilon(self, episodes: jax.Array) -> jax.Array:
        c = self.config
        return epsilon_schedule(episodes, c.epsilon_start, c.epsilon_end,
                                c.epsilon_decay_episodes)

    def meta_update(self, meta: MetaState, batch: Transition) -> tuple[MetaState, jax.Array]:
        """One Adam step on ``(r + γ (1 − terminated) max_k' Q'(s', k') − Q(s, k))²``, then the
        Polyak update of the target network."""
        c = self.config
        next_q = self.meta_q(meta.target, batch.next_obs).max(axis=-1)
        not_done = 1.0 - batch.terminated.astype(jnp.float32)
        y = jax.lax.stop_gradient(batch.reward + c.meta.gamma * not_done * next_q)

        def loss_fn(params: Any) -> jax.Array:
            q = self.meta_q(params, batch.obs)
            q_taken = jnp.take_along_axis(q, batch.action[:, None], axis=-1)[:, 0]
            return jnp.mean((y - q_taken) ** 2)

        loss, grads = jax.value_and_grad(loss_fn)(meta.params)
        updates, opt = self.meta_tx.update(grads, meta.opt, meta.params)
        params = optax.apply_updates(meta.params, updates)
        target = jax.tree_util.tree_map(
            lambda o, t: c.meta.tau * o + (1.0 - c.meta.tau) * t, params, meta.target)
        return MetaState(params=params, target=target, opt=opt), loss

    # -- skills (DDPG, vmapped over the skill axis) -------------------------------------------
    def skill_units(self, skills: BlockState, obs: jax.Array) -> jax.Array:
        """Every skill's unit output at ``obs``: ``(K, actor_dim)``."""
        return jax.vmap(self.block.mu, in_axes=(0, None))(skills.actor, obs)

    def skills_update(self, skills: BlockState, buffers: replay.ReplayBuffer, key: jax.Array):
        """One DDPG step for every skill whose replay holds a batch: ``(skills, gate, metrics)``
        with ``gate`` the ``(K,)`` mask of updated skills."""
        batch_size = self.config.skill.batch_size
        keys = jax.random.split(key, self.n_skills)
        batches = jax.vmap(lambda b, k: replay.sample(b, k, batch_size))(buffers, keys)
        new, metrics = jax.vmap(self.block.update)(skills, batches)
        gate = buffers.size >= batch_size
        return jax.vmap(select)(gate, new, skills), gate, metrics

    def _skill_learning_rates(self, skills: BlockState, episodes: jax.Array) -> BlockState:
        s = self.config.skill
        factor = jnp.float32(s.lr_decay) ** (episodes // s.lr_decay_every).astype(jnp.float32)
        lrs = (s.actor_lr * factor, s.critic_lr * factor)
        return jax.vmap(self.block.set_learning_rates, in_axes=(0, None, None))(skills, *lrs)

    # -- the Agent protocol -------------------------------------------------------------------
    def init(self, key: jax.Array, env_params: Any) -> HDDPGState:
        """Fresh skills and meta-critic, empty replays, zero counters."""
        del env_params
        c, k = self.config, self.n_skills
        k_skills, k_meta = jax.random.split(key)
        obs = jnp.zeros((self.env.obs_dim,), jnp.float32)
        skill_example = example(self.env.obs_dim, self.patterns.actor_dim)
        one = replay.init(skill_example, c.skill.buffer_size)
        meta_example = skill_example.replace(action=jnp.zeros((), jnp.int32))
        params = self.meta_net.init(k_meta, obs)
        zero = jnp.zeros((), jnp.int32)
        return HDDPGState(
            skills=jax.vmap(self.block.init)(jax.random.split(k_skills, k)),
            skill_buffers=jax.tree_util.tree_map(lambda x: jnp.stack([x] * k), one),
            meta=MetaState(params=params, target=params, opt=self.meta_tx.init(params)),
            meta_buffer=replay.init(meta_example, c.meta.buffer_size),
            env_steps=zero, episodes=zero,
        )

    @property
    def learning_starts(self) -> int:
        return self.config.skill.learning_starts

    def train_episode(self, key: jax.Array, state: HDDPGState, env_params: Any):
        """One episode of ε-greedy skill choice, OU-perturbed skills, replay and learning."""
        state, metrics, _ = run_episode(self, key, state, env_params, train=True)
        return state, metrics.as_dict()

    def evaluate(self, key: jax.Array, state: HDDPGState, env_params: Any):
        """A greedy, noise-free episode without learning: ``(metrics, trajectory)`` with ``obs``
        (before each action), ``action`` (the env's normalised action), ``reward``, ``alive``
        (1.0 while the episode runs) and ``skill`` (int32), each over the horizon."""
        _, metrics, traj = run_episode(self, key, state, env_params, train=False)
        return metrics.as_dict(), traj

    # -- the episode harness's hooks (hiddpg.agents.episode) ---------------------------------
    def step_keys(self, key: jax.Array, train: bool) -> dict[str, jax.Array]:
        return split_named(key, STREAMS)

    def decay(self, state: HDDPGState) -> HDDPGState:
        return state.replace(skills=self._skill_learning_rates(state.skills, state.episodes))

    def begin(self, state: HDDPGState, obs: jax.Array, horizon: int, train: bool):
        """The OU process and this episode's ε (0 in evaluation)."""
        epsilon = self.epsilon(state.episodes) if train else jnp.zeros((), jnp.float32)
        inner = (noise.init(self.config.skill.noise, self.patterns.actor_dim), epsilon)
        return inner, {n: jnp.zeros((), jnp.float32) for n in _SUMS}

    def act(self, state: HDDPGState, inner: Any, obs: jax.Array, alive: jax.Array,
            keys: dict, random_phase: jax.Array, env_params: Any, horizon: int, train: bool):
        """The meta-critic picks a skill (ε-greedy; greedy in evaluation); the skill's unit
        output (+ OU noise) goes through its movement pattern."""
        c, (noise_state, epsilon) = self.config, inner
        random_phase = random_phase if train else False
        eps = jnp.where(random_phase, 1.0, epsilon)
        skill = epsilon_greedy(keys["skill"], self.meta_q(state.meta.params, obs), eps)
        unit = self.skill_units(state.skills, obs)[skill]
        if train:
            noise_state, n = noise.sample(c.skill.noise, noise_state, keys["noise"],
                                          state.episodes)
            uniform = jax.random.uniform(keys["random"], unit.shape, jnp.float32, -1.0, 1.0)
            unit = jnp.where(random_phase, uniform, jnp.clip(unit + n, -1.0, 1.0))
        action = self.patterns.env_action(skill, unit, obs, env_params)
        return (noise_state, epsilon), action, (skill, unit, action)

    def observe(self, state: HDDPGState, inner: Any, obs: jax.Array, info: Any, res: Any,
                alive: jax.Array, keys: dict, random_phase: jax.Array, horizon: int,
                train: bool):
        """Store the step and learn (training)."""
        skill, unit, action = info
        reward = jnp.where(alive, jnp.asarray(res.reward, jnp.float32), 0.0)
        adds = {"ret": reward}
        if train:
            state = self._store(state, obs, skill, unit, reward,
                                jnp.asarray(res.obs, jnp.float32),
                                value_terminal(res, self.config.skill.end_is_terminal), alive)
            state, learned = self._learn(state, keys["learn"], alive & ~random_phase)
            adds.update(learned)
        out = {"obs": obs, "action": action, "reward": reward,
               "alive": alive.astype(jnp.float32), "skill": skill}
        return state, inner, adds, out

    def finish(self, state: HDDPGState, inner: Any, sums: dict, traj: dict, train: bool):
        s, (_, epsilon) = sums, inner
        length = traj["alive"].sum().astype(jnp.int32)
        switches = count_switches(traj["skill"], traj["alive"])
        if not train:
            return state, EpisodeMetrics(s["ret"], s["ret"], length, switches, {})
        n_meta, n_skill = jnp.maximum(s["meta_updates"], 1), jnp.maximum(s["skill_updates"], 1)
        extra = {"meta_loss": s["meta_loss"] / n_meta,
                 "skill_critic_loss": s["skill_critic_loss"] / n_skill,
                 "skill_actor_loss": s["skill_actor_loss"] / n_skill,
                 "epsilon": epsilon, "env_steps": state.env_steps}
        state = state.replace(episodes=state.episodes + 1)
        return state, EpisodeMetrics(s["ret"], s["ret"], length, switches, extra)

    def _store(self, agent, obs, skill, unit, reward, next_obs, terminated, alive):
        """Meta replay gets every step; skill ``k``'s replay only the steps it acted in."""
        alive = jnp.asarray(alive, bool)
        tr = Transition(obs=obs, context=jnp.zeros((0,)), action=unit, reward=reward,
                        next_obs=next_obs, terminated=terminated)
        chosen = alive & (jnp.arange(self.n_skills) == skill)
        skill_buffers = jax.vmap(replay.add, in_axes=(0, None, 0))(
            agent.skill_buffers, tr, chosen)
        meta_buffer = replay.add(agent.meta_buffer, tr.replace(action=skill), alive)
        return agent.replace(skill_buffers=skill_buffers, meta_buffer=meta_buffer,
                             env_steps=agent.env_steps + alive.astype(jnp.int32))

    def _learn(self, agent: HDDPGState, key: jax.Array, do_learn: jax.Array):
        """Meta-critic and skill updates, skipped (:func:`~hiddpg.agents.gate.gated`) unless
        ``do_learn``: the agent and the sums to add (losses, update counts)."""
        k_meta, k_skills = jax.random.split(key)
        f0 = jnp.zeros((), jnp.float32)

        def learn(a: HDDPGState):
            batch = replay.sample(a.meta_buffer, k_meta, self.config.meta.batch_size)
            meta, meta_loss = self.meta_update(a.meta, batch)
            skills, gate, m = self.skills_update(a.skills, a.skill_buffers, k_skills)
            g = gate.astype(jnp.float32)
            losses = (meta_loss, jnp.sum(m["critic_loss"] * g), jnp.sum(m["actor_loss"] * g),
                      jnp.ones(()), jnp.sum(g))
            return a.replace(meta=meta, skills=skills), losses

        def skip(a: HDDPGState):
            return a, (f0, f0, f0, f0, f0)

        agent, losses = gated(do_learn, learn, skip, agent)
        return agent, dict(zip(_SUMS[1:], losses, strict=True))


def make_hddpg(config: HDDPGConfig, env: Environment) -> HDDPG:
    """h-DDPG for ``env`` (a task with skill patterns: PuckWorld or arm)."""
    if not isinstance(config, HDDPGConfig):
        raise TypeError(f"algorithm 'h-ddpg' needs a HDDPGConfig, got {type(config).__name__}")
    return HDDPG(config, env, skill_patterns(env, config.puck_max_speed))
