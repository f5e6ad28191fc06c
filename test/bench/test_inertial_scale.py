"""bench/inertial_scale.py on synthetic recordings with a planted scale of the inertial torque."""

from __future__ import annotations

import numpy as np
import pytest
from repo_paths import SHARED

from bench.inertial_scale import inertial_scale, main
from bench.plain_fit import UrdfArm

URDF = SHARED / "reference" / "baxter.urdf"
RATE_HZ = 100.0


@pytest.fixture(scope="module")
def arm() -> UrdfArm:
    if not URDF.is_file():
        pytest.skip(f"Baxter's URDF is not at {URDF} (../shared/reference beside the checkout)")
    return UrdfArm.from_urdf("left", URDF)


@pytest.mark.parametrize("planted", [0.0, -0.2])
def test_recovers_a_planted_scale_of_the_inertial_torque(arm: UrdfArm, planted: float) -> None:
    """Effort = RNEA at the exact q̈ + planted·(its inertial part) + an offset and Coulomb friction
    at every joint + noise; sinusoids of 0.2–0.5 Hz: the shoulder and elbow joints' coefficient is
    the planted one (the 4 Hz filter costs a little of the inertial torque, well within 0.02)."""
    rng = np.random.default_rng(3)
    t = np.arange(int(30 * RATE_HZ)) / RATE_HZ
    lo, hi = arm.model.lowerPositionLimit, arm.model.upperPositionLimit
    q = np.tile(0.5 * (lo + hi), (len(t), 1))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    for _ in range(2):
        w = 2 * np.pi * rng.uniform(0.2, 0.5, 7)
        a = 0.15 * (hi - lo)
        arg = np.outer(t, w) + rng.uniform(0, 2 * np.pi, 7)
        q += a * np.sin(arg)
        qd += a * w * np.cos(arg)
        qdd -= a * w**2 * np.sin(arg)
    tau = arm.torque(q, qd, qdd)
    effort = tau + planted * (tau - arm.torque(q, qd, np.zeros_like(qdd))) + 0.4 + 0.3 * np.sign(qd)
    effort += rng.normal(0.0, 0.02, effort.shape)
    scale = inertial_scale(arm, q, qd, effort, RATE_HZ)
    np.testing.assert_allclose(scale[:4], planted, atol=0.02)


def test_no_recordings_is_one_error_line(tmp_path, capsys) -> None:
    assert main(["--data", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"ERROR: {tmp_path}: no folder of CSV recordings there"]
