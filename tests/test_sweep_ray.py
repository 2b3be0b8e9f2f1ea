"""``hiddpg sweep --backend ray`` against a real Ray cluster (no mock).

The test starts a Ray head node on 127.0.0.1 (its own temp dir and ports) with two worker
slots, runs a 2 × 2 sweep (two tasks × two values of ``agent.tau``, seeds 0-1) through the
``hiddpg sweep`` command, SIGKILLs the Ray worker process of one run after its first
checkpoint, and checks that every run finishes, that the killed run was retried from its last
checkpoint, and that every run's metrics are byte-identical to a local-backend sweep's.

Teardown stops exactly the processes this test started (found by its temp dir and their
descendants), not every Ray process of the machine as ``ray stop --force`` would.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from hiddpg import runs, sweep

pytest.importorskip("ray")
try:
    import pytest_timeout  # noqa: F401

    # a hang guard above the test's own deadlines (two sweeps of up to DEADLINE_S each): at
    # 360 s it failed a busy machine's run that took 343 s alone
    _TIMEOUT = [pytest.mark.timeout(900)]
except ImportError:
    _TIMEOUT = []
pytestmark = [pytest.mark.ray, pytest.mark.slow, *_TIMEOUT,
              pytest.mark.skipif(not sys.platform.startswith("linux"), reason="uses /proc")]

EPISODES = 40  # 4 chunks of 10: three windows in which a run is checkpointed but unfinished
SPEC = f"""
algos = "ddpg"
tasks = ["PuckTrajectory1", "PuckTrajectory2"]
seeds = "0-1"
presets = "quick"
set = ["episodes={EPISODES}", "eval_every=10", "chunk_episodes=10", "agent.hidden=[16,16]",
       "agent.learning_starts=50"]
