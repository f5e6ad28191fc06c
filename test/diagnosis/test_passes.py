"""The passes over the recordings (diagnosis/passes.py) and the held-out figures diagnose() reports
from them, against residuals computed without the package's dynamics: Pinocchio's RNEA with q̈ the
first difference of q̇ (raw) or the central difference of q̇ low-passed by scipy's sosfiltfilt at
the chosen cut-off (denoised), over every test recording's samples."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_recordings import friction_diagnosis, lowpassed_velocity, recording, reference_residuals

from baxter_dynamics_ros.diagnosis.gap_analysis import angle_histogram, quantile_edges, values_in_bins, wanted_bins
from baxter_dynamics_ros.diagnosis.passes import test_figures as pass_test_figures
from baxter_dynamics_ros.diagnosis.result import DiagnosisResult
from baxter_dynamics_ros.diagnosis.sources import InMemory
from baxter_dynamics_ros.diagnosis.statistics import CHUNK, column_layout
from baxter_dynamics_ros.diagnosis.validation import validation_arm

N = 7


@pytest.fixture(scope="module")
def arm():
    return validation_arm()


@pytest.fixture(scope="module")
def run() -> tuple[DiagnosisResult, list, list]:
    return friction_diagnosis()


def _rms(residuals: list[np.ndarray]) -> np.ndarray:
    r = np.vstack(residuals)
    return np.sqrt(np.mean(r**2, axis=0))


def test_test_rms_figures_are_of_the_test_recordings(arm, run) -> None:
    """The rigid model's held-out RMS (raw q̈: baseline; denoised: acceleration_noise's "after" and
    the first physical effect's "before") is that of the test recordings' own residuals, and the
    training baseline that of the training recordings'. The two sets differ by more than the tolerance."""
    result, train, test = run
    raw_test, den_test = zip(*(reference_residuals(arm, rec, result.cutoff_hz) for _, rec in test))
    raw_train, den_train = zip(*(reference_residuals(arm, rec, result.cutoff_hz) for _, rec in train))
    assert np.max(np.abs(_rms(list(den_test)) / _rms(list(den_train)) - 1)) > 0.01
    np.testing.assert_allclose(result.baseline_test_rms, _rms(list(raw_test)), rtol=1e-5)
    np.testing.assert_allclose(result.baseline_train_rms, _rms(list(raw_train)), rtol=1e-5)
    np.testing.assert_allclose(result.denoised_test_rms, _rms(list(den_test)), rtol=1e-5)
    noise = next(e for e in result.effects if e.name == "acceleration_noise")
    np.testing.assert_allclose(noise.test_rms_before, _rms(list(raw_test)), rtol=1e-5)
    np.testing.assert_allclose(noise.test_rms_after, _rms(list(den_test)), rtol=1e-5)
    first = max((e for e in result.selected() if e.name != "acceleration_noise"), key=lambda e: e.share)
    np.testing.assert_allclose(first.test_rms_before, _rms(list(den_test)), rtol=1e-5)


def test_gap_summaries_count_every_test_file_once(arm, run) -> None:
    """The gap summaries (raw and denoised q̈) are the RMS and mean over all test recordings' samples,
    each once; the residual series runs through the test recordings one after the other (each file's
    times following the previous file's end) and holds each one's raw residual. The test files differ
    in length and level, so a file dropped or counted twice changes the figures."""
    result, _, test = run
    raw, den = zip(*(reference_residuals(arm, rec, result.cutoff_hz) for _, rec in test))
    assert len({len(rec) for _, rec in test}) == len(test)
    np.testing.assert_allclose(result.gap.rms, _rms(list(raw)), rtol=1e-5)
    np.testing.assert_allclose(result.gap.mean, np.vstack(raw).mean(axis=0), rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(result.gap_filtered.rms, _rms(list(den)), rtol=1e-5)
    series = result.test_series
    np.testing.assert_allclose(series["baseline"], np.vstack(raw), rtol=1e-6, atol=1e-7)
    first, second = test[0][1], test[1][1]
    t = np.concatenate([first.stamps_s - first.stamps_s[0], second.stamps_s - second.stamps_s[0] + (first.stamps_s[-1] - first.stamps_s[0]) + 0.01])  # 100 Hz
    np.testing.assert_allclose(series["t_s"], t, atol=1e-9)


def test_figures_of_a_recording_longer_than_a_chunk(arm) -> None:
    """test_figures on a 9000-sample recording (longer than the pass's 8192-row chunk) with viscous
    friction x fitted and a cut-off per joint: every sample's final residual is the denoised one
    (joint j's with every q̈ at its cut-off) minus x ⊙ q̇ (q̇_j low-passed at joint j's cut-off by
    scipy), and the gap sums count all 9000 samples."""
    rec = recording(arm, 71, 90.0, viscous=1.0)
    assert len(rec) > CHUNK
    layout = column_layout()
    viscous = next(c for c in layout.candidates if c.name == "viscous_friction")
    x = np.array([1.0, 1.1, 0.9, 1.0, 0.8, 1.2, 1.0])
    hist = angle_histogram(rec.q)
    wanted = wanted_bins(hist)
    edges = quantile_edges(hist, wanted, [values_in_bins(rec.q, wanted)])
    cutoff = (4.0, 1.5, 4.0, 6.0, 12.0, 8.0, 12.0)
    figures = pass_test_figures(arm, layout, cutoff, np.asarray(viscous.columns), x, edges, 1, InMemory("long", rec))
    raw, den = reference_residuals(arm, rec, cutoff)
    assert figures.raw.samples == figures.filtered.samples == len(rec)
    np.testing.assert_allclose(figures.series["final"], den - x * lowpassed_velocity(rec, cutoff), rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(figures.filtered.sum_r2, np.sum(den**2, axis=0), rtol=1e-6)
    assert figures.end_s == pytest.approx(rec.stamps_s[-1] + 0.01)


def test_a_slow_test_recording_bounds_every_cutoff(arm) -> None:
    """Training at 100 Hz, testing at 12 Hz: the cut-offs are chosen among those every recording can
    be filtered at (below 0.45 · 12 Hz), not the training files' own best above the test file's
    Nyquist rate (which failed in the test pass); the denoised test figure is the reference one there."""
    from baxter_dynamics_ros.diagnosis.procedure import diagnose

    train = [("A", recording(arm, 81)), ("B", recording(arm, 82))]
    slow = recording(arm, 83, 30.0, rate_hz=12.0)
    result = diagnose(arm, train, [("slow", slow)])
    assert max(result.cutoff_hz) < 0.45 * 12.0
    np.testing.assert_allclose(result.denoised_test_rms, _rms([reference_residuals(arm, slow, result.cutoff_hz)[1]]), rtol=1e-6)


def test_a_recording_too_slow_for_the_filter_is_refused(arm) -> None:
    """At 3 Hz no cut-off of the grid (1.5 Hz and up) lies below 0.45 of the rate: refused, saying so."""
    from baxter_dynamics_ros.diagnosis.passes import check_recording
    from baxter_dynamics_ros.errors import DiagnosisError

    with pytest.raises(DiagnosisError, match=r"slow: sampled at 3 Hz; .* needs a rate above 3.33 Hz"):
        check_recording(arm, "slow", recording(arm, 84, 100.0, rate_hz=3.0), "test")
