"""Unmodelled effects: what a real Baxter adds to the rigid-body torque of eq. (1).

Each effect is a small frozen dataclass of its parameters (units in the field names) with

- ``torque(arm, q, qd, qdd, *, stamps_s=None)`` → (..., 7) N·m: the effect's **share of the recorded
  effort**. The sign convention is one rule for every effect::

      recorded effort = τ_rigid(q, q̇, q̈) + Σ_effects effect.torque(arm, q, q̇, q̈)

  where τ_rigid = M q̈ + C + G of the nominal ``arm``. Friction therefore has the sign of q̇ (the
  actuators must overcome it), armature the sign of q̈, a payload adds its own M q̈ + C + G.
- ``regressor(...)`` → (..., 7, p) and ``parameter_vector(arm)`` → (p,) with
  ``torque ≈ regressor @ parameter_vector(arm)``: exact for the effects linear in their parameters
  (offsets, friction coefficients at a fixed velocity scale, spring coefficients, inertial
  parameters, armature), first order in the delay, a unit scale for ``acceleration_noise``.
  ``parameter_names()`` labels the p columns.
- ``from_dict`` / ``to_dict`` for YAML and JSON (the files: :mod:`.effect_specs`).

The s1 gravity-assist spring
    Baxter's two external springs act on s1 and hold part of the arm's weight. The actuators
    therefore transmit τ_rigid − τ_spring, where τ_spring (:meth:`S1Spring.holding_torque`) is the
    torque the spring applies in the joint's positive direction; it has the sign of G_s1 (G_s1 =
    −52.9 N·m at q = 0, the arm pulled down, q_s1 < 0 raising it). The spring's share of the
    recorded effort, ``S1Spring.torque``, is −τ_spring: about +30 N·m at q_s1 = 0, falling as the
    arm rises — the positive s1 residual of the real recordings in ``../shared/data/baxter_real``
    (+37 N·m extrapolated to q_s1 = 0, +5 N·m at q_s1 = −1.3).

Measurement effects (``torque_offset``, ``delay``, ``acceleration_noise``) change what is recorded,
not how the arm moves; the others act on the arm (see :mod:`baxter_dynamics_ros.simulation.plant`).

The friction and spring laws are numba ufuncs, so that the simulator's compiled loop and these
numpy methods evaluate the very same expressions.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numba import njit, vectorize

from ..errors import EffectSpecError
from . import lagrange_euler
from .acceleration import zero_phase_acceleration
from .arm_model import ArmModel, LinkInertial, link_from_parameters, link_parameters
from .joints import JOINT_SUFFIXES, S1
from .joints import JOINTS as N

__all__ = [
    "EFFECTS",
    "INERTIAL_PARAMETERS",
    "AccelerationNoise",
    "Armature",
    "CoulombFriction",
    "DahlFriction",
    "Delay",
    "Effect",
    "InertialChange",
    "InertialError",
    "Payload",
    "PreslidingTracker",
    "S1Spring",
    "StribeckFriction",
    "TorqueGain",
    "TorqueOffset",
    "ViscousFriction",
    "friction_law",
    "presliding_state",
    "s1_spring_law",
    "total_torque",
]


#: Names of a link's 10 inertial parameters, in the order of the core's
#: :func:`~baxter_dynamics_ros.core.arm_model.link_parameters` and ``ArmModel.inertial_regressor``: mass
#: (kg), first moments m·c (kg·m), inertia tensor about the DH frame's origin (kg·m²).
INERTIAL_PARAMETERS = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


# ----------------------------------------------------------------------------- shared laws (numba ufuncs)
@vectorize(["float64(float64, float64, float64, float64, float64)"], cache=True)
def friction_law(qd, coulomb_nm, static_nm, stribeck_rad_s, smoothing_rad_s):
    """Friction share of the effort, N·m: (F_c + (F_s − F_c)·exp(−(q̇/v_s)²))·tanh(q̇/v_ε).

    Coulomb friction is the case F_s = F_c. tanh(q̇/v_ε) is a smooth sign(q̇) (v_ε in rad/s).
    """
    bump = (static_nm - coulomb_nm) * np.exp(-((qd / stribeck_rad_s) ** 2))
    return (coulomb_nm + bump) * np.tanh(qd / smoothing_rad_s)


@njit(cache=True)
def _presliding_step(state, step_rad, presliding_rad):
    """Dahl's state after turning step_rad (rad) from state: towards sign(step) by exp(−|step|/θ_p)."""
    if step_rad == 0.0:
        return state
    target = 1.0 if step_rad > 0.0 else -1.0
    return target + (state - target) * np.exp(-abs(step_rad) / presliding_rad)


