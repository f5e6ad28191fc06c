"""Collision thresholds from collision-free recordings.

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

With a slow-bias time constant T_b > 0 the rule runs on r̃ = r − r̄, the residual less the slow
bias the detector removes (:mod:`.detector`; :func:`without_bias`: r̄ as the detector follows it
while off). :func:`calibrate` does it all from recordings: the effort–state alignment
(:func:`~.observer.estimate_effort_delay`), the observer's r with it, then the rule.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.arm_model import ArmModel
from ..core.compensation import Compensation
from ..core.joints import JOINTS as N
from ..core.recording import Recording
from ..errors import CollisionError
from .detector import DEFAULT_BIAS_TIME_CONSTANT_S, follow_bias
from .observer import DEFAULT_GAIN_1_S, check_gain, estimate_effort_delay, observe
from .thresholds import DEFAULT_CONSECUTIVE, Thresholds, check_consecutive, check_time_constant

__all__ = [
    "DEFAULT_MARGIN",
    "calibrate",
    "calibrate_thresholds",
    "without_bias",
]

#: Default calibration margin: thresholds = margin × what the collision-free data reached.
DEFAULT_MARGIN = 2.5


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
    consecutive = check_consecutive(consecutive)
    bias_time_constant_s = check_time_constant(bias_time_constant_s)
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
        np.maximum(offset, floor_nm), slope, check_gain(gain_1_s), float(margin), tuple(files), consecutive, effort_delay_s, bias_time_constant_s
    )  # fmt: skip


def without_bias(r: np.ndarray, stamps_ns: np.ndarray, time_constant_s: float) -> np.ndarray:
    """r̃ = r − r̄ (N, 7) for r (N, 7) N·m at stamps_ns (N,): r̄ the slow bias (:mod:`.detector`), the detector off throughout."""
    if time_constant_s == 0:
        return np.array(r, dtype=np.float64)
    dt = np.diff(np.asarray(stamps_ns, dtype=np.int64), prepend=stamps_ns[0]) * 1e-9
    out = np.empty_like(r)
    bias = np.zeros(r.shape[1])
    for k in range(len(r)):
        if k:
            follow_bias(bias, r[k - 1], float(dt[k]), time_constant_s)
        out[k] = r[k] - bias
    return out


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
