"""``--set key=value`` overrides of a :class:`~hiddpg.configs.TrainConfig`.

Keys are dotted paths (``agent.low.lr=1e-3``, ``env.field=cw``); values are JSON or a bare word.
A field that holds an optional part (``agent.low_hindsight``, ``agent.high.huber``) is created
with its defaults when one of its keys is set and removed with ``=none``; a field that holds
one of several configs (``agent.choice``) takes the chosen one's ``kind``
(``agent.choice=hold``, with its defaults; its keys are set after it). The whole config is
validated once, after every override. A non-finite number (``nan``, ``inf``, ``-Infinity``,
in any spelling) for a numeric field or an environment parameter is refused with one message,
``--set agent.actor_lr=nan: must be a finite number``.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import types
import typing
from typing import Any

from hiddpg.configs import TrainConfig, from_dict, to_dict


def apply_overrides(cfg: TrainConfig, sets: list[str] | tuple[str, ...]) -> TrainConfig:
    """Apply ``key=value`` strings: ``episodes=100``, ``agent.low.lr=1e-3``,
    ``agent.hidden=[64,64]``, ``env.field=cw`` (environment parameters go under ``env.``)."""
    done: list[str] = []
    for item in sets:
        if "=" not in item:
            raise ValueError(f"--set {item!r} must have the form key=value")
        key, raw = item.split("=", 1)
        key = key.strip()
        earlier = [k for k in done if k.startswith(key + ".")]
        if earlier:  # a whole group set after one of its keys would silently drop that key
            raise ValueError(f"--set {key}={raw} comes after --set {earlier[0]}=...: set "
                             f"{key} first, then its keys")
        done.append(key)
        path = key.split(".")
        if path[0] == "env" and len(path) == 2:
            env = dict(cfg.env)
            env[path[1]] = _finite(_parse(raw), key)
            cfg = _replace_unchecked(cfg, env=tuple(sorted(env.items())))
            continue
        cfg = _set_path(cfg, path, raw, full=key)
    # validate once, after all of them: options that constrain each other (e.g.
    # choice=critic-durations with model_weight=0) can then be set in any order
    return from_dict(to_dict(cfg))


def _replace_unchecked(obj: Any, **changes: Any) -> Any:
    """``dataclasses.replace`` without ``__post_init__`` (:func:`apply_overrides` validates
    the whole config at the end)."""
    new = copy.copy(obj)
    for name, value in changes.items():
        object.__setattr__(new, name, value)
    return new


def _set_path(obj: Any, path: list[str], raw: str, full: str) -> Any:
    fields = {f.name: f for f in dataclasses.fields(obj)}
    name = path[0]
    if name not in fields:
        allowed = sorted(fields) + (["env.<param>"] if isinstance(obj, TrainConfig) else [])
        raise ValueError(f"--set {full}: unknown key {name!r} in {type(obj).__name__}; "
                         f"allowed: {allowed}")
    current = getattr(obj, name)
    hint = typing.get_type_hints(type(obj))[name]
    parts, optional = _parts(hint)
    if len(path) > 1:
        if current is None and len(parts) == 1:  # an optional part: created with its defaults
            current = parts[0]()
        if not dataclasses.is_dataclass(current):
            raise ValueError(f"--set {full}: {name!r} has no sub-keys")
        return _replace_unchecked(obj, **{name: _set_path(current, path[1:], raw, full)})
    if parts:
        return _replace_unchecked(obj, **{name: _set_part(parts, optional, _parse(raw), full)})
    if dataclasses.is_dataclass(current):
        raise ValueError(f"--set {full}: {name!r} is a group; set one of its keys, e.g. "
                         f"{full}.{dataclasses.fields(current)[0].name}=...")
    value = _coerce(_parse(raw), hint, current, full)
    return _replace_unchecked(obj, **{name: value})


def _parts(hint: Any) -> tuple[list[type], bool]:
    """The config classes a field may hold (one, or a union of them) and whether it may be
    None; ``([], False)`` for a plain value or a fixed group."""
    if typing.get_origin(hint) not in (typing.Union, types.UnionType):
        return [], False
    members = typing.get_args(hint)
    classes = [m for m in members if dataclasses.is_dataclass(m)]
    return classes, type(None) in members


def _set_part(parts: list[type], optional: bool, value: Any, full: str) -> Any:
    """A part field set as a whole: ``none``, a ``kind`` or ``{}`` (defaults)."""
    if value is None or (isinstance(value, str) and value.lower() == "none"):
        if optional:
            return None
        raise ValueError(f"--set {full}: cannot be none; choose one of {_kinds(parts)}")
    if isinstance(value, dict) and len(parts) == 1:
        return parts[0](**value)
    kinds = {getattr(c, "kind", None): c for c in parts}
    if isinstance(value, str) and value in kinds:
        return kinds[value]()
    allowed = _kinds(parts) if len(parts) > 1 else ["{} (the defaults)"]
    raise ValueError(f"--set {full}: {value!r} is not allowed; choose one of "
                     f"{allowed + (['none'] if optional else [])}, or set one of its keys")


def _kinds(parts: list[type]) -> list[str]:
    return [str(getattr(c, "kind", c.__name__)) for c in parts]


def _parse(raw: str) -> Any:
    try:
        return json.loads(raw)
    except json.JSONDecodeError:
        low = raw.strip().lower()
        if low in ("true", "false"):
            return low == "true"
        return raw.strip()


def _non_finite(value: Any) -> float | None:
    """``value`` as a float if it is a non-finite number or a word that spells one (``nan``,
    ``NaN``, ``inf``, ``-Infinity``, ``1e999``, ...); None otherwise."""
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        return None
    try:
        number = float(value)
    except (ValueError, OverflowError):
        return None
    return None if math.isfinite(number) else number


def _finite(value: Any, full: str) -> Any:
    """``value``, unless it is a non-finite number in any spelling: then one message that
    names the key and the value."""
    number = _non_finite(value)
    if number is not None:
        raise ValueError(f"--set {full}={number!r}: must be a finite number")
    return value


def _coerce(value: Any, hint: Any, current: Any, full: str) -> Any:
    bad = ValueError(f"--set {full}: {value!r} is not a valid {type(current).__name__}")
    if isinstance(current, int | float) and not isinstance(current, bool):
        _finite(value, full)
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise bad
        return value
    if isinstance(current, int):
        if isinstance(value, bool) or not isinstance(value, int | float) or value != int(value):
            raise bad
        return int(value)
    if isinstance(current, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise bad
        return float(value)
    if isinstance(current, tuple):
        if not isinstance(value, list):
            raise ValueError(f"--set {full}: {value!r} must be a list such as [64,64]")
        return tuple(value)
    if isinstance(current, str):
        return str(value)
    return value
