"""The live node's work on one joint-state sample: model torques and residual; numpy only, no ROS.

:class:`ResidualPipeline` turns one sample of the arm (stamp, q, q̇ or nothing, effort or nothing)
into G(q), τ and the residual, or into a :class:`~baxter_dynamics_ros.core.samples.SkipReason` (the message reader,
:mod:`msg_adapters.joint_state`, gives the others: ``unreadable``, ``missing_joint``,
``array_length``). For sample k, k−1 being the last accepted sample:

1. skipped if any of the arm's q, q̇ or effort values is NaN or ±inf (``non_finite_input``);
2. skipped if it is one no real Baxter can give (``implausible_input``): a joint angle beyond the
   joint limits by more than :data:`POSITION_MARGIN_RAD`, a speed above :data:`PLAUSIBLE_FACTOR`
   times the joint's velocity limit, an effort above that factor times its effort limit — the
   bounds of :mod:`baxter_dynamics_ros.core.plausibility`, which the offline readers apply too
   (the model file's limits, the URDF's: 1.5 rad/s and 50–100 N·m at s0–e1, 4 rad/s and 15 N·m at the
   wrist; the four real recordings reach 1.34 times a velocity limit and 0.31 times an effort
   limit). Nothing of such a sample reaches a filter or the observer: the next samples give the
   outputs they would have given without it;
3. skipped if t_k = t_{k−1} (``duplicate_stamp``); if t_k < t_{k−1} the estimator is reset and the
   sample skipped (``stamp_backwards``: a recording restarting, a publisher restarting), so the
   samples after it start afresh instead of being compared with the old ones;
4. without q̇ (empty velocity in the message) q̇_k = (q_k − q_{k−1}) / Δt_k, the backward difference
   of the positions; the first sample after a (re)start has nothing to difference and is skipped
   (``velocity_warm_up``, expected once, not a fault); a differenced q̇ beyond the bound of step 2
   (a jump of the positions) skips the sample as ``implausible_input`` and differences the next
   one from it;
5. q̈_k from the causal estimator on q̇ with Δt_k = t_k − t_{k−1} taken from the stamps:
   ``lowpass`` (:class:`~baxter_dynamics_ros.core.acceleration.LowPassDifferentiator`, −3 dB at
   ``cutoff_hz``) or ``first_difference`` (the paper's raw difference); q̈ = 0 on the first sample
   after a (re)start;
6. τ = M(q) q̈ + C(q, q̇) + G(q) (eq. 1) and G(q) = τ(q, 0, 0) from one call of the compiled core;
   with an effects file, of the compensated model (:mod:`baxter_dynamics_ros.core.compensation`: the
   inertial effects in M, C, G, the others' share of the effort added to τ; Dahl's friction state
   advanced by this sample's q̇ over Δt_k, from z = 0 at a (re)start);
   if either holds NaN/inf, or q̈, the residual or r does, the estimator and the observer (whose
   states hold the same values) are reset, the sample skipped (``non_finite_model``) and the reset
   counted (``resets_total.non_finite_state``). The plausibility bounds of step 2 keep every
   number far from overflow, so this is a guard, not an expected path;
7. residual = measured effort − τ, or None when the message has no effort;
8. external torque r = the generalised-momentum observer's output
   (:class:`~baxter_dynamics_ros.monitoring.observer.MomentumObserver`, gain ``observer_gain_1_s``,
   effort–state alignment ``observer_effort_delay_s``, the same compensated model) on the samples
   with effort, or None without effort. The observer restarts (r = 0) with the estimator, and after
   a sample without effort.

The records it takes and gives are the core's (:mod:`baxter_dynamics_ros.core.samples`); what
happened to every sample is counted by :mod:`.health`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..core import lagrange_euler
from ..core.acceleration import CAUSAL_ESTIMATORS, FirstDifference, LowPassDifferentiator
from ..core.arm_model import ArmModel
from ..core.compensation import Compensation
from ..core.joints import JOINTS as N
from ..core.plausibility import PLAUSIBLE_FACTOR, POSITION_MARGIN_RAD, plausibility_bounds
from ..core.samples import ArmSample, ModelTorques, SkipReason
from ..errors import CollisionError, SettingsError
from .observer import DEFAULT_GAIN_1_S, MomentumObserver

__all__ = [
    "PLAUSIBLE_FACTOR",
    "POSITION_MARGIN_RAD",
    "ResidualPipeline",
    "make_estimator",
]


def make_estimator(name: str, cutoff_hz: float) -> LowPassDifferentiator | FirstDifference:
    """The causal q̈ estimator called ``name`` (``lowpass`` at cutoff_hz, or ``first_difference``)."""
    if name not in CAUSAL_ESTIMATORS:
        raise SettingsError(f"estimator: expected one of {', '.join(CAUSAL_ESTIMATORS)}, got {name!r}")
    if name == "first_difference":
        return FirstDifference()
    try:
        return LowPassDifferentiator(cutoff_hz)
    except ValueError as err:
        raise SettingsError(f"cutoff_hz: {err}") from err


#: Stands for an absent array (no q̇, no effort) in the compiled checks: nothing to check.
_ABSENT = np.zeros(0)


@njit(cache=True)
def _finite(x: np.ndarray) -> bool:
    for v in x.flat:
        if not np.isfinite(v):
            return False
    return True


@njit(cache=True)
def _within(x: np.ndarray, low: np.ndarray, high: np.ndarray) -> bool:
    for j in range(x.shape[0]):
        if not (low[j] <= x[j] <= high[j]):
            return False
    return True


@njit(cache=True)
def _input_fault(q: np.ndarray, qd: np.ndarray, effort: np.ndarray, bounds: np.ndarray) -> int:
    """0 for a usable sample, 1 if a value is NaN or ±inf (step 1), 2 if it is implausible (step 2).

    q (7,); qd, effort (7,) or :data:`_ABSENT`; bounds (6, 7): low and high q, q̇, effort, in turn.
    One compiled call, as the node asks it of every sample."""
    if not (_finite(q) and _finite(qd) and _finite(effort)):
        return 1
    if not (_within(q, bounds[0], bounds[1]) and _within(qd, bounds[2], bounds[3]) and _within(effort, bounds[4], bounds[5])):
        return 2
    return 0


@njit(cache=True)
def _model_torques(K, P, B, g, q, qd, qdd, effort, extra, out) -> bool:
    """out (3, 7): τ(q, q̇, q̈) + extra, G(q) and, with effort, the residual effort − τ (row 2
    untouched without); effort and extra (7,) or :data:`_ABSENT`; (K, P, B) the workspace of
    :func:`~baxter_dynamics_ros.core.lagrange_euler.sample_workspace`. False if q̈ or a result
    holds NaN or ±inf. One compiled call, as the node asks it of every sample."""
    lagrange_euler.sample_torques(K, P, B, g, q, qd, qdd, out)
    if extra.size:
        for j in range(out.shape[1]):
            out[0, j] += extra[j]
    if effort.size:
        for j in range(out.shape[1]):
            out[2, j] = effort[j] - out[0, j]
        if not _finite(out[2]):
            return False
    return _finite(qdd) and _finite(out[0]) and _finite(out[1])


def _given(x: np.ndarray | None) -> np.ndarray:
    return _ABSENT if x is None else x


class ResidualPipeline:
    """G, τ and residual of one arm, one sample at a time (see the module docstring for the steps)."""

    def __init__(
        self,
        arm: ArmModel,
        estimator: str = "lowpass",
        cutoff_hz: float = 10.0,
        compensation: Compensation | None = None,
        observer_gain_1_s: float = DEFAULT_GAIN_1_S,
        observer_effort_delay_s: float = 0.0,
    ) -> None:
        self.compensation = compensation
        self.arm = arm if compensation is None else compensation.arm
        self._estimator = make_estimator(estimator, cutoff_hz)
        self._presliding = None if compensation is None else compensation.presliding_tracker()
        try:
            self._observer = MomentumObserver(arm, observer_gain_1_s, compensation, observer_effort_delay_s)
        except CollisionError as err:
            raise SettingsError(f"observer: {err}") from err
        self._observing = False  # whether the observer ran on the last sample
        self._last_stamp_ns: int | None = None  # of the last sample taken in (stamps must increase from it)
        self._last_q: np.ndarray | None = None  # its positions, which q̇ is differenced from
        self._estimated_ns: int | None = None  # stamp of the last q̇ the estimator (and the observer) took
        # Plausibility bounds (module docstring, step 2; the core's, which the offline readers apply
        # too): one (6, 7) array, rows low and high of q, q̇, effort in turn.
        self._bounds = np.array(plausibility_bounds(self.arm))  # writable: the compiled checks take plain arrays
        self._workspace = lagrange_euler.sample_workspace(self.arm.dh, self.arm.pseudo_inertias)
        self._gravity = np.ascontiguousarray(self.arm.gravity_m_s2, dtype=np.float64)
        self._warm_up()

    def _warm_up(self) -> None:
        """Load every compiled kernel a sample uses (numba's cache, or a compilation) now rather than
        on the first samples, where it would stall the node; then start afresh."""
        zero = np.zeros(N)
        for stamp_ns in (0, 1_000_000):
            self.process(ArmSample(stamp_ns, zero, zero, zero), observe=True)
        self.reset()

    def configure(self, estimator: str, cutoff_hz: float) -> None:
        """Switch to another estimator (or cutoff); the state starts afresh."""
        self._estimator = make_estimator(estimator, cutoff_hz)
        self.reset()

    def reset(self) -> None:
        """Forget every past sample: the next one restarts the estimator (q̈ = 0) and the observer (r = 0)."""
        self._estimator.reset()
        if self._presliding is not None:
            self._presliding.reset()
        self._observer.reset()
        self._observing = False
        self._last_stamp_ns = None
        self._last_q = None
        self._estimated_ns = None

    def process(self, sample: ArmSample, observe: bool = True) -> ModelTorques | SkipReason:
        """The model's torques for one sample, or why it was skipped.

        observe: run the momentum observer (its r is ``external_torque``); when False it is
        restarted and r is None, which saves its cost when nothing uses r."""
        stamp_ns, q, qd, effort = sample
        fault = _input_fault(q, _given(qd), _given(effort), self._bounds)
        if fault:
            return SkipReason.NON_FINITE_INPUT if fault == 1 else SkipReason.IMPLAUSIBLE_INPUT
        last_ns = self._last_stamp_ns
        if last_ns is not None:
            if stamp_ns == last_ns:
                return SkipReason.DUPLICATE_STAMP
            if stamp_ns < last_ns:
                self.reset()
                return SkipReason.STAMP_BACKWARDS
        qd_from_positions = qd is None
        if qd is None:
            if self._last_q is None:
                self._last_stamp_ns, self._last_q = stamp_ns, q
                return SkipReason.VELOCITY_WARM_UP
            qd = (q - self._last_q) / ((stamp_ns - last_ns) * 1e-9)
        self._last_stamp_ns, self._last_q = stamp_ns, q
        if qd_from_positions and not _within(qd, self._bounds[2], self._bounds[3]):
            return SkipReason.IMPLAUSIBLE_INPUT  # the positions jumped; the next sample is differenced from these
        dt_s = 0.0 if self._estimated_ns is None else (stamp_ns - self._estimated_ns) * 1e-9
        self._estimated_ns = stamp_ns
        qdd = self._estimator.update(qd, dt_s)
        extra = _ABSENT
        if self.compensation is not None:
            z = None if self._presliding is None else self._presliding.update(qd, dt_s)
            extra = self.compensation.torque(q, qd, qdd, z)
        torques = np.empty((3, N))  # τ, G, residual
        if not _model_torques(*self._workspace, self._gravity, q, qd, qdd, _given(effort), extra, torques):
            self.reset()
            return SkipReason.NON_FINITE_MODEL
        external_torque = None
        if effort is not None and observe:
            external_torque = self._observer.update(q, qd, effort, dt_s)
            self._observing = True
            if not _finite(external_torque):
                self.reset()
                return SkipReason.NON_FINITE_MODEL
        elif self._observing:  # restart it when it is next needed
            self._observer.reset()
            self._observing = False
        residual = None if effort is None else torques[2]
        return ModelTorques(stamp_ns, q, qd, qdd, torques[1], torques[0], residual, qd_from_positions, external_torque, effort)