@njit(cache=True)
def presliding_state(qd, stamps_s, presliding_rad):
    """Dahl's friction state z (n, 7) in [−1, 1] along a time series: after each reversal z moves
    towards sign(Δθ) as 1 − exp(−|Δθ|/θ_p) of the angle Δθ turned since, exactly for a monotone
    step; Δθ of a step the trapezoid of q̇ (n, 7) rad/s over stamps_s (n,) s; z = 0 at the start."""
    n, joints = qd.shape
    z = np.zeros((n, joints))
    for j in range(joints):
        state = 0.0
        for k in range(1, n):
            state = _presliding_step(state, 0.5 * (qd[k, j] + qd[k - 1, j]) * (stamps_s[k] - stamps_s[k - 1]), presliding_rad)
            z[k, j] = state
    return z


@njit(cache=True)
def _presliding_advance(z, qd_before, qd, dt_s, presliding_rad):
    """:func:`presliding_state`'s step for one new sample, z (7,) in place."""
    for j in range(z.shape[0]):
        z[j] = _presliding_step(z[j], 0.5 * (qd[j] + qd_before[j]) * dt_s, presliding_rad)


class PreslidingTracker:
    """Dahl's state z (7,) of a live stream of samples, one at a time: the numbers of
    :func:`presliding_state` over the samples since the last :meth:`reset` (z = 0 there)."""

    def __init__(self, presliding_rad: float) -> None:
        self.presliding_rad = float(presliding_rad)
        self.reset()

    def reset(self) -> None:
        """Forget the motion: the next sample starts from z = 0."""
        self._z = np.zeros(N)
        self._qd: np.ndarray | None = None

    def update(self, qd: np.ndarray, dt_s: float) -> np.ndarray:
        """z (7,) after a sample with q̇ (7,) rad/s, dt_s s after the last one (a copy)."""
        if self._qd is not None:
            _presliding_advance(self._z, self._qd, np.asarray(qd, dtype=np.float64), float(dt_s), self.presliding_rad)
        self._qd = np.array(qd, dtype=np.float64)
        return self._z.copy()


@vectorize(["float64(float64, float64, float64, float64, float64)"], cache=True)
def s1_spring_law(q_s1, preload_nm, linear_nm_rad, cosine_nm, sine_nm):
    """The s1 spring's share of the effort, N·m: preload + linear·q_s1 + cosine·cos(q_s1) + sine·sin(q_s1)."""
    return preload_nm + linear_nm_rad * q_s1 + cosine_nm * np.cos(q_s1) + sine_nm * np.sin(q_s1)


# ----------------------------------------------------------------------------- parameter fields
def _param(kind: str, default: Any = dataclasses.MISSING, *, minimum: float | None = None, strict: bool = False, fill: float = 0.0):
    """A dataclass field holding a parameter: kind "joint" (7,), "vector3" (3,), "tensor" (6,: a
    symmetric 3×3 tensor's xx xy xz yy yz zz), "links" (70,: 10 inertial parameters per link) or "scalar".

    minimum: lower bound (exclusive when strict); fill: the value of joints a mapping leaves out.
    """
    meta = {"kind": kind, "minimum": minimum, "strict": strict, "fill": fill}
    return dataclasses.field(default=default, metadata=meta)


