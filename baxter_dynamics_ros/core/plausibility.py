"""What a real Baxter can give: the bounds of a plausible joint-state sample, defined once.

A sample is implausible when a joint angle lies beyond the joint limits by more than
:data:`POSITION_MARGIN_RAD`, a speed above :data:`PLAUSIBLE_FACTOR` times the joint's velocity limit
or an effort above that factor times its effort limit (the model file's limits, the URDF's: 1.5 rad/s
and 50–100 N·m at s0–e1, 4 rad/s and 15 N·m at the wrist; the four real recordings reach 1.34 times a
velocity limit and 0.31 times an effort limit). NaN and ±inf are no measurement either.

Both users apply these bounds (:func:`plausibility_bounds`): the live node skips such a sample and
counts it (:mod:`baxter_dynamics_ros.monitoring.pipeline`), the offline readers (``msg_adapters/``)
leave it out of the recording, say how many per file (:meth:`Screening.warning`) and refuse a file
of which more than :data:`MAX_IMPLAUSIBLE_SHARE` is implausible (:meth:`Screening.refusal`).
The node's files are held to the same bounds: a collision threshold the plausible effort can never
cross (:mod:`baxter_dynamics_ros.monitoring.thresholds`), effects whose share of the effort exceeds it
(:mod:`.compensation`).

Numpy only at import (the message adapters use it; the arm model is loaded on demand).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING

import numpy as np

from ..errors import RecordingError
from .joints import arm_joint_names
from .recording import Recording

if TYPE_CHECKING:
    from .arm_model import ArmModel

__all__ = [
    "CAUSES",
    "MAX_IMPLAUSIBLE_SHARE",
    "PLAUSIBLE_FACTOR",
    "POSITION_MARGIN_RAD",
    "Screening",
    "first_beyond_plausible_effort",
    "package_bounds",
    "plausibility_bounds",
    "plausible_recording",
    "screen_samples",
]

#: How far beyond a joint limit a measured angle may be, rad (5.7°: past the hard stops).
POSITION_MARGIN_RAD = 0.1
#: A measured speed (effort) may be at most this many times the joint's velocity (effort) limit.
PLAUSIBLE_FACTOR = 3.0
#: A file of which more than this share of the samples is implausible is refused, not read. A real
#: recording's faults are isolated glitches (none in the four real recordings); a tenth of the
#: samples beyond what the arm can do means the file is not what it claims (angles in degrees,
#: torques in N·mm, another joint's columns), and what would remain is cut into pieces too short
#: for the q̈ filter.
MAX_IMPLAUSIBLE_SHARE = 0.1
#: Why a sample is implausible, by the code :func:`screen_samples` gives it (0: plausible).
CAUSES = {
    1: "NaN or inf",
    2: "position beyond the joint limits",
    3: f"velocity beyond {PLAUSIBLE_FACTOR:g} × the velocity limit",
    4: f"effort beyond {PLAUSIBLE_FACTOR:g} × the effort limit",
}


def plausibility_bounds(arm: ArmModel) -> np.ndarray:
    """The bounds of a plausible sample of ``arm``: (6, 7), rows low and high of q (rad), q̇ (rad/s)
    and effort (N·m) in turn (module docstring)."""
    qd_max = PLAUSIBLE_FACTOR * arm.velocity_limit_rad_s
    effort_max = PLAUSIBLE_FACTOR * arm.effort_limit_nm
    bounds = np.array(
        [arm.lower_rad - POSITION_MARGIN_RAD, arm.upper_rad + POSITION_MARGIN_RAD, -qd_max, qd_max, -effort_max, effort_max],
        dtype=np.float64,
    )
    bounds.flags.writeable = False
    return bounds


def first_beyond_plausible_effort(arm: ArmModel, torque_nm: np.ndarray) -> tuple[int, float] | None:
    """The first joint whose torque_nm (7,) N·m is not within :data:`PLAUSIBLE_FACTOR` × its effort
    limit (NaN counts as beyond), with that bound in N·m; None when every joint's is."""
    bound = PLAUSIBLE_FACTOR * arm.effort_limit_nm
    over = np.flatnonzero(~(np.abs(torque_nm) <= bound))
    return (int(over[0]), float(bound[over[0]])) if over.size else None


