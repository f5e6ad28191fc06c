"""Joint acceleration q̈ from measured joint velocity q̇: causal (live) and zero-phase (offline).

Baxter does not publish q̈; the paper took the raw first difference of q̇ at 50 Hz, whose noise
dominated its torque errors. Three estimators, all on (..., 7) arrays:

- :func:`first_difference` — the paper's q̈_k = (q̇_k − q̇_{k−1}) / Δt_k (causal, unfiltered);
  :class:`FirstDifference` is the same, one sample at a time, for the live node.
- :class:`LowPassDifferentiator` — causal, for the live node: q̇ through a second-order low-pass
  filter ẍ = ω_c² (q̇ − x) − 2ζω_c ẋ, whose state ẋ is the estimate. Discretised by the trapezoidal
  rule per sample with the sample's own Δt, so it is stable for any Δt and identical offline and
  live for the same stamps. Magnitude response of q̈ = s·H(s)·q̇ with H(s) = ω_c² / (s² + 2ζω_c s +
  ω_c²): −3 dB at ``cutoff_hz`` for ζ = 1/√2 (Butterworth), group delay ≈ √2 / ω_c at low
  frequency (22.5 ms at the default 10 Hz).
- :func:`zero_phase_acceleration` — offline: Butterworth low-pass on q̇ run forwards and
  backwards (no delay, :func:`zero_phase_lowpass`, the package's one zero-phase filter), then
  central differences.

:data:`ESTIMATORS` names them once, with their default cut-offs, for every place that offers a
choice (``process --acceleration``, the node's ``estimator`` parameter).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = [
    "CAUSAL_ESTIMATORS",
    "ESTIMATORS",
    "Estimator",
    "FirstDifference",
    "LowPassDifferentiator",
    "first_difference",
    "zero_phase_acceleration",
    "zero_phase_lowpass",
]


class Estimator(NamedTuple):
    """What an estimator of :data:`ESTIMATORS` is: its default cut-off in Hz (None: it has no
    filter, and takes no cut-off) and whether it is causal (usable live, sample by sample)."""

    default_cutoff_hz: float | None
    causal: bool


#: Every q̈ estimator by name (module docstring): ``zero_phase`` (offline), ``lowpass`` and
#: ``first_difference`` (causal; the node offers these).
ESTIMATORS: dict[str, Estimator] = {
    "zero_phase": Estimator(5.0, causal=False),
    "lowpass": Estimator(10.0, causal=True),
    "first_difference": Estimator(None, causal=True),
}
#: The causal ones, in that order: what the live node offers.
CAUSAL_ESTIMATORS = tuple(name for name, e in ESTIMATORS.items() if e.causal)


def first_difference(qd: np.ndarray, stamps_s: np.ndarray) -> np.ndarray:
    """The paper's q̈_k = (q̇_k − q̇_{k−1}) / (t_k − t_{k−1}); q̈_0 = 0. qd (N, 7) rad/s, stamps_s (N,) s."""
    qd = np.asarray(qd, dtype=float)
    dt = np.diff(np.asarray(stamps_s, dtype=float))
    qdd = np.zeros_like(qd)
    qdd[1:] = np.diff(qd, axis=0) / dt[:, None]
    return qdd


class FirstDifference:
    """:func:`first_difference` one sample at a time, with :class:`LowPassDifferentiator`'s interface.

    ``update(qd, dt_s)`` takes q̇ (7,) in rad/s and the time since the previous sample in s, and
    returns (q̇ − q̇_previous) / dt_s (7,) in rad/s²; zeros for the first sample after construction
    or :meth:`reset`.
    """

    def __init__(self) -> None:
        self._u: np.ndarray | None = None  # previous input q̇, (7,)

    def reset(self) -> None:
        """Forget the previous sample."""
        self._u = None

    def update(self, qd: np.ndarray, dt_s: float) -> np.ndarray:
        """Feed q̇ (7,) rad/s measured dt_s seconds after the previous sample; returns q̈ (7,) rad/s²."""
        u = np.array(qd, dtype=float)
        previous = self._u
        if previous is None:
            self._u = u
            return np.zeros_like(u)
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s}")
        self._u = u
        return (u - previous) / dt_s


