"""Lagrange-Euler dynamics of Baxter's 7-DoF arms, a ROS 2 node around them, and gap diagnosis.

The core (this package but :mod:`baxter_dynamics_ros.node`) imports numpy and never rclpy::

    from baxter_dynamics_ros import load_arm_model
    arm = load_arm_model("right")
    tau = arm.inverse_dynamics(q, qd, qdd)   # (..., 7) arrays in rad, rad/s, rad/s² -> N·m
"""

from __future__ import annotations

from .arm_model import ArmModel, LinkInertial, load_arm_model
from .errors import BaxterDynamicsError, InputShapeError, ModelFileError

__all__ = [
    "ArmModel",
    "BaxterDynamicsError",
    "InputShapeError",
    "LinkInertial",
    "ModelFileError",
    "load_arm_model",
]