def _normalise(value: Any, meta: Mapping[str, Any], where: str) -> float | np.ndarray:
    """A parameter as float or read-only array of its kind, validated; raises EffectSpecError."""
    kind = meta["kind"]
    if kind == "joint" and isinstance(value, Mapping):
        unknown = set(value) - set(JOINT_SUFFIXES)
        if unknown:
            raise EffectSpecError(f"{where}: unknown joints {sorted(unknown)}; use {', '.join(JOINT_SUFFIXES)}")
        value = [value.get(j, meta["fill"]) for j in JOINT_SUFFIXES]
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise EffectSpecError(f"{where}: expected numbers, got {value!r}") from err
    shape = {"joint": (N,), "vector3": (3,), "tensor": (6,), "links": (10 * N,), "scalar": ()}[kind]
    if kind == "joint" and arr.shape == ():
        arr = np.full(N, float(arr))
    if arr.shape != shape:
        hint = {
            "joint": "a number, a list of 7 or a mapping like {s1: 1.0}",
            "vector3": "a list of 3",
            "tensor": "a list of 6 (xx, xy, xz, yy, yz, zz)",
            "links": "a list of 70 (10 inertial parameters per link)",
            "scalar": "a number",
        }
        raise EffectSpecError(f"{where}: expected {hint[kind]}, got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise EffectSpecError(f"{where}: non-finite value in {arr.tolist()}")
    low, strict = meta["minimum"], meta["strict"]
    if low is not None and np.any(arr <= low if strict else arr < low):
        raise EffectSpecError(f"{where}: must be {'>' if strict else '>='} {low}, got {arr.tolist()}")
    if kind == "scalar":
        return float(arr)
    arr.flags.writeable = False
    return arr


def _batch(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> tuple[list[np.ndarray], tuple[int, ...]]:
    """(…, 7) q, q̇, q̈ as (M, 7) arrays and the leading shape (the core's shape check)."""
    return lagrange_euler.as_batches(q=q, qd=qd, qdd=qdd)


def _series(stamps_s: np.ndarray | None, values: np.ndarray, effect: str) -> np.ndarray:
    """Checked sample times (N,) s of a time series values (N, 7); effects that need time call this."""
    if stamps_s is None or values.ndim != 2:
        raise EffectSpecError(f"{effect}: needs a time series, (N, 7) inputs and their stamps_s (N,) in s")
    t = np.asarray(stamps_s, dtype=np.float64)
    n = len(values)
    if t.shape != (n,) or n < 2 or np.any(np.diff(t) <= 0):
        raise EffectSpecError(f"{effect}: stamps_s must be ({n},) strictly increasing, got shape {t.shape}")
    return t


def _diagonal(values: np.ndarray) -> np.ndarray:
    """(M, 7) per-joint columns → (M, 7, 7) regressor, column j acting on joint j only."""
    out = np.zeros(values.shape + (N,))
    idx = np.arange(N)
    out[:, idx, idx] = values
    return out


def _joint_labels(field: str) -> tuple[str, ...]:
    return tuple(f"{field}[{j}]" for j in JOINT_SUFFIXES)


# ----------------------------------------------------------------------------- base class
@dataclass(frozen=True, eq=False)
class Effect:
    """Base of the effects: parameter validation, dict round trip, equality by parameters."""

    name: ClassVar[str] = ""
    #: True when the effect changes what is recorded rather than how the arm moves.
    measurement: ClassVar[bool] = False

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            where = f"{self.name}.{f.name}"
            object.__setattr__(self, f.name, _normalise(getattr(self, f.name), f.metadata, where))

    @classmethod
    def from_dict(cls, raw: Any, where: str = "") -> Effect:
        """The effect from a mapping of its parameters (missing ones take their defaults)."""
        where = where or cls.name
        if raw is None:
            raw = {}
        if not isinstance(raw, Mapping):
            raise EffectSpecError(f"{where}: expected a mapping of parameters, got {raw!r}")
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = set(raw) - set(names)
        if unknown:
            raise EffectSpecError(f"{where}: unknown parameters {sorted(unknown)}; {cls.name} takes {', '.join(names)}")
        missing = [
            f.name
            for f in dataclasses.fields(cls)
            if f.default is dataclasses.MISSING and f.name not in raw
        ]
        if missing:
            raise EffectSpecError(f"{where}: missing parameters {', '.join(missing)}")
        return cls(**{k: raw[k] for k in names if k in raw})

    def to_dict(self) -> dict[str, float | list[float]]:
        """Plain floats and lists, for YAML and JSON."""
        out: dict[str, float | list[float]] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            out[f.name] = value.tolist() if isinstance(value, np.ndarray) else value
        return out

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self) and other.to_dict() == self.to_dict()

    __hash__ = None  # type: ignore[assignment]

    # -- to be provided by each effect
    def torque(self, arm: ArmModel, q, qd, qdd, *, stamps_s=None) -> np.ndarray:
        """The effect's share of the recorded effort, N·m, shape of q (module docstring)."""
        raise NotImplementedError

    def regressor(self, arm: ArmModel, q, qd, qdd, *, stamps_s=None) -> np.ndarray:
        """(…, 7, p): torque ≈ regressor @ parameter_vector(arm)."""
        raise NotImplementedError

    def parameter_vector(self, arm: ArmModel) -> np.ndarray:
        """(p,) the parameters the regressor multiplies (inertial ones are relative to ``arm``)."""
        raise NotImplementedError

    def parameter_names(self) -> tuple[str, ...]:
        """(p,) labels of the regressor columns, e.g. ``damping_nm_s_rad[s1]``."""
        raise NotImplementedError

    def parameter_lower_bounds(self) -> np.ndarray:
        """(p,) lower bound of each parameter of :meth:`parameter_vector`: its field's ``minimum``
        (the next float above it where the bound is strict), −inf where the field has none or the
        parameter is no field of its own (an inertial change's link parameters)."""
        meta = {f.name: f.metadata for f in dataclasses.fields(self)}
        out = []
        for label in self.parameter_names():
            m = meta.get(label.split("[", 1)[0], {})
            low = m.get("minimum")
            if low is None:
                out.append(-np.inf)
            else:
                out.append(float(np.nextafter(low, np.inf)) if m["strict"] else float(low))
        return np.array(out)


# ----------------------------------------------------------------------------- the effects
@dataclass(frozen=True, eq=False)
class TorqueOffset(Effect):
    """A constant offset of each joint's torque sensor: torque = offset_nm (7,), N·m."""

    name: ClassVar[str] = "torque_offset"
    measurement: ClassVar[bool] = True
    offset_nm: np.ndarray = _param("joint")

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (q2, _, _), lead = _batch(q, qd, qdd)
        return np.broadcast_to(self.offset_nm, q2.shape).reshape(lead + (N,)).copy()

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (q2, _, _), lead = _batch(q, qd, qdd)
        return _diagonal(np.ones_like(q2)).reshape(lead + (N, N))

    def parameter_vector(self, arm):
        return self.offset_nm.copy()

    def parameter_names(self):
        return _joint_labels("offset_nm")


@dataclass(frozen=True, eq=False)
class ViscousFriction(Effect):
    """Viscous friction: torque = damping_nm_s_rad (7,) ⊙ q̇, N·m."""

    name: ClassVar[str] = "viscous_friction"
    damping_nm_s_rad: np.ndarray = _param("joint", minimum=0.0)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, qd2, _), lead = _batch(q, qd, qdd)
        return (self.damping_nm_s_rad * qd2).reshape(lead + (N,))

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, qd2, _), lead = _batch(q, qd, qdd)
        return _diagonal(qd2).reshape(lead + (N, N))

    def parameter_vector(self, arm):
        return self.damping_nm_s_rad.copy()

    def parameter_names(self):
        return _joint_labels("damping_nm_s_rad")


