"""Reference trajectories: the IK of eq. (13) reaches the paper's Cartesian targets within the limits."""

from __future__ import annotations

import numpy as np
import pytest

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.arm_model import ArmModel
from baxter_dynamics_ros.errors import SimulationError
from baxter_dynamics_ros.simulation.trajectories import cartesian_target, make_reference, mirror_joints

DURATION_S = 10.0


@pytest.fixture(scope="module", params=["right", "left"])
def arm(request) -> ArmModel:
    return load_arm_model(request.param)


def hand_pose(arm: ArmModel, q: np.ndarray) -> np.ndarray:
    """(N, 4, 4) flange pose in the torso frame."""
    return arm.base_in_torso @ arm.forward_kinematics(q)


@pytest.mark.parametrize("name", ["paper_xyz", "paper_y", "paper_z"])
def test_ik_reaches_the_targets_with_the_hand_down(arm: ArmModel, name: str) -> None:
    ref = make_reference(arm, name, DURATION_S)
    pose = hand_pose(arm, ref.q)
    error = np.linalg.norm(pose[:, :3, 3] - ref.x_m, axis=1)
    assert error.max() < 1e-3, f"max position error {error.max() * 1e3:.2f} mm"
    assert np.all(pose[:, 2, 2] < -0.9999), "the flange z axis points down"
    assert np.all(ref.q > arm.lower_rad) and np.all(ref.q < arm.upper_rad)
    assert np.all(np.abs(ref.qd) < arm.velocity_limit_rad_s)


@pytest.mark.parametrize("name", ["paper_xyz", "paper_y", "paper_z", "random"])
def test_references_start_at_rest_and_qd_is_the_rate_of_q(arm: ArmModel, name: str) -> None:
    ref = make_reference(arm, name, DURATION_S, seed=4)
    assert ref.q.shape == ref.qd.shape and ref.duration_s >= DURATION_S
    np.testing.assert_allclose(ref.qd[0], 0.0, atol=1e-6)  # IK feedback on a converged start
    central = (ref.q[2:] - ref.q[:-2]) / (2 * ref.dt_s)
    scale = max(np.abs(ref.qd).max(), 1e-3)
    np.testing.assert_allclose(central, ref.qd[1:-1], atol=0.01 * scale)


def test_paper_xyz_is_the_caption_formula_after_the_ramp() -> None:
    t = np.linspace(2.0, 40.0, 200)
    x, xd = cartesian_target("paper_xyz", t, "right", ramp_s=1.0)
    p = t - 0.5  # the 1 s ramp delays the formula by half its length
    np.testing.assert_allclose(x[:, 0], 0.6 + 0.1 * np.sin(p), atol=1e-12)
    np.testing.assert_allclose(x[:, 1], -0.2 + 0.1 * np.cos(p), atol=1e-12)
    np.testing.assert_allclose(x[:, 2], 0.1 + 0.1 * np.cos(0.2 * p), atol=1e-12)
    np.testing.assert_allclose(xd[:, 0], 0.1 * np.cos(p), atol=1e-12)
    left, _ = cartesian_target("paper_xyz", t, "left")
    np.testing.assert_allclose(left * [1, -1, 1], x)


def test_paper_y_switches_between_two_positions() -> None:
    t = np.arange(0.0, 20.0, 0.01)
    x, xd = cartesian_target("paper_y", t, "right")
    np.testing.assert_allclose(x[:, [0, 2]], np.tile([0.6, 0.1], (len(t), 1)))
    y = x[:, 1]
    assert np.isclose(y.max(), -0.1) and np.isclose(y.min(), -0.3)
    held = np.isclose(y, -0.1) | np.isclose(y, -0.3)
    assert held.mean() > 0.5, "it dwells at the two positions"
    np.testing.assert_allclose(np.gradient(y, t)[1:-1], xd[1:-1, 1], atol=0.01)


def test_random_reference_is_seeded_and_inside_the_limits() -> None:
    arm = load_arm_model("right")
    a, b, c = (make_reference(arm, "random", 30.0, seed=s) for s in (1, 1, 2))
    np.testing.assert_array_equal(a.q, b.q)
    assert not np.allclose(a.q, c.q)
    assert np.all(a.q > arm.lower_rad) and np.all(a.q < arm.upper_rad)
    assert np.all(np.abs(a.qd) <= 0.6 * arm.velocity_limit_rad_s + 1e-12)
    assert np.all(np.ptp(a.q, axis=0) > 0.1), "every joint is excited"


def test_mirror_and_errors() -> None:
    np.testing.assert_array_equal(mirror_joints(np.ones(7)), [-1, 1, -1, 1, -1, 1, -1])
    arm = load_arm_model("right")
    with pytest.raises(SimulationError, match="unknown trajectory 'circle'"):
        make_reference(arm, "circle", 1.0)
    with pytest.raises(SimulationError, match="duration must be positive"):
        make_reference(arm, "random", 0.0)
