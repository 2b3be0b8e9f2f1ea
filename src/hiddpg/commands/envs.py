"""``hiddpg envs``: list the environments, or write an animated demo rollout of one.

    hiddpg envs list
    hiddpg envs demo PuckTrajectory2 --out puck.gif
    hiddpg envs demo ArmReach --out reach.gif --seed 3 --set field=cw --set max_steps=100

The demo runs a scripted controller (no learning): the LQR reference controller on the puck
trajectory tasks (return ≈ 0), a detour through a waypoint above the disc on PuckObstacle, the
two-stroke posture detour of the paper's Fig. 6B on ArmObstacle, and random muscle activations
(held for 0.2 s) on ArmReach. The controller's goals are drawn as overlays, with a legend below
the view and the ``env_return`` (the sum of the environment's rewards) so far.

Parsed with tyro (``subcommand_cli_from_dict``); errors in the task or params print one line
and exit with code 2. ``--out`` must name a file ending in ``.gif`` and ``--still`` one ending
in ``.png``, neither an existing directory; their missing parent directories are created. They
are checked before the rollout runs.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

import ast
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Annotated, Any

import jax
import jax.numpy as jnp
import numpy as np
import tyro

from hiddpg.commands.common import run_tyro
from hiddpg.envs import TASKS, make, task_name
from hiddpg.paths import gif_path, png_path

#: PuckObstacle demo [decision]: aim at a waypoint above the disc until within
#: ``WAYPOINT_RADIUS`` of it, then at the target (clearance ≈ 0.47 with the spec's disc).
WAYPOINT = (1.0, 0.6)
WAYPOINT_RADIUS = 0.4
#: ArmReach demo: random activations are redrawn every this many control steps (0.2 s).
HOLD_STEPS = 10
#: Frame rate cap of demo GIFs: the arm (50 control steps/s) plays at half speed.
MAX_FPS = 25.0
#: The narrowest frame ``--width`` allows, in pixels (the text and legend need the room).
MIN_WIDTH = 160

# A controller: (key, state, phase, params) -> (normalised action, goal shown, new phase).
Controller = Callable[[jax.Array, Any, jax.Array, Any], tuple[jax.Array, jax.Array, jax.Array]]


# -- scripted controllers ---------------------------------------------------------------------
def puck_reference_controller(core: Any, params: Any) -> tuple[Controller, jax.Array]:
    """The LQR reference controller through the reference goals (what built the reference)."""
    from hiddpg.envs.puckworld import reference_action, reference_goal

    def control(key, state, phase, p):
        goal = reference_goal(state.t, p.goals, p.switch_steps)
        return reference_action(state.x, goal, p), goal, phase

    return control, jnp.zeros((), jnp.int32)


def puck_waypoint_controller(core: Any, params: Any) -> tuple[Controller, jax.Array]:
    """LQR to :data:`WAYPOINT` until close to it (``phase`` becomes 1), then to the target."""
    from hiddpg.envs.puckworld import reference_action

    waypoint = jnp.asarray(WAYPOINT, jnp.float32)

    def control(key, state, phase, p):
        near = jnp.linalg.norm(state.x[:2] - waypoint) < WAYPOINT_RADIUS
        phase = jnp.maximum(phase, near.astype(jnp.int32))
        goal = jnp.where(phase > 0, p.target, waypoint)
        return reference_action(state.x, goal, p), goal, phase

    return control, jnp.zeros((), jnp.int32)


def arm_detour_controller(core: Any, params: Any) -> tuple[Controller, jax.Array]:
    """The scripted two-stroke detour of :mod:`hiddpg.envs.arm_tasks` (via (60°, 130°))."""
    from hiddpg.envs.arm_tasks import DetourScript, detour_action

    script = DetourScript()

    def control(key, state, phase, p):
        goal = jnp.where(state.t < script.switch_step, script.via, state.target)
        return detour_action(state, p, script), goal.astype(jnp.float32), phase

    return control, jnp.zeros((), jnp.int32)


def arm_random_controller(core: Any, params: Any) -> tuple[Controller, jax.Array]:
    """Uniform random activations, redrawn every :data:`HOLD_STEPS` steps (held in ``phase``);
    the goal shown is the episode's target."""

    def control(key, state, phase, p):
        fresh = jax.random.uniform(key, (core.action_dim,))
        action = jnp.where(state.t % HOLD_STEPS == 0, fresh, phase)
        return action, state.target.astype(jnp.float32), action

    return control, jnp.zeros((core.action_dim,), jnp.float32)


DEMO_CONTROLLERS: dict[str, Callable[[Any, Any], tuple[Controller, jax.Array]]] = {
    "PuckTrajectory1": puck_reference_controller,
    "PuckTrajectory2": puck_reference_controller,
    "PuckTrajectory3": puck_reference_controller,
    "PuckObstacle": puck_waypoint_controller,
    "ArmReach": arm_random_controller,
    "ArmObstacle": arm_detour_controller,
}


