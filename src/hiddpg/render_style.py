"""The renderer's palette: the colours of :mod:`hiddpg.render` and their blending."""

from __future__ import annotations

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


def blend(a: Color, b: Color, w: float) -> Color:
    """The colour ``w`` of the way from ``a`` to ``b`` (``w`` clipped to ``[0, 1]``)."""
    w = min(max(float(w), 0.0), 1.0)
    return tuple(int(round(x + (y - x) * w)) for x, y in zip(a, b, strict=True))  # type: ignore[return-value]
