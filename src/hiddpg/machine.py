"""Which machine trained which episodes of a run.

A run can be stopped and resumed on another machine, and the same seed's training time (and,
across instruction sets, its last bits) depends on the CPU. ``progress.json`` therefore keeps
``machines``: consecutive spans of episodes, each with the machine that trained it and the
wall-clock seconds it took. A span is extended while the same machine trains on (resumes
included) and a new one starts when another machine resumes the run. Episodes a run had
trained before it recorded spans form a first span with machine ``None`` (not recorded).

A machine is described by :func:`describe`: the CPU's model name, its widest vector
extension (``AVX-512``, ``AVX2``, ...), the cores this process may use, and the JAX backend's
device kind (``cpu`` or, say, an accelerator's name).
"""

from __future__ import annotations

import functools
import os
import platform
from pathlib import Path
from typing import Any

#: Vector extensions named by :func:`describe`, widest first, with the ``/proc/cpuinfo`` flag
#: that shows each.
ISA_FLAGS = (("AVX-512", "avx512f"), ("AVX2", "avx2"), ("AVX", "avx"), ("SSE4.2", "sse4_2"))


def _cpuinfo() -> tuple[str | None, set[str]]:
    """The CPU's model name and flags from ``/proc/cpuinfo`` (``None`` and no flags where
    there is none)."""
    name, flags = None, set()
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return None, flags
    for line in text.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "model name" and name is None:
            name = value.strip()
        elif key.strip() == "flags" and not flags:
            flags = set(value.split())
    return name, flags


def _cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


@functools.cache
def describe() -> dict[str, Any]:
    """This machine: ``cpu`` (model name), ``isa`` (widest vector extension, or ``None``),
    ``cores`` (usable by this process), ``device`` (the JAX backend's first device kind)."""
    import jax

    name, flags = _cpuinfo()
    isa = next((label for label, flag in ISA_FLAGS if flag in flags), None)
    try:
        device = str(jax.devices()[0].device_kind)
    except RuntimeError:  # no backend could start: the CPU description still stands
        device = None
    return {"cpu": name or platform.processor() or platform.machine(), "isa": isa,
            "cores": _cores(), "device": device}


def machine_text(machine: dict[str, Any] | None) -> str:
    """One line for a report: ``AMD EPYC (AVX2, 2 cores, cpu)``; ``not recorded`` for
    ``None``."""
    if not machine:
        return "not recorded"
    extra = [machine.get("isa"), f"{machine.get('cores')} cores", machine.get("device")]
    return f"{machine.get('cpu')} ({', '.join(str(x) for x in extra if x)})"


def _valid(spans: Any) -> list[dict[str, Any]]:
    """The well-formed spans of a progress.json's ``machines`` (none if it is not a list)."""
    if not isinstance(spans, list):
        return []
    keys = {"machine", "episodes", "wall_time"}
    return [dict(s) for s in spans
            if isinstance(s, dict) and keys <= set(s) and isinstance(s["episodes"], list)
            and len(s["episodes"]) == 2]


def extend_spans(previous: dict[str, Any] | None, episodes: int, wall_time: float,
                 here: dict[str, Any]) -> list[dict[str, Any]]:
    """The ``machines`` of a progress.json that records ``episodes`` trained in
    ``wall_time`` seconds in all, the last of them on ``here``; ``previous`` is the
    progress.json written before (``None`` for a new run).

    Each span is ``{"machine", "episodes": [first, last], "wall_time"}`` (episodes
    ``first < e <= last``). Spans past ``episodes`` (a run resumed from an older checkpoint)
    are cut back to it; the last span's seconds are what the earlier ones leave of
    ``wall_time`` (at least 0)."""
    previous = previous or {}
    spans = _valid(previous.get("machines"))
    done = int(previous.get("episodes") or 0)
    if not spans and done > 0:  # trained before spans were recorded
        spans = [{"machine": None, "episodes": [0, done],
                  "wall_time": round(float(previous.get("wall_time") or 0.0), 3)}]
    kept = []
    for span in spans:
        first, last = (int(x) for x in span["episodes"])
        last = min(last, int(episodes))
        if first < last:  # empty spans (a new run's, or cut off by the resume) are dropped
            kept.append({**span, "episodes": [first, last]})
    if kept and kept[-1]["machine"] == here:
        start = kept.pop()["episodes"][0]
    else:
        start = kept[-1]["episodes"][1] if kept else 0
    earlier = sum(float(s["wall_time"]) for s in kept)
    return [*kept, {"machine": here, "episodes": [start, int(episodes)],
                    "wall_time": round(max(0.0, float(wall_time) - earlier), 3)}]
