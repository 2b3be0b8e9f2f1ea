"""The renderer's palette, its blending, and the legend entries of :mod:`hiddpg.render`."""

from __future__ import annotations

from typing import NamedTuple

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
FORCE: Color = (120, 70, 190)
MUSCLE_REST: Color = (215, 190, 190)
MUSCLE_ACTIVE: Color = (220, 30, 30)

#: The swatches a legend entry can show (see :meth:`hiddpg.render.Scene.legend_items`): a line,
#: a thick band, a cross, a ring, a ring with a dot, a ring with a cross (a target), a filled
#: disc with an ink outline, a pale disc with a coloured outline, a ghost posture ending in a
#: ring.
SWATCHES = ("line", "band", "cross", "ring", "ring-dot", "target", "disc", "blob", "posture")


class LegendItem(NamedTuple):
    """One legend entry: the name of what is drawn, its swatch (one of :data:`SWATCHES`) and
    its colour."""

    label: str
    swatch: str
    color: Color


def blend(a: Color, b: Color, w: float) -> Color:
    """The colour ``w`` of the way from ``a`` to ``b`` (``w`` clipped to ``[0, 1]``)."""
    w = min(max(float(w), 0.0), 1.0)
    return tuple(int(round(x + (y - x) * w)) for x, y in zip(a, b, strict=True))  # type: ignore[return-value]
