"""A Pinocchio model of an :class:`~baxter_dynamics_ros.core.arm_model.ArmModel`, as an independent reference.

Pinocchio's recursive Newton-Euler algorithm (``pin.rnea``) is the RN-E method of the paper's
comparison (Table V); built from the arm's own DH table and link inertials it must agree with the
Lagrange-Euler core to rounding. Pinocchio is imported here only, and only when called.
"""

from __future__ import annotations

import numpy as np

from .arm_model import ArmModel

__all__ = ["pinocchio_from_arm", "rnea"]


def pinocchio_from_arm(arm: ArmModel):
    """A ``pin.Model``: a chain of 7 revolute-z joints from the arm's DH table and link inertials.

    Joint 1 sits on DH frame 0 and joint i+1 on joint i at X_i = Rz(θ offset_i)·Tz(d_i)·Tx(a_i)·Rx(α_i)
    (eq. 2 at q = 0); link i, whose inertials are given in DH frame i, is attached to joint i at
    X_i; frame "flange" is DH frame 7. Gravity is the arm's, in its base frame (Pinocchio's world).
    """
    import pinocchio as pin

    model = pin.Model()
    joint, placement = 0, pin.SE3.Identity()
    for (d, a, alpha, offset), name, link in zip(arm.dh, arm.joint_names, arm.links):
        joint = model.addJoint(joint, pin.JointModelRZ(), placement, name)
        placement = pin.SE3(pin.utils.rotate("z", offset), np.zeros(3)) * pin.SE3(pin.utils.rotate("x", alpha), np.array([a, 0.0, d]))
        inertia = pin.Inertia(link.mass_kg, np.array(link.com_m), np.array(link.inertia_kgm2))
        model.appendBodyToJoint(joint, inertia, placement)
    model.addFrame(pin.Frame("flange", joint, placement, pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array(arm.gravity_m_s2)
    return model


def rnea(model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """τ (N, 7) N·m by Pinocchio's RNEA for every sample of q, qd, qdd (N, 7) rad, rad/s, rad/s²."""
    import pinocchio as pin

    data = model.createData()
    return np.array([pin.rnea(model, data, a, b, c) for a, b, c in zip(q, qd, qdd)])
