"""Seeds sharded over CPU devices: the flag, the padding, and the same results as one device."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from hiddpg import devices
from hiddpg.devices import (
    COLLECTIVE_FLAGS,
    CPU_DEVICES_FLAG,
    DEVICES_ENV,
    SEEDS_ENV,
    batch_seeds,
    padding,
    request_cpu_devices,
)


def test_request_sets_the_flag_once_and_respects_the_users(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_enable_fast_math=false")
    monkeypatch.delenv(DEVICES_ENV, raising=False)
    assert request_cpu_devices(3) == 3
    assert os.environ["XLA_FLAGS"] == " ".join(["--xla_cpu_enable_fast_math=false",
                                                *COLLECTIVE_FLAGS, f"{CPU_DEVICES_FLAG}=3"])
    assert request_cpu_devices(5) is None  # already set: the first choice stays
    assert os.environ["XLA_FLAGS"].count(CPU_DEVICES_FLAG) == 1
    assert os.environ["XLA_FLAGS"].count("collective_call_terminate") == 1


def test_the_users_collective_timeout_wins(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_collective_call_terminate_timeout_seconds=5")
    request_cpu_devices(2)
    flags = os.environ["XLA_FLAGS"].split()
    assert "--xla_cpu_collective_call_terminate_timeout_seconds=5" in flags
    assert COLLECTIVE_FLAGS[0] not in flags and COLLECTIVE_FLAGS[1] in flags


LATE_DEVICE = textwrap.dedent("""
    import sys, time
    from hiddpg.devices import request_cpu_devices
    request_cpu_devices(2)
    import jax, jax.numpy as jnp
    from jax import shard_map
    from jax.sharding import Mesh, PartitionSpec as P
    def body(x):  # device 0 loops, device 1 goes straight to the gather and waits there
        n = jnp.where(jax.lax.axis_index("d") == 0, int(sys.argv[1]), 1)
        m = jnp.full((128, 128), 1e-3)
        y = jax.lax.fori_loop(0, n, lambda k, y: jnp.tanh(y @ m), x[0])
        return jax.lax.all_gather(y.sum()[None], "d", tiled=True)
    f = jax.jit(shard_map(body, mesh=Mesh(jax.devices(), ("d",)), in_specs=P("d"),
                          out_specs=P("d")))
    f(jnp.ones((2, 128, 128)))  # compiled, and both devices fast
    t = time.perf_counter()
    f(jnp.ones((2, 128, 128))).block_until_ready()
    print(time.perf_counter() - t)
""")


def test_a_late_device_aborts_xla_at_the_timeout_our_flag_raises():
    """XLA aborts the process when a device reaches a collective later than the terminate
    timeout after another (40 s by default): with the timeout at 1 s a late device aborts it;
    with the flags :func:`request_cpu_devices` adds (which XLA must accept at start) the same
    late device only makes the gather wait."""
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    ours = subprocess.run([sys.executable, "-c", LATE_DEVICE, "60000"], env=env, timeout=300,
                          capture_output=True, text=True)
    assert ours.returncode == 0, ours.stderr[-2000:]
    late_s = float(ours.stdout.split()[-1])
    assert late_s > 1.5, f"device 0 was only {late_s:.1f} s late: not late enough to test"
    env["XLA_FLAGS"] = ("--xla_cpu_collective_call_terminate_timeout_seconds=1 "
                        "--xla_cpu_collective_call_warn_stuck_timeout_seconds=1")
    short = subprocess.run([sys.executable, "-c", LATE_DEVICE, "60000"], env=env,
                           timeout=300, capture_output=True, text=True)
    assert short.returncode != 0 and "Termination timeout" in short.stderr


def test_request_defaults_to_the_env_variable_then_the_cores(monkeypatch):
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    monkeypatch.setenv(DEVICES_ENV, "1")
    assert request_cpu_devices() == 1
    monkeypatch.delenv("XLA_FLAGS")
    monkeypatch.delenv(DEVICES_ENV)
    assert request_cpu_devices() == len(os.sched_getaffinity(0))


@pytest.mark.parametrize("bad", ["zero", "0", "-2", ""])
def test_a_bad_device_count_is_named(monkeypatch, bad):
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    monkeypatch.setenv(DEVICES_ENV, bad)
    with pytest.raises(ValueError, match=f"{DEVICES_ENV}='{bad}'.*positive integer"):
        request_cpu_devices()


def test_padding_and_mesh():
    assert [padding(n, 2) for n in (1, 2, 3, 15, 16)] == [1, 0, 1, 1, 0]
    assert padding(15, 4) == 1 and padding(7, 7) == 0
    assert devices.seed_mesh(1) is None  # one seed: nothing to spread
    assert devices.seed_mesh(15) is None  # this test process has one CPU device


SCRIPT = textwrap.dedent("""
    import os, sys
    os.environ["XLA_FLAGS"] = "--xla_force_host_platform_device_count=" + sys.argv[1]
    os.environ["HIDDPG_SEEDS_ON_DEVICE"] = sys.argv[2]
    import jax, numpy as np
    from hiddpg.presets import make_config
    from hiddpg.train import Trainer, seed_keys
    cfg = make_config("hi-ddpg", "PuckTrajectory1", "paper", [
        "episodes=4", "eval_every=2", "agent.low.hidden=[16,16]", "agent.high.hidden=[16,16]",
        "agent.learning_starts=30", "agent.pretrain_episodes=1", "agent.high_learning_starts=2",
        "agent.low.batch_size=8", "agent.high.batch_size=8"])
    trainer = Trainer(cfg)
    out = {}
    for seeds in ([0, 1, 2], [1])[:int(sys.argv[4])]:
        state, tm, em = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys(seeds)), 4)
        leaves = jax.tree.leaves((state, tm, em))
        out.update({f"{len(seeds)}_{i}": np.asarray(x) for i, x in enumerate(leaves)})
        out[f"{len(seeds)}_devices"] = np.array(len(state.key.sharding.device_set))
    np.savez(sys.argv[3], **out)
