"""How :class:`hiddpg.render.Scene` draws its legend: a strip below the view naming each mark
next to its swatch, listing only what the frames draw."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from PIL import Image, ImageDraw

from hiddpg.render_style import (
    AGENT_GOAL,
    GRID,
    INK,
    SWATCHES,
    SWITCH,
    TRAIL,
    WHITE,
    Color,
    LegendItem,
    blend,
)

if TYPE_CHECKING:
    from hiddpg.render import Overlay


class LegendDrawing:
    """The legend part of :class:`hiddpg.render.Scene` (a mixin: it uses the scene's size, font
    and the families' ``_puck_legend`` / ``_arm_legend``)."""

    def legend_items(self, overlay: Overlay | None = None, action: bool = False
                     ) -> list[LegendItem]:
        """The legend of a frame drawn with ``overlay`` (and an action, when ``action``): the
        static layer's marks, the puck or hand, and of the overlay only what it draws (the
        trail, the goals, earlier goals faded, the switch points); the action's force or
        muscles last."""
        legend = self._puck_legend if self.kind == "puck" else self._arm_legend
        static, body = legend(action)
        items = list(static)
        if overlay is None:
            return items + body
        goal = "ring-dot" if self.kind == "puck" else "posture"
        if len(overlay.trail) > 1:
            items.append(LegendItem("trail", "line", TRAIL))
        if overlay.goals:
            items.append(LegendItem(overlay.goal_label, goal, AGENT_GOAL))
            if overlay.active_goal is not None and len(overlay.goals) > 1:
                items.append(LegendItem(f"earlier {overlay.goal_label}", goal,
                                        blend(AGENT_GOAL, WHITE, 0.55)))
        if overlay.switch_points:
            items.append(LegendItem(overlay.switch_label, "ring", SWITCH))
        return items + body

    def legend_strip(self, items: Sequence[LegendItem]) -> Image.Image:
        """The legend as an image as wide as the frame: entries in rows, each a swatch and its
        label (cached per list of entries)."""
        cache = self.__dict__.setdefault("_legend_strips", {})
        key = tuple(items)
        if key not in cache:
            cache[key] = self._draw_legend(key)
        return cache[key]

    def _draw_legend(self, items: tuple[LegendItem, ...]) -> Image.Image:
        width, pad, swatch, gap = self.size[0], 6, 18, 12
        row_h = self.font.size + 6
        rows: list[list[tuple[int, LegendItem]]] = [[]]
        x = pad
        for item in items:
            w = swatch + 4 + int(math.ceil(self.font.getlength(item.label)))
            if rows[-1] and x + w > width - pad:
                rows.append([])
                x = pad
            rows[-1].append((x, item))
            x += w + gap
        img = Image.new("RGB", (width, len(rows) * row_h + 2 * pad - 2), WHITE)
        draw = ImageDraw.Draw(img)
        draw.line((0, 0, width, 0), fill=blend(GRID, INK, 0.2))
        for r, row in enumerate(rows):
            cy = pad + r * row_h + row_h / 2
            for x, item in row:
                draw_swatch(draw, item.swatch, item.color, x, cy, swatch)
                draw.text((x + swatch + 4, cy), item.label, fill=INK, font=self.font,
                          anchor="lm")
        return img


def draw_swatch(draw: Any, kind: str, color: Color, x: float, cy: float, w: int) -> None:
    """Draw swatch ``kind`` (see :data:`hiddpg.render_style.SWATCHES`) in ``[x, x + w]``
    around height ``cy``."""
    cx = x + w / 2

    def ring(r: float, **kw: Any) -> None:
        draw.ellipse((cx - r, cy - r, cx + r, cy + r), **kw)

    def cross(r: float) -> None:
        draw.line((cx - r, cy - r, cx + r, cy + r), fill=color, width=2)
        draw.line((cx - r, cy + r, cx + r, cy - r), fill=color, width=2)

    if kind in ("line", "band"):
        draw.line((x, cy, x + w, cy), fill=color, width=2 if kind == "line" else 5)
    elif kind == "cross":
        cross(5)
    elif kind == "ring":
        ring(5, outline=color, width=2)
    elif kind == "ring-dot":
        ring(5, outline=color, width=2)
        ring(2, fill=color)
    elif kind == "target":
        ring(6, outline=color, width=2)
        cross(3)
    elif kind == "disc":
        ring(6, fill=color, outline=INK, width=1)
    elif kind == "blob":
        ring(6, fill=blend(color, WHITE, 0.55), outline=color, width=2)
    elif kind == "posture":
        draw.line((x, cy + 5, x + w - 8, cy - 2), fill=blend(color, WHITE, 0.35), width=2)
        draw.ellipse((x + w - 9, cy - 6, x + w - 1, cy + 2), outline=color, width=2)
    else:
        raise ValueError(f"unknown legend swatch {kind!r}; one of {SWATCHES}")
