"""bench/inertial_scale.py on synthetic recordings with a planted scale of the inertial torque."""

from __future__ import annotations

import numpy as np
import pytest
from urdf_motion import RATE_HZ, motion

from bench.inertial_scale import inertial_scale, main
from bench.plain_fit import UrdfArm


@pytest.mark.parametrize("planted", [0.0, -0.2])
def test_recovers_a_planted_scale_of_the_inertial_torque(arm: UrdfArm, planted: float) -> None:
    """Effort = RNEA at the exact q̈ + planted·(its inertial part) + an offset and Coulomb friction
    at every joint + noise; two sinusoids of 0.1–0.5 Hz per joint: the shoulder and elbow joints' coefficient is
    the planted one (the 4 Hz filter costs a little of the inertial torque, well within 0.02)."""
    q, qd, qdd = motion(arm, seed=3, seconds=30.0)
    rng = np.random.default_rng(4)
    tau = arm.torque(q, qd, qdd)
    effort = tau + planted * (tau - arm.torque(q, qd, np.zeros_like(qdd))) + 0.4 + 0.3 * np.sign(qd)
    effort += rng.normal(0.0, 0.02, effort.shape)
    scale = inertial_scale(arm, q, qd, effort, RATE_HZ)
    np.testing.assert_allclose(scale[:4], planted, atol=0.02)


def test_no_recordings_is_one_error_line(tmp_path, capsys) -> None:
    assert main(["--data", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"ERROR: {tmp_path}: no folder of CSV recordings there"]
