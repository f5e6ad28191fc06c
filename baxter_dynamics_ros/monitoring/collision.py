"""Collision monitoring: a momentum observer, calibrated per-joint thresholds, a hysteresis detector.

Residual sign: as ``~/residual``, measured effort − model, so an external torque τ_ext acting on
the arm (M q̈ + C + G = τ_motor + τ_ext) shows as r ≈ −τ_ext.

Generalised-momentum observer (De Luca et al.), needing no q̈. With p = M(q) q̇ and the identity
ṗ = M q̈ + Ṁ q̇ = τ_motor + τ_ext + Cᵀ(q, q̇) q̇ − G(q), where Cᵀ q̇ = Ṁ q̇ − C(q, q̇) q̇:

    r(t) = K_O [ ∫₀ᵗ (τ_meas + Cᵀ q̇ − G − r) ds − (p(t) − p(0)) ],   so ṙ = K_O (d − r),

d = τ_meas − τ_rigid the unmodelled torque (= −τ_ext): r follows d through a first-order lag of
time constant 1/K_O (K_O per joint, 1/s). This is the textbook observer with the sign of r flipped
to the residual's convention. Ṁ q̇ is exact up to O(ε²): Ṁ = (M(q + ε q̇) − M(q − ε q̇)) / (2ε),
ε = :data:`MDOT_STEP_S`, from the core's ``mass_matrix``; C(q, q̇) q̇ is the core's ``coriolis``.
Discretisation, per sample k with its own Δt_k (backward Euler in r, so stable for any K_O Δt):

    I_k = I_{k−1} + (β_k − r_k) Δt_k,  β = τ_meas + Cᵀ q̇ − G,  r_k = K_O (I_k − (p_k − p_0))
    ⇒ r_k = K_O (I_{k−1} + β_k Δt_k − (p_k − p_0)) / (1 + K_O Δt_k);  r_0 = 0.

With a :class:`~baxter_dynamics_ros.core.compensation.Compensation`, the model is its ``arm`` and τ_meas
has the additive effects' share at q̈ = 0 removed (q̈-dependent shares, armature, are not).

Effort–state alignment: the recorded effort and joint state need not belong to the same instant.
``effort_delay_s`` = d says recorded effort(t) = true effort(t − d) (d > 0: the effort is late, as
the diagnosis' ``delay`` effect; d < 0: it is early, or the state late). The observer pairs the
state at t_k − a with the effort at t_k − b, a = max(d, 0), b = max(−d, 0), each by linear
interpolation between samples (the first sample held before the start), so it stays causal at the
price of |d| more detection delay; r_k is stamped t_k. :func:`estimate_effort_delay` finds d from
collision-free recordings: the d, on a grid of :data:`EFFORT_DELAY_STEP_S` over
± :data:`MAX_EFFORT_DELAY_S` refined by a parabola through the best three, that minimises the
squared r over all joints and samples. It also makes up for the discrete step (β_k Δt_k integrates
over the step ending at t_k): simulated recordings, effort and state simultaneous, give −4.9 ms at
100 Hz; the real ones −11.3 to −12.8 ms (any three of the four).

Public scheme (as in public Baxter code): r = τ_meas − τ(q, q̇, 0) against
:data:`PUBLIC_THRESHOLDS_NM`, a collision on any sample above (:func:`public_residual`,
:func:`public_detector`).

Calibration rule (:func:`calibrate_thresholds`) from collision-free observer residuals r (N, 7),
for a detector that needs ``consecutive`` = c samples in a row above: per recording and joint, every
run of c samples is summarised by its smallest |r_j| (ρ_j) and its smallest |q̇_j| (σ_j); then
a_j = margin · max ρ_j over the runs with σ_j ≤ ``slow_rad_s`` (all runs if none),
b_j = max over all runs of (margin · ρ_j − a_j) / σ_j (≥ 0; 0 when not speed dependent, then
a_j = margin · max ρ_j), and a_j raised to ``floor_nm`` at least. The threshold a_j + b_j |q̇_j| is
at least a_j + b_j σ_j ≥ margin · ρ_j on every sample of a run, so on the run's sample with |r_j| = ρ_j
it is not crossed: no calibration run of c samples is above margin · threshold throughout. With
c = 1 this is margin · |r_j| below the threshold on every calibration sample. ``consecutive`` is
stored with the thresholds and used by the detector.

Slow bias: torque-sensor offsets drift between recordings (on the real ones, w2's by 0.09 N·m
between the random-motion recording and the sinusoids, against thresholds of 0.2 N·m there). With
``bias_time_constant_s`` = T_b > 0 the detector compares r̃ = r − r̄ with the thresholds, r̄ a
first-order low-pass of r (r̄_k = r̄_{k−1} + (Δt_k/T_b)(r_{k−1} − r̄_{k−1}), r̄ = 0 at the start)
updated while the detector is off and held while it is on, so a contact never leaks into r̄. The
calibration rule then runs on the r̃ of its collision-free data (:func:`calibrate_thresholds` with
stamps; :func:`without_bias`). T_b = 0: r̃ = r.

Detector (:class:`CollisionDetector`): on when some joint's |r̃_j| > threshold_j for ≥ ``consecutive``
samples in a row; off once every |r̃_j| < ``release_fraction`` · threshold_j for ``hold_s``. The
release fraction defaults to 1 / margin, the level the calibration data stayed under: lower, and
normal motion alone keeps the detector on after a contact.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import yaml
from numba import njit

from ..core import lagrange_euler
from ..core.arm_model import ArmModel
from ..core.compensation import Compensation
from ..core.joints import JOINT_SUFFIXES
from ..core.joints import JOINTS as N
from ..core.output_files import staged_outputs
from ..core.recording import Recording
from ..core.yaml_files import read_yaml
from ..errors import CollisionError

__all__ = [
    "DEFAULT_BIAS_TIME_CONSTANT_S",
    "DEFAULT_CONSECUTIVE",
    "DEFAULT_GAIN_1_S",
    "DEFAULT_MARGIN",
    "EFFORT_DELAY_STEP_S",
    "MAX_EFFORT_DELAY_S",
    "MDOT_STEP_S",
    "PUBLIC_THRESHOLDS_NM",
    "CollisionDetector",
    "DetectorState",
    "MomentumObserver",
    "Thresholds",
    "calibrate",
    "calibrate_thresholds",
    "detect",
    "estimate_effort_delay",
    "momentum_terms",
    "observe",
    "observe_arrays",
    "public_detector",
    "public_residual",
    "read_thresholds",
    "without_bias",
    "write_thresholds",
]

#: Default observer gain K_O, 1/s (time constant 50 ms).
DEFAULT_GAIN_1_S = 20.0
#: Samples in a row above a threshold before the detector turns on.
DEFAULT_CONSECUTIVE = 2
#: Default calibration margin: thresholds = margin × what the collision-free data reached.
DEFAULT_MARGIN = 2.5
#: Default time constant of the detector's slow-bias low-pass, s.
DEFAULT_BIAS_TIME_CONSTANT_S = 20.0
#: Largest |effort_delay_s| the alignment estimate considers, s.
MAX_EFFORT_DELAY_S = 0.05
#: Grid step of that estimate, s (then refined by a parabola).
EFFORT_DELAY_STEP_S = 0.0025
#: Time step of the central difference giving Ṁ along q̇, s.
MDOT_STEP_S = 1e-6
#: The fixed thresholds of public Baxter code, s0 … w2, N·m.
PUBLIC_THRESHOLDS_NM = (10.0, 10.0, 5.0, 4.5, 2.0, 2.0, 1.0)


# ----------------------------------------------------------------------------- observer
def _gain(gain_1_s: float | Sequence[float]) -> np.ndarray:
    k = np.broadcast_to(np.asarray(gain_1_s, dtype=np.float64), (N,)).copy()
    if not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise CollisionError(f"observer gain must be > 0 1/s per joint (a number or 7), got {gain_1_s!r}")
    return k


def _consecutive(value: Any) -> int:
    """``consecutive`` checked: a whole number ≥ 1."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise CollisionError(f"consecutive: expected a whole number >= 1, got {value!r}")
    return int(value)