@dataclass(frozen=True, eq=False)
class CoulombFriction(Effect):
    """Coulomb friction: torque = friction_nm (7,) ⊙ tanh(q̇ / smoothing_rad_s), N·m.

    smoothing_rad_s (default 0.05) smooths sign(q̇) so that an explicit integrator can step
    through velocity reversals; the simulator checks the resulting stiffness against its step.
    """

    name: ClassVar[str] = "coulomb_friction"
    friction_nm: np.ndarray = _param("joint", minimum=0.0)
    smoothing_rad_s: float = _param("scalar", 0.05, minimum=0.0, strict=True)

    def _sign(self, qd2: np.ndarray) -> np.ndarray:
        return np.tanh(qd2 / self.smoothing_rad_s)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, qd2, _), lead = _batch(q, qd, qdd)
        fc = self.friction_nm
        return friction_law(qd2, fc, fc, 1.0, self.smoothing_rad_s).reshape(lead + (N,))

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, qd2, _), lead = _batch(q, qd, qdd)
        return _diagonal(self._sign(qd2)).reshape(lead + (N, N))

    def parameter_vector(self, arm):
        return self.friction_nm.copy()

    def parameter_names(self):
        return _joint_labels("friction_nm")


@dataclass(frozen=True, eq=False)
class StribeckFriction(Effect):
    """Stribeck friction: torque = (F_c + (F_s − F_c)·exp(−(q̇/v_s)²))·tanh(q̇/v_ε), N·m per joint.

    coulomb_nm F_c (7,) and static_nm F_s (7,): the sliding and breakaway friction; v_s =
    stribeck_rad_s (default 0.1) the velocity scale of the fall from F_s to F_c; v_ε =
    smoothing_rad_s (default 0.02) the smooth sign. Linear in (F_c, F_s) for fixed v_s, v_ε.
    """

    name: ClassVar[str] = "stribeck_friction"
    coulomb_nm: np.ndarray = _param("joint", minimum=0.0)
    static_nm: np.ndarray = _param("joint", minimum=0.0)
    stribeck_rad_s: float = _param("scalar", 0.1, minimum=0.0, strict=True)
    smoothing_rad_s: float = _param("scalar", 0.02, minimum=0.0, strict=True)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, qd2, _), lead = _batch(q, qd, qdd)
        law = friction_law(qd2, self.coulomb_nm, self.static_nm, self.stribeck_rad_s, self.smoothing_rad_s)
        return law.reshape(lead + (N,))

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, qd2, _), lead = _batch(q, qd, qdd)
        bump = np.exp(-((qd2 / self.stribeck_rad_s) ** 2))
        sign = np.tanh(qd2 / self.smoothing_rad_s)
        cols = np.concatenate([_diagonal((1.0 - bump) * sign), _diagonal(bump * sign)], axis=2)
        return cols.reshape(lead + (N, 2 * N))

    def parameter_vector(self, arm):
        return np.concatenate([self.coulomb_nm, self.static_nm])

    def parameter_names(self):
        return _joint_labels("coulomb_nm") + _joint_labels("static_nm")