class LowPassDifferentiator:
    """Causal second-order low-pass differentiator of q̇, one sample at a time.

    ``update(qd, dt_s)`` takes q̇ (7,) in rad/s and the time since the previous sample in s, and
    returns q̈ (7,) in rad/s². The first sample after construction or :meth:`reset` starts the
    filter at rest on that q̇ and returns zeros.
    """

    def __init__(self, cutoff_hz: float = 10.0, damping: float = 1.0 / np.sqrt(2.0)) -> None:
        if not (np.isfinite(cutoff_hz) and cutoff_hz > 0):
            raise ValueError(f"cutoff_hz must be positive and finite, got {cutoff_hz}")
        if not (np.isfinite(damping) and damping > 0):
            raise ValueError(f"damping must be positive and finite, got {damping}")
        self.cutoff_hz = float(cutoff_hz)
        self.damping = float(damping)
        self._wc = 2.0 * np.pi * self.cutoff_hz
        self._x: np.ndarray | None = None  # filtered q̇, (7,)
        self._xd: np.ndarray | None = None  # its derivative, the estimate, (7,)
        self._u: np.ndarray | None = None  # previous input q̇, (7,)

    def reset(self) -> None:
        """Forget the state; the next sample restarts the filter."""
        self._x = self._xd = self._u = None

    def update(self, qd: np.ndarray, dt_s: float) -> np.ndarray:
        """Feed q̇ (7,) rad/s measured dt_s seconds after the previous sample; returns q̈ (7,) rad/s²."""
        u = np.asarray(qd, dtype=np.float64)
        if self._x is None:
            self._x, self._xd, self._u = u.copy(), np.zeros_like(u), u.copy()
            return np.zeros_like(u)
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s}")
        _lowpass_step(self._x, self._xd, self._u, u, self._wc, self.damping, dt_s)
        return self._xd.copy()

    def run(self, qd: np.ndarray, stamps_s: np.ndarray) -> np.ndarray:
        """Filter a whole recording from a fresh state: qd (N, 7) rad/s, stamps_s (N,) s → q̈ (N, 7)."""
        self.reset()
        qd = np.asarray(qd, dtype=float)
        stamps_s = np.asarray(stamps_s, dtype=float)
        out = np.empty_like(qd)
        previous = stamps_s[0] if len(stamps_s) else 0.0
        for k in range(len(qd)):
            out[k] = self.update(qd[k], stamps_s[k] - previous)
            previous = stamps_s[k]
        return out


@njit(cache=True)
def _lowpass_step(x, xd, u_previous, u, wc, damping, dt_s):
    """One step of :class:`LowPassDifferentiator`, in place on the (7,) states x, ẋ; u_previous := u.

    State z = (x, ẋ), ż = A z + B u, A = [[0, 1], [−ω², −2ζω]], B = [0, ω²]; trapezoidal step
    z⁺ = (I − hA)⁻¹ [(I + hA) z + hB (u + u⁺)], h = Δt/2, written out for the 2×2 case.
    """
    w2, c, h = wc * wc, 2.0 * damping * wc, 0.5 * dt_s
    det = 1.0 + h * c + h * h * w2
    for j in range(x.shape[0]):
        r0 = x[j] + h * xd[j]
        r1 = -h * w2 * x[j] + (1.0 - h * c) * xd[j] + h * w2 * (u_previous[j] + u[j])
        x[j] = ((1.0 + h * c) * r0 + h * r1) / det
        xd[j] = (-h * w2 * r0 + r1) / det
        u_previous[j] = u[j]


def zero_phase_lowpass(
    x: np.ndarray, rate_hz: float, cutoff_hz: float, order: int = 2, segments: Sequence[tuple[int, int]] | None = None
) -> np.ndarray:
    """x (N, k) low-passed forwards and backwards: zero phase, −6 dB at cutoff_hz, x sampled at rate_hz.

    A Butterworth filter of ``order`` in second-order sections (``scipy.signal.sosfiltfilt``), the
    ends padded by odd reflection over scipy's default length, 3 · (2 · sections + 1) samples (9 for
    order 2), or N − 1 samples when the series is shorter. cutoff_hz must lie in (0, rate_hz / 2).
    segments: (start, stop) of the runs of evenly spaced samples
    (:attr:`~.recording.Recording.segments`), each filtered on its own, never across a gap; None: one run.
    """
    from scipy.signal import butter, sosfiltfilt

    x = np.asarray(x, dtype=float)
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be positive and finite, got {rate_hz}")
    if not (0 < cutoff_hz < rate_hz / 2):
        raise ValueError(f"cutoff_hz must lie in (0, {rate_hz / 2}) Hz, got {cutoff_hz}")
    if segments is not None and len(segments) > 1:
        out = np.empty_like(x)
        for start, stop in segments:
            out[start:stop] = zero_phase_lowpass(x[start:stop], rate_hz, cutoff_hz, order)
        return out
    if len(x) < 2:
        return x.copy()
    sos = butter(order, cutoff_hz, fs=rate_hz, output="sos")
    padlen = min(3 * (2 * len(sos) + 1), len(x) - 1)
    return sosfiltfilt(sos, x, axis=0, padlen=padlen)


def zero_phase_acceleration(
    qd: np.ndarray, rate_hz: float, cutoff_hz: float | None = 5.0, order: int = 2, segments: Sequence[tuple[int, int]] | None = None
) -> np.ndarray:
    """Offline q̈ (N, 7) rad/s² from q̇ (N, 7) rad/s sampled at rate_hz.

    q̇ is low-passed forwards and backwards (:func:`zero_phase_lowpass`: Butterworth of ``order``,
    −6 dB at ``cutoff_hz``, zero phase), then differentiated by central differences.
    ``cutoff_hz=None`` skips the filter. segments: (start, stop) of the runs of evenly spaced
    samples (:attr:`~.recording.Recording.segments`), each filtered on its own, so that no filter
    or difference reaches across a gap; None: one run. A run of one sample has q̈ = 0.
    """
    qd = np.asarray(qd, dtype=float)
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be positive and finite, got {rate_hz}")
    if segments is not None and len(segments) > 1:
        out = np.zeros_like(qd)
        for start, stop in segments:
            out[start:stop] = zero_phase_acceleration(qd[start:stop], rate_hz, cutoff_hz, order)
        return out
    if len(qd) < 2:
        return np.zeros_like(qd)
    smooth = qd if cutoff_hz is None else zero_phase_lowpass(qd, rate_hz, cutoff_hz, order)
    return np.gradient(smooth, 1.0 / rate_hz, axis=0)
