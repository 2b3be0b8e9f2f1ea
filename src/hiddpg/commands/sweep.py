"""``hiddpg sweep``: train a grid of algorithms × tasks × seeds × presets × overrides.

::

    hiddpg sweep [SPEC] --out DIR [--backend local|ray] [--workers N] [--address ADDR]
                 [--algos A,B] [--tasks T,U] [--seeds 0-4] [--presets quick]
                 [--set KEY=VALUE ...] [--grid KEY=V1,V2 ...]
                 [--cpus-per-run C] [--gpus-per-run G] [--retries R] [--dry-run]

SPEC is a TOML file (see :mod:`hiddpg.sweep_spec`); flags replace its algos/tasks/seeds/presets
and add to its set/grid. Every run's config is validated before anything runs (errors: exit 2).
Complete runs are skipped, interrupted ones resumed from their last checkpoint. The local
backend trains one configuration after another in this process, or ``--workers N`` at a time
in subprocesses (logs in ``OUT/.sweep/logs/``); ``--backend ray`` sends one Ray task per
configuration to a cluster (:mod:`hiddpg.sweep_ray`). Exit code 0 if every run finished, 1 if
some failed, 130 if interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from hiddpg import sweep
from hiddpg.commands import train as train_cmd
from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, report_error, run_command
from hiddpg.commands.sweep_progress import SweepProgress, reason
from hiddpg.devices import DEVICES_ENV, cpu_cores
from hiddpg.host.declare import declarations_scope
from hiddpg.runs import Run
from hiddpg.stopping import on_stop

PROG = "hiddpg sweep"
POLL_S = 0.5
#: how long a stopped sweep waits for a worker to stop before killing it
STOP_WAIT_S = 30.0



def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Train every configuration of a sweep spec (one run "
                "directory each, seeds vmapped inside), locally or on a Ray cluster.")
    p.add_argument("spec", nargs="?", metavar="SPEC", help="a sweep spec (TOML)")
    p.add_argument("--out", required=True, help="output directory: one run directory per "
                   "configuration (on a shared filesystem for a multi-host Ray cluster)")
    p.add_argument("--backend", choices=("local", "ray"), default="local")
    p.add_argument("--workers", type=int, default=1,
                   help="local backend: configurations trained at once (default 1)")
    p.add_argument("--address", default=None, help="ray backend: the cluster, e.g. 'auto' or "
                   "HOST:PORT (default: RAY_ADDRESS, else start Ray on this machine)")
    p.add_argument("--algos", help="comma-separated algorithms (replaces the spec's)")
    p.add_argument("--tasks", help="comma-separated tasks (replaces the spec's)")
    p.add_argument("--seeds", help="seeds, e.g. 0-4 or 0,3,5 (replaces the spec's)")
    p.add_argument("--presets", help="comma-separated presets (replaces the spec's)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="an override of every run (repeatable)")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2",
                   help="a grid axis: JSON values separated by commas, e.g. agent.tau=0.01,0.005"
                   " or agent.hidden=[64,64],[16,16] (repeatable)")
    p.add_argument("--goal", action="append", default=[], metavar="INDEX:LOW:HIGH",
                   help="a Gymnasium task's goal entry, as for hiddpg train (repeatable; "
                   "replaces the spec's goal)")
    p.add_argument("--skills", default=None, metavar="MODULE:FUNCTION",
                   help="a Gymnasium task's h-DDPG skills, as for hiddpg train (replaces "
                   "the spec's)")
    p.add_argument("--cpus-per-run", type=float, default=1.0, help="ray: CPUs a run reserves")
    p.add_argument("--gpus-per-run", type=float, default=0.0,
                   help="ray: GPUs a run reserves (fractions share a GPU)")
    p.add_argument("--retries", type=int, default=3,
                   help="ray: retries of a run whose worker dies or raises (default 3)")
    p.add_argument("--index", type=int, default=None, metavar="I",
                   help="train only the I-th run (from 0, in --dry-run order): one run per "
                   "Slurm array task, e.g. --index $SLURM_ARRAY_TASK_ID")
    p.add_argument("--dry-run", action="store_true", help="list the runs and their state only")
    return p


def spec_from_args(args: argparse.Namespace) -> dict[str, Any]:
    """The spec file's table with the command-line flags applied."""
    spec = sweep.load_spec(args.spec) if args.spec else {}
    for key in ("algos", "tasks", "presets"):
        if getattr(args, key):
            spec[key] = [v.strip() for v in getattr(args, key).split(",")]
    if args.seeds:
        spec["seeds"] = args.seeds
    if args.goal:
        spec["goal"] = list(args.goal)
    if args.skills:
        spec["skills"] = args.skills
    if args.sets:
        spec["set"] = sweep.set_list(spec.get("set", [])) + list(args.sets)
    if args.grid:
        spec["grid"] = dict(sweep.grid_table(spec.get("grid", {})))
        for item in args.grid:
            key, sep, raw = item.partition("=")
            if not sep or not raw:
                raise UsageError(f"--grid {item!r} must have the form KEY=V1,V2")
            spec["grid"][key.strip()] = _grid_values(raw)
    return spec


