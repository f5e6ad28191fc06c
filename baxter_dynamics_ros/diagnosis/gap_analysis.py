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

Several recordings are summarised without holding them together: each is reduced to additive sums
(:func:`gap_sums`: counts, Σ r and Σ r² per band and joint, with its own filter and reversals, so
nothing is filtered across the seam of two recordings), the sums are added in the recordings'
order and finished by :func:`gap_summary`. The angle bins' edges are the quantiles of q over all
recordings, found exactly from per-recording histograms (:func:`angle_histogram`) and the values
in the few bins that hold a quantile (:func:`values_in_bins`, :func:`quantile_edges`). The same
histograms say what range of each joint the training recordings cover and how much of other data
lies outside it (:func:`angle_span`, :func:`share_outside`): there a fit extrapolates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.acceleration import zero_phase_lowpass
from ..core.joints import S1

__all__ = [
    "Band", "GapOptions", "GapSums", "GapSummary", "angle_histogram", "angle_span", "gap_sums", "gap_summary", "quantile_edges",
    "share_outside", "summarise_gap", "values_in_bins", "wanted_bins",
]



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


@dataclass(frozen=True)
class GapOptions:
    """The regime thresholds (module docstring); the angle bins' edges come separately."""

    still_rad_s: float = 0.02
    reversal_window_s: float = 0.05
    speed_edges_rad_s: tuple[float, ...] = (0.1, 0.3, 0.7)
    acceleration_edges_rad_s2: tuple[float, ...] = (0.5, 2.0, 5.0)
    angle_bins: int = 4
    systematic_cutoff_hz: float = 2.0


@dataclass(frozen=True)
class GapSums:
    """Additive statistics of a residual over some samples (arrays (7,) or (bands, 7)).

    samples: count; sum_r, sum_r2: Σ r and Σ r²; systematic_r2, noise_r2: Σ of the squared
    systematic part and rest; labels: (regime, label) per band; band_count, band_r, band_r2:
    per band the samples in it, Σ r and Σ r² over them.
    """

    samples: int
    sum_r: np.ndarray
    sum_r2: np.ndarray
    systematic_r2: np.ndarray
    noise_r2: np.ndarray
    labels: tuple[tuple[str, str], ...]
    band_count: np.ndarray
    band_r: np.ndarray
    band_r2: np.ndarray

    def __add__(self, other: GapSums) -> GapSums:
        if self.labels != other.labels:
            raise ValueError("gap sums of different bands cannot be added")
        return GapSums(
            self.samples + other.samples, self.sum_r + other.sum_r, self.sum_r2 + other.sum_r2,
            self.systematic_r2 + other.systematic_r2, self.noise_r2 + other.noise_r2, self.labels,
            self.band_count + other.band_count, self.band_r + other.band_r, self.band_r2 + other.band_r2,
        )  # fmt: skip


def _angles(q: np.ndarray) -> tuple[tuple[str, np.ndarray], ...]:
    """The angle regimes' values (N, 7): each joint's own angle, and q_s1 for every joint."""
    return (("angle", q), ("angle_s1", np.repeat(q[:, S1 : S1 + 1], q.shape[1], axis=1)))


def gap_sums(
    residual: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    rate_hz: float,
    angle_edges: np.ndarray,
    options: GapOptions = GapOptions(),
    segments: Sequence[tuple[int, int]] | None = None,
) -> GapSums:
    """The sums of one recording's residual (N, 7) N·m at states q, qd, qdd (N, 7) sampled at rate_hz.

    angle_edges: (2, angle_bins + 1, 7) the edges of the ``angle`` and ``angle_s1`` bins
    (:func:`quantile_edges`); segments: the recording's runs between gaps
    (:attr:`~baxter_dynamics_ros.core.recording.Recording.segments`), split into bands each on its
    own, None for one. Joint by joint: the temporaries of an hour-long recording are (N,)."""
    residual = np.asarray(residual, dtype=float)
    if len(residual) < 16:
        raise ValueError(f"need at least 16 samples to summarise a residual, got {len(residual)}")
    joints = [
        _joint_sums(residual[:, j], q[:, j], q[:, S1], qd[:, j], qdd[:, j], rate_hz, angle_edges[:, :, j], angle_edges[:, :, S1], options, segments)
        for j in range(residual.shape[1])
    ]
    labels = joints[0][0]
    totals, count, band_r, band_r2 = (np.stack([joint[k] for joint in joints], axis=-1) for k in range(1, 5))
    return GapSums(len(residual), *totals, labels, count, band_r, band_r2)


