"""iLQR benchmark (run by hand): iterations and wall time after compilation.

Problems (spec ``algorithms.md`` §5, the paper's Fig. 5 "standard controller"):

* PuckTrajectory2, 30 steps, tracking the reference goals ``[1.2, -0.9]`` then ``[2.3, 1.5]``
  (switch at step 15) with ``|p - g|^2 + r |a|^2``; ``r = 3`` in normalised actions is the
  spec's ``0.03 |F|^2`` (bounds inactive), ``r = 0.03`` makes the force bounds bind;
* the arm, 75 steps (ArmObstacle's horizon), from ``(45°, 90°)`` to ``(90°, 60°)`` (the obstacle
  is not part of the iLQR cost), ``|θ - θ*|^2 + 0.001 |a|^2``.

Usage::

    python benchmarks/ilqr.py [--repeats 20] [--write FILE]   (results: docs/performance.md)
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg import make
from hiddpg.control import solve_task


def _problems():
    """``(name, jitted solve, x0, how to score the result)`` of each benchmark problem."""
    puck, puck_params = make("PuckTrajectory2")
    for r, label in ((3.0, "bounds inactive"), (0.03, "bounds active")):
        solve = jax.jit(lambda x, r=r: solve_task(
            puck, puck_params, x, 30, puck_params.goals, puck_params.switch_steps,
            action_weight=r))
        yield (f"PuckTrajectory2, 30 steps, r = {r} ({label})", solve, puck_params.init_state,
               lambda res: f"final position error {_puck_error(res, puck_params):.3f}")
    arm, arm_params = make("ArmObstacle")
    x0 = jnp.concatenate([arm_params.start, jnp.zeros(2)])
    target = arm_params.target
    solve = jax.jit(lambda x: solve_task(arm, arm_params, x, 75, target, action_weight=1e-3))
    yield ("Arm reaching, 75 steps, (45°, 90°) → (90°, 60°)", solve, x0,
           lambda res: "final joint error "
           f"{np.degrees(np.abs(np.asarray(res.states[-1, :2] - target))).max():.2f}°")


def _puck_error(result, params) -> float:
    return float(jnp.linalg.norm(result.states[-1, :2] - params.goals[-1]))


def _time(solve, x0, repeats: int) -> tuple[float, float, object]:
    """Compile time (s) and the median solve time (ms) over ``repeats`` calls."""
    start = time.perf_counter()
    result = jax.block_until_ready(solve(x0))
    compile_s = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = jax.block_until_ready(solve(x0))
        times.append(1e3 * (time.perf_counter() - start))
    return compile_s, statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=20, help="timed solves per problem")
    parser.add_argument("--write", default=None, help="also write the table to this file")
    args = parser.parse_args()
    device = jax.devices()[0]
    lines = [
        f"iLQR (`hiddpg.control.solve_task`, default `ILQRConfig`), jax {jax.__version__} on "
        f"{device.platform} ({platform.machine()}, {os.cpu_count()} cores); median of "
        f"{args.repeats} solves after compilation (float32, one start state, jitted).",
        "",
        "| problem | iterations | converged | solve (ms) | ms / iteration | compile (s) "
        "| final cost | result |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, solve, x0, score in _problems():
        compile_s, ms, res = _time(solve, x0, args.repeats)
        iters = int(res.iterations)
        lines.append(
            f"| {name} | {iters} | {bool(res.converged)} | {ms:.1f} | {ms / iters:.2f} "
            f"| {compile_s:.1f} | {float(res.cost):.4g} | {score(res)} |"
        )
    lines += [
        "",
        "`iterations`: outer iterations (backward pass + vectorised line search) to the relative "
        "tolerance 1e-6; on the linear-quadratic puck problem the first iteration already is the "
        "finite-horizon LQR solution and the second confirms it. `r` is the action weight on "
        "normalised actions (`r = 3` is the spec's `0.03 |F|^2`). Final position error: "
        "distance of the last state to the last goal (a tracking cost with `r = 3` trades it "
        "for effort). The arm's cost ignores the obstacle.",
    ]
    table = "\n".join(lines)
    print(table)
    if args.write:
        with open(args.write, "w") as handle:
            handle.write("# iLQR benchmark\n\nProduced by `python benchmarks/ilqr.py "
                         f"--repeats {args.repeats}`.\n\n{table}\n")


if __name__ == "__main__":
    main()
