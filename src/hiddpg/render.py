"""Pictures of the environments: uint8 RGB frames drawn with PIL, and GIF/PNG writers.

A shell module (needs Pillow, the ``plot`` extra). A :class:`Scene` draws the static part of a
task once (the puck's reference trajectory and goals, the obstacle, the arm's target) and then
each frame on a copy of it, so a frame costs only the drawing of what moves.

Frames can carry an :class:`Overlay`: a hierarchical agent's goals (the active one highlighted),
the trail of positions so far, the points where the agent switched goals, lines of text, and a
legend: a strip below the view naming each mark next to its swatch, listing only what is drawn
(:meth:`Scene.legend_items`). :func:`render_rollout` gives every frame of an episode the same
legend and the step and ``env_return`` (the sum of the environment's rewards) so far.
What each environment family looks like is drawn by :mod:`hiddpg.render_puck` and
:mod:`hiddpg.render_arm`, in the colours of :mod:`hiddpg.render_style`.

>>> from hiddpg import make, render
>>> env, params = make("PuckTrajectory2")
>>> obs, state = env.reset(key, params)
>>> frame = render.render_frame(env, params, state)          # (H, W, 3) uint8
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

try:
    from PIL import Image, ImageDraw, ImageFont
except ImportError as e:  # pragma: no cover
    raise ImportError("hiddpg.render needs Pillow: pip install 'hiddpg[plot]'") from e

from hiddpg.envs.arm import ArmParams
from hiddpg.envs.puckworld import PuckParams
from hiddpg.render_arm import MUSCLES, ArmDrawing
from hiddpg.render_legend import LegendDrawing
from hiddpg.render_puck import PuckDrawing
from hiddpg.render_style import (
    AGENT_GOAL,
    FORCE,
    GRID,
    INK,
    MUSCLE_ACTIVE,
    MUSCLE_REST,
    OBSTACLE,
    PUCK,
    REF_GOAL,
    REFERENCE,
    SWITCH,
    TARGET,
    TRAIL,
    WHITE,
    Color,
    LegendItem,
)
from hiddpg.render_style import blend as _blend

__all__ = [
    "AGENT_GOAL", "FORCE", "GRID", "INK", "MUSCLES", "MUSCLE_ACTIVE", "MUSCLE_REST", "OBSTACLE",
    "PUCK", "REFERENCE", "REF_GOAL", "SWITCH", "TARGET", "TRAIL", "WHITE", "Color", "LegendItem",
    "Overlay", "Scene", "render_frame", "render_rollout", "rollout_overlays", "write_gif",
    "write_png",
]


@dataclasses.dataclass
class Overlay:
    """Optional marks drawn on top of a frame.

    Attributes:
        goals: an agent's goals in goal space: ``(x, y)`` for the puck, joint angles
            ``(θ1, θ2)`` in radians for the arm (drawn as a ghost posture and its hand).
        active_goal: index in ``goals`` of the goal being pursued (highlighted).
        trail: world positions visited so far (puck centre or hand), oldest first.
        switch_points: world positions at which the agent switched goals.
        text: lines written in the top-left corner (e.g. ``"step 12  env_return -3.4"``).
        goal_label: the legend's name of the goals (e.g. ``"learned goal"``).
        switch_label: the legend's name of the switch points (e.g. ``"skill change"``).
        legend: entries drawn in a strip below the view (none: no strip); see
            :meth:`Scene.legend_items`.
    """

    goals: Sequence[Sequence[float]] = ()
    active_goal: int | None = None
    trail: Sequence[Sequence[float]] = ()
    switch_points: Sequence[Sequence[float]] = ()
    text: Sequence[str] = ()
    goal_label: str = "goal"
    switch_label: str = "goal switch"
    legend: Sequence[LegendItem] = ()


class Scene(PuckDrawing, ArmDrawing, LegendDrawing):
    """Draws frames of one task with fixed params.

    Args:
        core: the functional environment (from :func:`hiddpg.make`).
        params: its params.
        width: frame width in pixels (default 400 for the puck, 480 for the arm); the height
            follows the aspect of the view.
        view: world box ``(xmin, xmax, ymin, ymax)`` in metres; default: one that contains the
            task (the goal space and reference for the puck, the reachable disc for the arm).
        target: the arm's joint-space target (rad) when it is not in the params (ArmReach
            draws it per episode); a state with a ``target`` field overrides it.
    """

    def __init__(self, core: Any, params: Any, width: int | None = None,
                 view: tuple[float, float, float, float] | None = None,
                 target: Any = None) -> None:
        if not isinstance(params, PuckParams | ArmParams):
            raise TypeError(f"no renderer for params of type {type(params).__name__}")
        self.kind = "puck" if isinstance(params, PuckParams) else "arm"
        self.core, self.params = core, params
        self.target = getattr(params, "target", None) if target is None else target
        if self.kind == "arm":
            self._l1, self._l2 = float(params.upper_arm_length), float(params.forearm_length)
        self.view = view or (self._puck_view() if self.kind == "puck" else self._arm_view())
        xmin, xmax, ymin, ymax = self.view
        width = width or (400 if self.kind == "puck" else 480)
        self.scale = width / (xmax - xmin)
        self.size = (int(width), int(round((ymax - ymin) * self.scale)))
        self.font = ImageFont.load_default(size=max(11, width // 32))
        self.background = self._draw_background()

    # -- coordinates --------------------------------------------------------------------------
    def px(self, p: Sequence[float]) -> tuple[float, float]:
        """World ``(x, y)`` to pixel coordinates (y up in the world, down in the image)."""
        xmin, _, _, ymax = self.view
        return ((float(p[0]) - xmin) * self.scale, (ymax - float(p[1])) * self.scale)

    def _circle(self, draw: Any, p: Sequence[float], r_px: float, **kw: Any) -> None:
        x, y = self.px(p)
        draw.ellipse((x - r_px, y - r_px, x + r_px, y + r_px), **kw)

    def _world_circle(self, draw: Any, p: Sequence[float], r: float, **kw: Any) -> None:
        self._circle(draw, p, r * self.scale, **kw)

    def _cross(self, draw: Any, p: Sequence[float], r_px: float, color: Color, w: int) -> None:
        x, y = self.px(p)
        draw.line((x - r_px, y - r_px, x + r_px, y + r_px), fill=color, width=w)
        draw.line((x - r_px, y + r_px, x + r_px, y - r_px), fill=color, width=w)

    # -- static layer -------------------------------------------------------------------------
    def _draw_background(self) -> Image.Image:
        img = Image.new("RGB", self.size, WHITE)
        draw = ImageDraw.Draw(img)
        self._draw_grid(draw, 1.0 if self.kind == "puck" else 0.1)
        (self._puck_background if self.kind == "puck" else self._arm_background)(draw)
        return img

    def _draw_grid(self, draw: Any, step: float) -> None:
        xmin, xmax, ymin, ymax = self.view
        for x in np.arange(math.ceil(xmin / step) * step, xmax, step):
            draw.line((*self.px((x, ymin)), *self.px((x, ymax))), fill=GRID, width=1)
        for y in np.arange(math.ceil(ymin / step) * step, ymax, step):
            draw.line((*self.px((xmin, y)), *self.px((xmax, y))), fill=GRID, width=1)
        draw.line((*self.px((xmin, 0)), *self.px((xmax, 0))), fill=_blend(GRID, INK, 0.2))
        draw.line((*self.px((0, ymin)), *self.px((0, ymax))), fill=_blend(GRID, INK, 0.2))

    # -- dynamic layer ------------------------------------------------------------------------
    def frame(self, x: Any, action: Any = None, overlay: Overlay | None = None) -> np.ndarray:
        """One ``(H, W, 3)`` uint8 frame of physical state ``x`` (or a state with ``.x``);
        ``action`` (normalised) shades the arm's muscles or draws the puck's force."""
        target = getattr(x, "target", self.target)
        x = np.asarray(getattr(x, "x", x), np.float64)
        img = self.background.copy()
        draw = ImageDraw.Draw(img)
        overlay = overlay or Overlay()
        if len(overlay.trail) > 1:
            draw.line([self.px(q) for q in overlay.trail], fill=TRAIL, width=2)
        if self.kind == "puck":
            self._draw_puck(draw, x, action, overlay)
        else:
            self._draw_arm(draw, x, action, overlay, target)
        for q in overlay.switch_points:
            self._circle(draw, q, 5, outline=SWITCH, width=2)
        for i, line in enumerate(overlay.text):
            draw.text((6, 4 + i * (self.font.size + 3)), line, fill=INK, font=self.font)
        if overlay.legend:
            strip = self.legend_strip(overlay.legend)
            framed = Image.new("RGB", (self.size[0], self.size[1] + strip.size[1]), WHITE)
            framed.paste(img, (0, 0))
            framed.paste(strip, (0, self.size[1]))
            img = framed
        return np.asarray(img, np.uint8)

    def _goal_color(self, i: int, overlay: Overlay) -> Color:
        if overlay.active_goal is None or i == overlay.active_goal:
            return AGENT_GOAL
        return _blend(AGENT_GOAL, WHITE, 0.55)

    def position(self, x: Any) -> np.ndarray:
        """The world point a trail follows: the puck centre or the hand."""
        x = np.asarray(getattr(x, "x", x), np.float64)
        return x[:2] if self.kind == "puck" else self.joints(x[:2])[2]


def render_frame(core: Any, params: Any, state: Any, action: Any = None,
                 overlay: Overlay | None = None, width: int | None = None) -> np.ndarray:
    """One frame (builds a :class:`Scene`; keep a Scene to draw many frames)."""
    return Scene(core, params, width).frame(state, action, overlay)


def rollout_overlays(scene: Scene, states: Any, actions: Any = None, rewards: Any = None,
                     goals: Any = None, switches: Any = None, title: str = "",
                     notes: Sequence[str] | None = None, goal_label: str = "goal",
                     switch_label: str = "goal switch", legend: bool = True) -> list[Overlay]:
    """The overlays of an episode's frames (see :func:`render_rollout` for the arguments): the
    trail, goals and switch points so far, the text ``step k   env_return R`` (the sum of the
    environment's rewards so far) and, when ``legend``, one legend for every frame naming all
    that the episode draws."""
    states = np.asarray(states)
    if goals is not None:
        goals = np.asarray(goals)
        if switches is None:  # a switch wherever the goal changes
            switches = np.r_[True, np.any(goals[1:] != goals[:-1], axis=-1)]
    if switches is not None:
        switches = np.asarray(switches, bool)
    trail, ret, switch_points, goal_list, overlays = [], 0.0, [], [], []
    for k, x in enumerate(states):
        trail.append(scene.position(x))
        if rewards is not None and k > 0:
            ret += float(np.asarray(rewards)[k - 1])
        new = switches is not None and k < len(switches) and bool(switches[k])
        if goals is not None and k < len(goals) and (new or not goal_list):
            goal_list.append(goals[k])
        if new and k > 0:
            switch_points.append(trail[-1])
        text = [title] if title else []
        text.append(f"step {k:3d}" + (f"   env_return {ret:8.2f}" if rewards is not None else "")
                    + (f"   {notes[k]}" if notes is not None and k < len(notes) else ""))
        overlays.append(Overlay(
            goals=list(goal_list), active_goal=len(goal_list) - 1 if goal_list else None,
            trail=list(trail), switch_points=list(switch_points), text=text,
            goal_label=goal_label, switch_label=switch_label))
    if legend and overlays:
        items = scene.legend_items(overlays[-1], action=actions is not None)
        for overlay in overlays:
            overlay.legend = items
    return overlays


def render_rollout(core: Any, params: Any, states: Any, actions: Any = None,
                   rewards: Any = None, goals: Any = None, switches: Any = None,
                   width: int | None = None, title: str = "", target: Any = None,
                   notes: Sequence[str] | None = None, goal_label: str = "goal",
                   switch_label: str = "goal switch", legend: bool = True) -> list[np.ndarray]:
    """Frames of an episode with its trail, step counter, ``env_return`` so far and a legend.

    Args:
        states: ``(T + 1, state_dim)`` physical states, the initial one first.
        actions: ``(T, action_dim)`` normalised actions (frame ``k > 0`` shows action ``k - 1``).
        rewards: ``(T,)`` the environment's rewards; the text shows their sum so far
            (``env_return``, as in ``hiddpg eval``'s table).
        goals: ``(T, goal_dim)`` the goal an agent pursued at each step, or ``None``.
        switches: ``(T,)`` bools, True where the agent chose a new goal (or skill) at that step
            (default: wherever ``goals`` changes); marked from step 1 on.
        title: a first line of text on every frame.
        target: the arm's joint-space target if not in the params (see :class:`Scene`).
        notes: ``(T + 1,)`` text added to each frame's step line (e.g. the current skill).
        goal_label, switch_label: the legend's names of the goals and switch points.
        legend: draw the legend strip below the view.
    """
    scene = Scene(core, params, width, target=target)
    overlays = rollout_overlays(scene, states, actions, rewards, goals, switches, title, notes,
                                goal_label, switch_label, legend)
    actions = None if actions is None else np.asarray(actions)
    return [scene.frame(x, None if actions is None or k == 0 else actions[k - 1], overlay)
            for k, (x, overlay) in enumerate(zip(np.asarray(states), overlays, strict=True))]


def write_gif(frames: Sequence[np.ndarray], path: str | Path, fps: float = 10.0) -> Path:
    """Write frames (uint8 RGB) as a looping animated GIF; returns the path."""
    if not frames:
        raise ValueError("write_gif needs at least one frame")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    frames = [np.asarray(f, np.uint8) for f in frames]
    # one shared palette from a montage of up to 8 frames: fast, and no colour flicker
    sample = np.linspace(0, len(frames) - 1, min(8, len(frames))).astype(int)
    montage = Image.fromarray(np.concatenate([frames[i] for i in sample], axis=0))
    palette = montage.quantize(colors=255, method=Image.Quantize.MEDIANCUT,
                               dither=Image.Dither.NONE)
    images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE)
              for f in frames]
    duration = max(20, int(round(1000.0 / fps)))
    images[0].save(path, save_all=True, append_images=images[1:], duration=duration, loop=0)
    return path


def write_png(frame: np.ndarray, path: str | Path) -> Path:
    """Write one frame as an optimised PNG; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.asarray(frame, np.uint8)).save(path, optimize=True)
    return path
