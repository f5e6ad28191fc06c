"""Where the sim-to-real gap lies: statistics of a torque residual by joint, motion regime and frequency.

Input is a residual r = measured effort − model torque, (N, 7) in N·m, with the states it was
measured at. Everything here is descriptive (no fitting), so it may be run on any data set.

Regimes, per joint j (thresholds are keyword options with these defaults):
- ``still``: |q̇_j| < ``still_rad_s`` (0.02 rad/s, about 3 quantisation steps of q per 10 ms);
- ``reversal``: within ``reversal_window_s`` (0.05 s) of a sign change of q̇_j while moving;
- ``speed``: |q̇_j| bands (``speed_edges_rad_s``); ``acceleration``: |q̈_j| bands;
- ``angle``: bins of q_j and of q_s1 (the joint whose spring dominates Baxter's gap), each cut
  into ``angle_bins`` equal-count bins so every bin holds data.
Frequency content: the residual is split by the core's zero-phase low-pass
(:func:`~baxter_dynamics_ros.core.acceleration.zero_phase_lowpass`, order 2) at
``systematic_cutoff_hz`` (2 Hz) into a systematic part (what a model of the robot's physics could
explain) and the rest (sensor noise and noisy differentiated accelerations).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.acceleration import zero_phase_lowpass
from ..core.joints import S1

__all__ = ["Band", "GapSummary", "summarise_gap"]



@dataclass(frozen=True)
class Band:
    """Residual statistics of the samples of one regime band, per joint (arrays (7,), N·m)."""

    regime: str
    label: str
    fraction: np.ndarray
    rms: np.ndarray
    mean: np.ndarray


@dataclass(frozen=True)
class GapSummary:
    """Per-joint statistics of a residual (arrays (7,), N·m unless stated)."""

    joint_names: tuple[str, ...]
    rms: np.ndarray
    mean: np.ndarray
    share: np.ndarray  # fraction of Σ_j RMS_j² carried by joint j
    systematic_rms: np.ndarray
    noise_rms: np.ndarray
    bands: tuple[Band, ...]

    def to_dict(self) -> dict:
        """Plain JSON-ready form."""
        as_list = lambda a: [float(x) for x in a]  # noqa: E731
        return {
            "joints": list(self.joint_names),
            "rms": as_list(self.rms),
            "mean": as_list(self.mean),
            "share": as_list(self.share),
            "systematic_rms": as_list(self.systematic_rms),
            "noise_rms": as_list(self.noise_rms),
            "bands": [
                {
                    "regime": b.regime,
                    "label": b.label,
                    "fraction": as_list(b.fraction),
                    "rms": as_list(b.rms),
                    "mean": as_list(b.mean),
                }
                for b in self.bands
            ],
        }


def _masked_stats(residual: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fraction, RMS and mean of each column of residual (N, 7) over mask (N, 7); NaN where empty."""
    count = mask.sum(axis=0)
    safe = np.maximum(count, 1)
    rms = np.sqrt(np.where(mask, residual**2, 0.0).sum(axis=0) / safe)
    mean = np.where(mask, residual, 0.0).sum(axis=0) / safe
    empty = count == 0
    rms[empty] = mean[empty] = np.nan
    return count / len(residual), rms, mean


def _band(regime: str, label: str, residual: np.ndarray, mask: np.ndarray) -> Band:
    fraction, rms, mean = _masked_stats(residual, mask)
    return Band(regime, label, fraction, rms, mean)


def _reversal_mask(qd: np.ndarray, still_rad_s: float, window: int) -> np.ndarray:
    """(N, 7): samples within `window` samples of a sign change of a moving joint's velocity."""
    moving_sign = np.where(np.abs(qd) >= still_rad_s, np.sign(qd), 0.0)
    # Carry the last non-zero sign forward so that a pause between two motions still counts.
    idx = np.where(moving_sign != 0, np.arange(len(qd))[:, None], 0)
    np.maximum.accumulate(idx, axis=0, out=idx)
    carried = np.take_along_axis(moving_sign, idx, axis=0)
    flips = np.zeros_like(qd, dtype=bool)
    flips[1:] = (carried[1:] * carried[:-1]) < 0
    kernel = np.ones(2 * window + 1)
    near = np.stack([np.convolve(flips[:, j], kernel, mode="same") > 0 for j in range(qd.shape[1])], axis=1)
    return near


def summarise_gap(
    joint_names: tuple[str, ...],
    residual: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    rate_hz: float,
    *,
    still_rad_s: float = 0.02,
    reversal_window_s: float = 0.05,
    speed_edges_rad_s: tuple[float, ...] = (0.1, 0.3, 0.7),
    acceleration_edges_rad_s2: tuple[float, ...] = (0.5, 2.0, 5.0),
    angle_bins: int = 4,
    systematic_cutoff_hz: float = 2.0,
) -> GapSummary:
    """Statistics of residual (N, 7) N·m at states q, qd, qdd (N, 7) sampled at rate_hz."""
    residual = np.asarray(residual, dtype=float)
    n = len(residual)
    if n < 16:
        raise ValueError(f"need at least 16 samples to summarise a residual, got {n}")
    everywhere = np.ones_like(residual, dtype=bool)
    _, rms, mean = _masked_stats(residual, everywhere)
    share = rms**2 / max(float(np.sum(rms**2)), 1e-300)

    systematic = zero_phase_lowpass(residual, rate_hz, systematic_cutoff_hz)
    noise_rms = np.sqrt(np.mean((residual - systematic) ** 2, axis=0))
    systematic_rms = np.sqrt(np.mean(systematic**2, axis=0))

    bands: list[Band] = []
    speed = np.abs(qd)
    bands.append(_band("still", f"|qd| < {still_rad_s:g} rad/s", residual, speed < still_rad_s))
    window = max(1, int(round(reversal_window_s * rate_hz)))
    bands.append(
        _band("reversal", f"within {reversal_window_s:g} s of a reversal", residual, _reversal_mask(qd, still_rad_s, window))
    )
    for regime, values, edges, unit in (
        ("speed", speed, speed_edges_rad_s, "rad/s"),
        ("acceleration", np.abs(qdd), acceleration_edges_rad_s2, "rad/s²"),
    ):
        bounds = (0.0, *edges, np.inf)
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            label = f"{lo:g}–{hi:g} {unit}" if np.isfinite(hi) else f"≥ {lo:g} {unit}"
            bands.append(_band(regime, label, residual, (values >= lo) & (values < hi)))
    quantiles = np.linspace(0.0, 1.0, angle_bins + 1)
    for regime, angle in (("angle", q), ("angle_s1", np.repeat(q[:, S1 : S1 + 1], q.shape[1], axis=1))):
        edges = np.quantile(angle, quantiles, axis=0)  # (bins + 1, 7)
        for b in range(angle_bins):
            lo, hi = edges[b], edges[b + 1]
            inside = (angle >= lo) & ((angle < hi) if b < angle_bins - 1 else (angle <= hi))
            label = f"bin {b + 1}/{angle_bins}" + (
                f" q_s1 {lo[S1]:+.2f}…{hi[S1]:+.2f} rad" if regime == "angle_s1" else " of the joint's range"
            )
            bands.append(_band(regime, label, residual, inside))
    return GapSummary(tuple(joint_names), rms, mean, share, systematic_rms, noise_rms, tuple(bands))