@dataclass(frozen=True, eq=False)
class DahlFriction(Effect):
    """Friction with presliding hysteresis (Dahl's model): torque = friction_nm (7,) ⊙ z, N·m, z the
    state of :func:`presliding_state`, which after each reversal of a joint builds up from the
    opposite sign over a presliding angle presliding_rad θ_p (rad) instead of switching at once.

    Coulomb friction is its limit θ_p → 0. Over small oscillations (amplitude below θ_p) it acts as
    a stiffness F/θ_p in phase with the displacement: seen at one frequency, a negative armature.
    Needs a time series (stamps_s); linear in friction_nm for a fixed θ_p.
    """

    name: ClassVar[str] = "dahl_friction"
    friction_nm: np.ndarray = _param("joint", minimum=0.0)
    presliding_rad: float = _param("scalar", 0.02, minimum=0.0, strict=True)

    def state(self, qd: np.ndarray, stamps_s: np.ndarray | None) -> np.ndarray:
        """(N, 7) the friction state z along a time series q̇ (N, 7) rad/s at stamps_s (N,) s."""
        qd = np.asarray(qd, dtype=np.float64)
        t = _series(stamps_s, qd, self.name)
        return presliding_state(np.ascontiguousarray(qd), t, self.presliding_rad)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        return self.state(qd, stamps_s) * self.friction_nm

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        return _diagonal(self.state(qd, stamps_s))

    def parameter_vector(self, arm):
        return self.friction_nm.copy()

    def parameter_names(self):
        return _joint_labels("friction_nm")


@dataclass(frozen=True, eq=False)
class S1Spring(Effect):
    """Baxter's s1 gravity-assist spring; share of the effort on s1 only, N·m:

        torque_s1 = preload_nm + linear_nm_rad·q_s1 + cosine_nm·cos(q_s1) + sine_nm·sin(q_s1)

    The spring's torque is its force times its moment arm about s1, and Baxter's springs reach the
    s1 link through a linkage whose geometry is not the same on every unit. Two limiting mechanisms
    span it: a spring pulling a lever (anchored at distance a from the axis, lever length r) gives
    k·a·r·sin(q_s1 − q_a) — the cosine and sine terms, amplitude k·a·r and phase q_a (exact for a
    zero free length); a spring acting through a cable on a cam or pulley of radius ρ stretches by
    ρ·q_s1 at a constant moment arm, so Hooke's law gives a torque linear in q_s1 — the linear term
    k·ρ². The preload stands for the free length and the pretension. Four coefficients, linear:
    the regressor on s1 is [1, q_s1, cos q_s1, sin q_s1]. Over the ~1.5 rad that s1 spans in use, a
    spring of either kind, and of a free length between them, is fitted to within the effort's
    noise on the two real units of ``../shared/data`` (docs/real_robot_diagnosis.md); a sinusoid
    alone left twice the plain fit's held-out s1 error on the second unit.
    The defaults (25, 0, 5, 20) give 30 N·m at q_s1 = 0, 20 N·m at −0.5, 11 N·m at −1.0 (arm up)
    and 44 N·m at +1.0 (arm down): the real recordings' s1 residual (≈ 37.5 + 24.5·q_s1 N·m on
    q_s1 ∈ [−1.5, 0]) scaled to 30 N·m at q_s1 = 0. :meth:`holding_torque` is the spring's
    own torque, −torque (module docstring).
    """

    name: ClassVar[str] = "s1_spring"
    preload_nm: float = _param("scalar", 25.0)
    linear_nm_rad: float = _param("scalar", 0.0)
    cosine_nm: float = _param("scalar", 5.0)
    sine_nm: float = _param("scalar", 20.0)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (q2, _, _), lead = _batch(q, qd, qdd)
        out = np.zeros_like(q2)
        out[:, S1] = s1_spring_law(q2[:, S1], self.preload_nm, self.linear_nm_rad, self.cosine_nm, self.sine_nm)
        return out.reshape(lead + (N,))

    def holding_torque(self, arm, q, qd, qdd, *, stamps_s=None) -> np.ndarray:
        """τ_spring, N·m: the torque the spring applies, sign of G_s1; the actuators transmit τ_rigid − τ_spring."""
        return -self.torque(arm, q, qd, qdd)

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (q2, _, _), lead = _batch(q, qd, qdd)
        out = np.zeros(q2.shape + (4,))
        q_s1 = q2[:, S1]
        out[:, S1] = np.stack([np.ones(len(q2)), q_s1, np.cos(q_s1), np.sin(q_s1)], axis=1)
        return out.reshape(lead + (N, 4))

    def parameter_vector(self, arm):
        return np.array([self.preload_nm, self.linear_nm_rad, self.cosine_nm, self.sine_nm])

    def parameter_names(self):
        return ("preload_nm", "linear_nm_rad", "cosine_nm", "sine_nm")


