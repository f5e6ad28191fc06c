"""Lagrange-Euler dynamics of Baxter's 7-DoF arms, a ROS 2 node around them, and gap diagnosis.

The public API is the arm model and the package's errors::

    from baxter_dynamics_ros import load_arm_model
    arm = load_arm_model("right")
    tau = arm.inverse_dynamics(q, qd, qdd)   # (..., 7) arrays in rad, rad/s, rad/s² -> N·m

The layers, each a subpackage that imports only those before it (``test/test_layering.py``):
:mod:`~baxter_dynamics_ros.core` (the arm model, the L-E kernels, q̈ estimators, recordings,
effects; numpy, numba, scipy, yaml), :mod:`~baxter_dynamics_ros.monitoring` (the live pipeline and
collision monitoring), :mod:`~baxter_dynamics_ros.simulation`, :mod:`~baxter_dynamics_ros.diagnosis`,
:mod:`~baxter_dynamics_ros.ros` (the node and the player: rclpy and ``msg_adapters``) and
:mod:`~baxter_dynamics_ros.cli`. Beside them only this front and :mod:`~baxter_dynamics_ros.errors`.
The arm model is imported on first use, so that importing the errors (as ``msg_adapters`` does)
loads neither numba nor the kernels.
"""

from __future__ import annotations

from typing import Any

from .errors import BaxterDynamicsError, InputShapeError, ModelFileError

__all__ = [
    "ArmModel",
    "BaxterDynamicsError",
    "InputShapeError",
    "LinkInertial",
    "ModelFileError",
    "load_arm_model",
]

#: Public names defined in :mod:`baxter_dynamics_ros.core.arm_model`, imported when first asked for.
_ARM_MODEL_NAMES = ("ArmModel", "LinkInertial", "load_arm_model")


def __getattr__(name: str) -> Any:
    if name in _ARM_MODEL_NAMES:
        from .core import arm_model

        return getattr(arm_model, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
