"""The live node's health report: what happened to every sample, once per window; numpy only, no ROS.

:class:`HealthMonitor` counts what happened to every sample and reports once per window (the
node's ``diagnostics_period_s``, 1 s by default) as plain data, which the node publishes on
/diagnostics. Levels:

- OK — samples came in and every one was published, with a residual, and every statistic is
  finite (a non-finite residual RMS is reported as WARN, never OK);
- WARN — no sample came in the window (robot or recording stopped, wrong topic), or some samples
  were skipped for a fault, or some samples had no effort (no residual published for them);
- ERROR — samples came in but none could be published (every one skipped for a fault).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import njit

from ..core.samples import Health, HealthReport, ModelTorques, ResetCause, SkipReason

__all__ = ["HealthMonitor"]


@njit(cache=True)
def _add_squares(total: np.ndarray, x: np.ndarray) -> None:
    """total += x² in place (compiled: no overflow warning on stderr; an overflow gives inf)."""
    for j in range(x.shape[0]):
        total[j] += x[j] * x[j]


class HealthMonitor:
    """Counts the pipeline's results over a window and reports (see the module docstring).

    Per window: input rate, samples received / published / skipped per cause, processing latency
    (mean and max, as measured by the caller), and the per-joint residual RMS
    sqrt(mean(residual²)) over the window's samples. Totals since start for skips and resets.
    """

    def __init__(self, joint_names: Sequence[str], topic: str) -> None:
        self.joint_names = tuple(joint_names)
        self.topic = topic
        self._skips_total = dict.fromkeys(SkipReason, 0)
        self._resets_total = dict.fromkeys(ResetCause, 0)
        self._new_window()

    def _new_window(self) -> None:
        self._skips = dict.fromkeys(SkipReason, 0)
        self._published = 0
        self._with_residual = 0
        self._qd_from_positions = 0
        self._residual_sq_sum = np.zeros(len(self.joint_names))
        self._latency_sum_ns = 0
        self._latency_max_ns = 0

    def record(self, result: ModelTorques | SkipReason, latency_ns: int) -> None:
        """Count one sample's result and the time the caller took to handle it (ns)."""
        self._latency_sum_ns += latency_ns
        if latency_ns > self._latency_max_ns:
            self._latency_max_ns = latency_ns
        if isinstance(result, SkipReason):
            self._skips[result] += 1
            if result is SkipReason.NON_FINITE_MODEL:  # the pipeline reset its states
                self._resets_total[ResetCause.NON_FINITE_STATE] += 1
            return
        self._published += 1
        self._qd_from_positions += result.qd_from_positions
        if result.residual is not None:
            self._with_residual += 1
            _add_squares(self._residual_sq_sum, result.residual)

    def record_reset(self, cause: ResetCause) -> None:
        """Count an estimator reset asked from outside the pipeline (its own are counted by :meth:`record`)."""
        self._resets_total[cause] += 1

    def report(self, elapsed_s: float) -> HealthReport:
        """Summarise the window that lasted elapsed_s seconds, and start the next one."""
        skipped = sum(self._skips.values())
        received = self._published + skipped
        faults = {r.value: n for r, n in self._skips.items() if n and r.is_fault}
        fault_text = ", ".join(f"{name}: {n}" for name, n in faults.items())
        if received == 0:
            level, message = Health.WARN, f"no joint states on {self.topic} in the last {elapsed_s:.1f} s"
        elif self._published == 0 and faults:
            level, message = Health.ERROR, f"all {received} samples skipped ({fault_text}): nothing published"
        elif self._published == 0:
            level, message = Health.WARN, "no velocity in the input: waiting for a second sample"
        elif faults:
            level, message = Health.WARN, f"{skipped} of {received} samples skipped ({fault_text})"
        elif self._with_residual < self._published:
            missing = self._published - self._with_residual
            level, message = Health.WARN, f"{missing} of {received} samples had no effort: no residual for them"
        else:
            level, message = Health.OK, f"publishing at {received / elapsed_s:.1f} Hz"
        with np.errstate(invalid="ignore", over="ignore"):
            rms = np.sqrt(self._residual_sq_sum / max(self._with_residual, 1))
        if self._with_residual and not np.isfinite(rms).all():  # a statistic that says nothing is never OK
            overflowed = ", ".join(j for j, r in zip(self.joint_names, rms) if not np.isfinite(r))
            level, message = max(level, Health.WARN), f"{message}; residual RMS not finite at {overflowed}"

        for reason, n in self._skips.items():
            self._skips_total[reason] += n
        rate_hz = received / elapsed_s if elapsed_s > 0 else 0.0
        values: list[tuple[str, str]] = [
            ("topic", self.topic),
            ("window_s", f"{elapsed_s:.3f}"),
            ("input_rate_hz", f"{rate_hz:.1f}"),
            ("samples_received", str(received)),
            ("samples_published", str(self._published)),
            ("residuals_published", str(self._with_residual)),
            ("velocity_from_positions", str(self._qd_from_positions)),
            ("latency_mean_us", f"{self._latency_sum_ns / received / 1e3:.1f}" if received else "n/a"),
            ("latency_max_us", f"{self._latency_max_ns / 1e3:.1f}" if received else "n/a"),
        ]
        values += [(f"skipped.{r.value}", str(n)) for r, n in self._skips.items()]
        values += [(f"skipped_total.{r.value}", str(n)) for r, n in self._skips_total.items()]
        values += [(f"resets_total.{c.value}", str(n)) for c, n in self._resets_total.items()]
        if self._with_residual:
            values += [(f"residual_rms_nm.{j}", f"{r:.4g}") for j, r in zip(self.joint_names, rms)]
        else:
            values += [(f"residual_rms_nm.{j}", "n/a") for j in self.joint_names]
        self._new_window()
        return HealthReport(level, message, tuple(values))
