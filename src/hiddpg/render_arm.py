"""How :class:`hiddpg.render.Scene` draws the arm: its view, torso and obstacle, postures and
muscles, and the legend entries of what it draws."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from hiddpg.render_style import (
    INK,
    MUSCLE_ACTIVE,
    MUSCLE_REST,
    OBSTACLE,
    PUCK,
    TARGET,
    WHITE,
    LegendItem,
    blend,
)

if TYPE_CHECKING:
    from hiddpg.render import Overlay

#: Muscle layout for drawing (not physics): (name, segments spanned, side of the bone).
MUSCLES: tuple[tuple[str, str, int], ...] = (
    ("shoulder flexor", "shoulder", +1), ("shoulder extensor", "shoulder", -1),
    ("elbow flexor", "elbow", +1), ("elbow extensor", "elbow", -1),
    ("biarticular flexor", "both", +1), ("biarticular extensor", "both", -1),
)


class ArmDrawing:
    """The arm part of :class:`hiddpg.render.Scene` (a mixin: it uses the scene's coordinates
    and marks)."""

    def joints(self, theta: Sequence[float]) -> np.ndarray:
        """Shoulder, elbow and hand positions ``(3, 2)`` of joint angles (numpy twin of
        :func:`hiddpg.envs.arm.forward_kinematics`, fast enough to call per frame)."""
        t1, t12 = float(theta[0]), float(theta[0]) + float(theta[1])
        elbow = self._l1 * np.array([math.cos(t1), math.sin(t1)])
        return np.stack([np.zeros(2), elbow, elbow + self._l2 * np.array([math.cos(t12),
                                                                         math.sin(t12)])])

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

    def _arm_background(self, draw: Any) -> None:
        p = self.params
        # torso: a rounded block behind the shoulder
        box = (*self.px((-0.10, 0.04)), *self.px((0.02, -0.12)))
        draw.rounded_rectangle(box, radius=8, fill=(225, 225, 230))
        center = getattr(p, "obstacle_center", None)
        if center is not None:
            d = float(p.obstacle_diameter)
            self._world_circle(draw, center, d, outline=blend(OBSTACLE, WHITE, 0.6), width=1)
            self._world_circle(draw, center, d / 2, fill=OBSTACLE)

    def _draw_arm(self, draw: Any, x: np.ndarray, action: Any, overlay: Overlay,
                  target: Any) -> None:
        if target is not None:
            hand = self.joints(np.asarray(target))[2]
            self._circle(draw, hand, 8, outline=TARGET, width=3)
            self._cross(draw, hand, 4, TARGET, 2)
        for i, g in enumerate(overlay.goals):
            ghost = self.joints(g)
            color = blend(self._goal_color(i, overlay), WHITE, 0.35)
            draw.line([self.px(q) for q in ghost], fill=color, width=2)
            self._circle(draw, ghost[2], 5, outline=self._goal_color(i, overlay), width=2)
        joints = self.joints(x[:2])
        act = np.zeros(6) if action is None else np.clip(np.asarray(action, np.float64), 0, 1)
        for (_, span, side), a in zip(MUSCLES, act, strict=True):
            path = self._muscle_path(joints, span, side)
            draw.line([self.px(q) for q in path], fill=blend(MUSCLE_REST, MUSCLE_ACTIVE, a),
                      width=int(round(2 + 4 * a)), joint="curve")
        draw.line([self.px(q) for q in joints], fill=INK, width=6, joint="curve")
        for q in joints[:2]:
            self._circle(draw, q, 6, fill=WHITE, outline=INK, width=2)
        self._circle(draw, joints[2], 5, fill=PUCK, outline=INK, width=1)

    def _arm_legend(self, action: bool) -> tuple[list[LegendItem], list[LegendItem]]:
        """The entries of the static layer (obstacle, its collision distance, the target) and of
        the arm and its muscles (shaded by activation when ``action``), in the order listed."""
        static = []
        if getattr(self.params, "obstacle_center", None) is not None:
            static += [LegendItem("obstacle", "disc", OBSTACLE),
                       LegendItem("collision distance", "ring", blend(OBSTACLE, WHITE, 0.6))]
        if self.target is not None:
            static.append(LegendItem("target (hand)", "target", TARGET))
        body = [LegendItem("hand", "disc", PUCK)]
        if action:
            body.append(LegendItem("muscles (red: active)", "band", MUSCLE_ACTIVE))
        return static, body

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
