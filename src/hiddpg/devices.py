"""Seeds spread over devices: one CPU device per core, or the accelerators there are.

XLA's CPU backend is one device that splits each matrix multiply over all cores. The updates
of our agents are small (batch 64, 300-300 networks), so the split gains little, and many
vmapped seeds are no faster in total than one. Asking XLA for one CPU device per core
(``--xla_force_host_platform_device_count``) and giving each device its share of the seeds
fills the cores: :class:`hiddpg.train.Trainer` shards the seed axis over :func:`seed_mesh`
with ``shard_map`` (seeds padded to a multiple of the devices; the padding is dropped), and a
device runs its seeds one after another on CPU or as one ``vmap`` on an accelerator
(:func:`batch_seeds`). On CPU each seed then computes exactly what it computes alone, so
results do not depend on the number of seeds or devices.

The flag must be set before JAX starts its backends: the ``hiddpg`` command calls
:func:`request_cpu_devices` first thing; in your own script call it before any JAX
computation (or set ``XLA_FLAGS`` yourself). Measured gains: ``docs/performance.md``.
"""

from __future__ import annotations

import os

import numpy as np

#: the XLA flag that splits the host into several CPU devices.
CPU_DEVICES_FLAG = "--xla_force_host_platform_device_count"
#: mesh axis over which seeds are sharded.
DEVICE_AXIS = "devices"
#: XLA aborts the whole process when one CPU device reaches a collective (the seeds' gather at
#: a chunk's end) more than 40 s after another, which happens on a loaded machine; with these
#: it waits (a day at most) and warns after an hour. Added unless ``XLA_FLAGS`` sets them.
COLLECTIVE_FLAGS = ("--xla_cpu_collective_call_terminate_timeout_seconds=86400",
                    "--xla_cpu_collective_call_warn_stuck_timeout_seconds=3600")
#: environment variable that overrides the number of CPU devices the CLI asks for.
DEVICES_ENV = "HIDDPG_CPU_DEVICES"
#: environment variable that overrides how seeds share a device: ``vmap`` or ``map``.
SEEDS_ENV = "HIDDPG_SEEDS_ON_DEVICE"


def request_cpu_devices(n: int | None = None) -> int | None:
    """Ask XLA for ``n`` CPU devices (default: ``$HIDDPG_CPU_DEVICES``, else one per core).

    Returns the number requested, or ``None`` when ``XLA_FLAGS`` already sets the count (the
    user's choice wins). Also adds :data:`COLLECTIVE_FLAGS` that ``XLA_FLAGS`` does not set.
    Has no effect once JAX has started its CPU backend.
    """
    flags = os.environ.get("XLA_FLAGS", "")
    missing = [f for f in COLLECTIVE_FLAGS if f.partition("=")[0] not in flags]
    flags = os.environ["XLA_FLAGS"] = " ".join([flags, *missing]).strip()
    if CPU_DEVICES_FLAG in flags:
        return None
    if n is None:
        env = os.environ.get(DEVICES_ENV)
        if env is not None:
            if not env.isdigit() or int(env) < 1:
                raise ValueError(f"{DEVICES_ENV}={env!r}: expected a positive integer")
            n = int(env)
        else:
            n = cpu_cores()
    if n < 1:
        raise ValueError(f"n={n}: the number of CPU devices must be at least 1")
    os.environ["XLA_FLAGS"] = f"{flags} {CPU_DEVICES_FLAG}={n}".strip()
    return n


def cpu_cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def seed_mesh(n_seeds: int):
    """A 1-D mesh over the default backend's devices for ``n_seeds`` seeds, or ``None`` when
    there is nothing to spread (one device or one seed)."""
    import jax
    from jax.sharding import Mesh

    devices = jax.devices()
    n = min(len(devices), n_seeds)
    if n < 2:
        return None
    return Mesh(np.array(devices[:n]), (DEVICE_AXIS,))


def batch_seeds() -> bool:
    """Whether the seeds on one device are a ``vmap`` (True) or run one after another with
    ``lax.map`` (False).

    ``$HIDDPG_SEEDS_ON_DEVICE`` (``vmap`` or ``map``) decides if set; otherwise ``map`` on CPU
    and ``vmap`` on accelerators. On CPU a seed's update already uses the core well, and the
    batched matrix multiplies of a ``vmap`` are slower than the same multiplies one seed at a
    time (``docs/performance.md``); one after another, each seed also computes bit for bit what it
    computes alone. An accelerator needs the batch to fill it.
    """
    import jax

    choice = seeds_on_device()
    if choice is not None:
        return choice == "vmap"
    return jax.default_backend() != "cpu"


def seeds_on_device() -> str | None:
    """``$HIDDPG_SEEDS_ON_DEVICE`` checked (``"vmap"``, ``"map"`` or unset: ``None``)."""
    choice = os.environ.get(SEEDS_ENV)
    if choice is not None and choice not in ("vmap", "map"):
        raise ValueError(f"{SEEDS_ENV}={choice!r}: expected 'vmap' or 'map'")
    return choice


def padding(n_seeds: int, n_devices: int) -> int:
    """Seeds to add so that ``n_seeds`` splits evenly over ``n_devices``."""
    return -n_seeds % n_devices
