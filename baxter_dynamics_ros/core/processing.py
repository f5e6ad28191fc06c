"""Offline processing of a recording: q̈, gravity, inverse dynamics and residual for every sample.

The same quantities as the live node, for a whole :class:`~baxter_dynamics_ros.core.recording.Recording`
at once. q̈ comes from one of the estimators of :mod:`baxter_dynamics_ros.core.acceleration`:

- ``zero_phase`` (default offline): Butterworth forwards and backwards on q̇, then central
  differences; no delay, uses future samples.
- ``lowpass``: the live node's causal estimator, run over the stamps exactly as the node sees them
  (so ``process`` and the node agree sample by sample).
- ``first_difference``: the paper's raw difference, for comparison with its results.
"""

from __future__ import annotations

import numpy as np

from ..errors import RecordingError
from .acceleration import ESTIMATORS, LowPassDifferentiator, first_difference, zero_phase_acceleration
from .arm_model import ArmModel
from .recording import ProcessedRecording, Recording

__all__ = ["estimate_acceleration", "process_recording"]


def estimate_acceleration(recording: Recording, method: str = "zero_phase", cutoff_hz: float | None = None) -> np.ndarray:
    """q̈ (N, 7) rad/s² of a recording by ``method`` (see the module docstring).

    cutoff_hz: the filter's cutoff in Hz; None takes the method's default from
    :data:`~.acceleration.ESTIMATORS`. first_difference has no filter and accepts no cutoff.
    """
    if method not in ESTIMATORS:
        raise RecordingError(f"acceleration method must be one of {', '.join(ESTIMATORS)}, got {method!r}")
    if method == "first_difference":
        if cutoff_hz is not None:
            raise RecordingError("first_difference has no filter: leave the cutoff unset")
        return first_difference(recording.qd, recording.stamps_s)
    if cutoff_hz is None:
        cutoff_hz = ESTIMATORS[method].default_cutoff_hz
    try:
        if method == "zero_phase":
            return zero_phase_acceleration(recording.qd, recording.rate_hz, cutoff_hz, segments=recording.segments)
        return LowPassDifferentiator(cutoff_hz).run(recording.qd, recording.stamps_s)
    except ValueError as err:  # the estimators' own checks (cutoff range)
        raise RecordingError(
            f"cannot estimate q̈ by {method} on this recording ({len(recording)} samples at {recording.rate_hz:.3g} Hz): {err}; "
            "give a longer recording at a higher rate, or a lower --cutoff-hz"
        ) from err


def process_recording(
    arm: ArmModel, recording: Recording, *, acceleration: str = "zero_phase", cutoff_hz: float | None = None
) -> ProcessedRecording:
    """Gravity, inverse dynamics and residual of every sample of ``recording`` with ``arm``'s model."""
    if arm.side != recording.side or tuple(arm.joint_names) != recording.joint_names:
        raise RecordingError(
            f"the recording is of the {recording.side} arm but the model is of the {arm.side} arm; "
            f"load the {recording.side} model or choose the arm with --arm"
        )
    qdd = estimate_acceleration(recording, acceleration, cutoff_hz)
    gravity = arm.gravity(recording.q)
    tau = arm.inverse_dynamics(recording.q, recording.qd, qdd)
    return ProcessedRecording(recording, qdd, gravity, tau, recording.effort - tau)