def _effort_delay(value: Any) -> float:
    """``effort_delay_s`` checked: a number of seconds within ±MAX_EFFORT_DELAY_S."""
    try:
        d = float(value)
    except (TypeError, ValueError) as err:
        raise CollisionError(f"effort_delay_s: expected a number of seconds, got {value!r}") from err
    if not abs(d) <= MAX_EFFORT_DELAY_S:
        raise CollisionError(f"effort_delay_s: expected seconds within ±{MAX_EFFORT_DELAY_S:g}, got {value!r}")
    return d


class _Aligner:
    """The effort–state alignment (module docstring), one sample at a time: returns the state at
    t − a and the effort at t − b, interpolated over the samples it keeps (the first held before)."""

    def __init__(self, effort_delay_s: float) -> None:
        self.state_lag_s = max(effort_delay_s, 0.0)
        self.effort_lag_s = max(-effort_delay_s, 0.0)
        self.reset()

    def reset(self) -> None:
        self._t: list[float] = []  # s since the first sample
        self._x: list[np.ndarray] = []  # (3, 7): q, q̇, effort

    def push(self, dt_s: float, q: np.ndarray, qd: np.ndarray, effort: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇ and effort (7,) aligned, for a sample dt_s after the last one."""
        t_now = self._t[-1] + dt_s if self._t else 0.0
        self._t.append(t_now)
        self._x.append(np.stack((q, qd, effort)))
        oldest_needed = t_now - max(self.state_lag_s, self.effort_lag_s)
        while len(self._t) > 1 and self._t[1] <= oldest_needed:
            del self._t[0], self._x[0]
        state = self._at(t_now - self.state_lag_s)
        effort_then = self._at(t_now - self.effort_lag_s)
        return state[0], state[1], effort_then[2]

    def _at(self, t: float) -> np.ndarray:
        times = self._t
        i = len(times) - 1
        while i > 0 and times[i] > t:
            i -= 1
        if times[i] >= t or i == len(times) - 1:
            return self._x[i]
        w = (t - times[i]) / (times[i + 1] - times[i])
        return self._x[i] + w * (self._x[i + 1] - self._x[i])


def _time_constant(value: Any) -> float:
    """``bias_time_constant_s`` checked: finite seconds ≥ 0 (0: no bias removed)."""
    try:
        t = float(value)
    except (TypeError, ValueError) as err:
        raise CollisionError(f"bias_time_constant_s: expected seconds >= 0, got {value!r}") from err
    if not (t >= 0 and np.isfinite(t)):
        raise CollisionError(f"bias_time_constant_s: expected seconds >= 0, got {value!r}")
    return t


def _model(arm: ArmModel, compensation: Compensation | None) -> ArmModel:
    return arm if compensation is None else compensation.arm


def momentum_terms(
    arm: ArmModel, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, compensation: Compensation | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """p = M(q) q̇ (kg·m²/s) and β = τ_meas + Cᵀ(q, q̇) q̇ − G(q) (N·m), both (M, 7), for (M, 7) inputs."""
    model = _model(arm, compensation)
    p, w = lagrange_euler.momentum_terms(model.dh, model.pseudo_inertias, model.gravity_m_s2, q, qd, MDOT_STEP_S)
    return p, _beta_in_place(w, q, qd, effort, compensation)


def _beta_in_place(w: np.ndarray, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, compensation: Compensation | None) -> np.ndarray:
    """β = w + τ_meas (less the compensation's share at q̈ = 0), in w (M, 7): w = Cᵀ q̇ − G of the core."""
    w += effort
    if compensation is not None:
        w -= compensation.torque(q, qd, np.zeros_like(q))
    return w


class MomentumObserver:
    """The generalised-momentum observer (module docstring), one sample at a time.

    arm: the nominal model; gain_1_s: K_O, a number or (7,) 1/s; compensation: identified effects
    (its ``arm`` replaces ``arm``); effort_delay_s: the effort–state alignment, s (module docstring).
    """

    def __init__(
        self,
        arm: ArmModel,
        gain_1_s: float | Sequence[float] = DEFAULT_GAIN_1_S,
        compensation: Compensation | None = None,
        effort_delay_s: float = 0.0,
    ) -> None:
        self.arm = arm
        self.gain_1_s = _gain(gain_1_s)
        self.compensation = compensation
        self.effort_delay_s = _effort_delay(effort_delay_s)
        self._aligner = _Aligner(self.effort_delay_s) if self.effort_delay_s else None
        self._model = _model(arm, compensation)
        self._sample = np.zeros((3, 1, N))  # q, q̇, τ_meas of one sample as (1, 7) rows: no per-call allocation
        self._terms = np.zeros((2, 1, N))  # p and Cᵀ q̇ − G of that sample
        self.reset()

    def reset(self) -> None:
        """Start afresh: the next sample is the new p(0), with r = 0."""
        self._p0: np.ndarray | None = None
        self._integral = np.zeros(N)
        self.r = np.zeros(N)
        if self._aligner is not None:
            self._aligner.reset()

    def update(self, q: np.ndarray, qd: np.ndarray, tau_meas: np.ndarray, dt_s: float) -> np.ndarray:
        """r (7,) N·m for one sample: q (7,) rad, qd (7,) rad/s, tau_meas (7,) N·m, dt_s since the last one."""
        if self._aligner is not None:
            q, qd, tau_meas = self._aligner.push(dt_s, q, qd, tau_meas)
        sample, terms, model = self._sample, self._terms, self._model
        sample[0, 0], sample[1, 0], sample[2, 0] = q, qd, tau_meas
        # momentum_terms with the compiled kernel called directly, without its front's per-call checks.
        lagrange_euler.batch_momentum_terms(
            model.dh, model.pseudo_inertias, model.gravity_m_s2, sample[0], sample[1], MDOT_STEP_S, terms[0], terms[1]
        )  # fmt: skip
        _beta_in_place(terms[1], sample[0], sample[1], sample[2], self.compensation)
        return self._step(terms[0, 0], terms[1, 0], dt_s)

    def _step(self, p: np.ndarray, beta: np.ndarray, dt_s: float) -> np.ndarray:
        """r (7,) of the sample with p and β (7,), dt_s after the last one (the first sets p(0))."""
        if self._p0 is None:
            self._p0 = p.copy()
            self.r = np.zeros(N)
            return self.r.copy()
        r = np.empty(N)
        _observer_step(p, beta, self._p0, self._integral, self.gain_1_s, dt_s, r)
        self.r = r
        return r.copy()


@njit(cache=True)
def _observer_step(p, beta, p0, integral, k, dt_s, r):
    """r = K (I + β Δt − (p − p0)) / (1 + K Δt), then I += (β − r) Δt, on (7,) arrays (r, I in place)."""
    for j in range(p.shape[0]):
        r[j] = k[j] * (integral[j] + beta[j] * dt_s - p[j] + p0[j]) / (1.0 + k[j] * dt_s)
        integral[j] += (beta[j] - r[j]) * dt_s


def observe(
    arm: ArmModel,
    recording: Recording,
    gain_1_s: float | Sequence[float] = DEFAULT_GAIN_1_S,
    compensation: Compensation | None = None,
    effort_delay_s: float = 0.0,
) -> np.ndarray:
    """The observer's r (N, 7) over a recording: the numbers of :class:`MomentumObserver`, sample by sample."""
    return observe_arrays(
        arm, recording.stamps_ns, recording.q, recording.qd, recording.effort,
        gain_1_s=gain_1_s, compensation=compensation, effort_delay_s=effort_delay_s,
    )  # fmt: skip


def observe_arrays(
    arm: ArmModel,
    stamps_ns: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    effort: np.ndarray,
    *,
    gain_1_s: float | Sequence[float] = DEFAULT_GAIN_1_S,
    compensation: Compensation | None = None,
    effort_delay_s: float = 0.0,
) -> np.ndarray:
    """:func:`observe` on arrays: stamps_ns (N,) ns, q, qd, effort (N, 7); r (N, 7) N·m."""
    k = _gain(gain_1_s)
    effort_delay_s = _effort_delay(effort_delay_s)
    dt = np.diff(np.asarray(stamps_ns, dtype=np.int64), prepend=stamps_ns[0]) * 1e-9
    if effort_delay_s:
        aligner = _Aligner(effort_delay_s)
        aligned = [aligner.push(float(dt[i]), q[i], qd[i], effort[i]) for i in range(len(q))]
        q, qd, effort = (np.array([a[i] for a in aligned]).reshape(-1, N) for i in range(3))
    p, beta = momentum_terms(arm, q, qd, effort, compensation)
    return _observer_run(p, beta, dt, k)


def _observer_run(p: np.ndarray, beta: np.ndarray, dt: np.ndarray, k: np.ndarray) -> np.ndarray:
    """r (N, 7) of the observer over p, β (N, 7) with steps dt (N,) s and gains k (7,) 1/s: the
    numbers of :class:`MomentumObserver` (r_0 = 0, sample 0 sets p(0))."""
    r = np.zeros_like(p)
    _observer_steps(p, beta, dt, k, r)
    return r


@njit(cache=True)
def _observer_steps(p, beta, dt, k, r):
    """:func:`_observer_step` over samples 1 … N−1 into r (N, 7), from p(0) = p[0] and I = 0."""
    integral = np.zeros(p.shape[1])
    for i in range(1, p.shape[0]):
        _observer_step(p[i], beta[i], p[0], integral, k, dt[i], r[i])


def estimate_effort_delay(
    arm: ArmModel,
    recordings: Sequence[Recording],
    gain_1_s: float | Sequence[float] = DEFAULT_GAIN_1_S,
    compensation: Compensation | None = None,
) -> float:
    """The effort–state alignment effort_delay_s, s, of collision-free recordings (module docstring)."""
    if not recordings:
        raise CollisionError("estimating the effort delay needs at least one recording")
    k = _gain(gain_1_s)
    prepared = []
    for rec in recordings:
        p, w = momentum_terms(arm, rec.q, rec.qd, np.zeros_like(rec.q), compensation)
        t = (rec.stamps_ns - rec.stamps_ns[0]) * 1e-9
        dt = np.diff(rec.stamps_ns, prepend=rec.stamps_ns[0]) * 1e-9
        prepared.append((t, dt, p, w, rec.effort))
    candidates = np.arange(-MAX_EFFORT_DELAY_S, MAX_EFFORT_DELAY_S + EFFORT_DELAY_STEP_S / 2, EFFORT_DELAY_STEP_S)
    # The state at t with the effort recorded at t + d (the same pairs as the observer's, shifted in time).
    cost = np.array([
        sum(np.sum(_observer_run(p, w + np.stack([np.interp(t + d, t, e[:, j]) for j in range(N)], axis=1), dt, k) ** 2) for t, dt, p, w, e in prepared)
        for d in candidates
    ])  # fmt: skip
    i = int(np.argmin(cost))
    best = float(candidates[i])
    if 0 < i < len(cost) - 1:
        curvature = cost[i - 1] - 2 * cost[i] + cost[i + 1]
        if curvature > 0:
            best += EFFORT_DELAY_STEP_S * 0.5 * (cost[i - 1] - cost[i + 1]) / curvature
    return round(best, 4)


def public_residual(arm: ArmModel, recording: Recording, compensation: Compensation | None = None) -> np.ndarray:
    """The public scheme's residual τ_meas − τ(q, q̇, 0), (N, 7) N·m (minus the effects' share, q̈ = 0)."""
    zero = np.zeros_like(recording.q)
    r = recording.effort - _model(arm, compensation).inverse_dynamics(recording.q, recording.qd, zero)
    if compensation is not None:
        r = r - compensation.torque(recording.q, recording.qd, zero)
    return r


# ----------------------------------------------------------------------------- thresholds
def _joint_vector(value: Any, where: str, *, positive: bool) -> np.ndarray:
    if isinstance(value, dict):
        unknown = set(value) - set(JOINT_SUFFIXES)
        missing = set(JOINT_SUFFIXES) - set(value)
        if unknown or missing:
            raise CollisionError(f"{where}: expected the joints {', '.join(JOINT_SUFFIXES)}, got {sorted(value)}")
        value = [value[j] for j in JOINT_SUFFIXES]
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise CollisionError(f"{where}: expected 7 numbers, got {value!r}") from err
    if arr.shape != (N,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0 if positive else arr < 0):
        raise CollisionError(f"{where}: expected 7 finite numbers {'> 0' if positive else '>= 0'}, got {value!r}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class Thresholds:
    """Per-joint thresholds a + b |q̇|: offset_nm (7,) N·m > 0, slope_nm_s_rad (7,) N·m·s/rad ≥ 0.

    gain_1_s (7,): the observer gain they were calibrated with (r depends on it); consecutive: the
    samples in a row above that the detector needs (they were calibrated for it); effort_delay_s:
    the effort–state alignment the observer ran with, s; bias_time_constant_s: T_b of the slow bias
    the detector removes, s (0: none); both as in the module docstring; margin and files: how they
    were calibrated (for the record).
    """

    offset_nm: np.ndarray
    slope_nm_s_rad: np.ndarray = field(default_factory=lambda: np.zeros(N))
    gain_1_s: np.ndarray = field(default_factory=lambda: np.full(N, DEFAULT_GAIN_1_S))
    margin: float = 1.0
    files: tuple[str, ...] = ()
    consecutive: int = DEFAULT_CONSECUTIVE
    effort_delay_s: float = 0.0
    bias_time_constant_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset_nm", _joint_vector(self.offset_nm, "offset_nm", positive=True))
        object.__setattr__(self, "slope_nm_s_rad", _joint_vector(self.slope_nm_s_rad, "slope_nm_s_rad", positive=False))
        object.__setattr__(self, "gain_1_s", _joint_vector(self.gain_1_s, "gain_1_s", positive=True))
        if isinstance(self.files, (str, bytes)) or not isinstance(self.files, (list, tuple)):
            raise CollisionError(f"files: expected a list of file names, got {self.files!r}")
        object.__setattr__(self, "files", tuple(str(f) for f in self.files))
        object.__setattr__(self, "consecutive", _consecutive(self.consecutive))
        object.__setattr__(self, "effort_delay_s", _effort_delay(self.effort_delay_s))
        object.__setattr__(self, "bias_time_constant_s", _time_constant(self.bias_time_constant_s))
        try:
            margin = float(self.margin)
        except (TypeError, ValueError) as err:
            raise CollisionError(f"margin: expected a number >= 1, got {self.margin!r}") from err
        if not margin >= 1.0 or not np.isfinite(margin):
            raise CollisionError(f"margin: expected a number >= 1, got {self.margin!r}")
        object.__setattr__(self, "margin", margin)

    def at(self, qd: np.ndarray) -> np.ndarray:
        """Thresholds at the speed qd, (..., 7) N·m; qd (..., 7) rad/s."""
        return self.offset_nm + self.slope_nm_s_rad * np.abs(qd)

    def to_dict(self) -> dict[str, Any]:
        def joints(v: np.ndarray) -> dict[str, float]:
            return {j: float(x) for j, x in zip(JOINT_SUFFIXES, v)}

        return {
            "offset_nm": joints(self.offset_nm),
            "slope_nm_s_rad": joints(self.slope_nm_s_rad),
            "gain_1_s": joints(self.gain_1_s),
            "consecutive": self.consecutive,
            "effort_delay_s": self.effort_delay_s,
            "bias_time_constant_s": self.bias_time_constant_s,
            "margin": float(self.margin),
            "files": list(self.files),
        }

    @classmethod
    def from_dict(cls, raw: Any, where: str = "thresholds") -> Thresholds:
        if not isinstance(raw, dict) or "offset_nm" not in raw:
            raise CollisionError(f"{where}: expected a mapping with offset_nm (and slope_nm_s_rad, gain_1_s), got {raw!r}")
        unknown = set(raw) - {"offset_nm", "slope_nm_s_rad", "gain_1_s", "consecutive", "effort_delay_s", "bias_time_constant_s", "margin", "files"}
        if unknown:
            raise CollisionError(f"{where}: unknown keys {sorted(unknown)}")
        try:
            return cls(**raw)
        except CollisionError as err:
            raise CollisionError(f"{where}: {err}") from err


def write_thresholds(path: str | os.PathLike[str], thresholds: Thresholds) -> None:
    """Write ``thresholds`` as YAML (thresholds.yaml), whole or not at all (:mod:`.output_files`)."""
    with staged_outputs([Path(path)]) as (staged,), open(staged, "w", encoding="utf-8") as stream:
        stream.write("# Collision thresholds a + b|q̇| per joint, from `baxter-dynamics calibrate`.\n")
        yaml.safe_dump(thresholds.to_dict(), stream, sort_keys=False, allow_unicode=True)


def read_thresholds(path: str | os.PathLike[str]) -> Thresholds:
    """The :class:`Thresholds` of a YAML file written by :func:`write_thresholds`."""
    return Thresholds.from_dict(read_yaml(path, CollisionError, "thresholds file"), str(path))


def calibrate_thresholds(
    residuals: Sequence[np.ndarray],
    velocities: Sequence[np.ndarray],
    *,
    margin: float = DEFAULT_MARGIN,
    speed_dependent: bool = True,
    slow_rad_s: float = 0.05,
    floor_nm: float = 0.05,
    gain_1_s: float | Sequence[float] = DEFAULT_GAIN_1_S,
    consecutive: int = DEFAULT_CONSECUTIVE,
    effort_delay_s: float = 0.0,
    stamps_ns: Sequence[np.ndarray] | None = None,
    bias_time_constant_s: float = 0.0,
    files: Sequence[str] = (),
) -> Thresholds:
    """Thresholds from collision-free data by the module docstring's rule.

    residuals, velocities: per recording, observer r (N, 7) N·m (of an observer with gain_1_s and
    effort_delay_s, which the thresholds record) and q̇ (N, 7) rad/s; stamps_ns: per recording (N,)
    ns, needed when bias_time_constant_s > 0 (the slow bias is then removed from r first).
    """
    if not residuals or len(residuals) != len(velocities):
        raise CollisionError("calibration needs at least one recording (residuals and velocities alike)")
    consecutive = _consecutive(consecutive)
    bias_time_constant_s = _time_constant(bias_time_constant_s)
    if bias_time_constant_s > 0:
        if stamps_ns is None or len(stamps_ns) != len(residuals):
            raise CollisionError("removing the slow bias needs the stamps of every recording")
        residuals = [without_bias(r_k, t_k, bias_time_constant_s) for r_k, t_k in zip(residuals, stamps_ns)]
    runs = [(_run_minimum(np.abs(r_k), consecutive), _run_minimum(np.abs(qd_k), consecutive)) for r_k, qd_k in zip(residuals, velocities)]
    if not any(len(rho) for rho, _ in runs):
        raise CollisionError(f"calibration needs at least {consecutive} samples in one recording")
    r = np.concatenate([rho for rho, _ in runs]) * margin
    speed = np.concatenate([sigma for _, sigma in runs])
    offset = np.empty(N)
    slope = np.zeros(N)
    for j in range(N):
        slow = speed[:, j] <= slow_rad_s
        if not speed_dependent or not slow.any():
            offset[j] = r[:, j].max()
        else:
            offset[j] = r[slow, j].max()
            moving = ~slow
            if moving.any():
                slope[j] = max(0.0, float(np.max((r[moving, j] - offset[j]) / speed[moving, j])))
    return Thresholds(
        np.maximum(offset, floor_nm), slope, _gain(gain_1_s), float(margin), tuple(files), consecutive, effort_delay_s, bias_time_constant_s
    )  # fmt: skip


def without_bias(r: np.ndarray, stamps_ns: np.ndarray, time_constant_s: float) -> np.ndarray:
    """r̃ = r − r̄ (N, 7) for r (N, 7) N·m at stamps_ns (N,): r̄ the slow bias (module docstring), the detector off throughout."""
    if time_constant_s == 0:
        return np.array(r, dtype=np.float64)
    dt = np.diff(np.asarray(stamps_ns, dtype=np.int64), prepend=stamps_ns[0]) * 1e-9
    out = np.empty_like(r)
    bias = np.zeros(r.shape[1])
    for k in range(len(r)):
        if k:
            _follow_bias(bias, r[k - 1], float(dt[k]), time_constant_s)
        out[k] = r[k] - bias
    return out


def _follow_bias(bias: np.ndarray, r_before: np.ndarray, dt_s: float, time_constant_s: float) -> None:
    """One step of the slow bias r̄ (7,), in place (module docstring): r̄ += min(Δt/T_b, 1)(r_{k−1} − r̄)."""
    bias += min(dt_s / time_constant_s, 1.0) * (r_before - bias)


def calibrate(
    arm: ArmModel,
    recordings: Sequence[Recording],
    *,
    compensation: Compensation | None = None,
    gain_1_s: float | Sequence[float] = DEFAULT_GAIN_1_S,
    effort_delay_s: float | None = None,
    margin: float = DEFAULT_MARGIN,
    consecutive: int = DEFAULT_CONSECUTIVE,
    bias_time_constant_s: float = DEFAULT_BIAS_TIME_CONSTANT_S,
    speed_dependent: bool = True,
    files: Sequence[str] = (),
) -> Thresholds:
    """Thresholds from collision-free recordings: the effort–state alignment (estimated when
    effort_delay_s is None), the observer's r with it, then :func:`calibrate_thresholds`."""
    if effort_delay_s is None:
        effort_delay_s = estimate_effort_delay(arm, recordings, gain_1_s, compensation)
    residuals = [observe(arm, rec, gain_1_s, compensation, effort_delay_s) for rec in recordings]
    return calibrate_thresholds(
        residuals, [rec.qd for rec in recordings], margin=margin, speed_dependent=speed_dependent,
        gain_1_s=gain_1_s, consecutive=consecutive, effort_delay_s=effort_delay_s,
        stamps_ns=[rec.stamps_ns for rec in recordings], bias_time_constant_s=bias_time_constant_s, files=files,
    )  # fmt: skip


def _run_minimum(x: np.ndarray, length: int) -> np.ndarray:
    """The smallest value of every run of ``length`` rows of x (N, 7): (N − length + 1, 7)."""
    if len(x) < length:
        return x[:0]
    return np.lib.stride_tricks.sliding_window_view(x, length, axis=0).min(axis=-1)


# ----------------------------------------------------------------------------- detection
class DetectorState(NamedTuple):
    """The detector after a sample: collision on or off; joints (indices) above their threshold in
    the current event (empty when off)."""

    collision: bool
    joints: tuple[int, ...]


class CollisionDetector:
    """Hysteresis on |r̃| = |r − r̄| against thresholds (module docstring; r̄ = 0 when the thresholds'
    bias_time_constant_s is 0).

    It turns on after ``thresholds.consecutive`` samples in a row above on one joint; release_fraction:
    of the threshold, below which every joint must stay for hold_s before it turns off (default
    1 / ``thresholds.margin``).
    """

    def __init__(self, thresholds: Thresholds, *, release_fraction: float | None = None, hold_s: float = 0.1) -> None:
        if release_fraction is None:
            release_fraction = 1.0 / thresholds.margin
        if not 0 < release_fraction <= 1 or hold_s < 0:
            raise CollisionError(f"detector: need 0 < release_fraction <= 1, hold_s >= 0; got {release_fraction}, {hold_s}")
        self.thresholds = thresholds
        self.release_fraction = float(release_fraction)
        self.hold_s = float(hold_s)
        self.reset()

    def reset(self) -> None:
        """Off, counters and bias cleared."""
        self._above = np.zeros(N, dtype=np.int64)  # samples in a row above, per joint
        self._quiet_s = 0.0
        self._bias = np.zeros(N)
        self._last_r: np.ndarray | None = None
        self.state = DetectorState(False, ())

    def update(self, r: np.ndarray, qd: np.ndarray, dt_s: float) -> DetectorState:
        """The state after one sample: r (7,) N·m, qd (7,) rad/s, dt_s since the last sample."""
        time_constant = self.thresholds.bias_time_constant_s
        if time_constant > 0:
            if self._last_r is not None and not self.state.collision:
                _follow_bias(self._bias, self._last_r, dt_s, time_constant)
            self._last_r = np.array(r, dtype=np.float64)
            r = r - self._bias
        limit = self.thresholds.at(qd)
        above = np.abs(r) > limit
        counts = self._above
        counts += 1
        counts[~above] = 0
        if not self.state.collision:
            on = counts >= self.thresholds.consecutive
            if on.any():
                self._quiet_s = 0.0
                self.state = DetectorState(True, tuple(int(j) for j in np.flatnonzero(on)))
            return self.state
        joints = tuple(sorted(set(self.state.joints) | {int(j) for j in np.flatnonzero(above)}))
        if np.all(np.abs(r) < self.release_fraction * limit):
            self._quiet_s += dt_s
            if self._quiet_s >= self.hold_s:
                counts[:] = 0
                self.state = DetectorState(False, ())
                return self.state
        else:
            self._quiet_s = 0.0
        self.state = DetectorState(True, joints)
        return self.state


def detect(detector: CollisionDetector, r: np.ndarray, qd: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
    """The detector's on/off (N,) bool over r, qd (N, 7) at stamps_ns (N,), from a reset."""
    detector.reset()
    dt = np.diff(np.asarray(stamps_ns), prepend=stamps_ns[0]) * 1e-9
    return np.array([detector.update(r[k], qd[k], float(dt[k])).collision for k in range(len(r))], dtype=bool)


def public_detector() -> CollisionDetector:
    """The public scheme's detector: fixed :data:`PUBLIC_THRESHOLDS_NM`, on at the first sample
    above, off at the first sample with every joint below."""
    return CollisionDetector(Thresholds(np.array(PUBLIC_THRESHOLDS_NM), consecutive=1), release_fraction=1.0, hold_s=0.0)
