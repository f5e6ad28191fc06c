"""The dynamics of given states on request: the arm's model, rigid or with identified effects.

What the node's services compute (:mod:`baxter_dynamics_ros.ros.dynamics_services`), for a batch
of states at once: G(q), τ(q, q̇, q̈), M(q), q̈(q, q̇, τ), and the flange's pose and geometric
Jacobian. With ``compensate=True`` the model is the one of the node's ``effects_file``
(:class:`~baxter_dynamics_ros.core.compensation.Compensation`): the inertial changes applied to the
links, the additive effects' torque added —

- G_c(q) = G'(q) + τ_add(q, 0, 0) (the additive effects at rest: offsets, springs);
- τ_c = M'(q) q̈ + C'(q, q̇) + G'(q) + τ_add(q, q̇, q̈), the node's own live model;
- M_c(q) = M'(q) (the additive effects carry no inertia);
- q̈_c = M'⁻¹(τ − C' − G' − τ_add(q, q̇, 0)): the additive effects at q̈ = 0 (an armature would
  need q̈ itself);

where ' marks the model with the inertial changes. A queried state has no motion before it, so
Dahl's friction (``dahl_friction``) is taken at steady sliding, F sign(q̇), 0 at rest. Kinematics do
not depend on the effects.
Every input is (N, 7) in rad, rad/s, rad/s², N·m; results are new arrays.
"""

from __future__ import annotations

import numpy as np

from ..errors import QueryError
from .arm_model import ArmModel
from .compensation import Compensation

__all__ = ["DynamicsQueries"]


class DynamicsQueries:
    """The batched dynamics of ``arm``, and of ``compensation``'s model when asked (None: rigid only)."""

    def __init__(self, arm: ArmModel, compensation: Compensation | None = None) -> None:
        self.arm = arm
        self.compensation = compensation

    def _model(self, compensate: bool) -> tuple[ArmModel, Compensation | None]:
        if not compensate:
            return self.arm, None
        if self.compensation is None:
            raise QueryError("compensate_effects: no effects are loaded (start the node with effects_file:=<effects.yaml>)")
        return self.compensation.arm, self.compensation

    def gravity(self, q: np.ndarray, compensate: bool = False) -> np.ndarray:
        """G(q), N·m, (N, 7); q (N, 7) rad."""
        arm, comp = self._model(compensate)
        tau = arm.gravity(q)
        return tau if comp is None else tau + comp.torque(q, np.zeros_like(q), np.zeros_like(q))

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, compensate: bool = False) -> np.ndarray:
        """τ = M q̈ + C + G, N·m, (N, 7); q, qd, qdd (N, 7) rad, rad/s, rad/s²."""
        arm, comp = self._model(compensate)
        tau = arm.inverse_dynamics(q, qd, qdd)
        return tau if comp is None else tau + comp.torque(q, qd, qdd)

    def mass_matrix(self, q: np.ndarray, compensate: bool = False) -> np.ndarray:
        """M(q), kg·m², (N, 7, 7) symmetric; q (N, 7) rad."""
        arm, _ = self._model(compensate)
        return arm.mass_matrix(q)

    def forward_dynamics(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray, compensate: bool = False) -> np.ndarray:
        """q̈ = M⁻¹(τ − C − G), rad/s², (N, 7); q, qd, tau (N, 7) rad, rad/s, N·m."""
        arm, comp = self._model(compensate)
        if comp is not None:
            tau = tau - comp.torque(q, qd, np.zeros_like(q))
        return arm.forward_dynamics(q, qd, tau)

    def flange_kinematics(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pose of the flange (DH frame 7) in the base frame (N, 4, 4), metres, and its geometric
        Jacobian (N, 6, 7), rows v (m/s) then ω (rad/s) per rad/s of each joint; q (N, 7) rad."""
        return self.arm.forward_kinematics(q), self.arm.jacobian(q)