class InertialChange:
    """Mixin of the effects that change link inertials: torque through the core from ΔJ."""

    def apply_to(self, arm: ArmModel) -> ArmModel:
        """The arm with the change made (a new ArmModel)."""
        raise NotImplementedError

    def pseudo_inertia_change(self, arm: ArmModel) -> np.ndarray:
        """ΔJ (7, 4, 4): the changed arm's pseudo-inertias minus the arm's."""
        return self.apply_to(arm).pseudo_inertias - arm.pseudo_inertias

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        # eq. (5) is linear in the pseudo-inertias: τ(J + ΔJ) − τ(J) = τ(ΔJ), gravity included.
        return lagrange_euler.inverse_dynamics(arm.dh, self.pseudo_inertia_change(arm), arm.gravity_m_s2, q, qd, qdd)


@dataclass(frozen=True, eq=False)
class Payload(InertialChange, Effect):
    """A load held in the hand, rigidly fixed to the flange (DH frame 7).

    mass_kg; com_m (3,) its centre of mass in the flange frame (z along the w2 axis, away from
    the arm), m; size_m (3,) the edges of a solid box along the flange axes, m (0 = a point mass);
    inertia_kgm2 (6,: xx xy xz yy yz zz) a further inertia tensor about the centre of mass, kg·m²
    (what ``diagnose`` fits; added to the box's). The total tensor must be physical (positive
    semi-definite, each principal moment at most the sum of the other two).
    Its torque is the core's M q̈ + C + G of the load alone; the regressor is the core's
    inertial regressor of link 7 (10 columns, :data:`INERTIAL_PARAMETERS`), linear in the load's.
    """

    name: ClassVar[str] = "payload"
    mass_kg: float = _param("scalar", minimum=0.0, strict=True)
    com_m: np.ndarray = _param("vector3", (0.0, 0.0, 0.0))
    size_m: np.ndarray = _param("vector3", (0.0, 0.0, 0.0), minimum=0.0)
    inertia_kgm2: np.ndarray = _param("tensor", (0.0,) * 6)

    def __post_init__(self) -> None:
        super().__post_init__()
        moments = np.linalg.eigvalsh(self.link().inertia_kgm2)
        tol = 1e-12 + 1e-9 * float(np.max(np.abs(moments)))
        if moments[0] < -tol or 2.0 * moments[-1] > moments.sum() + tol:
            raise EffectSpecError(
                f"payload.inertia_kgm2: the load's tensor about its centre of mass has principal moments "
                f"{moments.tolist()} kg·m²; a physical body has them >= 0, each at most the sum of the other two"
            )

    def link(self) -> LinkInertial:
        """The load as a link inertial in the flange frame (box inertia + inertia_kgm2, about its centre)."""
        a, b, c = self.size_m**2
        xx, xy, xz, yy, yz, zz = self.inertia_kgm2
        extra = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        inertia = self.mass_kg / 12.0 * np.diag([b + c, a + c, a + b]) + extra
        return LinkInertial(name="payload", mass_kg=self.mass_kg, com_m=np.array(self.com_m), inertia_kgm2=inertia)

    def apply_to(self, arm: ArmModel) -> ArmModel:
        hand = arm.links[-1]
        # Inertial parameters about the frame origin add up: hand + load = one rigid link 7.
        merged = link_from_parameters(f"{hand.name}+payload", link_parameters(hand) + link_parameters(self.link()))
        return dataclasses.replace(arm, links=arm.links[:-1] + (merged,))

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        return arm.inertial_regressor(q, qd, qdd)[..., 10 * (N - 1) :]

    def parameter_vector(self, arm):
        return link_parameters(self.link())

    def parameter_names(self):
        return tuple(f"link7.{p}" for p in INERTIAL_PARAMETERS)


