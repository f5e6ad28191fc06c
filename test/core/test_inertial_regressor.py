"""The inertial-parameter regressor: τ = Y(q, q̇, q̈) π, exactly, and linear in parameter changes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.arm_model import ArmModel, link_from_parameters, link_parameters
from baxter_dynamics_ros.core.lagrange_euler import inertial_basis


@pytest.fixture(scope="module")
def arm() -> ArmModel:
    return load_arm_model("right")


def states(arm: ArmModel, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(arm.lower_rad, arm.upper_rad, (n, 7))
    return q, rng.uniform(-1.5, 1.5, (n, 7)), rng.uniform(-5.0, 5.0, (n, 7))


def test_basis_rebuilds_each_pseudo_inertia(arm: ArmModel) -> None:
    basis = inertial_basis()
    for link, j in zip(arm.links, arm.pseudo_inertias):
        np.testing.assert_allclose(np.tensordot(link_parameters(link), basis, axes=1), j, atol=1e-15)


def test_regressor_times_parameters_is_inverse_dynamics(arm: ArmModel) -> None:
    q, qd, qdd = states(arm, 500, seed=1)
    y = arm.inertial_regressor(q, qd, qdd)
    assert y.shape == (500, 7, 70)
    np.testing.assert_allclose(y @ arm.inertial_parameters, arm.inverse_dynamics(q, qd, qdd), atol=1e-10)


def test_regressor_predicts_a_changed_model(arm: ArmModel) -> None:
    """Heavier link 4 with a shifted centre of mass: τ' − τ = Y Δπ, Y from the nominal arm."""
    link = arm.links[3]
    changed = dataclasses.replace(link, mass_kg=link.mass_kg * 1.3, com_m=link.com_m + [0.01, -0.02, 0.005])
    other = dataclasses.replace(arm, links=arm.links[:3] + (changed,) + arm.links[4:])
    q, qd, qdd = states(arm, 200, seed=2)
    delta = other.inertial_parameters - arm.inertial_parameters
    assert np.all(delta[:30] == 0) and np.all(delta[40:] == 0) and np.any(delta[30:40] != 0)
    np.testing.assert_allclose(
        arm.inertial_regressor(q, qd, qdd) @ delta,
        other.inverse_dynamics(q, qd, qdd) - arm.inverse_dynamics(q, qd, qdd),
        atol=1e-10,
    )


def test_link_parameters_round_trip(arm: ArmModel) -> None:
    for link in arm.links:
        back = link_from_parameters(link.name, link_parameters(link))
        assert back.mass_kg == pytest.approx(link.mass_kg)
        np.testing.assert_allclose(back.com_m, link.com_m, atol=1e-15)
        np.testing.assert_allclose(back.inertia_kgm2, link.inertia_kgm2, atol=1e-15)


def test_regressor_keeps_the_batch_shape(arm: ArmModel) -> None:
    q, qd, qdd = states(arm, 6, seed=3)
    y = arm.inertial_regressor(q.reshape(2, 3, 7), qd.reshape(2, 3, 7), qdd.reshape(2, 3, 7))
    assert y.shape == (2, 3, 7, 70)
    np.testing.assert_allclose(y.reshape(6, 7, 70), arm.inertial_regressor(q, qd, qdd))

def test_a_link_loads_only_the_joints_before_it(arm: ArmModel) -> None:
    """Link j's parameters enter τ_i for i ≤ j only (the sums of eq. 5 start at j = i)."""
    y = arm.inertial_regressor(*states(arm, 50, seed=4))
    for j in range(7):
        assert np.all(y[:, j + 1 :, 10 * j : 10 * j + 10] == 0.0)
        assert np.any(y[:, j, 10 * j : 10 * j + 10] != 0.0)
