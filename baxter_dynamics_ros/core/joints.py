"""Baxter's arm joints: their names, their number and the index of s1, defined once.

Every module that needs the joint count or order imports it from here (``JOINTS``, written ``N``
in the kernels' loops; ``S1`` for the joint whose gravity-assist spring dominates Baxter's gap).
"""

from __future__ import annotations

from ..errors import RecordingError

__all__ = ["ARM_SIDES", "JOINTS", "JOINT_SUFFIXES", "S1", "arm_joint_names"]

#: The arms, by the prefix of their joint names.
ARM_SIDES = ("right", "left")
#: Joint order of the model (shoulder s0 s1, elbow e0 e1, wrist w0 w1 w2), as in config/*.yaml.
JOINT_SUFFIXES = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
#: Joints per arm (7).
JOINTS = len(JOINT_SUFFIXES)
#: Index of joint s1 in that order.
S1 = JOINT_SUFFIXES.index("s1")


def arm_joint_names(side: str) -> tuple[str, ...]:
    """The 7 joint names of ``side`` ("right" or "left") in model order, e.g. ``right_s0``."""
    if side not in ARM_SIDES:
        raise RecordingError(f"arm must be 'right' or 'left', got {side!r}")
    return tuple(f"{side}_{suffix}" for suffix in JOINT_SUFFIXES)
