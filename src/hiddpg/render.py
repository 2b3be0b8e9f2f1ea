"""Pictures of the environments: uint8 RGB frames drawn with PIL, and GIF/PNG writers.

A shell module (needs Pillow, the ``plot`` extra). A :class:`Scene` draws the static part of a
task once (the puck's reference trajectory and goals, the obstacle, the arm's target) and then
each frame on a copy of it, so a 75-step GIF takes a few tens of milliseconds to draw.

Frames can carry an :class:`Overlay`: a hierarchical agent's goals (the active one highlighted),
the trail of positions so far, the points where the agent switched goals, and lines of text.

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
from hiddpg.envs.puckworld import PuckObstacleParams, PuckParams, PuckTrajectoryParams

Color = tuple[int, int, int]
WHITE: Color = (255, 255, 255)
INK: Color = (40, 40, 48)
GRID: Color = (232, 232, 236)
REFERENCE: Color = (150, 150, 160)
REF_GOAL: Color = (90, 90, 100)
PUCK: Color = (30, 110, 200)
TRAIL: Color = (120, 170, 230)
AGENT_GOAL: Color = (230, 120, 20)
SWITCH: Color = (200, 40, 140)
TARGET: Color = (40, 160, 70)
OBSTACLE: Color = (200, 60, 50)
MUSCLE_REST: Color = (215, 190, 190)
MUSCLE_ACTIVE: Color = (220, 30, 30)

#: Muscle layout for drawing (not physics): (name, segments spanned, side of the bone).
MUSCLES: tuple[tuple[str, str, int], ...] = (
    ("shoulder flexor", "shoulder", +1), ("shoulder extensor", "shoulder", -1),
    ("elbow flexor", "elbow", +1), ("elbow extensor", "elbow", -1),
    ("biarticular flexor", "both", +1), ("biarticular extensor", "both", -1),
)


@dataclasses.dataclass
class Overlay:
    """Optional marks drawn on top of a frame.

    Attributes:
        goals: an agent's goals in goal space: ``(x, y)`` for the puck, joint angles
            ``(θ1, θ2)`` in radians for the arm (drawn as a ghost posture and its hand).
        active_goal: index in ``goals`` of the goal being pursued (highlighted).
        trail: world positions visited so far (puck centre or hand), oldest first.
        switch_points: world positions at which the agent switched goals.
        text: lines written in the top-left corner (e.g. ``"step 12  return -3.4"``).
    """

    goals: Sequence[Sequence[float]] = ()
    active_goal: int | None = None
    trail: Sequence[Sequence[float]] = ()
    switch_points: Sequence[Sequence[float]] = ()
    text: Sequence[str] = ()


def _blend(a: Color, b: Color, w: float) -> Color:
    w = min(max(float(w), 0.0), 1.0)
    return tuple(int(round(x + (y - x) * w)) for x, y in zip(a, b, strict=True))  # type: ignore[return-value]


class Scene:
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

    def joints(self, theta: Sequence[float]) -> np.ndarray:
        """Shoulder, elbow and hand positions ``(3, 2)`` of joint angles (numpy twin of
        :func:`hiddpg.envs.arm.forward_kinematics`, fast enough to call per frame)."""
        t1, t12 = float(theta[0]), float(theta[0]) + float(theta[1])
        elbow = self._l1 * np.array([math.cos(t1), math.sin(t1)])
        return np.stack([np.zeros(2), elbow, elbow + self._l2 * np.array([math.cos(t12),
                                                                         math.sin(t12)])])

    def _world_circle(self, draw: Any, p: Sequence[float], r: float, **kw: Any) -> None:
        self._circle(draw, p, r * self.scale, **kw)

    def _cross(self, draw: Any, p: Sequence[float], r_px: float, color: Color, w: int) -> None:
        x, y = self.px(p)
        draw.line((x - r_px, y - r_px, x + r_px, y + r_px), fill=color, width=w)
        draw.line((x - r_px, y + r_px, x + r_px, y - r_px), fill=color, width=w)

    # -- views --------------------------------------------------------------------------------
    def _puck_view(self) -> tuple[float, float, float, float]:
        gs = self.core.goal_space
        p = self.params
        pts = [np.asarray(gs.low), np.asarray(gs.high), np.asarray(p.init_state[:2])]
        if isinstance(p, PuckTrajectoryParams):
            pts += list(np.asarray(p.ref_states)[:, :2]) + list(np.asarray(p.goals))
        if isinstance(p, PuckObstacleParams):
            c, r = np.asarray(p.obstacle_center), float(p.obstacle_radius)
            pts += [np.asarray(p.target), c - r, c + r]
        pts = np.stack(pts)
        lo, hi = pts.min(0) - 0.2, pts.max(0) + 0.2
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])

    def _arm_view(self) -> tuple[float, float, float, float]:
        """The bounding box of every posture within the joint limits, plus a margin."""
        p = self.params
        lo, hi = np.asarray(p.joint_low, np.float64), np.asarray(p.joint_high, np.float64)
        t1, t2 = np.meshgrid(np.linspace(lo[0], hi[0], 29), np.linspace(lo[1], hi[1], 33))
        l1, l2 = float(p.upper_arm_length), float(p.forearm_length)
        ex, ey = l1 * np.cos(t1), l1 * np.sin(t1)
        hx, hy = ex + l2 * np.cos(t1 + t2), ey + l2 * np.sin(t1 + t2)
        xs = np.concatenate([[0.0, -0.10], ex.ravel(), hx.ravel()])
        ys = np.concatenate([[0.0, -0.12], ey.ravel(), hy.ravel()])
        m = 0.04
        return xs.min() - m, xs.max() + m, ys.min() - m, ys.max() + m

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

    def _puck_background(self, draw: Any) -> None:
        p = self.params
        if isinstance(p, PuckTrajectoryParams):
            ref = [np.asarray(p.init_state[:2])] + list(np.asarray(p.ref_states)[:, :2])
            draw.line([self.px(q) for q in ref], fill=REFERENCE, width=2)
            for q in ref[1:]:
                self._circle(draw, q, 2, fill=REFERENCE)
            for i, g in enumerate(np.asarray(p.goals)):
                self._cross(draw, g, 6, REF_GOAL, 2)
                x, y = self.px(g)
                draw.text((x + 7, y - 7), f"g{i + 1}", fill=REF_GOAL, font=self.font)
        if isinstance(p, PuckObstacleParams):
            self._world_circle(draw, p.obstacle_center, float(p.obstacle_radius),
                               fill=_blend(OBSTACLE, WHITE, 0.55), outline=OBSTACLE, width=2)
            self._circle(draw, p.target, 7, outline=TARGET, width=3)
            self._cross(draw, p.target, 4, TARGET, 2)

    def _arm_background(self, draw: Any) -> None:
        p = self.params
        # torso: a rounded block behind the shoulder
        box = (*self.px((-0.10, 0.04)), *self.px((0.02, -0.12)))
        draw.rounded_rectangle(box, radius=8, fill=(225, 225, 230))
        center = getattr(p, "obstacle_center", None)
        if center is not None:
            d = float(p.obstacle_diameter)
            self._world_circle(draw, center, d, outline=_blend(OBSTACLE, WHITE, 0.6), width=1)
            self._world_circle(draw, center, d / 2, fill=OBSTACLE)

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
        return np.asarray(img, np.uint8)

    def _goal_color(self, i: int, overlay: Overlay) -> Color:
        if overlay.active_goal is None or i == overlay.active_goal:
            return AGENT_GOAL
        return _blend(AGENT_GOAL, WHITE, 0.55)

    def _draw_puck(self, draw: Any, x: np.ndarray, action: Any, overlay: Overlay) -> None:
        for i, g in enumerate(overlay.goals):
            color = self._goal_color(i, overlay)
            self._circle(draw, g, 6, outline=color, width=2)
            self._circle(draw, g, 2, fill=color)
        if action is not None:
            a = np.clip(np.asarray(action, np.float64), -1.0, 1.0)
            tip = x[:2] + 0.3 * a
            draw.line((*self.px(x[:2]), *self.px(tip)), fill=AGENT_GOAL, width=2)
        self._circle(draw, x[:2], 7, fill=PUCK, outline=INK, width=1)

    def _draw_arm(self, draw: Any, x: np.ndarray, action: Any, overlay: Overlay,
                  target: Any) -> None:
        if target is not None:
            hand = self.joints(np.asarray(target))[2]
            self._circle(draw, hand, 8, outline=TARGET, width=3)
            self._cross(draw, hand, 4, TARGET, 2)
        for i, g in enumerate(overlay.goals):
            ghost = self.joints(g)
            color = _blend(self._goal_color(i, overlay), WHITE, 0.35)
            draw.line([self.px(q) for q in ghost], fill=color, width=2)
            self._circle(draw, ghost[2], 5, outline=self._goal_color(i, overlay), width=2)
        joints = self.joints(x[:2])
        act = np.zeros(6) if action is None else np.clip(np.asarray(action, np.float64), 0, 1)
        for (_, span, side), a in zip(MUSCLES, act, strict=True):
            path = self._muscle_path(joints, span, side)
            draw.line([self.px(q) for q in path], fill=_blend(MUSCLE_REST, MUSCLE_ACTIVE, a),
                      width=int(round(2 + 4 * a)), joint="curve")
        draw.line([self.px(q) for q in joints], fill=INK, width=6, joint="curve")
        for q in joints[:2]:
            self._circle(draw, q, 6, fill=WHITE, outline=INK, width=2)
        self._circle(draw, joints[2], 5, fill=PUCK, outline=INK, width=1)

    @staticmethod
    def _muscle_path(joints: np.ndarray, span: str, side: int) -> list[np.ndarray]:
        """A schematic muscle line: flexors (side +1) on the counter-clockwise side of the bones,
        extensors (-1) on the other; ``span`` is the joint(s) crossed."""
        shoulder, elbow, hand = joints
        l1, l2 = np.linalg.norm(elbow - shoulder), np.linalg.norm(hand - elbow)
        u1, u2 = (elbow - shoulder) / max(l1, 1e-9), (hand - elbow) / max(l2, 1e-9)
        n1, n2 = np.array([-u1[1], u1[0]]) * side, np.array([-u2[1], u2[0]]) * side
        corner = (n1 + n2) / max(np.linalg.norm(n1 + n2), 1e-9)
        torso = shoulder + (np.array([-0.045, 0.0]) if side > 0 else np.array([0.01, -0.045]))
        if span == "shoulder":
            return [torso, shoulder + 0.4 * l1 * u1 + 0.014 * n1]
        if span == "elbow":
            return [shoulder + 0.55 * l1 * u1 + 0.014 * n1, elbow + 0.02 * corner,
                    elbow + 0.25 * l2 * u2 + 0.014 * n2]
        return [torso + 0.012 * n1, shoulder + 0.25 * l1 * u1 + 0.03 * n1,
                elbow + 0.036 * corner, elbow + 0.35 * l2 * u2 + 0.028 * n2]

    def position(self, x: Any) -> np.ndarray:
        """The world point a trail follows: the puck centre or the hand."""
        x = np.asarray(getattr(x, "x", x), np.float64)
        return x[:2] if self.kind == "puck" else self.joints(x[:2])[2]


def render_frame(core: Any, params: Any, state: Any, action: Any = None,
                 overlay: Overlay | None = None, width: int | None = None) -> np.ndarray:
    """One frame (builds a :class:`Scene`; keep a Scene to draw many frames)."""
    return Scene(core, params, width).frame(state, action, overlay)


def render_rollout(core: Any, params: Any, states: Any, actions: Any = None,
                   rewards: Any = None, goals: Any = None, switches: Any = None,
                   width: int | None = None, title: str = "",
                   target: Any = None) -> list[np.ndarray]:
    """Frames of an episode with its trail, step counter and return so far.

    Args:
        states: ``(T + 1, state_dim)`` physical states, the initial one first.
        actions: ``(T, action_dim)`` normalised actions (frame ``k > 0`` shows action ``k - 1``).
        rewards: ``(T,)`` rewards; the text shows the return accumulated so far.
        goals: ``(T, goal_dim)`` the goal an agent pursued at each step, or ``None``.
        switches: ``(T,)`` bools, True where the agent chose a new goal at that step (default:
            wherever ``goals`` changes).
        title: a first line of text on every frame.
        target: the arm's joint-space target if not in the params (see :class:`Scene`).
    """
    scene = Scene(core, params, width, target=target)
    states = np.asarray(states)
    if goals is not None:
        goals = np.asarray(goals)
        if switches is None:  # a switch wherever the goal changes
            switches = np.r_[True, np.any(goals[1:] != goals[:-1], axis=-1)]
        switches = np.asarray(switches, bool)
    trail, ret, switch_points, goal_list, frames = [], 0.0, [], [], []
    for k, x in enumerate(states):
        trail.append(scene.position(x))
        a = None if actions is None or k == 0 else np.asarray(actions)[k - 1]
        if rewards is not None and k > 0:
            ret += float(np.asarray(rewards)[k - 1])
        if goals is not None and k < len(goals) and (switches[k] or not goal_list):
            goal_list.append(goals[k])
            if k > 0:
                switch_points.append(trail[-1])
        text = [title] if title else []
        text.append(f"step {k:3d}" + (f"   return {ret:8.2f}" if rewards is not None else ""))
        overlay = Overlay(goals=list(goal_list),
                          active_goal=len(goal_list) - 1 if goal_list else None,
                          trail=list(trail), switch_points=list(switch_points), text=text)
        frames.append(scene.frame(x, a, overlay))
    return frames


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
