"""A host run's evaluation episode drawn by the Gymnasium environment itself.

``hiddpg eval DIR --gif FILE`` on a Gymnasium task replays the evaluated episode in one
environment made with ``render_mode="rgb_array"``: reset with the episode's reset seed (the
one the evaluation used, :class:`hiddpg.host.loop.HostEpisodes`), then stepped with the
recorded actions, one frame after the reset and after every step. An environment that is
deterministic given its seed replays the evaluation exactly; one that is not is said so, with
the replay's return. Each frame gets a strip of text below it: the title, the step, the
``env_return`` so far and, for HI-DDPG, the current goal (marked at a switch) or, for h-DDPG,
the skill. Our own tasks (``gym:hiddpg/...``) are drawn by :mod:`hiddpg.render` instead, with
their goals and legend (``hiddpg eval`` decides).
"""

from __future__ import annotations

from typing import Any

import jax
import numpy as np

from hiddpg.host.env import HostEnv, one_line
from hiddpg.host.loop import HostEpisodes

#: a frame rate cap for the GIF (a GIF cannot show more than 50 frames/s).
MAX_FPS = 25.0


def reset_seed(episode_key: jax.Array) -> int:
    """The Gymnasium reset seed of the episode keyed ``episode_key``, as the host loop draws it."""
    return int(np.asarray(HostEpisodes._reset_seed(episode_key)))


def open_renderer(env: HostEnv) -> Any:
    """One environment of ``env``'s task made with ``render_mode="rgb_array"``, checked to draw
    a frame; ``ValueError`` (one line) saying why it cannot."""
    where = f"--gif: {env.name} cannot draw rgb_array frames"
    try:
        made = env.make_render()
    except Exception as err:  # the environment's own error, whatever it is
        raise ValueError(f"{where}: {one_line(err)}") from None
    modes = list(made.metadata.get("render_modes") or [])
    if "rgb_array" not in modes:
        made.close()
        raise ValueError(f"{where} (its render modes: {modes or 'none'}); without --gif "
                         "hiddpg eval prints its evaluation")
    try:
        made.reset(seed=0)
        _frame(made)
    except Exception as err:
        made.close()
        hint = ("; MuJoCo without a display needs MUJOCO_GL=egl (or osmesa) set"
                if "OpenGL" in str(err) or "GL" in type(err).__name__ else "")
        raise ValueError(f"{where}: {one_line(err)}{hint}") from None
    return made


def _frame(made: Any) -> np.ndarray:
    frame = made.render()
    frame = np.asarray(frame) if frame is not None else None
    if frame is None or frame.ndim != 3 or frame.shape[-1] not in (3, 4):
        shape = None if frame is None else frame.shape
        raise ValueError(f"render() returned {shape}, not an (H, W, 3) frame")
    return frame[..., :3].astype(np.uint8)


def _goal_text(traj: dict[str, np.ndarray], env: HostEnv, t: int) -> str:
    if "goal" in traj:
        goal = np.asarray(traj["goal"][t])
        if env.goal_space is not None and goal.shape[-1] == env.obs_dim != env.goal_space.dim:
            goal = goal[list(env.goal_space.indices)]
        switch = "switch" in traj and bool(traj["switch"][t])
        return (f"goal {np.array2string(goal, precision=2, floatmode='fixed', separator=', ')}"
                + ("  (new)" if switch else ""))
    if "skill" in traj:
        return f"skill {np.asarray(traj['skill'][t]).tolist()}"
    return ""


def _with_text(frame: np.ndarray, lines: list[str]) -> np.ndarray:
    from PIL import Image, ImageDraw, ImageFont

    height, width = frame.shape[:2]
    size = max(11, width // 36)
    font = ImageFont.load_default(size=size)
    strip = Image.new("RGB", (width, (size + 4) * len(lines) + 6), "white")
    draw = ImageDraw.Draw(strip)
    for i, line in enumerate(lines):
        draw.text((6, 3 + i * (size + 4)), line, fill="black", font=font)
    return np.concatenate([frame, np.asarray(strip)], axis=0)


def replay_frames(env: HostEnv, made: Any, traj: dict[str, np.ndarray], seed: int, title: str
                  ) -> tuple[list[np.ndarray], float, bool]:
    """The frames of the episode ``traj`` (one seed's evaluation trajectory) replayed in
    ``made`` (:func:`open_renderer`) from the reset seed ``seed``; with the replay's return and
    whether it replayed the evaluation (the same observations and return)."""
    n = max(int(np.asarray(traj["alive"]).sum()), 1)
    actions, rewards = np.asarray(traj["action"])[:n], np.asarray(traj["reward"])[:n]
    obs, _ = made.reset(seed=seed)
    same = bool(np.allclose(np.asarray(obs, np.float32), traj["obs"][0], rtol=1e-5, atol=1e-6))
    total, frames = 0.0, []
    frames.append(_with_text(_frame(made), [title, f"step 0/{n}   env_return 0.00",
                                            _goal_text(traj, env, 0)]))
    for t in range(n):
        obs, reward, terminated, truncated, _ = made.step(env.to_box(actions[t][None])[0])
        total += float(reward)
        if t + 1 < n:
            same &= bool(np.allclose(np.asarray(obs, np.float32), traj["obs"][t + 1],
                                     rtol=1e-5, atol=1e-6))
        lines = [title, f"step {t + 1}/{n}   env_return {total:.2f}",
                 _goal_text(traj, env, t)]
        frames.append(_with_text(_frame(made), lines))
        if terminated or truncated:
            break
    same &= bool(np.isclose(total, float(rewards.sum()), rtol=1e-5, atol=1e-5))
    return frames, total, same


def write_host_gif(env: HostEnv, made: Any, traj: dict[str, np.ndarray], episode_key: jax.Array,
                   path: str, title: str) -> tuple[Any, str | None]:
    """Replay and write the episode as a GIF (:func:`replay_frames`); returns its path and a
    note if the replay differs from the evaluation, else None. Closes ``made``."""
    from hiddpg import render

    try:
        frames, total, same = replay_frames(env, made, traj, reset_seed(episode_key), title)
    finally:
        made.close()
    fps = float(made.metadata.get("render_fps") or 1.0 / env.dt)
    written = render.write_gif(frames, path, fps=min(fps, MAX_FPS))
    note = None if same else (
        f"note: {env.name} did not replay the evaluated episode exactly (it is not "
        f"deterministic given its seed); the GIF shows the replay, env_return {total:.2f}")
    return written, note
