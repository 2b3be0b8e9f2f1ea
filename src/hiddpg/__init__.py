"""hiddpg: Hierarchical Intermittent DDPG (Shi et al., IEEE Access 2019) in JAX."""

import importlib.util

from hiddpg.envs import make, register_task

__version__ = "0.1.0"

if importlib.util.find_spec("gymnasium") is not None:  # the `gym` extra is installed
    from hiddpg.envs.gym import register_envs as _register_envs

    _register_envs()

__all__ = ["make", "register_task", "__version__"]
