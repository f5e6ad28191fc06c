"""Identified effects as a correction of the model, sample by sample (the node's ``effects_file``).

An effects file written by ``baxter-dynamics diagnose`` (``effects.yaml``) lists the effects the
diagnosis selected, with their fitted parameters. :class:`Compensation` turns them into the model the
node uses in place of the rigid body:

- ``payload`` and ``inertial_error`` change the links' inertials: they are applied to the arm model
  once (a new :class:`~baxter_dynamics_ros.core.arm_model.ArmModel`), so τ and G come from the core as before;
- ``torque_offset``, the frictions, ``s1_spring`` and ``armature`` add their share of the effort,
  computed from q, q̇ and the estimated q̈ of the same sample;
- ``delay`` and ``acceleration_noise`` describe the recording, not the arm: the node does not
  compensate them (its own causal estimator filters q̇; a delayed effort would need the future
  state), and says so in its log.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..errors import EffectSpecError
from .arm_model import ArmModel
from .effect_specs import effects_from_dict, read_spec_file
from .effects import Effect, InertialChange

__all__ = ["NOT_COMPENSATED", "Compensation", "load_compensation"]

#: Effects of a recording that a live, causal model cannot undo.
NOT_COMPENSATED = ("delay", "acceleration_noise")


class Compensation:
    """The compensated model: ``arm`` with the inertial effects applied, plus :meth:`torque`."""

    def __init__(self, arm: ArmModel, effects: tuple[Effect, ...]) -> None:
        for effect in effects:
            if isinstance(effect, InertialChange):
                arm = effect.apply_to(arm)
        self.arm = arm
        self.effects = tuple(effects)
        self.additive = tuple(e for e in effects if not isinstance(e, InertialChange) and e.name not in NOT_COMPENSATED)
        self.ignored = tuple(e.name for e in effects if e.name in NOT_COMPENSATED)

    def torque(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """Σ of the additive effects' shares of the effort, N·m, shape of q; inputs (..., 7).

        Absurd parameters (a damping of 1e308) overflow to inf without a warning on stderr: the
        callers check their results (the live pipeline resets and counts it)."""
        out = np.zeros(np.shape(q))
        with np.errstate(over="ignore", invalid="ignore"):
            for effect in self.additive:
                out += effect.torque(self.arm, q, qd, qdd)
        return out


def load_compensation(arm: ArmModel, path: str | os.PathLike[str]) -> Compensation:
    """The compensation of an effects file (``effects:`` section; an ``arm:`` entry must match)."""
    raw: dict[str, Any] = read_spec_file(path)
    side = raw.get("arm")
    if side is not None and side != arm.side:
        raise EffectSpecError(f"{path}: effects identified on the {side} arm, but the model is of the {arm.side} arm")
    if "effects" not in raw:
        raise EffectSpecError(f"{path}: no 'effects' section; write effects: {{name: {{parameter: value}}}}")
    return Compensation(arm, effects_from_dict(raw["effects"], f"{path}: effects"))
