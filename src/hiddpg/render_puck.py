"""How :class:`hiddpg.render.Scene` draws PuckWorld: its view, reference, obstacle and puck,
and the legend entries of what it draws."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from hiddpg.envs.puckworld import PuckObstacleParams, PuckTrajectoryParams
from hiddpg.render_style import (
    FORCE,
    INK,
    OBSTACLE,
    PUCK,
    REF_GOAL,
    REFERENCE,
    TARGET,
    WHITE,
    LegendItem,
    blend,
)

if TYPE_CHECKING:
    from hiddpg.render import Overlay


class PuckDrawing:
    """The PuckWorld part of :class:`hiddpg.render.Scene` (a mixin: it uses the scene's
    coordinates and marks)."""

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
                               fill=blend(OBSTACLE, WHITE, 0.55), outline=OBSTACLE, width=2)
            self._circle(draw, p.target, 7, outline=TARGET, width=3)
            self._cross(draw, p.target, 4, TARGET, 2)

    def _draw_puck(self, draw: Any, x: np.ndarray, action: Any, overlay: Overlay) -> None:
        for i, g in enumerate(overlay.goals):
            color = self._goal_color(i, overlay)
            self._circle(draw, g, 6, outline=color, width=2)
            self._circle(draw, g, 2, fill=color)
        if action is not None:
            a = np.clip(np.asarray(action, np.float64), -1.0, 1.0)
            tip = x[:2] + 0.3 * a
            draw.line((*self.px(x[:2]), *self.px(tip)), fill=FORCE, width=2)
        self._circle(draw, x[:2], 7, fill=PUCK, outline=INK, width=1)

    def _puck_legend(self, action: bool) -> tuple[list[LegendItem], list[LegendItem]]:
        """The entries of the static layer (reference, obstacle, target) and of the puck and
        its force (when ``action``), in the order they are listed."""
        p = self.params
        static = []
        if isinstance(p, PuckTrajectoryParams):
            n = len(np.asarray(p.goals))
            names = ", ".join(f"g{i + 1}" for i in range(n))
            static += [LegendItem("reference path", "line", REFERENCE),
                       LegendItem(f"reference goal{'s' if n > 1 else ''} {names}", "cross",
                                  REF_GOAL)]
        if isinstance(p, PuckObstacleParams):
            static += [LegendItem("obstacle", "blob", OBSTACLE),
                       LegendItem("target", "target", TARGET)]
        body = [LegendItem("puck", "disc", PUCK)]
        if action:
            body.append(LegendItem("force (action)", "line", FORCE))
        return static, body