def demo_rollout(task: str, seed: int = 0, **overrides: Any) -> dict[str, Any]:
    """Run the demo controller of ``task`` for one episode (one jitted ``lax.scan``).

    Returns numpy arrays cut at the end of the episode: ``states`` ``(T + 1, state_dim)``,
    ``actions`` ``(T, action_dim)``, ``rewards`` ``(T,)``, ``goals`` ``(T, 2)``, plus ``core``,
    ``params``, ``target`` (ArmReach's target or ``None``) and ``return``.
    """
    name = task_name(task)
    core, params = make(name, **overrides)
    control, phase0 = DEMO_CONTROLLERS[name](core, params)
    reset_key, run_key = jax.random.split(jax.random.PRNGKey(seed))

    @jax.jit
    def run(reset_key, run_key, params):
        _, state0 = core.reset(reset_key, params)

        def body(carry, key):
            state, phase = carry
            control_key, step_key = jax.random.split(key)
            action, goal, phase = control(control_key, state, phase, params)
            result = core.step(step_key, state, action, params)
            done = result.terminated | result.truncated
            return (result.state, phase), (result.state.x, action, result.reward, goal, done)

        keys = jax.random.split(run_key, core.max_steps(params))
        _, out = jax.lax.scan(body, (state0, phase0), keys)
        return state0, out

    state0, (xs, actions, rewards, goals, done) = jax.device_get(run(reset_key, run_key, params))
    steps = int(np.argmax(done)) + 1 if done.any() else len(done)
    states = np.concatenate([np.asarray(state0.x)[None], xs[:steps]])
    return {
        "core": core, "params": params, "states": states, "actions": actions[:steps],
        "rewards": rewards[:steps], "goals": goals[:steps], "return": float(rewards[:steps].sum()),
        "target": getattr(state0, "target", None) if name == "ArmReach" else None,
    }


# -- command line -----------------------------------------------------------------------------
def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """``["field=cw", "dt=0.05", "goals=[[1, 0]]"]`` -> ``{"field": "cw", "dt": 0.05, ...}``.
    Values are Python literals where they parse as one, else strings."""
    overrides: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {item!r} must have the form KEY=VALUE")
        try:
            overrides[key.strip()] = ast.literal_eval(value.strip())
        except (ValueError, SyntaxError):
            overrides[key.strip()] = value.strip()
    return overrides


def list_envs() -> int:
    """List every registered environment: id, sizes, horizon and goal space."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title="hiddpg environments")
    table.add_column("id", no_wrap=True)
    for column in ("obs", "action", "horizon", "goal dims", "summary"):
        table.add_column(column, overflow="fold")
    for spec in TASKS.values():
        core, params = make(spec.name)
        gs = core.goal_space
        bounds = ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi in zip(gs.low, gs.high, strict=True))
        table.add_row(
            spec.env_id, str(core.obs_dim),
            f"{core.action_dim} in [{core.action_low:g}, {core.action_high:g}]",
            f"{core.max_steps(params)} × {core.dt:g} s",
            f"obs{list(gs.indices)} in {bounds}", spec.summary,
        )
    Console(width=max(Console().width, 150)).print(table)
    return 0


def demo(
    task: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="TASK")],
    out: Path,
    seed: int = 0,
    overrides: Annotated[
        tuple[str, ...], tyro.conf.arg(name="set", metavar="KEY=VALUE"), tyro.conf.UseAppendAction
    ] = (),
    width: int | None = None,
    still: Path | None = None,
    still_step: int = -1,
) -> int:
    """Write an animated GIF of a scripted rollout and print its return.

    Args:
        task: a task name or id, e.g. PuckTrajectory2 or hiddpg/ArmReach-v0.
        out: the GIF to write (a name ending in .gif).
        seed: PRNG seed (ArmReach's target and random activations).
        overrides: a core parameter, e.g. --set field=cw --set dt=0.05.
        width: frame width in pixels (default 400 for the puck, 480 for the arm).
        still: also write one frame as a PNG here (a name ending in .png; the pictures in
            docs/img are made so).
        still_step: which frame --still writes (Python index; -1 is the last).
    """
    from hiddpg import render

    out = gif_path(out, "--out")
    still = None if still is None else png_path(still, "--still")
    if width is not None and width < MIN_WIDTH:
        raise ValueError(f"--width {width} must be at least {MIN_WIDTH} (pixels)")
    run = demo_rollout(task, seed, **parse_overrides(overrides))
    core = run["core"]
    name = task_name(task)
    frames = render.render_rollout(
        core, run["params"], run["states"], run["actions"], run["rewards"], goals=run["goals"],
        width=width, title=f"{name} (scripted demo)", target=run["target"],
        goal_label="scripted goal",
    )
    if still is not None and not -len(frames) <= still_step < len(frames):
        raise ValueError(f"--still-step {still_step} is outside the {len(frames)} frames; give "
                         f"an index in [{-len(frames)}, {len(frames) - 1}]")
    path = render.write_gif(frames, out, fps=min(1.0 / core.dt, MAX_FPS))
    if still is not None:
        render.write_png(frames[still_step], still)
    steps = len(run["rewards"])
    print(f"{name}: return {run['return']:.4f} over {steps} steps; "
          f"wrote {path} ({len(frames)} frames)")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``hiddpg envs {list, demo}``; returns the exit code."""
    commands = {"list": list_envs, "demo": demo}
    return run_tyro("hiddpg envs", argv, lambda args: tyro.extras.subcommand_cli_from_dict(
        commands, prog="hiddpg envs", args=args), errors=(ValueError,))