def _grid_values(raw: str) -> list:
    try:
        values = json.loads(f"[{raw}]")
    except json.JSONDecodeError:
        values = [v.strip() for v in raw.split(",")]  # bare strings: kind=ou,gaussian
    return values


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``hiddpg sweep`` with ``argv``; returns the exit code."""
    with declarations_scope():  # Gymnasium declarations read from run directories end here
        return run_command(PROG, argv, build_parser, _plan, _sweep,
                           errors=(UsageError, sweep.SweepError))


class _Plan(NamedTuple):
    """The runs of a sweep command line: those to train, every run of the spec, the output
    directory, each run's state and the Ray backend (``None``: local, or a dry run)."""

    runs: list[sweep.SweepRun]
    every: list[sweep.SweepRun]
    out: Path
    states: dict[str, str]
    run_ray: Callable | None


def _plan(args: argparse.Namespace) -> _Plan:
    """Check the flags, expand and validate the spec and read each run's state."""
    if args.backend == "local" and args.address:
        raise UsageError("--address needs --backend ray")
    if args.workers < 1 or (args.workers > 1 and args.backend == "ray"):
        raise UsageError(f"--workers {args.workers}: give a number >= 1, and "
                         "only with --backend local")
    runs = every = sweep.expand(spec_from_args(args), args.spec or "command line")
    if args.index is not None:
        if not 0 <= args.index < len(runs):
            raise UsageError(f"--index {args.index} is out of range: the sweep "
                             f"has {len(runs)} runs, 0 to {len(runs) - 1}")
        runs = [runs[args.index]]
    out = Path(args.out).resolve()
    states = {run.name: sweep.run_state(out, run) for run in runs}
    run_ray = _ray_backend() if args.backend == "ray" and not args.dry_run else None
    return _Plan(runs, every, out, states, run_ray)


def _sweep(args: argparse.Namespace, plan: _Plan) -> int:
    """List the runs (``--dry-run``) or train those not finished; the sweep's exit code."""
    runs, every, out, states, run_ray = plan
    if args.dry_run:
        for i, run in enumerate(runs):
            print(f"{i:>4}  {states[run.name]:<8}  {run.name}  ({run.describe()})")
        return 0
    out.mkdir(parents=True, exist_ok=True)
    sweep.write_manifest(out, every)  # all runs, so that array tasks write the same file
    todo = [run for run in runs if states[run.name] != sweep.FINISHED]
    counts = {s: sum(v == s for v in states.values()) for s in (sweep.NEW, sweep.RESUME)}
    print(f"sweep {out}: {len(runs)} runs x {len(runs[0].seeds)} seeds; "
          f"{len(runs) - len(todo)} complete (skipped), {counts[sweep.RESUME]} to resume, "
          f"{counts[sweep.NEW]} new; backend {args.backend}", file=sys.stderr)
    progress = SweepProgress(out, todo)

    def stopped(sig: str) -> None:
        progress.close()
        print(f"{PROG}: stopped by {sig}; run the same command again to resume",
              file=sys.stderr)

    try:
        with on_stop(stopped):
            codes = _run(args, todo, out, run_ray, progress)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; run the same command again to resume", file=sys.stderr)
        return 130
    except sweep.SweepError as err:  # the Ray cluster cannot be reached
        return report_error(PROG, err)
    finally:
        progress.close()
    return summarize(out, runs, codes)


