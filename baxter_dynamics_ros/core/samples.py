"""The live pipeline's records: one arm sample in, the model's torques out, why a sample was skipped,
and the health report.

Plain data (named tuples of numpy arrays, enums) passed between the per-sample pipeline
(:mod:`baxter_dynamics_ros.monitoring.pipeline`, :mod:`baxter_dynamics_ros.monitoring.health`) and the
message adapters (:mod:`msg_adapters.joint_state`), which know only the core.
"""

from __future__ import annotations

from enum import Enum, IntEnum
from typing import NamedTuple

import numpy as np

__all__ = [
    "SKIP_DESCRIPTIONS",
    "ArmSample",
    "Health",
    "HealthReport",
    "ModelTorques",
    "ResetCause",
    "SkipReason",
]


class SkipReason(Enum):
    """Why a sample gave no output; the value names the cause in diagnostics and logs."""

    UNREADABLE = "unreadable"
    MISSING_JOINT = "missing_joint"
    ARRAY_LENGTH = "array_length"
    NON_FINITE_INPUT = "non_finite_input"
    IMPLAUSIBLE_INPUT = "implausible_input"
    DUPLICATE_STAMP = "duplicate_stamp"
    STAMP_BACKWARDS = "stamp_backwards"
    VELOCITY_WARM_UP = "velocity_warm_up"
    NON_FINITE_MODEL = "non_finite_model"

    @property
    def is_fault(self) -> bool:
        """False for the one expected skip (the first sample without velocity), True otherwise."""
        return self is not SkipReason.VELOCITY_WARM_UP

#: One line per cause, for the node's warnings.
SKIP_DESCRIPTIONS: dict[SkipReason, str] = {
    SkipReason.UNREADABLE: "the message's bytes are not a JointState in plain CDR",
    SkipReason.MISSING_JOINT: "an arm joint is missing from the message's name list, or named twice",
    SkipReason.ARRAY_LENGTH: "position (or a non-empty velocity/effort) has not one entry per name",
    SkipReason.NON_FINITE_INPUT: "NaN or inf in the arm's position, velocity or effort",
    SkipReason.IMPLAUSIBLE_INPUT: "a position beyond the joint limits, or a speed or effort no real Baxter reaches",
    SkipReason.DUPLICATE_STAMP: "same header stamp as the previous sample",
    SkipReason.STAMP_BACKWARDS: "header stamp earlier than the previous sample's; estimator reset",
    SkipReason.VELOCITY_WARM_UP: "no velocity in the message: waiting for a second sample to difference",
    SkipReason.NON_FINITE_MODEL: "the dynamics gave NaN or inf (absurdly large input?); estimator reset",
}


class ResetCause(Enum):
    """Why the estimator was reset: from outside the pipeline, or by it when a state went non-finite."""

    SERVICE = "service"
    CLOCK_JUMP = "clock_jump"
    SETTINGS = "settings"
    NON_FINITE_STATE = "non_finite_state"


class ArmSample(NamedTuple):
    """One sample of the arm: stamp in ns; q (7,) rad; qd (7,) rad/s or None; effort (7,) N·m or None."""

    stamp_ns: int
    q: np.ndarray
    qd: np.ndarray | None
    effort: np.ndarray | None


class ModelTorques(NamedTuple):
    """The pipeline's output for one sample, all (7,): q rad, qd rad/s (measured, or differenced
    from positions when ``qd_from_positions``), qdd rad/s² (estimated), gravity G(q), tau (eq. 1),
    residual = effort − tau and external_torque = the momentum observer's r, in N·m (both None
    without effort); effort: the measured one it came from (None without)."""

    stamp_ns: int
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    gravity: np.ndarray
    tau: np.ndarray
    residual: np.ndarray | None
    qd_from_positions: bool
    external_torque: np.ndarray | None = None
    effort: np.ndarray | None = None


class Health(IntEnum):
    """Report level; the values are diagnostic_msgs/DiagnosticStatus's OK, WARN and ERROR."""

    OK = 0
    WARN = 1
    ERROR = 2


class HealthReport(NamedTuple):
    """One window's summary: level, a one-line message, and (key, value) pairs to publish."""

    level: Health
    message: str
    values: tuple[tuple[str, str], ...]
