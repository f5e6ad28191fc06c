"""The diagnosis by parts (issue 14 §2): one recording in memory at a time, sums that add up to the
whole, exact quantiles from per-recording histograms.

References are computed here with numpy on the recordings put together, not with the code's sums.
"""

from __future__ import annotations

import gc
import json
import weakref
from dataclasses import dataclass, field

import numpy as np
import pytest
from synthetic_recordings import reference_residuals

from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.diagnosis.gap_analysis import (
    GapOptions,
    angle_histogram,
    gap_sums,
    gap_summary,
    quantile_edges,
    values_in_bins,
    wanted_bins,
)
from baxter_dynamics_ros.diagnosis.procedure import diagnose
from baxter_dynamics_ros.diagnosis.statistics import CUTOFF_GRID_HZ, choose_cutoff, cutoff_scores
from baxter_dynamics_ros.diagnosis.validation import SCENARIOS, simulated_recordings, validation_arm


def test_quantile_edges_by_parts_are_numpys_of_the_whole() -> None:
    rng = np.random.default_rng(3)
    # Ties (values rounded to 1 mrad), values beyond the histogram's range, parts of very different sizes.
    parts = [np.round(rng.normal(0.0, 1.0, (n, 7)), 3) for n in (1001, 500, 37, 2)]
    parts[1][:5] = 9.0
    parts[2][:, 3] = -0.25
    whole = np.concatenate(parts)
    histogram = sum(angle_histogram(p) for p in parts)
    wanted = wanted_bins(histogram)
    edges = quantile_edges(histogram, wanted, [values_in_bins(p, wanted) for p in parts])
    quantiles = np.linspace(0.0, 1.0, GapOptions().angle_bins + 1)
    np.testing.assert_array_equal(edges[0], np.quantile(whole, quantiles, axis=0))
    np.testing.assert_array_equal(edges[1], np.quantile(np.repeat(whole[:, 1:2], 7, axis=1), quantiles, axis=0))