def _run(args: argparse.Namespace, todo: list[sweep.SweepRun], out: Path, run_ray,
         progress: SweepProgress) -> dict[str, int | str]:
    """Train ``todo`` on the chosen backend; each run's exit code (or error) by name."""
    if not todo:
        return {}
    if run_ray is not None:
        return run_ray(todo, out, address=args.address, cpus_per_run=args.cpus_per_run,
                       gpus_per_run=args.gpus_per_run, retries=args.retries, progress=progress)
    if args.workers == 1:
        return run_sequential(todo, out, progress)
    return run_parallel(todo, out, args.workers, progress)


def _ray_backend():
    try:
        from hiddpg.sweep_ray import run_ray
    except ImportError as err:
        raise UsageError(f"--backend ray needs Ray ({err}); install it with "
                         "pip install 'hiddpg[ray]'") from None
    return run_ray


def run_sequential(todo: list[sweep.SweepRun], out: Path, progress: SweepProgress
                   ) -> dict[str, int | str]:
    """One configuration after another in this process (each prints its own progress); a
    run that raises is reported and the sweep goes on."""
    codes: dict[str, int | str] = {}
    for i, run in enumerate(todo):
        print(f"[{i + 1}/{len(todo)}] {run.name}", file=sys.stderr)
        argv, start = sweep.prepare(run, out)
        if argv is not None:
            sweep.record_attempt(out, run, pid=os.getpid(), start_episode=start)
        try:
            codes[run.name] = 0 if argv is None else train_cmd.main(argv)
        except Exception as err:  # marked failed in its progress.json; go on with the next
            traceback.print_exc()
            codes[run.name] = f"{type(err).__name__}: {err}"
        if codes[run.name] == 130:
            raise KeyboardInterrupt
        progress.run_done(run, codes[run.name])
    return codes


def run_parallel(todo: list[sweep.SweepRun], out: Path, workers: int, progress: SweepProgress
                 ) -> dict[str, int | str]:
    """``workers`` configurations at once, each in a ``hiddpg train`` subprocess."""
    logs = out / sweep.SWEEP_DIR / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    queue, running, codes = list(todo), {}, {}
    env = dict(os.environ)  # share the cores: each worker gets cores // workers CPU devices
    env.setdefault(DEVICES_ENV, str(max(1, cpu_cores() // workers)))
    try:
        with on_stop(lambda sig: _stop(list(running))):
            while queue or running:
                while queue and len(running) < workers:
                    run = queue.pop(0)
                    argv, start = sweep.prepare(run, out)
                    if argv is None:
                        codes[run.name] = 0
                        continue
                    cmd = [sys.executable, "-m", "hiddpg.cli", "train", *argv]
                    with open(logs / f"{run.name}.log", "ab") as log:
                        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                                                env=env)
                    sweep.record_attempt(out, run, pid=proc.pid, start_episode=start)
                    running[proc] = run
                time.sleep(POLL_S)
                progress.poll()
                for proc in [p for p in running if p.poll() is not None]:
                    run = running.pop(proc)
                    codes[run.name] = proc.returncode
                    progress.run_done(run, proc.returncode)
    finally:
        _stop(list(running))
    return codes


def _stop(procs: list[subprocess.Popen]) -> None:
    """Stop our own ``hiddpg train`` children (SIGTERM: each marks its run interrupted at its
    last checkpoint, so the runs stay resumable) and wait for them."""
    for proc in procs:
        if proc.poll() is None:
            proc.terminate()
    for proc in procs:
        try:
            proc.wait(timeout=STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def summarize(out: Path, runs: list[sweep.SweepRun], codes: dict[str, int | str]) -> int:
    """One line per run (final eval return over seeds) on stdout; the exit code."""
    failed = 0
    for run in runs:
        code = codes.get(run.name, 0)
        if code != 0 or not sweep.is_finished(out / run.name, run.config.episodes):
            failed += 1
            print(f"FAILED  {run.name}  ({reason(code)}; see {out / run.name})")
            continue
        finals = np.array(list(Run.open(out / run.name).final_eval().values()))
        std = finals.std(ddof=1) if finals.size > 1 else 0.0
        score = (f"final eval return {finals.mean():.3f} ± {std:.3f} over {finals.size} seeds"
                 if finals.size else "no evaluation recorded")
        print(f"ok      {run.name}  {score}")
    print(f"sweep {out}: {len(runs) - failed}/{len(runs)} runs finished", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
