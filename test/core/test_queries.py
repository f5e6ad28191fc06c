"""The dynamics queries the node's services answer (issue 21): identities between them, rigid and compensated."""

from __future__ import annotations

import numpy as np
import pytest
from reference_models import assert_close, random_states
from repo_paths import CONFIG

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.compensation import load_compensation
from baxter_dynamics_ros.core.queries import DynamicsQueries
from baxter_dynamics_ros.errors import QueryError

ARM = load_arm_model("right")
QUERIES = DynamicsQueries(ARM, load_compensation(ARM, CONFIG / "effects_example.yaml"))
Q, QD, QDD = random_states(ARM, 200, seed=5, qdd_max_rad_s2=10.0)


@pytest.mark.parametrize("compensate", [False, True])
def test_gravity_is_inverse_dynamics_at_rest(compensate: bool) -> None:
    zeros = np.zeros_like(Q)
    assert_close(QUERIES.gravity(Q, compensate), QUERIES.inverse_dynamics(Q, zeros, zeros, compensate), "G = tau(q, 0, 0)", rtol=1e-12)


@pytest.mark.parametrize("compensate", [False, True])
def test_forward_dynamics_inverts_inverse_dynamics(compensate: bool) -> None:
    """No effect of effects_example.yaml depends on q̈, so q̈(q, q̇, τ(q, q̇, q̈)) = q̈."""
    tau = QUERIES.inverse_dynamics(Q, QD, QDD, compensate)
    assert_close(QUERIES.forward_dynamics(Q, QD, tau, compensate), QDD, "qdd round trip", atol=1e-9)


@pytest.mark.parametrize("compensate", [False, True])
def test_mass_matrix_columns_are_unit_accelerations(compensate: bool) -> None:
    zeros = np.zeros_like(Q[:5])
    bias = QUERIES.inverse_dynamics(Q[:5], zeros, zeros, compensate)
    columns = np.stack([QUERIES.inverse_dynamics(Q[:5], zeros, np.tile(np.eye(7)[j], (5, 1)), compensate) - bias for j in range(7)], axis=-1)
    assert_close(QUERIES.mass_matrix(Q[:5], compensate), columns, "M columns", atol=1e-12)


def test_compensation_changes_the_answers_and_is_refused_without_effects() -> None:
    assert np.abs(QUERIES.gravity(Q, True) - QUERIES.gravity(Q)).max() > 1.0  # the s1 spring: ~30 N·m
    rigid = DynamicsQueries(ARM)
    with pytest.raises(QueryError, match="compensate_effects: no effects"):
        rigid.gravity(Q, compensate=True)


def test_dahl_friction_of_a_state_without_history_is_steady_sliding() -> None:
    """A query has no motion before it: Dahl's friction is taken at steady sliding, F sign(q̇), 0 at rest."""
    from baxter_dynamics_ros.core.compensation import Compensation
    from baxter_dynamics_ros.core.effects import DahlFriction

    friction = np.array([0.3, 1.0, 0.5, 0.4, 0.1, 0.08, 0.05])
    queries = DynamicsQueries(ARM, Compensation(ARM, (DahlFriction(friction, 0.05),)))
    qd = QD.copy()
    qd[:10] = 0.0
    assert_close(queries.inverse_dynamics(Q, qd, QDD, True) - ARM.inverse_dynamics(Q, qd, QDD), friction * np.sign(qd), "F sign(qd)", atol=1e-12)
    assert_close(queries.gravity(Q, True), ARM.gravity(Q), "no friction at rest", atol=1e-12)


def test_flange_kinematics_are_the_models() -> None:
    pose, jacobian = QUERIES.flange_kinematics(Q)
    np.testing.assert_array_equal(pose, ARM.forward_kinematics(Q))
    np.testing.assert_array_equal(jacobian, ARM.jacobian(Q))
