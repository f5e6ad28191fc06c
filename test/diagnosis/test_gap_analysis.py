"""Where the gap lies (diagnosis/gap_analysis.py), on hand-made signals whose regimes are counted here.

Each regime's samples are found by a rule written out in the test (a loop over samples for the
reversals), and the bands' fractions, RMS and means are compared with those samples' own figures;
the systematic/noise split with a residual of two sines on either side of its 2 Hz cut-off.
"""

from __future__ import annotations

import numpy as np
import pytest

from baxter_dynamics_ros.diagnosis.gap_analysis import HISTOGRAM_BINS, GapOptions, angle_histogram, angle_span, share_outside, summarise_gap

RATE_HZ = 100.0
N_SAMPLES = 3000
JOINTS = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")


@pytest.fixture(scope="module")
def signals() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(residual, q, q̇, q̈), each (N_SAMPLES, 7): joint j moves as a sine of its own frequency and
    amplitude, with a pause (q̇ = 0) at s0; the residual is random, unrelated to the motion."""
    t = np.arange(N_SAMPLES) / RATE_HZ
    freq = np.linspace(0.1, 0.7, 7)
    amp = np.linspace(0.3, 1.2, 7)
    q = amp * np.sin(2 * np.pi * freq * t[:, None]) + np.linspace(-0.5, 0.5, 7)
    qd = amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * t[:, None])
    qd[1000:1300, 0] = 0.0  # a pause at s0
    qdd = np.gradient(qd, 1.0 / RATE_HZ, axis=0)
    residual = np.random.default_rng(5).normal(0.3, 1.0, (N_SAMPLES, 7)) * np.linspace(0.5, 2.0, 7)
    return residual, q, qd, qdd


def band(summary, regime: str, label_start: str):
    return next(b for b in summary.bands if b.regime == regime and b.label.startswith(label_start))


def check(b, inside: np.ndarray, residual: np.ndarray) -> None:
    """A band's fraction, RMS and mean (7,) against its samples ``inside`` (N, 7) bool."""
    np.testing.assert_allclose(b.fraction, inside.mean(axis=0), rtol=0, atol=1e-15)
    for j in range(7):
        r = residual[inside[:, j], j]
        if len(r):
            np.testing.assert_allclose(b.rms[j], np.sqrt(np.mean(r**2)), rtol=1e-12)
            np.testing.assert_allclose(b.mean[j], r.mean(), rtol=1e-12, atol=1e-15)
        else:
            assert np.isnan(b.rms[j]) and np.isnan(b.mean[j])


def reversals_by_hand(qd: np.ndarray, still: float, window: int) -> np.ndarray:
    """(N,) samples within ``window`` samples of a change of the sign of the last moving q̇."""
    flips = []
    last = 0.0
    for k, v in enumerate(qd):
        if abs(v) >= still:
            s = np.sign(v)
            if last and s != last:
                flips.append(k)
            last = s
    out = np.zeros(len(qd), dtype=bool)
    for k in flips:
        out[max(0, k - window) : k + window + 1] = True
    return out


