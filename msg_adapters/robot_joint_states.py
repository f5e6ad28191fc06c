"""Baxter's /robot/joint_states as the robot publishes it: all 21 joints, in its order.

A real Baxter sends both arms, the head, the grippers and the torso, alphabetically. Readers map
the arm's joints by name (:mod:`msg_adapters.joint_state`, :mod:`msg_adapters.bag_io`);
:func:`robot_joint_states` lays one arm's recording out the robot's way, for the writers
(:func:`msg_adapters.recording_files.write_joint_states`): the simulator's recordings and the tests'.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from baxter_dynamics_ros.core.joints import JOINT_SUFFIXES
from baxter_dynamics_ros.core.recording import Recording

__all__ = ["BAXTER_JOINT_NAMES", "RobotJointStates", "robot_joint_states"]

#: The names on a real Baxter's /robot/joint_states, in its (alphabetical) order.
BAXTER_JOINT_NAMES = (
    "head_nod",
    "head_pan",
    "l_gripper_l_finger_joint",
    "l_gripper_r_finger_joint",
    *(f"left_{j}" for j in sorted(JOINT_SUFFIXES)),
    "r_gripper_l_finger_joint",
    "r_gripper_r_finger_joint",
    *(f"right_{j}" for j in sorted(JOINT_SUFFIXES)),
    "torso_t0",
)


class RobotJointStates(NamedTuple):
    """Joint states as on Baxter's /robot/joint_states: names (J,), stamps_ns (N,), position,
    velocity, effort (N, J) in rad, rad/s, N·m."""

    names: tuple[str, ...]
    stamps_ns: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray


def robot_joint_states(recording: Recording, other_q: np.ndarray, other_effort: np.ndarray) -> RobotJointStates:
    """All 21 joints of Baxter (:data:`BAXTER_JOINT_NAMES`): ``recording``'s arm as recorded; the other
    arm held at other_q (7,) rad with effort other_effort (N, 7) N·m (its holding torque), zero
    velocity; head, grippers and torso at 0."""
    n = len(recording)
    position = np.zeros((n, len(BAXTER_JOINT_NAMES)))
    velocity = np.zeros_like(position)
    effort = np.zeros_like(position)
    other = "left" if recording.side == "right" else "right"
    index = {name: k for k, name in enumerate(BAXTER_JOINT_NAMES)}
    for j, name in enumerate(recording.joint_names):
        k = index[name]
        position[:, k], velocity[:, k], effort[:, k] = recording.q[:, j], recording.qd[:, j], recording.effort[:, j]
    for j, name in enumerate(recording.joint_names):
        k = index[name.replace(recording.side, other, 1)]
        position[:, k], effort[:, k] = other_q[j], other_effort[:, j]
    return RobotJointStates(BAXTER_JOINT_NAMES, recording.stamps_ns.copy(), position, velocity, effort)
