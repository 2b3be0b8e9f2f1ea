"""The networks of the DDPG block: actor, critic and a plain MLP for dynamics models.

Paper §II-D: "Both the critic and the actor networks have two hidden layers, each with 300
nodes, except the state and the action are fed to critic network separately: the state is
directly fed to the input layer, while the action is fed to the first hidden layer. Both hidden
layers had a ReLU activation [...] and the output units have linear activation." The actor's
output goes through ``tanh`` so that it lies in the unit box ``[-1, 1]`` (spec §1); agents map
that box affinely onto the environment's action box, the goal bounds or ``[T_min, T_max]``.

Initialisation [decision, from the DDPG paper (Lillicrap et al. 2016, §7)]:

* hidden layers: ``U(-1/sqrt(fan_in), 1/sqrt(fan_in))`` for weights (``variance_scaling(1/3,
  "fan_in", "uniform")``), biases 0;
* final layers of actor and critic: ``U(-3e-3, 3e-3)`` for weights and biases, so that the
  initial policy outputs and Q-values are close to zero.

Layers are named ``hidden_0, hidden_1, ...`` and ``out`` so that tests and tools can find them.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

from collections.abc import Sequence

import flax.linen as nn
import jax
import jax.numpy as jnp

#: half-width of the uniform init of the final layer of actor and critic (DDPG paper).
FINAL_INIT_SCALE = 3e-3

#: fan-in uniform init of the hidden layers: U(-1/sqrt(fan_in), 1/sqrt(fan_in)).
hidden_init = nn.initializers.variance_scaling(1.0 / 3.0, "fan_in", "uniform")


def uniform_init(scale: float) -> nn.initializers.Initializer:
    """``U(-scale, scale)`` (flax's ``uniform`` is one-sided)."""

    def init(key: jax.Array, shape: tuple[int, ...], dtype=jnp.float32) -> jax.Array:
        return jax.random.uniform(key, shape, dtype, -scale, scale)

    return init


def _dense(size: int, name: str) -> nn.Dense:
    return nn.Dense(size, kernel_init=hidden_init, name=name)


def _final(size: int, scale: float | None) -> nn.Dense:
    if scale is None:
        return nn.Dense(size, kernel_init=hidden_init, name="out")
    return nn.Dense(size, kernel_init=uniform_init(scale), bias_init=uniform_init(scale),
                    name="out")


#: the actor output layers: "tanh" [spec §1] or "linear" [paper §II-D: "the output units
#: have linear activation"]
ACTOR_OUTPUTS = ("tanh", "linear")


class Actor(nn.Module):
    """Deterministic policy ``μ(s|θ^μ)`` (paper eq. 2).

    Attributes:
        hidden: hidden layer sizes (ReLU).
        action_dim: output size.
        final_init_scale: half-width of the final layer's uniform init.
        output: ``"tanh"`` (in ``[-1, 1]``) or ``"linear"`` (unbounded; the block clips it to
            the unit box wherever the action is used, see :class:`hiddpg.agents.block.DDPGBlock`).
    """

    hidden: Sequence[int]
    action_dim: int
    final_init_scale: float = FINAL_INIT_SCALE
    output: str = "tanh"

    @nn.compact
    def __call__(self, obs: jax.Array) -> jax.Array:
        x = obs
        for i, size in enumerate(self.hidden):
            x = nn.relu(_dense(size, f"hidden_{i}")(x))
        out = _final(self.action_dim, self.final_init_scale)(x)
        return jnp.tanh(out) if self.output == "tanh" else out


class Critic(nn.Module):
    """Action value ``Q(s, a)`` (paper eq. 3's ``Q(s, a|θ^Q)``, architecture §II-D).

    The observation enters the input layer; the action is concatenated to the output of the
    first hidden layer (after its ReLU). The output is linear and squeezed: shape ``(batch,)``
    for batched inputs, ``()`` for single ones.
    """

    hidden: Sequence[int]
    final_init_scale: float = FINAL_INIT_SCALE

    @nn.compact
    def __call__(self, obs: jax.Array, action: jax.Array) -> jax.Array:
        x = nn.relu(_dense(self.hidden[0], "hidden_0")(obs))
        x = jnp.concatenate([x, action], axis=-1)
        for i, size in enumerate(self.hidden[1:], start=1):
            x = nn.relu(_dense(size, f"hidden_{i}")(x))
        return _final(1, self.final_init_scale)(x)[..., 0]


class MLP(nn.Module):
    """ReLU MLP with a linear output of ``out_dim`` (the dynamics models of spec §3).

    ``final_init_scale=None`` (default) uses the hidden layers' fan-in init for the output too.
    """

    hidden: Sequence[int]
    out_dim: int
    final_init_scale: float | None = None

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        for i, size in enumerate(self.hidden):
            x = nn.relu(_dense(size, f"hidden_{i}")(x))
        return _final(self.out_dim, self.final_init_scale)(x)