def test_whole_residual_and_shares(signals) -> None:
    residual, q, qd, qdd = signals
    s = summarise_gap(JOINTS, residual, q, qd, qdd, RATE_HZ)
    rms = np.sqrt(np.mean(residual**2, axis=0))
    np.testing.assert_allclose(s.rms, rms, rtol=1e-12)
    np.testing.assert_allclose(s.mean, residual.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(s.share, rms**2 / np.sum(rms**2), rtol=1e-12)
    assert s.joint_names == JOINTS


def test_still_reversal_speed_and_acceleration_bands(signals) -> None:
    residual, q, qd, qdd = signals
    o = GapOptions()
    s = summarise_gap(JOINTS, residual, q, qd, qdd, RATE_HZ)
    check(band(s, "still", "|qd|"), np.abs(qd) < o.still_rad_s, residual)
    window = round(o.reversal_window_s * RATE_HZ)
    by_hand = np.stack([reversals_by_hand(qd[:, j], o.still_rad_s, window) for j in range(7)], axis=1)
    # s0 pauses from 10 s to 13 s and resumes the other way: the reversal is where it resumes
    assert by_hand[1300, 0] and not by_hand[1000 : 1300 - window, 0].any()
    check(band(s, "reversal", "within"), by_hand, residual)
    check(band(s, "speed", "0.1–0.3"), (np.abs(qd) >= 0.1) & (np.abs(qd) < 0.3), residual)
    check(band(s, "speed", "≥ 0.7"), np.abs(qd) >= 0.7, residual)
    check(band(s, "acceleration", "0–0.5"), np.abs(qdd) < 0.5, residual)
    check(band(s, "acceleration", "2–5"), (np.abs(qdd) >= 2.0) & (np.abs(qdd) < 5.0), residual)


def test_a_reversal_through_a_pause_counts_where_the_motion_resumes() -> None:
    """q̇ +, then still for 1 s, then −: the reversal is at the first moving sample of the other sign."""
    qd = np.concatenate([np.full(200, 0.5), np.zeros(100), np.full(200, -0.5)])[:, None] * np.ones(7)
    q = np.cumsum(qd, axis=0) / RATE_HZ
    residual = np.random.default_rng(1).normal(size=qd.shape)
    s = summarise_gap(JOINTS, residual, q, qd, np.zeros_like(qd), RATE_HZ)
    inside = np.zeros(500, dtype=bool)
    inside[300 - 5 : 300 + 6] = True
    check(band(s, "reversal", "within"), np.repeat(inside[:, None], 7, axis=1), residual)


def test_angle_bins_hold_equal_counts_and_s1_bins_use_q_s1(signals) -> None:
    residual, q, qd, qdd = signals
    s = summarise_gap(JOINTS, residual, q, qd, qdd, RATE_HZ)
    for b in range(4):
        lo, hi = np.quantile(q, [b / 4, (b + 1) / 4], axis=0)
        inside = (q >= lo) & ((q < hi) if b < 3 else (q <= hi))
        check(band(s, "angle", f"bin {b + 1}/4"), inside, residual)
        s1 = q[:, 1:2]
        lo1, hi1 = np.quantile(s1, [b / 4, (b + 1) / 4])
        inside1 = np.repeat((s1 >= lo1) & ((s1 < hi1) if b < 3 else (s1 <= hi1)), 7, axis=1)
        angle_s1 = next(x for x in s.bands if x.regime == "angle_s1" and x.label.startswith(f"bin {b + 1}/4"))
        check(angle_s1, inside1, residual)
        assert f"q_s1 {lo1:+.2f}…{hi1:+.2f} rad" in angle_s1.label
        np.testing.assert_allclose(angle_s1.fraction, 0.25, atol=1.0 / N_SAMPLES)


def test_systematic_part_and_noise_split_at_the_cutoff() -> None:
    """A 0.3 Hz sine of 0.8 N·m and a 20 Hz one of 0.3 N·m: the systematic part (below 2 Hz) is the
    first, the rest the second (RMS amplitude/√2, within 2 % — the filter's edges)."""
    t = np.arange(6000) / RATE_HZ
    residual = (0.8 * np.sin(2 * np.pi * 0.3 * t) + 0.3 * np.sin(2 * np.pi * 20 * t))[:, None] * np.ones(7)
    q = np.zeros_like(residual)
    s = summarise_gap(JOINTS, residual, q, q, q, RATE_HZ)
    np.testing.assert_allclose(s.systematic_rms, 0.8 / np.sqrt(2), rtol=0.02)
    np.testing.assert_allclose(s.noise_rms, 0.3 / np.sqrt(2), rtol=0.02)


def test_the_range_covered_and_the_share_outside_it_agree_with_the_angles_to_a_bin() -> None:
    """angle_span brackets each joint's lowest and highest angle within one bin (3 mrad); the share
    outside it lies between the share strictly outside the training angles and the share outside them
    widened by a bin, both counted here from the angles themselves."""
    width = 4 * np.pi / HISTOGRAM_BINS
    rng = np.random.default_rng(11)
    train = [rng.uniform(-0.8, 0.3, (500, 7)), rng.uniform(-0.2, 0.9, (400, 7))]
    test = rng.uniform(-1.2, 1.0, (700, 7))
    test[:50, 3] = train[0][:50, 3]  # samples on the training data's own values count as inside
    span = angle_span(angle_histogram(train[0]) + angle_histogram(train[1]))
    low, high = np.min([t.min(axis=0) for t in train], axis=0), np.max([t.max(axis=0) for t in train], axis=0)
    assert np.all(span[0] <= low) and np.all(low < span[0] + width)
    assert np.all(span[1] > high) and np.all(high >= span[1] - width)
    share = share_outside(angle_histogram(test), span)
    strict = np.mean((test < low) | (test > high), axis=0)
    loose = np.mean((test < low - width) | (test > high + width), axis=0)
    assert np.all(loose <= share) and np.all(share <= strict), (loose, share, strict)
    assert 0.15 < share.min() and share.max() < 0.3  # about (0.4 + 0.1) / 2.2 of -1.2…1.0 lies outside -0.8…0.9
    np.testing.assert_array_equal(share_outside(angle_histogram(train[0]), span), 0.0)
    with pytest.raises(ValueError, match="covers no range"):
        angle_span(np.zeros((2, 7, HISTOGRAM_BINS), dtype=np.int64))