[grid]
"agent.tau" = [0.01, 0.005]
"""
DEADLINE_S = 300
POLL_S = 0.02


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _procs() -> dict[int, tuple[int, str]]:
    """pid -> (parent pid, command line) of every process we can read."""
    out = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{entry}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
        except (OSError, IndexError, ValueError):
            continue
        out[int(entry)] = (ppid, cmd)
    return out


def _cluster_pids(temp_dir: str) -> set[int]:
    """Processes of our cluster: those naming its temp dir, and all their descendants (Ray
    workers rename themselves ``ray::...`` and do not name it)."""
    procs = _procs()
    mine = {pid for pid, (_, cmd) in procs.items() if temp_dir in cmd}
    grown = True
    while grown:
        more = {pid for pid, (ppid, _) in procs.items() if ppid in mine} - mine
        mine |= more
        grown = bool(more)
    return mine - {os.getpid()}


def _kill(pids: set[int]) -> None:
    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    end = time.monotonic() + 10
    while time.monotonic() < end and any(os.path.exists(f"/proc/{p}") for p in pids):
        time.sleep(0.1)


@pytest.fixture
def cluster():
    """A Ray head node on 127.0.0.1 with 2 CPUs; yields ``(address, env, temp_dir)``."""
    temp_dir = tempfile.mkdtemp(prefix="hsw", dir="/tmp")  # short: Unix socket paths
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    env.update(RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER="0",  # keep 127.0.0.1, bind loopback only
               RAY_USAGE_STATS_ENABLED="0",
               RAY_memory_monitor_refresh_ms="0",  # others' memory use must not kill our tasks
               AUTOSCALER_METRIC_PORT=str(_free_port()),
               DASHBOARD_METRIC_PORT=str(_free_port()),
               JAX_PLATFORMS="cpu",
               JAX_COMPILATION_CACHE_DIR=os.path.join(temp_dir, "jax-cache"))
    port = _free_port()
    ray_bin = Path(sys.executable).with_name("ray")
    ray_bin = str(ray_bin) if ray_bin.is_file() else shutil.which("ray")
    cmd = [ray_bin, "start", "--head", "--node-ip-address=127.0.0.1", f"--port={port}",
           "--num-cpus=2", "--num-gpus=0", "--object-store-memory=100000000",
           f"--temp-dir={temp_dir}", "--include-dashboard=false", "--disable-usage-stats",
           f"--ray-client-server-port={_free_port()}",
           f"--dashboard-agent-listen-port={_free_port()}",
           f"--dashboard-agent-grpc-port={_free_port()}",
           f"--runtime-env-agent-port={_free_port()}",
           f"--metrics-export-port={_free_port()}"]
    try:
        started = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
        assert started.returncode == 0, started.stdout + started.stderr
        yield f"127.0.0.1:{port}", env, temp_dir
    finally:
        _kill(_cluster_pids(temp_dir))
        leftover = _cluster_pids(temp_dir)
        shutil.rmtree(temp_dir, ignore_errors=True)
        assert not leftover, f"Ray processes still running: {sorted(leftover)}"


def _sweep(spec: Path, out: Path, env: dict, log: Path, *extra: str) -> subprocess.Popen:
    with open(log, "w") as f:
        return subprocess.Popen([sys.executable, "-m", "hiddpg.cli", "sweep", str(spec),
                                 "--out", str(out), *extra], env=env, stdout=f,
                                stderr=subprocess.STDOUT)


def _progress(path: Path) -> dict:
    try:
        return json.loads((path / runs.PROGRESS_FILE).read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return {}


def _kill_one_worker_mid_run(out: Path, names: list[str], temp_dir: str, driver, log: Path):
    """SIGKILL the worker of the first run seen checkpointed (>= 10 episodes) but unfinished.
    The worker is frozen (SIGSTOP) first, so "unfinished" is checked while it cannot move on.
    Returns ``(name, pid, episodes checkpointed when killed)``."""
    tried: set[int] = set()
    end = time.monotonic() + DEADLINE_S
    while time.monotonic() < end:
        assert driver.poll() is None, "sweep ended before a worker was killed:\n" + \
            log.read_text()[-3000:]
        for name in names:
            attempts_file = out / sweep.SWEEP_DIR / "attempts" / f"{name}.json"
            p = _progress(out / name)
            if not attempts_file.is_file() or p.get("status") != "running" \
                    or p.get("episodes", 0) < 10:
                continue
            pid = json.loads(attempts_file.read_text())[-1]["pid"]
            if pid in tried or pid not in _cluster_pids(temp_dir):
                continue  # only ever signal a worker of our own cluster
            tried.add(pid)
            os.kill(pid, signal.SIGSTOP)
            p = _progress(out / name)
            if p.get("status") == "running" and p.get("episodes", 0) < EPISODES:
                os.kill(pid, signal.SIGKILL)
                return name, pid, p["episodes"]
            os.kill(pid, signal.SIGCONT)  # it finished meanwhile: try another run
        time.sleep(POLL_S)
    pytest.fail("no run was caught between its first checkpoint and its end")


@pytest.mark.heavy
def test_ray_sweep_survives_a_killed_worker(cluster, tmp_path):
    address, env, temp_dir = cluster
    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC)
    names = [r.name for r in sweep.expand(sweep.load_spec(spec))]
    assert len(names) == 4

    t0 = time.monotonic()
    out, log = tmp_path / "ray", tmp_path / "ray.log"
    driver = _sweep(spec, out, env, log, "--backend", "ray", "--address", address,
                    "--retries", "3")
    try:
        killed, pid, at = _kill_one_worker_mid_run(out, names, temp_dir, driver, log)
        code = driver.wait(timeout=DEADLINE_S)
    finally:
        if driver.poll() is None:
            driver.kill()
            driver.wait()
    t_ray = time.monotonic() - t0
    assert code == 0, log.read_text()[-5000:]

    # every run finished; the killed one was retried in a new worker from its checkpoint
    for name in names:
        assert sweep.is_finished(out / name, EPISODES), name
    attempts = json.loads((out / sweep.SWEEP_DIR / "attempts" / f"{killed}.json").read_text())
    assert len(attempts) >= 2 and attempts[0]["pid"] == pid and attempts[-1]["pid"] != pid
    assert 10 <= at <= attempts[-1]["start_episode"] < EPISODES, (at, attempts)

    # the same sweep on the local backend gives byte-identical metrics
    t0 = time.monotonic()
    local, local_log = tmp_path / "local", tmp_path / "local.log"
    ref = _sweep(spec, local, env, local_log)
    try:
        assert ref.wait(timeout=DEADLINE_S) == 0, local_log.read_text()[-5000:]
    finally:
        if ref.poll() is None:
            ref.kill()
            ref.wait()
    t_local = time.monotonic() - t0
    assert sorted(p.name for p in sweep.find_runs(out)) == sorted(names)
    for name in names:
        mine = runs.Run.open(out / name).read_metrics()
        assert len(mine) == 2 * EPISODES
        assert (out / name / runs.METRICS_FILE).read_bytes() == \
            (local / name / runs.METRICS_FILE).read_bytes(), name
    print(f"ray sweep {t_ray:.0f} s (killed {killed} at episode {at}), "
          f"local sweep {t_local:.0f} s")


def test_task_environment_gives_cpu_tasks_one_device_per_core(monkeypatch):
    from hiddpg.sweep_ray import _env_vars

    monkeypatch.delenv("XLA_FLAGS", raising=False)
    assert _env_vars(0.0, 2.0) == {
        "JAX_PLATFORMS": "cpu", "XLA_FLAGS": "--xla_force_host_platform_device_count=2"}
    assert _env_vars(0.0, 0.5)["XLA_FLAGS"].endswith("=1")  # a fraction of a core: one device
    monkeypatch.setenv("XLA_FLAGS", "--xla_force_host_platform_device_count=4")
    assert _env_vars(0.0, 2.0)["XLA_FLAGS"] == "--xla_force_host_platform_device_count=4"
    assert "XLA_FLAGS" not in _env_vars(1.0, 2.0)  # a GPU task: the GPU is the device