@cache
def package_bounds(side: str) -> np.ndarray:
    """:func:`plausibility_bounds` of the package's model of ``side`` ("right" or "left")."""
    from .arm_model import load_arm_model

    return plausibility_bounds(load_arm_model(side))


@dataclass(frozen=True)
class Screening:
    """Which samples of a recording are plausible: keep (N,) bool; counts: samples left out by
    cause (:data:`CAUSES`' descriptions), the first cause of each sample."""

    keep: np.ndarray
    counts: dict[str, int]

    @property
    def skipped(self) -> int:
        return int(len(self.keep) - np.count_nonzero(self.keep))

    def warning(self, label: str) -> str | None:
        """The one line telling the user what was left out of ``label``, None if nothing was."""
        if not self.skipped:
            return None
        causes = ", ".join(f"{n} {cause}" for cause, n in self.counts.items() if n)
        return f"WARNING: {label}: {self.skipped} of {len(self.keep)} samples skipped as implausible ({causes}); the recording is split into pieces at them"

    def refusal(self) -> RecordingError | None:
        """The error for a recording of fewer than 2 samples (no time series: a lone sample has no
        q̇ to difference either), or of which more than :data:`MAX_IMPLAUSIBLE_SHARE` is implausible."""
        if len(self.keep) < 2:
            return RecordingError(f"holds {len(self.keep)} sample(s) of the arm: a recording is a time series of at least 2")
        if self.skipped <= MAX_IMPLAUSIBLE_SHARE * len(self.keep):
            return None
        causes = ", ".join(f"{n} {cause}" for cause, n in self.counts.items() if n)
        return RecordingError(
            f"{self.skipped} of {len(self.keep)} samples are implausible ({causes}): more than "
            f"{MAX_IMPLAUSIBLE_SHARE:.0%}, so this is not a recording of the arm in rad, rad/s and N·m; check the file's units and columns"
        )


def screen_samples(bounds: np.ndarray, q: np.ndarray, qd: np.ndarray, effort: np.ndarray) -> Screening:
    """The plausible samples of q, qd, effort (N, 7) (rad, rad/s, N·m) within ``bounds`` (6, 7)."""
    code = np.zeros(len(q), dtype=np.int8)
    arrays = (np.asarray(q, dtype=np.float64), np.asarray(qd, dtype=np.float64), np.asarray(effort, dtype=np.float64))
    with np.errstate(invalid="ignore"):
        tests = [~np.isfinite(np.concatenate(arrays, axis=1)).all(axis=1)]
        tests += [~((bounds[2 * k] <= x) & (x <= bounds[2 * k + 1])).all(axis=1) for k, x in enumerate(arrays)]
    for c, bad in zip(sorted(CAUSES, reverse=True), tests[::-1]):  # the first cause wins: assign the last first
        code[bad] = c
    return Screening(code == 0, {cause: int(np.count_nonzero(code == c)) for c, cause in CAUSES.items()})


def plausible_recording(
    label: str, side: str, stamps_ns: np.ndarray, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, note=None, screening: Screening | None = None
) -> Recording:
    """The :class:`~.recording.Recording` of ``side`` from the plausible samples of stamps_ns (N,) ns
    and q, qd, effort (N, 7), the others left out (their stamps then lie in a gap, at which the
    offline filters split the recording: :attr:`~.recording.Recording.segments`).

    label names the file in the warning said through ``note`` (one line, when a sample is left out);
    raises RecordingError for a file of which more than :data:`MAX_IMPLAUSIBLE_SHARE` is implausible.
    screening: the result of :func:`screen_samples` when the caller has it already."""
    if screening is None:
        screening = screen_samples(package_bounds(side), q, qd, effort)
    error = screening.refusal()
    if error is not None:
        raise error
    warning = screening.warning(label)
    if warning is not None and note is not None:
        note(warning)
    keep = screening.keep
    return Recording(side, arm_joint_names(side), np.asarray(stamps_ns)[keep], np.asarray(q)[keep], np.asarray(qd)[keep], np.asarray(effort)[keep])