def test_gap_sums_of_parts_add_up_to_the_whole() -> None:
    rng = np.random.default_rng(4)
    parts = [(rng.normal(0, 1, (n, 7)), rng.uniform(-1, 1, (n, 7)), rng.normal(0, 0.3, (n, 7)), rng.normal(0, 2, (n, 7))) for n in (400, 250)]
    edges = np.stack([np.tile(np.array([-1.0, -0.5, 0.0, 0.5, 1.0])[:, None], (1, 7))] * 2)
    sums = [gap_sums(r, q, qd, qdd, 100.0, edges) for r, q, qd, qdd in parts]
    summary = gap_summary(tuple(f"j{k}" for k in range(7)), sums[0] + sums[1])
    r = np.concatenate([p[0] for p in parts])
    qd = np.concatenate([p[2] for p in parts])
    np.testing.assert_allclose(summary.rms, np.sqrt(np.mean(r**2, axis=0)), rtol=1e-12)
    np.testing.assert_allclose(summary.mean, r.mean(axis=0), rtol=1e-12)
    band = next(b for b in summary.bands if b.regime == "speed" and b.label.startswith("0.1–0.3"))
    inside = (np.abs(qd) >= 0.1) & (np.abs(qd) < 0.3)
    np.testing.assert_allclose(band.fraction, inside.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(band.rms, np.sqrt((np.where(inside, r, 0.0) ** 2).sum(axis=0) / inside.sum(axis=0)), rtol=1e-12)


@pytest.mark.parametrize("scenario", [SCENARIOS[0], SCENARIOS[9]], ids=[SCENARIOS[0].label, SCENARIOS[9].label])
def test_the_cutoff_by_parts_is_the_best_of_the_whole(scenario) -> None:
    """Each joint's cut-off chosen from per-recording scores is the grid's best for that joint on all
    training data together: the squared error of Pinocchio's rigid residual (q̇ filtered by scipy)
    less its least-squares fit, per recording, on an offset and at s1 on [1, q, cos q, sin q] of q_s1,
    torque no filter changes. With a strong s1 spring, the plain residual's choice at s1 differs."""
    arm = validation_arm()
    recs = [r for _, r in simulated_recordings(scenario, scenario.train, scenario.per_recording[:3])]
    sse, plain = [], []
    for cutoff in CUTOFF_GRID_HZ:
        left, raw = np.zeros(7), np.zeros(7)
        for r in recs:
            residual = reference_residuals(arm, r, cutoff)[1]
            q1 = r.q[:, 1]
            for j in range(7):
                basis = np.column_stack([np.ones(len(r)), q1, np.cos(q1), np.sin(q1)]) if j == 1 else np.ones((len(r), 1))
                fitted = basis @ np.linalg.pinv(basis) @ residual[:, j]
                left[j] += np.sum((residual[:, j] - fitted) ** 2)
                raw[j] += np.sum(residual[:, j] ** 2)
        sse.append(left)
        plain.append(raw)
    best = tuple(CUTOFF_GRID_HZ[k] for k in np.argmin(np.array(sse), axis=0))
    assert len(set(best)) > 1  # the joints differ here, so one cut-off for all cannot pass
    assert choose_cutoff([cutoff_scores(arm, r) for r in recs], min(r.rate_hz for r in recs)) == best
    if "s1_spring" in scenario.effects:
        assert CUTOFF_GRID_HZ[int(np.argmin(np.array(plain)[:, 1]))] != best[1]


@dataclass
class _Watched:
    """A source that counts its reads and checks that no recording it gave out earlier is still alive."""

    label: str
    recording: Recording
    alive: list = field(default_factory=list)  # shared by all the sources of one run
    reads: int = 0

    def read(self) -> Recording:
        gc.collect()
        held = [ref for ref in self.alive if ref() is not None]
        assert not held, f"reading {self.label} while {len(held)} recording(s) read before are still held"
        self.reads += 1
        copy = Recording(self.recording.side, self.recording.joint_names, self.recording.stamps_ns, self.recording.q, self.recording.qd, self.recording.effort)
        self.alive.append(weakref.ref(copy))
        return copy


def test_the_diagnosis_holds_one_recording_at_a_time() -> None:
    """Every read finds the recordings read before released, each training file is read twice and
    each test file three times (checks and scores; statistics; held-out figures), the result is
    that of the same recordings given in memory, and its rigid-model figures are those of Pinocchio's
    residuals of the recordings put together (``synthetic_recordings.reference_residuals``)."""
    scenario = SCENARIOS[0]
    train = simulated_recordings(scenario, scenario.train, scenario.per_recording[:3])
    test = simulated_recordings(scenario, scenario.test, scenario.per_recording[3:])
    alive: list = []
    train_sources = [_Watched(label, rec, alive) for label, rec in train]
    test_sources = [_Watched(label, rec, alive) for label, rec in test]
    streamed = diagnose(validation_arm(), train_sources, test_sources)
    assert [s.reads for s in train_sources] == [2] * 3 and [s.reads for s in test_sources] == [3] * 2
    in_memory = diagnose(validation_arm(), train, test)
    assert json.dumps(streamed.to_dict()) == json.dumps(in_memory.to_dict())  # NaN (an empty band) written alike
    # The streamed figures against the recordings put together, without the diagnosis' code:
    # Pinocchio's residuals with the paper's and with scipy's filtered q̈ at the chosen cut-off.
    arm = validation_arm()
    rms = lambda rs: np.sqrt(np.mean(np.vstack(rs) ** 2, axis=0))  # noqa: E731
    raw_train = [reference_residuals(arm, rec, streamed.cutoff_hz)[0] for _, rec in train]
    raw_test, den_test = zip(*(reference_residuals(arm, rec, streamed.cutoff_hz) for _, rec in test))
    np.testing.assert_allclose(streamed.baseline_train_rms, rms(raw_train), rtol=1e-5)
    np.testing.assert_allclose(streamed.baseline_test_rms, rms(raw_test), rtol=1e-5)
    np.testing.assert_allclose(streamed.denoised_test_rms, rms(den_test), rtol=1e-5)
    np.testing.assert_allclose(streamed.gap.rms, rms(raw_test), rtol=1e-5)
    np.testing.assert_allclose(streamed.gap_filtered.rms, rms(den_test), rtol=1e-5)
    np.testing.assert_allclose(streamed.test_series["baseline"], np.vstack(raw_test), rtol=1e-6, atol=1e-7)
