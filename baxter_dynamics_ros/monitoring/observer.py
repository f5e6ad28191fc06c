"""The generalised-momentum observer: the external torque on the arm from the effort and the state.

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
has the additive effects' share at q̈ = 0 removed (q̈-dependent shares, armature, are not); Dahl's
friction with its state over the (aligned) samples since the observer's start.

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

Thresholds on r (:mod:`.thresholds`), calibrated from collision-free data (:mod:`.calibration`),
are watched by the detector (:mod:`.detector`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit

from ..core import lagrange_euler
from ..core.arm_model import ArmModel
from ..core.compensation import Compensation
from ..core.joints import JOINTS as N
from ..core.recording import Recording
from ..errors import CollisionError

__all__ = [
    "DEFAULT_GAIN_1_S",
    "EFFORT_DELAY_STEP_S",
    "MAX_EFFORT_DELAY_S",
    "MDOT_STEP_S",
    "MomentumObserver",
    "check_effort_delay",
    "check_gain",
    "estimate_effort_delay",
    "momentum_terms",
    "observe",
    "observe_arrays",
]

#: Default observer gain K_O, 1/s (time constant 50 ms).
DEFAULT_GAIN_1_S = 20.0
#: Largest |effort_delay_s| the alignment estimate considers, s.
MAX_EFFORT_DELAY_S = 0.05
#: Grid step of that estimate, s (then refined by a parabola).
EFFORT_DELAY_STEP_S = 0.0025
#: Time step of the central difference giving Ṁ along q̇, s.
MDOT_STEP_S = 1e-6


def check_gain(gain_1_s: float | Sequence[float]) -> np.ndarray:
    k = np.broadcast_to(np.asarray(gain_1_s, dtype=np.float64), (N,)).copy()
    if not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise CollisionError(f"observer gain must be > 0 1/s per joint (a number or 7), got {gain_1_s!r}")
    return k


def check_effort_delay(value: Any) -> float:
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


def _model(arm: ArmModel, compensation: Compensation | None) -> ArmModel:
    return arm if compensation is None else compensation.arm


def momentum_terms(
    arm: ArmModel, stamps_ns: np.ndarray, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, compensation: Compensation | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """p = M(q) q̇ (kg·m²/s) and β = τ_meas + Cᵀ(q, q̇) q̇ − G(q) (N·m), both (M, 7), for (M, 7)
    inputs of a time series at stamps_ns (M,), ns (Dahl's friction state is the series')."""
    model = _model(arm, compensation)
    p, w = lagrange_euler.momentum_terms(model.dh, model.pseudo_inertias, model.gravity_m_s2, q, qd, MDOT_STEP_S)
    presliding = None if compensation is None else compensation.presliding_state(qd, stamps_ns)
    return p, _beta_in_place(w, q, qd, effort, compensation, presliding)


def _beta_in_place(
    w: np.ndarray, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, compensation: Compensation | None, presliding: np.ndarray | None
) -> np.ndarray:
    """β = w + τ_meas (less the compensation's share at q̈ = 0, Dahl's state presliding), in w (M, 7):
    w = Cᵀ q̇ − G of the core."""
    w += effort
    if compensation is not None:
        w -= compensation.torque(q, qd, np.zeros_like(q), presliding)
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
        self.gain_1_s = check_gain(gain_1_s)
        self.compensation = compensation
        self.effort_delay_s = check_effort_delay(effort_delay_s)
        self._aligner = _Aligner(self.effort_delay_s) if self.effort_delay_s else None
        self._model = _model(arm, compensation)
        self._presliding = None if compensation is None else compensation.presliding_tracker()
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
        if self._presliding is not None:
            self._presliding.reset()

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
        presliding = None if self._presliding is None else self._presliding.update(qd, dt_s)[None]
        _beta_in_place(terms[1], sample[0], sample[1], sample[2], self.compensation, presliding)
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
    k = check_gain(gain_1_s)
    effort_delay_s = check_effort_delay(effort_delay_s)
    dt = np.diff(np.asarray(stamps_ns, dtype=np.int64), prepend=stamps_ns[0]) * 1e-9
    if effort_delay_s:
        aligner = _Aligner(effort_delay_s)
        aligned = [aligner.push(float(dt[i]), q[i], qd[i], effort[i]) for i in range(len(q))]
        q, qd, effort = (np.array([a[i] for a in aligned]).reshape(-1, N) for i in range(3))
    p, beta = momentum_terms(arm, stamps_ns, q, qd, effort, compensation)
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
    k = check_gain(gain_1_s)
    prepared = []
    for rec in recordings:
        p, w = momentum_terms(arm, rec.stamps_ns, rec.q, rec.qd, np.zeros_like(rec.q), compensation)
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