@dataclass(frozen=True, eq=False)
class InertialError(InertialChange, Effect):
    """Errors of the model's link inertials: each link's mass × mass_scale (7,) and centre of
    mass × com_scale (7,) (componentwise, in its DH frame); the inertia tensor about the centre of
    mass scales with the mass. Scales default to 1 (no error). Then parameter_change (70,), the
    change of each link's 10 inertial parameters (:data:`INERTIAL_PARAMETERS`, link by link) that
    the diagnosis fits, is added (default zeros). The regressor is every link's 10 inertial
    parameters (the core's 70-column regressor; only combinations are identifiable)."""

    name: ClassVar[str] = "inertial_error"
    mass_scale: np.ndarray = _param("joint", 1.0, minimum=0.0, strict=True, fill=1.0)
    com_scale: np.ndarray = _param("joint", 1.0, minimum=0.0, strict=True, fill=1.0)
    parameter_change: np.ndarray = _param("links", (0.0,) * (10 * N))

    def apply_to(self, arm: ArmModel) -> ArmModel:
        links = tuple(
            link_from_parameters(
                link.name,
                link_parameters(LinkInertial(link.name, float(link.mass_kg * sm), link.com_m * sc, link.inertia_kgm2 * sm))
                + self.parameter_change[10 * i : 10 * i + 10],
            )
            for i, (link, sm, sc) in enumerate(zip(arm.links, self.mass_scale, self.com_scale))
        )
        return dataclasses.replace(arm, links=links)

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        return arm.inertial_regressor(q, qd, qdd)

    def parameter_vector(self, arm):
        return self.apply_to(arm).inertial_parameters - arm.inertial_parameters

    def parameter_names(self):
        return tuple(f"link{i + 1}.{p}" for i in range(N) for p in INERTIAL_PARAMETERS)


@dataclass(frozen=True, eq=False)
class Armature(Effect):
    """Rotor (armature) inertia reflected to each joint: torque = inertia_kgm2 (7,) ⊙ q̈, N·m."""

    name: ClassVar[str] = "armature"
    inertia_kgm2: np.ndarray = _param("joint", minimum=0.0)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, _, qdd2), lead = _batch(q, qd, qdd)
        return (self.inertia_kgm2 * qdd2).reshape(lead + (N,))

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (_, _, qdd2), lead = _batch(q, qd, qdd)
        return _diagonal(qdd2).reshape(lead + (N, N))

    def parameter_vector(self, arm):
        return self.inertia_kgm2.copy()

    def parameter_names(self):
        return _joint_labels("inertia_kgm2")


@dataclass(frozen=True, eq=False)
class Delay(Effect):
    """Each joint's effort is stamped delay_s (7,) seconds late: recorded effort_j(t) = effort_j(t − d_j).

    A negative d_j is an effort that leads the joint state (the real recordings' effort leads it by
    about 12 ms). Its share, for a time series: τ_rigid,j(t − d_j) − τ_rigid,j(t) (linear
    interpolation between samples, the end samples held beyond the ends); regressor −dτ_rigid,j/dt
    on joint j (first order in d_j). In the simulator each joint's whole transmitted effort is
    delayed, effects included, causally (d_j ≥ 0 there).
    """

    name: ClassVar[str] = "delay"
    measurement: ClassVar[bool] = True
    delay_s: np.ndarray = _param("joint")

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        tau = arm.inverse_dynamics(q, qd, qdd)
        t = _series(stamps_s, tau, self.name)
        late = np.stack([np.interp(t - self.delay_s[j], t, tau[:, j]) for j in range(N)], axis=1)
        return late - tau

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        tau = arm.inverse_dynamics(q, qd, qdd)
        t = _series(stamps_s, tau, self.name)
        return _diagonal(-np.gradient(tau, t, axis=0))

    def parameter_vector(self, arm):
        return self.delay_s.copy()

    def parameter_names(self):
        return _joint_labels("delay_s")


