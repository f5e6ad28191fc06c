"""Effects specs: the ``effects:`` mapping of YAML and JSON files to effect objects and back.

``{name: {parameter: value}}``, one entry per effect of :data:`~.effects.EFFECTS`, as the
``simulate`` spec file, ``diagnose``'s ``effects.yaml`` (the node's ``effects_file``) and the ground
truth's JSON write it. Every file is read through :func:`~.yaml_files.read_yaml` (a binary, empty
or invalid file: one :class:`~baxter_dynamics_ros.errors.EffectSpecError` naming it).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from ..errors import EffectSpecError
from .effects import EFFECTS, Effect
from .yaml_files import read_yaml

__all__ = ["effects_from_dict", "effects_to_dict", "load_effects", "read_spec_file"]


def effects_from_dict(raw: Any, where: str = "effects") -> tuple[Effect, ...]:
    """Effects from a mapping ``{name: {parameter: value}}``, in :data:`EFFECTS` order.

    Joint parameters take a number (every joint), a list of 7 (s0 … w2) or a mapping by joint
    (``{s1: 2.0}``, the others 0, or 1 for scales). Missing parameters with defaults take them.
    """
    if raw is None:
        return ()
    if not isinstance(raw, Mapping):
        raise EffectSpecError(f"{where}: expected a mapping of effect names to parameters, got {raw!r}")
    unknown = set(raw) - set(EFFECTS)
    if unknown:
        raise EffectSpecError(f"{where}: unknown effects {sorted(unknown)}; known: {', '.join(EFFECTS)}")
    return tuple(cls.from_dict(raw[name], f"{where}.{name}") for name, cls in EFFECTS.items() if name in raw)


def effects_to_dict(effects: tuple[Effect, ...]) -> dict[str, dict[str, float | list[float]]]:
    """The inverse of :func:`effects_from_dict`."""
    return {e.name: e.to_dict() for e in effects}


def read_spec_file(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A YAML (or JSON) spec file as a mapping; raises EffectSpecError naming the path (also for
    an empty file: "no effects" is said by leaving the file out, or by ``effects: {}``)."""
    raw = read_yaml(path, EffectSpecError, "effects file")
    if not isinstance(raw, dict):
        raise EffectSpecError(f"{path}: expected a mapping with an 'effects' section")
    return raw


def load_effects(path: str | os.PathLike[str]) -> tuple[Effect, ...]:
    """The effects of the ``effects:`` section of a spec file (other sections are left to their users)."""
    raw = read_spec_file(path)
    if "effects" not in raw:
        raise EffectSpecError(f"{path}: no 'effects' section; write effects: {{name: {{parameter: value}}}}")
    return effects_from_dict(raw["effects"], f"{path}: effects")
