"""The bounds of a plausible sample, defined once (core/plausibility.py), and the pieces a recording
is split into at the gaps they leave (issue 22 item 1)."""

from __future__ import annotations

import numpy as np
import pytest

from baxter_dynamics_ros.core.acceleration import zero_phase_acceleration
from baxter_dynamics_ros.core.arm_model import load_arm_model
from baxter_dynamics_ros.core.plausibility import package_bounds, plausible_recording, screen_samples
from baxter_dynamics_ros.errors import RecordingError
from baxter_dynamics_ros.monitoring.pipeline import ResidualPipeline

RIGHT = load_arm_model("right")


def states(n: int = 400) -> tuple[np.ndarray, ...]:
    t = np.arange(n) * 0.01
    q = 0.3 * np.sin(np.outer(t, np.linspace(0.5, 1.1, 7))) + np.array([0, -0.5, 0, 1.2, 0, 0.5, 0])
    qd = 0.3 * np.linspace(0.5, 1.1, 7) * np.cos(np.outer(t, np.linspace(0.5, 1.1, 7)))
    return (np.round(t * 1e9).astype(np.int64), q, qd, np.full((n, 7), 5.0))


def test_the_node_and_the_readers_share_one_definition_of_the_bounds() -> None:
    assert np.array_equal(ResidualPipeline(RIGHT)._bounds, package_bounds("right"))
    assert package_bounds("right")[5].tolist() == (3 * RIGHT.effort_limit_nm).tolist()


def test_each_absurd_sample_is_counted_once_by_its_first_cause() -> None:
    _, q, qd, effort = states()
    q[3, 0], qd[4, 2], effort[5, 1], effort[6, 6], q[7, 1] = 10.0, 1e3, 1e30, np.nan, np.inf
    screening = screen_samples(package_bounds("right"), q, qd, effort)
    assert np.flatnonzero(~screening.keep).tolist() == [3, 4, 5, 6, 7]
    assert screening.counts == {"NaN or inf": 2, "position beyond the joint limits": 1, "velocity beyond 3 × the velocity limit": 1, "effort beyond 3 × the effort limit": 1}


def test_a_recording_is_filtered_piece_by_piece_at_the_gap_a_skipped_sample_leaves() -> None:
    stamps, q, qd, effort = states()
    effort[150, 1] = 1e30
    notes: list[str] = []
    rec = plausible_recording("f.csv", "right", stamps, q, qd, effort, notes.append)
    assert notes == ["WARNING: f.csv: 1 of 400 samples skipped as implausible (1 effort beyond 3 × the effort limit); the recording is split into pieces at them"]
    assert len(rec) == 399 and rec.segments == ((0, 150), (150, 399))
    qdd = zero_phase_acceleration(rec.qd, rec.rate_hz, 5.0, segments=rec.segments)
    np.testing.assert_array_equal(qdd[:150], zero_phase_acceleration(qd[:150], 100.0, 5.0))
    np.testing.assert_array_equal(qdd[150:], zero_phase_acceleration(qd[151:], 100.0, 5.0))


def test_a_recording_more_than_a_tenth_implausible_is_refused() -> None:
    stamps, q, qd, effort = states()
    effort[::9, 0] = 1e30  # 45 of 400: 11 %
    with pytest.raises(RecordingError, match="45 of 400 samples are implausible .*more than 10%"):
        plausible_recording("f.csv", "right", stamps, q, qd, effort)


def test_jittery_stamps_are_cut_at_a_real_gap_only() -> None:
    """Receive-time stamps jittering by 25 % of the period (a loaded machine) make steps of 1.5
    periods every few hundred samples; only the lost run of three samples is a gap."""
    stamps, q, qd, effort = states(2000)
    jitter = np.random.default_rng(3).normal(0.0, 0.25 * 1e7, len(stamps)).astype(np.int64)
    stamps = np.sort(stamps + jitter)
    keep = np.r_[0:1200, 1203:2000]
    steps = np.diff(stamps[keep])
    assert np.count_nonzero(steps > 1.5 * np.median(steps)) > 3  # the plain 1.5-period rule would cut here
    rec = plausible_recording("f.csv", "right", stamps[keep], q[keep], qd[keep], effort[keep])
    assert rec.segments == ((0, 1200), (1200, 1997))
