"""Identified effects as a correction of the model, sample by sample (the node's ``effects_file``).

An effects file written by ``baxter-dynamics diagnose`` (``effects.yaml``) lists the effects the
diagnosis selected, with their fitted parameters. :class:`Compensation` turns them into the model the
node uses in place of the rigid body:

- ``payload`` and ``inertial_error`` change the links' inertials: they are applied to the arm model
  once (a new :class:`~baxter_dynamics_ros.core.arm_model.ArmModel`), so τ and G come from the core as before;
- ``torque_offset``, the frictions, ``s1_spring`` and ``armature`` add their share of the effort,
  computed from q, q̇ and the estimated q̈ of the same sample;
- ``dahl_friction`` adds F ⊙ z, z its state, which depends on each joint's motion since its last
  reversal: the caller keeps that history and passes z — along a recording
  :meth:`Compensation.presliding_state`, live a :meth:`Compensation.presliding_tracker` fed every
  sample (the node's pipeline and observer each keep one, started afresh with them). A state given
  without its history (a query of the node's services) is taken as steady sliding, z = sign(q̇);
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
from .effects import DahlFriction, Effect, InertialChange, PreslidingTracker
from .plausibility import PLAUSIBLE_FACTOR, first_beyond_plausible_effort

__all__ = ["NOT_COMPENSATED", "PLAUSIBILITY_STATES", "PLAUSIBLE_QDD_RAD_S2", "Compensation", "load_compensation", "require_plausible"]

#: Effects of the recording, not of the arm, which the compensated model does not undo.
NOT_COMPENSATED = ("delay", "acceleration_noise")


class Compensation:
    """The compensated model: ``arm`` with the inertial effects applied, plus :meth:`torque`."""

    def __init__(self, arm: ArmModel, effects: tuple[Effect, ...]) -> None:
        for effect in effects:
            if isinstance(effect, InertialChange):
                arm = effect.apply_to(arm)
        self.arm = arm
        self.effects = tuple(effects)
        #: Dahl's friction, whose share needs the motion's history (None without it).
        self.presliding: DahlFriction | None = next((e for e in effects if isinstance(e, DahlFriction)), None)
        self.additive = tuple(
            e for e in effects if not isinstance(e, (InertialChange, DahlFriction)) and e.name not in NOT_COMPENSATED
        )
        self.ignored = tuple(e.name for e in effects if e.name in NOT_COMPENSATED)

    def torque(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, presliding: np.ndarray | None = None) -> np.ndarray:
        """Σ of the additive effects' shares of the effort, N·m, shape of q; inputs (..., 7).

        presliding: Dahl's state z (..., 7) of these samples (:meth:`presliding_state`, or a
        :meth:`presliding_tracker`'s); None takes steady sliding, z = sign(q̇). Absurd parameters
        (a damping of 1e308) overflow to inf without a warning on stderr: the callers check their
        results (the live pipeline resets and counts it)."""
        out = np.zeros(np.shape(q))
        with np.errstate(over="ignore", invalid="ignore"):
            for effect in self.additive:
                out += effect.torque(self.arm, q, qd, qdd)
            if self.presliding is not None:
                out += self.presliding.friction_nm * (np.sign(qd) if presliding is None else presliding)
        return out

    def presliding_state(self, qd: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray | None:
        """Dahl's state z (N, 7) along a time series q̇ (N, 7) rad/s at stamps_ns (N,), ns, from z = 0
        (None without ``dahl_friction``); the numbers of a :meth:`presliding_tracker` fed those samples."""
        if self.presliding is None:
            return None
        qd = np.asarray(qd, dtype=np.float64)
        if len(qd) < 2:
            return np.zeros(qd.shape)
        stamps_s = (np.asarray(stamps_ns, dtype=np.int64) - int(stamps_ns[0])) * 1e-9
        return self.presliding.state(qd, stamps_s)

    def presliding_tracker(self) -> PreslidingTracker | None:
        """A new live tracker of Dahl's state, from z = 0 (None without ``dahl_friction``)."""
        return None if self.presliding is None else PreslidingTracker(self.presliding.presliding_rad)


def load_compensation(arm: ArmModel, path: str | os.PathLike[str]) -> Compensation:
    """The compensation of an effects file (``effects:`` section; an ``arm:`` entry must match)."""
    raw: dict[str, Any] = read_spec_file(path)
    side = raw.get("arm")
    if side is not None and side != arm.side:
        raise EffectSpecError(f"{path}: effects identified on the {side} arm, but the model is of the {arm.side} arm")
    if "effects" not in raw:
        raise EffectSpecError(f"{path}: no 'effects' section; write effects: {{name: {{parameter: value}}}}")
    compensation = Compensation(arm, effects_from_dict(raw["effects"], f"{path}: effects"))
    require_plausible(compensation, str(path))
    return compensation


#: States the effects are checked at (:func:`require_plausible`): this many, drawn once (seed 0)
#: within the joint limits, at speeds up to the velocity limits and |q̈| up to PLAUSIBLE_QDD_RAD_S2.
PLAUSIBILITY_STATES = 512
#: The largest |q̈| of those states, rad/s² (that of the Pinocchio cross-checks; the arm's own
#: motions stay below).
PLAUSIBLE_QDD_RAD_S2 = 5.0


def require_plausible(compensation: Compensation, where: str) -> None:
    """Refuse (EffectSpecError) effects under which the model's torque τ + Σ shares leaves the
    plausible effort (:data:`~.plausibility.PLAUSIBLE_FACTOR` × the effort limit, the largest effort a
    real Baxter gives, :mod:`.plausibility`) somewhere within the joint and velocity limits: such
    parameters describe no Baxter (the example effects reach at most 0.6 × the limit, at s1), and
    compensating them would swamp every residual. Checked at :data:`PLAUSIBILITY_STATES` states."""
    arm = compensation.arm
    rng = np.random.default_rng(0)
    shape = (PLAUSIBILITY_STATES, len(arm.joint_names))
    q = arm.lower_rad + (arm.upper_rad - arm.lower_rad) * rng.random(shape)
    qd = arm.velocity_limit_rad_s * (2.0 * rng.random(shape) - 1.0)
    qdd = PLAUSIBLE_QDD_RAD_S2 * (2.0 * rng.random(shape) - 1.0)
    with np.errstate(over="ignore", invalid="ignore"):
        tau = np.abs(arm.inverse_dynamics(q, qd, qdd) + compensation.torque(q, qd, qdd)).max(axis=0)
    beyond = first_beyond_plausible_effort(arm, tau)
    if beyond is not None:
        j, bound = beyond
        raise EffectSpecError(
            f"{where}: with these effects the model's torque at {arm.joint_names[j]} reaches {tau[j]:.3g} N·m within the "
            f"joint and velocity limits, above {bound:g} N·m ({PLAUSIBLE_FACTOR:g} × its effort limit, more than a real "
            "Baxter gives); check the effects' parameters and units (baxter-dynamics diagnose writes plausible ones)"
        )
