"""The live node's collision monitoring on the observer's r, sample by sample; numpy only, no ROS.

:class:`CollisionMonitor` holds, for the node:

- the latest samples with effort (stamp, q, q̇, effort and r when the observer ran) in preallocated
  ring buffers of ``calibration_window_s`` · :data:`MAX_RATE_HZ` rows, from which
  :meth:`~CollisionMonitor.calibrate` takes thresholds
  (:func:`~baxter_dynamics_ros.monitoring.calibration.calibrate_thresholds`) over the last
  ``calibration_window_s`` (``~/calibrate``). The node runs the observer only while detection is
  active or ``~/external_torque`` has a subscriber; for the other samples r is computed at
  calibration, by ``observe_window`` over the buffered window (its first
  :data:`SETTLE_TIME_CONSTANTS` observer time constants left out, while r settles from 0);
- a :class:`~baxter_dynamics_ros.monitoring.detector.CollisionDetector` on r, run while monitoring is on
  (``~/set_monitoring``) and thresholds are known (``thresholds_file`` or a calibration);
- the diagnostics window's collision summary: :meth:`~CollisionMonitor.report` raises the health
  report to ERROR naming the joints when a collision was on at any time in the window.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..core.samples import Health, HealthReport
from ..errors import CollisionError
from .calibration import calibrate_thresholds
from .detector import DEFAULT_BIAS_TIME_CONSTANT_S, CollisionDetector
from .thresholds import Thresholds

__all__ = ["MAX_RATE_HZ", "MIN_CALIBRATION_SAMPLES", "SETTLE_TIME_CONSTANTS", "CollisionMonitor"]

#: Highest input rate whose whole calibration window the buffers hold, Hz.
MAX_RATE_HZ = 2000.0
#: Fewest samples a calibration accepts (besides covering half the window).
MIN_CALIBRATION_SAMPLES = 50
#: Observer time constants (1 / K_O) left out at the start of a window computed at calibration.
SETTLE_TIME_CONSTANTS = 5.0


class CollisionMonitor:
    """Collision detection and online calibration on the observer's r (module docstring).

    joint_names: the arm's 7 joints; window_s: calibration window, s; gain_1_s and effort_delay_s: the
    observer's gain and effort–state alignment (recorded in calibrated thresholds); thresholds: to detect with from the start (None: not until
    calibrated); source: where they come from, for diagnostics.
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        window_s: float,
        gain_1_s: float,
        thresholds: Thresholds | None = None,
        source: str = "",
        observe_window: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
        effort_delay_s: float = 0.0,
    ) -> None:
        self.joint_names = tuple(joint_names)
        self.window_s = float(window_s)
        self.gain_1_s = float(gain_1_s)
        self.effort_delay_s = float(effort_delay_s)
        capacity = int(math.ceil(self.window_s * MAX_RATE_HZ)) + 1
        self._stamps_ns = np.zeros(capacity, dtype=np.int64)
        self._r = np.zeros((capacity, len(self.joint_names)))
        self._qd = np.zeros((capacity, len(self.joint_names)))
        self._q = np.zeros((capacity, len(self.joint_names)))
        self._effort = np.zeros((capacity, len(self.joint_names)))
        self._observe_window = observe_window
        self._next = 0
        self._count = 0
        self._last_stamp_ns: int | None = None
        self.monitoring = True
        self.detector: CollisionDetector | None = None
        self.source = ""
        if thresholds is not None:
            self.set_thresholds(thresholds, source)
        self._new_window()

    def _new_window(self) -> None:
        self._events = 0
        self._window_joints: set[int] = set(self.detector.state.joints) if self.collision else set()

    @property
    def collision(self) -> bool:
        """Whether a collision is detected now."""
        return self.detector is not None and self.detector.state.collision

    @property
    def active(self) -> bool:
        """Whether detection runs now (thresholds known and monitoring on): the observer is needed."""
        return self.detector is not None and self.monitoring

    def update(
        self, stamp_ns: int, r: np.ndarray | None, qd: np.ndarray, q: np.ndarray | None = None, effort: np.ndarray | None = None
    ) -> bool | None:
        """Buffer one accepted sample (r or None when the observer did not run; q, qd, effort (7,))
        and detect; the new collision state if it changed, else None."""
        i = self._next
        self._stamps_ns[i] = stamp_ns
        self._r[i] = np.nan if r is None else r
        self._qd[i] = qd
        if q is not None and effort is not None:
            self._q[i] = q
            self._effort[i] = effort
        self._next = (i + 1) % len(self._stamps_ns)
        self._count = min(self._count + 1, len(self._stamps_ns))
        last = self._last_stamp_ns
        self._last_stamp_ns = stamp_ns
        detector = self.detector
        if detector is None or not self.monitoring or r is None:
            return None
        before = detector.state
        state = detector.update(r, qd, 0.0 if last is None or stamp_ns <= last else (stamp_ns - last) * 1e-9)
        if state.collision == before.collision:
            return None
        self._events += state.collision
        self._window_joints.update(state.joints if state.collision else before.joints)
        return state.collision

    def reset(self) -> bool:
        """Forget the buffered samples and restart the detector (off); True if a collision was on."""
        self._next = self._count = 0
        self._last_stamp_ns = None
        return self._detector_off()

    def _detector_off(self) -> bool:
        was = self.collision
        if self.detector is not None:
            if was:
                self._window_joints.update(self.detector.state.joints)
            self.detector.reset()
        return was

    def set_monitoring(self, on: bool) -> bool:
        """Switch detection on or off (off: no collision); True if a collision was on and is now off."""
        self.monitoring = bool(on)
        return False if on else self._detector_off()

    def set_thresholds(self, thresholds: Thresholds, source: str) -> bool:
        """Detect with ``thresholds`` from now on (from off); True if a collision was on and is now off."""
        was = self._detector_off()
        self.detector = CollisionDetector(thresholds)
        self.source = source
        return was

    def calibrate(self) -> tuple[Thresholds, str]:
        """Thresholds from the last ``window_s`` of buffered samples, and the text saying what they came from.

        Raises :class:`CollisionError` when a collision is detected now or the samples cover less than
        half the window (or fewer than :data:`MIN_CALIBRATION_SAMPLES`). Does not apply them
        (:meth:`set_thresholds` does).
        """
        if self.collision:
            raise CollisionError(
                "a collision is detected now: calibrate on collision-free motion (switch ~/set_monitoring off first "
                "if the thresholds in use are too low)"
            )
        stamps = self._stamps_ns[: self._count]
        newest = int(self._stamps_ns[self._next - 1]) if self._count else 0
        keep = (stamps >= newest - int(self.window_s * 1e9)) & (stamps <= newest)
        n = int(np.count_nonzero(keep))
        span_s = (newest - int(stamps[keep].min())) * 1e-9 if n else 0.0
        if n < MIN_CALIBRATION_SAMPLES or span_s < self.window_s / 2:
            raise CollisionError(
                f"too little data: {n} samples with effort over {span_s:.2f} s since the last reset; calibration "
                f"needs at least {MIN_CALIBRATION_SAMPLES} samples over {self.window_s / 2:g} s (half of "
                f"calibration_window_s = {self.window_s:g} s) of collision-free motion: move the arm and call again"
            )
        window = np.flatnonzero(keep)
        window = window[np.argsort(stamps[window], kind="stable")]
        t = stamps[window]
        r = self._r[window]
        qd = self._qd[window]
        if not np.all(np.isfinite(r)):
            if self._observe_window is None:
                raise CollisionError("the observer did not run on the buffered samples and there is no way to compute it")
            r = self._observe_window(t, self._q[window], qd, self._effort[window])
            settled = t >= t[0] + int(SETTLE_TIME_CONSTANTS / self.gain_1_s * 1e9)
            t, r, qd = t[settled], r[settled], qd[settled]
        thresholds = calibrate_thresholds(
            [r], [qd], gain_1_s=self.gain_1_s, effort_delay_s=self.effort_delay_s,
            stamps_ns=[t], bias_time_constant_s=DEFAULT_BIAS_TIME_CONSTANT_S,
        )  # fmt: skip
        return thresholds, f"~/calibrate over {span_s:.2f} s ({n} samples)"

    def report(self, health: HealthReport) -> HealthReport:
        """``health`` with the window's collision summary added (ERROR naming the joints if one was on); starts the next window."""
        if self.collision:
            self._window_joints.update(self.detector.state.joints)
        joints = ", ".join(self.joint_names[j] for j in sorted(self._window_joints))
        if self.detector is None:
            status = "no thresholds: call ~/calibrate or set thresholds_file"
        else:
            status = "on" if self.monitoring else "off"
        values = [
            ("monitoring", status),
            ("thresholds", self.source or "none"),
            ("collision", "true" if self.collision else "false"),
            ("collisions_in_window", str(self._events)),
            ("collision_joints", joints),
        ]
        if self.detector is None:
            values += [(f"threshold_offset_nm.{j}", "n/a") for j in self.joint_names]
        else:
            values += [(f"threshold_offset_nm.{j}", f"{x:.4g}") for j, x in zip(self.joint_names, self.detector.thresholds.offset_nm)]
        level, message = health.level, health.message
        if self._window_joints:
            level, message = Health.ERROR, f"collision at {joints}; {message}"
        self._new_window()
        return HealthReport(level, message, health.values + tuple(values))