def _joint_sums(
    r: np.ndarray,
    q: np.ndarray,
    q_s1: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    rate_hz: float,
    edges: np.ndarray,
    edges_s1: np.ndarray,
    o: GapOptions,
    segments: Sequence[tuple[int, int]] | None = None,
) -> tuple[tuple[tuple[str, str], ...], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One joint's part of :func:`gap_sums` from its (N,) columns: the labels, (4,) Σ r, Σ r², the
    systematic part's and the rest's Σ², and per band its count, Σ r and Σ r²; edges (2, bins + 1) of
    its angle bins, edges_s1 those of s1 (the ``angle_s1`` bins' labels)."""
    systematic = zero_phase_lowpass(r, rate_hz, o.systematic_cutoff_hz, segments=segments)
    squared = r**2
    totals = np.array([r.sum(), squared.sum(), (systematic**2).sum(), ((r - systematic) ** 2).sum()])
    del systematic
    labels: list[tuple[str, str]] = []
    count, band_r, band_r2 = [], [], []

    def band(regime: str, label: str, mask: np.ndarray) -> None:
        labels.append((regime, label))
        count.append(np.count_nonzero(mask))
        band_r.append(r[mask].sum())
        band_r2.append(squared[mask].sum())

    speed = np.abs(qd)
    band("still", f"|qd| < {o.still_rad_s:g} rad/s", speed < o.still_rad_s)
    window = max(1, int(round(o.reversal_window_s * rate_hz)))
    band("reversal", f"within {o.reversal_window_s:g} s of a reversal", _reversal_mask(qd[:, None], o.still_rad_s, window)[:, 0])
    for regime, values, bin_edges, unit in (
        ("speed", speed, o.speed_edges_rad_s, "rad/s"),
        ("acceleration", np.abs(qdd), o.acceleration_edges_rad_s2, "rad/s²"),
    ):
        bounds = (0.0, *bin_edges, np.inf)
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            label = f"{lo:g}–{hi:g} {unit}" if np.isfinite(hi) else f"≥ {lo:g} {unit}"
            band(regime, label, (values >= lo) & (values < hi))
    for (regime, angle), angle_edges, s1_edges in zip((("angle", q), ("angle_s1", q_s1)), edges, edges_s1):
        for b in range(o.angle_bins):
            lo, hi = angle_edges[b], angle_edges[b + 1]
            inside = (angle >= lo) & ((angle < hi) if b < o.angle_bins - 1 else (angle <= hi))
            label = f"bin {b + 1}/{o.angle_bins}" + (f" q_s1 {s1_edges[b]:+.2f}…{s1_edges[b + 1]:+.2f} rad" if regime == "angle_s1" else " of the joint's range")
            band(regime, label, inside)
    return tuple(labels), totals, np.array(count), np.array(band_r), np.array(band_r2)


def gap_summary(joint_names: tuple[str, ...], sums: GapSums) -> GapSummary:
    """The summary of (the added) sums: RMS, mean, shares and bands; NaN in an empty band."""
    n = sums.samples
    rms = np.sqrt(sums.sum_r2 / n)
    mean = sums.sum_r / n
    share = rms**2 / max(float(np.sum(rms**2)), 1e-300)
    safe = np.maximum(sums.band_count, 1)
    band_rms = np.sqrt(sums.band_r2 / safe)
    band_mean = sums.band_r / safe
    empty = sums.band_count == 0
    band_rms[empty] = band_mean[empty] = np.nan
    bands = tuple(
        Band(regime, label, sums.band_count[k] / n, band_rms[k], band_mean[k]) for k, (regime, label) in enumerate(sums.labels)
    )
    return GapSummary(tuple(joint_names), rms, mean, share, np.sqrt(sums.systematic_r2 / n), np.sqrt(sums.noise_r2 / n), bands)


# ----------------------------------------------------------------------------- exact quantiles by parts
#: Histogram bins per joint and angle regime for the quantiles (the range of a float is split evenly).
HISTOGRAM_BINS = 4096
#: The histograms' range, rad: every joint angle of any arm lies within it.
HISTOGRAM_RANGE_RAD = (-2.0 * np.pi, 2.0 * np.pi)


def _bin_of(values: np.ndarray) -> np.ndarray:
    lo, hi = HISTOGRAM_RANGE_RAD
    return np.clip(((values - lo) / (hi - lo) * HISTOGRAM_BINS).astype(np.int64), 0, HISTOGRAM_BINS - 1)


def angle_histogram(q: np.ndarray) -> np.ndarray:
    """(2, 7, HISTOGRAM_BINS) counts of one recording's angle values (q (N, 7) rad), per regime and column."""
    out = np.zeros((2, q.shape[1], HISTOGRAM_BINS), dtype=np.int64)
    for r, (_, angle) in enumerate(_angles(q)):
        bins = _bin_of(angle)
        for j in range(q.shape[1]):
            out[r, j] = np.bincount(bins[:, j], minlength=HISTOGRAM_BINS)
    return out


def angle_span(histogram: np.ndarray) -> np.ndarray:
    """(2, 7) rad: per joint, the lower edge of the lowest and the upper edge of the highest bin of
    its own angle that a histogram (:func:`angle_histogram`, or several added) holds samples in: the
    range its recordings cover, to a bin (4π / HISTOGRAM_BINS, 3 mrad)."""
    lo, hi = HISTOGRAM_RANGE_RAD
    width = (hi - lo) / HISTOGRAM_BINS
    counts = histogram[0]
    if not np.all(counts.any(axis=1)):
        raise ValueError("an empty histogram covers no range")
    first = np.argmax(counts > 0, axis=1)
    last = HISTOGRAM_BINS - 1 - np.argmax(counts[:, ::-1] > 0, axis=1)
    return np.stack([lo + first * width, lo + (last + 1) * width])


def share_outside(histogram: np.ndarray, span: np.ndarray) -> np.ndarray:
    """(7,) per joint, the share of a histogram's samples whose own angle lies in bins wholly outside
    ``span`` (:func:`angle_span` of other recordings): how much of them a fit on those extrapolates to."""
    lo, hi = HISTOGRAM_RANGE_RAD
    edges = lo + np.arange(HISTOGRAM_BINS + 1) * ((hi - lo) / HISTOGRAM_BINS)
    counts = histogram[0]
    outside = (edges[None, 1:] <= span[0][:, None] + 1e-12) | (edges[None, :-1] >= span[1][:, None] - 1e-12)
    return (counts * outside).sum(axis=1) / counts.sum(axis=1)


def _ranks(samples: int, bins: int) -> np.ndarray:
    """The order statistics (0-based) that numpy's linear quantiles at k / bins use, and the weights."""
    h = (samples - 1) * np.linspace(0.0, 1.0, bins + 1)
    low = np.floor(h).astype(np.int64)
    return np.stack([low, np.minimum(low + 1, samples - 1)]), h - low


def wanted_bins(histogram: np.ndarray, angle_bins: int = GapOptions.angle_bins) -> np.ndarray:
    """(2, 7, HISTOGRAM_BINS) bool: the bins that hold an order statistic of a quantile edge."""
    samples = int(histogram[0, 0].sum())
    ranks, _ = _ranks(samples, angle_bins)
    cum = np.cumsum(histogram, axis=-1)
    out = np.zeros(histogram.shape, dtype=bool)
    for r in range(histogram.shape[0]):
        for j in range(histogram.shape[1]):
            out[r, j, np.searchsorted(cum[r, j], ranks.ravel(), side="right")] = True
    return out


def values_in_bins(q: np.ndarray, wanted: np.ndarray) -> list[list[np.ndarray]]:
    """One recording's angle values (q (N, 7) rad) that fall in the wanted bins, per regime and column."""
    out = []
    for r, (_, angle) in enumerate(_angles(q)):
        bins = _bin_of(angle)
        out.append([angle[wanted[r, j][bins[:, j]], j] for j in range(q.shape[1])])
    return out


def quantile_edges(histogram: np.ndarray, wanted: np.ndarray, values: list[list[list[np.ndarray]]], angle_bins: int = GapOptions.angle_bins) -> np.ndarray:
    """(2, angle_bins + 1, 7) edges: numpy's linear quantiles at k / angle_bins of all recordings' angles.

    histogram: the recordings' added :func:`angle_histogram`; wanted: :func:`wanted_bins` of it;
    values: each recording's :func:`values_in_bins`, in the recordings' order."""
    samples = int(histogram[0, 0].sum())
    ranks, weight = _ranks(samples, angle_bins)
    cum = np.cumsum(histogram, axis=-1)
    edges = np.empty((histogram.shape[0], angle_bins + 1, histogram.shape[1]))
    for r in range(histogram.shape[0]):
        for j in range(histogram.shape[1]):
            held = np.sort(np.concatenate([v[r][j] for v in values]))  # every value in the wanted bins, in bin order
            before = np.concatenate([[0], cum[r, j]])[np.flatnonzero(wanted[r, j])]  # samples below each wanted bin
            start = np.concatenate([[0], np.cumsum(histogram[r, j][wanted[r, j]])[:-1]])  # its first value in held

            def order_statistic(k: int) -> float:
                b = np.searchsorted(before, k, side="right") - 1
                return float(held[start[b] + k - before[b]])

            for e in range(angle_bins + 1):
                a, b = order_statistic(int(ranks[0, e])), order_statistic(int(ranks[1, e]))
                t = weight[e]
                edges[r, e, j] = a + (b - a) * t if t < 0.5 else b - (b - a) * (1 - t)
    return edges


def summarise_gap(
    joint_names: tuple[str, ...],
    residual: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    rate_hz: float,
    options: GapOptions = GapOptions(),
) -> GapSummary:
    """Statistics of one residual (N, 7) N·m at states q, qd, qdd (N, 7) sampled at rate_hz."""
    quantiles = np.linspace(0.0, 1.0, options.angle_bins + 1)
    edges = np.stack([np.quantile(angle, quantiles, axis=0) for _, angle in _angles(np.asarray(q, dtype=float))])
    return gap_summary(joint_names, gap_sums(residual, q, qd, qdd, rate_hz, edges, options))
