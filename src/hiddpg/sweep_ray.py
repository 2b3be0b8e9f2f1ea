"""The Ray backend of ``hiddpg sweep``: one Ray task per configuration, its seeds vmapped inside.

* Each task declares its resources (``num_cpus``, ``num_gpus``) and runs in a fresh worker
  process (``max_calls=1``: JAX memory is returned after every run).
* Each task writes its run directory under the sweep's output directory, which must be the same
  path on every node (a shared filesystem); the driver reads progress from it.
* If a task's worker process dies (killed, out of memory, node lost) or the task raises, Ray
  runs it again, up to ``retries`` times; the retry resumes from the run's last checkpoint
  (:func:`hiddpg.runner.open_for_resume`), so chunks already checkpointed are not trained
  again. A config error or a non-finite loss is an exit code, not an exception, and is not
  retried.
* ``address``: ``None`` joins ``RAY_ADDRESS`` if set, else starts Ray on this machine;
  ``"auto"`` joins the cluster started on this machine with ``ray start``; ``HOST:PORT`` joins
  that cluster's head node.

Ray is imported only here (it is the ``ray`` extra).
"""

from __future__ import annotations

import os
import socket
import sys
from pathlib import Path

import ray

from hiddpg import runner, summary, sweep
from hiddpg.devices import CPU_DEVICES_FLAG
from hiddpg.reporter import ConsoleReporter

WAIT_S = 0.5
#: a task's result as the exit code ``hiddpg train`` gives it (2: a config error)
EXIT_CODES = {runner.FINISHED: 0, runner.FAILED: 1, runner.INTERRUPTED: 130}


def train_task(run: sweep.SweepRun, out: str) -> int:
    """Create or resume ``run`` under ``out`` and train it to the end; the exit code
    ``hiddpg train`` would give (0 also when it was already finished)."""
    path = Path(out)
    if not path.is_dir():
        print(f"hiddpg sweep: error: output directory {out} is not visible on host "
              f"{socket.gethostname()}; put --out on a filesystem shared by all nodes",
              file=sys.stderr)
        return 2
    try:
        ready = sweep.open_run(run, path)
    except (ValueError, TypeError, FileNotFoundError) as err:  # SweepError is a ValueError
        print(f"hiddpg sweep: error: {err}", file=sys.stderr)
        return 2
    if ready is None:
        return 0
    sweep.record_attempt(path, run, pid=os.getpid(), start_episode=ready.done)
    result = runner.train_run(ready.run, ready.trainer, reporter=ConsoleReporter())
    if result.status == runner.FINISHED:
        print(summary.result_line(ready.run, result.wall_time))
    elif result.status == runner.FAILED:
        print(f"hiddpg sweep: error: {result.error}", file=sys.stderr)
    return EXIT_CODES[result.status]


def _env_vars(gpus_per_run: float, cpus_per_run: float = 1.0) -> dict[str, str]:
    """Keep JAX off GPUs a task did not reserve, let fractional GPUs be shared, and give a
    CPU task one XLA CPU device per reserved core (:mod:`hiddpg.devices`)."""
    if gpus_per_run == 0:
        flags = os.environ.get("XLA_FLAGS", "")
        if CPU_DEVICES_FLAG not in flags:
            flags = f"{flags} {CPU_DEVICES_FLAG}={max(1, int(cpus_per_run))}".strip()
        return {"JAX_PLATFORMS": "cpu", "XLA_FLAGS": flags}
    if gpus_per_run < 1:
        return {"XLA_PYTHON_CLIENT_PREALLOCATE": "false"}
    return {}


def run_ray(todo: list[sweep.SweepRun], out: Path, *, address: str | None = None,
            cpus_per_run: float = 1.0, gpus_per_run: float = 0.0, retries: int = 3,
            progress=None) -> dict[str, int | str]:
    """Train ``todo`` as Ray tasks; returns each run's exit code, or the error of a task that
    failed after its retries. ``progress`` (the sweep command's ``SweepProgress``) is polled
    while waiting and told when a run ends."""
    try:
        if address is None and not os.environ.get("RAY_ADDRESS"):
            ray.init(include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    except ConnectionError as err:
        raise sweep.SweepError(f"cannot reach the Ray cluster at {address or 'RAY_ADDRESS'}: "
                               f"{err}") from None
    task = ray.remote(max_calls=1)(train_task)
    env = _env_vars(gpus_per_run, cpus_per_run)
    refs = {}
    try:
        for run in todo:
            opts = dict(num_cpus=cpus_per_run, num_gpus=gpus_per_run, max_retries=retries,
                        retry_exceptions=True, name=f"hiddpg-sweep:{run.name}")
            if env:
                opts["runtime_env"] = {"env_vars": env}
            refs[task.options(**opts).remote(run, str(out))] = run
        return _wait(refs, progress)
    except BaseException:
        for ref in refs:  # interrupted: stop our tasks; their runs stay resumable
            ray.cancel(ref, force=True)
        raise
    finally:
        ray.shutdown()


def _wait(refs: dict, progress) -> dict[str, int | str]:
    codes: dict[str, int | str] = {}
    pending = list(refs)
    while pending:
        ready, pending = ray.wait(pending, num_returns=1, timeout=WAIT_S)
        for ref in ready:
            run = refs[ref]
            try:
                codes[run.name] = ray.get(ref)
            except ray.exceptions.RayError as err:
                codes[run.name] = str(err).strip().splitlines()[-1][:300]
            if progress is not None:
                progress.run_done(run, codes[run.name])
        if progress is not None:
            progress.poll()
    return codes