@dataclass(frozen=True, eq=False)
class TorqueGain(Effect):
    """Each joint's torque sensor reads (1 + gain_j) times the torque, gain (7,) dimensionless:
    recorded effort_j = (1 + g_j)·effort_j.

    A series-elastic actuator (Baxter's) measures its torque as its spring's deflection times the
    stiffness it was calibrated with; an error of that stiffness is a gain on everything the joint
    transmits — inertial, Coriolis and gravity torque alike — unlike a change of the arm's inertia,
    which moves them by different factors. Share, to first order in g: g_j·τ_rigid,j; regressor
    τ_rigid,j on joint j. In the simulator the recorded effort is scaled exactly. Where a joint's
    torque is mostly gravity (s1, e1), a gain is close to a change of the links' masses, which only
    motion with large inertial torques tells apart; elsewhere a gain at one joint changes that
    joint's torque alone, a change of a link's inertia the torque of every joint that carries it.
    """

    name: ClassVar[str] = "torque_gain"
    measurement: ClassVar[bool] = True
    gain: np.ndarray = _param("joint", minimum=-1.0, strict=True)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        return self.gain * arm.inverse_dynamics(q, qd, qdd)

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        (q2, qd2, qdd2), lead = _batch(q, qd, qdd)
        return _diagonal(arm.inverse_dynamics(q2, qd2, qdd2)).reshape(lead + (N, N))

    def parameter_vector(self, arm):
        return self.gain.copy()

    def parameter_names(self):
        return _joint_labels("gain")


@dataclass(frozen=True, eq=False)
class AccelerationNoise(Effect):
    """Noise of the measured q̇, seen through the differentiated q̈.

    Simulator: white Gaussian noise of standard deviation velocity_noise_rad_s (7,) added to the
    recorded q̇. Estimator: with q̈ from raw differences of noisy q̇, the residual holds
    M(q)(q̈_smooth − q̈); its share is that term, q̈_smooth being the zero-phase estimate with a
    low-pass at cutoff_hz (default 5 Hz) on q̇. Needs stamps_s; regressor: the share (scale 1).
    """

    name: ClassVar[str] = "acceleration_noise"
    measurement: ClassVar[bool] = True
    velocity_noise_rad_s: np.ndarray = _param("joint", minimum=0.0)
    cutoff_hz: float = _param("scalar", 5.0, minimum=0.0, strict=True)

    def torque(self, arm, q, qd, qdd, *, stamps_s=None):
        (q2, qd2, qdd2), lead = _batch(q, qd, qdd)
        t = _series(stamps_s, q2.reshape(lead + (N,)), self.name)
        smooth = zero_phase_acceleration(qd2, 1.0 / float(np.median(np.diff(t))), self.cutoff_hz)
        return (arm.inverse_dynamics(q2, qd2, smooth) - arm.inverse_dynamics(q2, qd2, qdd2)).reshape(lead + (N,))

    def regressor(self, arm, q, qd, qdd, *, stamps_s=None):
        return self.torque(arm, q, qd, qdd, stamps_s=stamps_s)[..., None]

    def parameter_vector(self, arm):
        return np.array([1.0])

    def parameter_names(self):
        return ("scale",)


#: Every effect class by its name, in the order of the diagnosis issue.
EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        TorqueOffset,
        ViscousFriction,
        CoulombFriction,
        StribeckFriction,
        DahlFriction,
        S1Spring,
        Payload,
        InertialError,
        Armature,
        Delay,
        TorqueGain,
        AccelerationNoise,
    )
}


# ----------------------------------------------------------------------------- collections
def total_torque(effects: tuple[Effect, ...], arm: ArmModel, q, qd, qdd, *, stamps_s=None) -> np.ndarray:
    """Σ of the effects' shares of the recorded effort, N·m, shape of q."""
    out = np.zeros(np.shape(q))
    for effect in effects:
        out = out + effect.torque(arm, q, qd, qdd, stamps_s=stamps_s)
    return out
