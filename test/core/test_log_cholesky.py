"""The log-Cholesky parametrisation of pseudo-inertias: round trips, physical consistency, exact derivatives."""

from __future__ import annotations

import numpy as np
import pytest

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.arm_model import link_parameters, pseudo_inertia
from baxter_dynamics_ros.core.log_cholesky import (
    contraction_hessian,
    log_cholesky_from_pseudo,
    parameters_from_log_cholesky,
    parameters_from_pseudo,
    pseudo_from_log_cholesky,
)


@pytest.fixture(scope="module")
def nominal() -> tuple[np.ndarray, np.ndarray]:
    arm = load_arm_model("right")
    J = np.stack([pseudo_inertia(link) for link in arm.links])
    return J, np.stack([link_parameters(link) for link in arm.links])


def test_round_trip_and_parameters(nominal) -> None:
    J, pi = nominal
    phi = log_cholesky_from_pseudo(J)
    np.testing.assert_allclose(pseudo_from_log_cholesky(phi), J, rtol=0, atol=1e-15)
    np.testing.assert_allclose(parameters_from_pseudo(J), pi, rtol=0, atol=1e-15)
    np.testing.assert_allclose(parameters_from_log_cholesky(phi)[0], pi, rtol=0, atol=1e-15)
    # Mass and centre of mass are coordinates of their own: m = e^{2α}, c = t.
    np.testing.assert_allclose(np.exp(2 * phi[:, 0]), J[:, 3, 3], rtol=1e-15)
    np.testing.assert_allclose(phi[:, 7:], J[:, :3, 3] / J[:, 3:, 3], rtol=0, atol=1e-15)


def test_every_coordinate_vector_is_a_physical_body() -> None:
    """Any φ gives a positive-definite J: a mass > 0 and a centroidal inertia satisfying the triangle inequalities."""
    rng = np.random.default_rng(3)
    phi = rng.normal(0.0, 2.0, (2000, 10))
    J = pseudo_from_log_cholesky(phi)
    assert np.all(np.linalg.eigvalsh(J)[:, 0] > 0)
    m = J[:, 3, 3]
    c = J[:, :3, 3] / m[:, None]
    sigma = J[:, :3, :3] - m[:, None, None] * c[:, :, None] * c[:, None, :]
    inertia = np.trace(sigma, axis1=1, axis2=2)[:, None, None] * np.eye(3) - sigma
    moments = np.linalg.eigvalsh(inertia)
    assert np.all(moments > 0)
    assert np.all(moments[:, 2] <= moments[:, 0] + moments[:, 1] + 1e-12 * moments[:, 2])


def test_not_positive_definite_is_refused() -> None:
    J = np.diag([1.0, 1.0, -1.0, 2.0])
    with pytest.raises(ValueError, match="positive definite"):
        log_cholesky_from_pseudo(J)


def test_derivatives_match_central_differences(nominal) -> None:
    """∂π/∂φ and ∇²(γ·π) against central differences of π itself (an independent computation)."""
    J, _ = nominal
    rng = np.random.default_rng(1)
    phi = log_cholesky_from_pseudo(J) + rng.normal(0.0, 0.1, (7, 10))
    gamma = rng.normal(size=(7, 10))
    _, jac = parameters_from_log_cholesky(phi)
    hess = contraction_hessian(phi, gamma)
    h = 1e-5
    for k in range(10):
        step = np.zeros(10)
        step[k] = h
        up, down = parameters_from_log_cholesky(phi + step)[0], parameters_from_log_cholesky(phi - step)[0]
        np.testing.assert_allclose(jac[:, :, k], (up - down) / (2 * h), rtol=0, atol=1e-8 * np.abs(jac).max())
        g_up = np.einsum("lk,lk->l", gamma, parameters_from_log_cholesky(phi + 2 * step)[0])
        g_mid = np.einsum("lk,lk->l", gamma, parameters_from_log_cholesky(phi)[0])
        g_down = np.einsum("lk,lk->l", gamma, parameters_from_log_cholesky(phi - 2 * step)[0])
        np.testing.assert_allclose(hess[:, k, k], (g_up - 2 * g_mid + g_down) / (4 * h * h), rtol=1e-5, atol=1e-6 * np.abs(hess).max())
    # Mixed terms: symmetric, and the difference of the gradient.
    np.testing.assert_allclose(hess, np.swapaxes(hess, 1, 2), rtol=0, atol=1e-12 * np.abs(hess).max())
    for k in range(10):
        step = np.zeros(10)
        step[k] = h
        grad_up = np.einsum("lk,lkm->lm", gamma, parameters_from_log_cholesky(phi + step)[1])
        grad_down = np.einsum("lk,lkm->lm", gamma, parameters_from_log_cholesky(phi - step)[1])
        np.testing.assert_allclose(hess[:, :, k], (grad_up - grad_down) / (2 * h), rtol=0, atol=1e-7 * np.abs(hess).max())
