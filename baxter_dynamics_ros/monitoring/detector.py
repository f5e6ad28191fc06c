"""Collision detection on the observer's r: a hysteresis detector, and the public scheme to compare.

Slow bias: torque-sensor offsets drift between recordings (on the real ones, w2's by 0.09 N·m
between the random-motion recording and the sinusoids, against thresholds of 0.2 N·m there). With
``bias_time_constant_s`` = T_b > 0 the detector compares r̃ = r − r̄ with the thresholds, r̄ a
first-order low-pass of r (r̄_k = r̄_{k−1} + (Δt_k/T_b)(r_{k−1} − r̄_{k−1}), r̄ = 0 at the start)
updated while the detector is off and held while it is on, so a contact never leaks into r̄ (one
step: :func:`follow_bias`; the calibration removes the same, :mod:`.calibration`). T_b = 0: r̃ = r.

Detector (:class:`CollisionDetector`): on when some joint's |r̃_j| > threshold_j for ≥ ``consecutive``
samples in a row; off once every |r̃_j| < ``release_fraction`` · threshold_j for ``hold_s``. The
release fraction defaults to 1 / margin, the level the calibration data stayed under: lower, and
normal motion alone keeps the detector on after a contact.

Public scheme (as in public Baxter code): r = τ_meas − τ(q, q̇, 0) against
:data:`PUBLIC_THRESHOLDS_NM`, a collision on any sample above (:func:`public_residual`,
:func:`public_detector`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..core.arm_model import ArmModel
from ..core.compensation import Compensation
from ..core.joints import JOINTS as N
from ..core.recording import Recording
from ..errors import CollisionError
from .thresholds import Thresholds

__all__ = [
    "DEFAULT_BIAS_TIME_CONSTANT_S",
    "PUBLIC_THRESHOLDS_NM",
    "CollisionDetector",
    "DetectorState",
    "detect",
    "follow_bias",
    "public_detector",
    "public_residual",
]

#: Default time constant of the detector's slow-bias low-pass, s.
DEFAULT_BIAS_TIME_CONSTANT_S = 20.0
#: The fixed thresholds of public Baxter code, s0 … w2, N·m.
PUBLIC_THRESHOLDS_NM = (10.0, 10.0, 5.0, 4.5, 2.0, 2.0, 1.0)


def follow_bias(bias: np.ndarray, r_before: np.ndarray, dt_s: float, time_constant_s: float) -> None:
    """One step of the slow bias r̄ (7,), in place (module docstring): r̄ += min(Δt/T_b, 1)(r_{k−1} − r̄)."""
    bias += min(dt_s / time_constant_s, 1.0) * (r_before - bias)


class DetectorState(NamedTuple):
    """The detector after a sample: collision on or off; joints (indices) above their threshold in
    the current event (empty when off)."""

    collision: bool
    joints: tuple[int, ...]


class CollisionDetector:
    """Hysteresis on |r̃| = |r − r̄| against thresholds (module docstring; r̄ = 0 when the thresholds'
    bias_time_constant_s is 0).

    It turns on after ``thresholds.consecutive`` samples in a row above on one joint; release_fraction:
    of the threshold, below which every joint must stay for hold_s before it turns off (default
    1 / ``thresholds.margin``).
    """

    def __init__(self, thresholds: Thresholds, *, release_fraction: float | None = None, hold_s: float = 0.1) -> None:
        if release_fraction is None:
            release_fraction = 1.0 / thresholds.margin
        if not 0 < release_fraction <= 1 or hold_s < 0:
            raise CollisionError(f"detector: need 0 < release_fraction <= 1, hold_s >= 0; got {release_fraction}, {hold_s}")
        self.thresholds = thresholds
        self.release_fraction = float(release_fraction)
        self.hold_s = float(hold_s)
        self.reset()

    def reset(self) -> None:
        """Off, counters and bias cleared."""
        self._above = np.zeros(N, dtype=np.int64)  # samples in a row above, per joint
        self._quiet_s = 0.0
        self._bias = np.zeros(N)
        self._last_r: np.ndarray | None = None
        self.state = DetectorState(False, ())

    def update(self, r: np.ndarray, qd: np.ndarray, dt_s: float) -> DetectorState:
        """The state after one sample: r (7,) N·m, qd (7,) rad/s, dt_s since the last sample."""
        time_constant = self.thresholds.bias_time_constant_s
        if time_constant > 0:
            if self._last_r is not None and not self.state.collision:
                follow_bias(self._bias, self._last_r, dt_s, time_constant)
            self._last_r = np.array(r, dtype=np.float64)
            r = r - self._bias
        limit = self.thresholds.at(qd)
        above = np.abs(r) > limit
        counts = self._above
        counts += 1
        counts[~above] = 0
        if not self.state.collision:
            on = counts >= self.thresholds.consecutive
            if on.any():
                self._quiet_s = 0.0
                self.state = DetectorState(True, tuple(int(j) for j in np.flatnonzero(on)))
            return self.state
        joints = tuple(sorted(set(self.state.joints) | {int(j) for j in np.flatnonzero(above)}))
        if np.all(np.abs(r) < self.release_fraction * limit):
            self._quiet_s += dt_s
            if self._quiet_s >= self.hold_s:
                counts[:] = 0
                self.state = DetectorState(False, ())
                return self.state
        else:
            self._quiet_s = 0.0
        self.state = DetectorState(True, joints)
        return self.state


def detect(detector: CollisionDetector, r: np.ndarray, qd: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
    """The detector's on/off (N,) bool over r, qd (N, 7) at stamps_ns (N,), from a reset."""
    detector.reset()
    dt = np.diff(np.asarray(stamps_ns), prepend=stamps_ns[0]) * 1e-9
    return np.array([detector.update(r[k], qd[k], float(dt[k])).collision for k in range(len(r))], dtype=bool)


def public_detector() -> CollisionDetector:
    """The public scheme's detector: fixed :data:`PUBLIC_THRESHOLDS_NM`, on at the first sample
    above, off at the first sample with every joint below."""
    return CollisionDetector(Thresholds(np.array(PUBLIC_THRESHOLDS_NM), consecutive=1), release_fraction=1.0, hold_s=0.0)


def public_residual(arm: ArmModel, recording: Recording, compensation: Compensation | None = None) -> np.ndarray:
    """The public scheme's residual τ_meas − τ(q, q̇, 0), (N, 7) N·m (minus the effects' share, q̈ = 0)."""
    zero = np.zeros_like(recording.q)
    r = recording.effort - (arm if compensation is None else compensation.arm).inverse_dynamics(recording.q, recording.qd, zero)
    if compensation is not None:
        r = r - compensation.torque(recording.q, recording.qd, zero, compensation.presliding_state(recording.qd, recording.stamps_ns))
    return r