""")


@pytest.fixture(scope="module")
def run_script(tmp_path_factory):
    """``(devices, mode) -> the script's arrays``, each combination run once per module."""
    done = {}

    def run(devices: int, mode: str):
        """Seeds 0-2, and seed 1 alone on one device (what the others are compared with)."""
        if (devices, mode) not in done:
            path = tmp_path_factory.mktemp("devices") / f"{devices}-{mode}.npz"
            env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
            lists = 2 if devices == 1 else 1
            subprocess.run([sys.executable, "-c", SCRIPT, str(devices), mode, str(path),
                            str(lists)], check=True, env=env, timeout=600)
            with np.load(path) as z:
                done[devices, mode] = {k: z[k] for k in z.files}
        return done[devices, mode]

    return run


def state_keys(out, n_seeds):
    return [k for k in out if k.startswith(f"{n_seeds}_") and "devices" not in k]


@pytest.mark.slow
@pytest.mark.heavy
def test_seeds_on_cpu_devices_are_bitwise_independent_of_the_split(run_script):
    """CPU default (seeds one after another per device): 3 seeds on 1 or 2 devices and seed 1
    alone compute exactly the same numbers."""
    one, two = run_script(1, "map"), run_script(2, "map")
    assert int(one["3_devices"]) == 1 and int(two["3_devices"]) == 2  # 3 seeds (+1 pad) sharded
    keys = state_keys(one, 3)
    assert len(keys) > 100  # the whole run state and every metric
    for k in keys:
        np.testing.assert_array_equal(two[k], one[k], err_msg=k)
    # seed 1 of the three (on one device, hence on two) == seed 1 alone
    assert len(state_keys(one, 1)) == len(keys)
    for i in range(len(state_keys(one, 1))):
        np.testing.assert_array_equal(one[f"3_{i}"][1], one[f"1_{i}"][0])


@pytest.mark.slow
@pytest.mark.heavy
def test_vmapped_seeds_on_devices_match_within_rounding(run_script):
    """Accelerator mode (a vmap per device) forced on CPU: batched matmuls of 2 seeds per
    device round differently from unbatched ones in the last bit only."""
    ref, vm = run_script(1, "map"), run_script(2, "vmap")
    assert int(vm["3_devices"]) == 2
    for k in state_keys(ref, 3):
        np.testing.assert_allclose(vm[k], ref[k], rtol=1e-5, atol=1e-5, err_msg=k)


def test_seeds_on_device_choice(monkeypatch):
    monkeypatch.setenv(SEEDS_ENV, "vmap")
    assert batch_seeds()
    monkeypatch.setenv(SEEDS_ENV, "map")
    assert not batch_seeds()
    monkeypatch.delenv(SEEDS_ENV)
    assert not batch_seeds()  # CPU: one after another
    monkeypatch.setenv(SEEDS_ENV, "pmap")
    with pytest.raises(ValueError, match="HIDDPG_SEEDS_ON_DEVICE='pmap'.*'vmap' or 'map'"):
        batch_seeds()


@pytest.mark.parametrize("var,value,needle", [
    (DEVICES_ENV, "two", "HIDDPG_CPU_DEVICES='two': expected a positive integer"),
    (SEEDS_ENV, "pmap", "HIDDPG_SEEDS_ON_DEVICE='pmap': expected 'vmap' or 'map'"),
])
def test_the_command_names_a_bad_device_setting(var, value, needle):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    env[var] = value
    out = subprocess.run([sys.executable, "-m", "hiddpg.cli", "envs", "list"], env=env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert out.stderr.strip() == f"hiddpg: error: {needle}"
