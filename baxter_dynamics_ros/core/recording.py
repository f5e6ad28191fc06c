"""A recording of one arm: joint states over time, as read from a bag or CSV file, and processed.

:class:`Recording` is the core's data container between the file readers of ``msg_adapters/``
and the computations: immutable, validated once when it is made, numpy only.
:class:`ProcessedRecording` adds the model's torques of every sample
(:func:`~baxter_dynamics_ros.core.processing.process_recording`), for the writers.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import RecordingError
from .joints import ARM_SIDES, JOINTS, arm_joint_names

__all__ = [
    "GAP_JITTER_SDS",
    "GAP_PERIODS",
    "JUMP_GAP_PERIODS",
    "MAX_BACK_SHARE",
    "MIN_MOTION_RAD",
    "MIN_FIT_S",
    "MIN_RECORDING_S",
    "MIN_RECORDING_SAMPLES",
    "OtherArm",
    "ProcessedRecording",
    "Recording",
    "detect_arm",
    "estimate_rate_hz",
    "even_runs",
    "jumps",
    "length_shortfall",
    "require_activity",
    "require_length",
    "require_total_span",
    "summed_range_rad",
    "taken_apart",
    "velocity_from_positions",
]

#: An arm moves in a recording when one of its joint angles spans at least this much, rad (0.57°:
#: 26 steps of Baxter's 2π/16384 rad encoders; an arm at rest stays within a few steps).
MIN_MOTION_RAD = 0.01
#: Least correlation of Δq with q̇ Δt for a sample rate estimated from them to be believed.
MIN_RATE_FIT_CORRELATION = 0.5
#: Most estimates of the rate made while the steps taken for jumps change (they settle in two or three).
_JUMP_ROUNDS = 8
#: The least one recording must hold for the offline methods (``diagnose``, ``calibrate``): 2 s —
#: four periods of the gap analysis' 2 Hz systematic band, twenty of the diagnosis' 0.1 s
#: decorrelation time, forty time constants of the momentum observer at its default gain — in
#: at least 200 samples.
MIN_RECORDING_S = 2.0
MIN_RECORDING_SAMPLES = 200
#: A step between two samples longer than this many median sample periods is a gap (samples left
#: out as implausible, messages lost): the offline filters treat the samples on either side as
#: separate pieces (:attr:`Recording.segments`). A lost sample makes a step of 2 periods; the
#: shared recordings' own jitter stays well below 1.5.
GAP_PERIODS = 1.5
#: Where the stamps jitter (receive times of a loaded machine), a gap must also stand this many
#: robust standard deviations (1.4826 · MAD) of the steps above the median step: jitter alone then
#: cuts a recording about once in 10⁶ steps instead of into pieces too short to filter.
GAP_JITTER_SDS = 6.0
#: The step given to a jump (:func:`jumps`) in the stamps of samples without times: a gap of this
#: many sample periods (any length above :data:`GAP_PERIODS` cuts the recording there).
JUMP_GAP_PERIODS = 10
#: Stamps that go back at more than this share of their steps are no time series (:func:`taken_apart`
#: takes apart only runs laid end to end): the readers refuse them.
MAX_BACK_SHARE = 0.5
#: The least data a fit takes in all (the diagnosis' training recordings, a calibration's), s.
MIN_FIT_S = 10.0


def even_runs(stamps_ns: np.ndarray) -> tuple[tuple[int, int], ...]:
    """(start, stop) indices of the runs of evenly spaced stamps (N,) ns: split at every step longer
    than :data:`GAP_PERIODS` median steps and :data:`GAP_JITTER_SDS` robust SDs of the steps above
    the median (:attr:`Recording.segments`)."""
    steps = np.diff(np.asarray(stamps_ns)).astype(np.float64)
    median = float(np.median(steps)) if steps.size else 0.0
    jitter = 1.4826 * float(np.median(np.abs(steps - median))) if steps.size else 0.0
    limit = median + max((GAP_PERIODS - 1.0) * median, GAP_JITTER_SDS * jitter)
    cuts = (np.flatnonzero(steps > limit) + 1).tolist()
    return tuple(zip([0, *cuts], [*cuts, len(stamps_ns)]))


def taken_apart(stamps_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (N,) ns that go back at some steps (trials laid end to end, each timed from its own
    start; a clock set back): (the stamps with each run after such a step moved to begin
    :data:`JUMP_GAP_PERIODS` median forward steps after the one before ends, a gap that cuts the
    recording there; the indices k of the steps back, from sample k to k + 1). Stamps that never go
    back are returned as they are."""
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    steps = np.diff(stamps_ns)
    back = np.flatnonzero(steps < 0)
    if not back.size:
        return stamps_ns, back
    forward = steps[steps > 0]
    period = int(np.median(forward)) if forward.size else 0  # none: stamps that repeat, refused with the recording
    shift = np.zeros(len(stamps_ns), dtype=np.int64)
    shift[back + 1] = stamps_ns[back] - stamps_ns[back + 1] + JUMP_GAP_PERIODS * period
    return stamps_ns + np.cumsum(shift), back


def velocity_from_positions(stamps_ns: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N, m) rad/s, q̇ of positions q (N, m) rad at stamps (N,) ns that give no velocities: the
    central difference of q over the stamps, one-sided at the ends of each run of evenly spaced
    samples (:func:`even_runs`), NaN in a run of one sample (and inf where a stamp repeats: refused
    with the recording)."""
    t = (np.asarray(stamps_ns, dtype=np.int64) - stamps_ns[0]) * 1e-9
    qd = np.full_like(q, np.nan, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for start, stop in even_runs(stamps_ns):
            if stop - start >= 2:
                qd[start:stop] = np.gradient(q[start:stop], t[start:stop], axis=0)
    return qd


def summed_range_rad(q: np.ndarray) -> float:
    """Summed range (max − min) of each joint's angle over its finite samples, rad; q (N, m) rad.
    A joint without a finite sample adds 0 (one NaN in a dump does not decide which arm moves)."""
    q = np.where(np.isfinite(q), q, np.nan)
    seen = ~np.all(np.isnan(q), axis=0)
    if not seen.any():
        return 0.0
    return float(np.sum(np.nanmax(q[:, seen], axis=0) - np.nanmin(q[:, seen], axis=0)))


def detect_arm(names: Sequence[str], q_range_rad: dict[str, float] | None = None) -> str:
    """The arm whose 7 joints are all in ``names``.

    When both arms are there (Baxter's /robot/joint_states carries both), the one that moves more
    is chosen: ``q_range_rad`` maps each side to the summed range (max − min) of its joint angles
    over the recording. Raises :class:`RecordingError` when neither arm is complete or the choice
    is a tie.
    """
    present = set(names)
    sides = [side for side in ARM_SIDES if present.issuperset(arm_joint_names(side))]
    if not sides:
        shown = ", ".join(sorted(present)) or "none"
        raise RecordingError(
            f"no arm has all 7 joints (right_s0..right_w2 or left_s0..left_w2); joint names found: {shown}"
        )
    if len(sides) == 1:
        return sides[0]
    ranges = q_range_rad or {}
    right, left = ranges.get("right", 0.0), ranges.get("left", 0.0)
    if right == left:
        raise RecordingError("both arms are recorded and move alike; choose one with --arm right|left")
    return "right" if right > left else "left"


def _span_rad(q: np.ndarray) -> float:
    """The largest range (max − min) of one joint's angle, rad; 0 without samples or joints."""
    return float(np.ptp(q, axis=0).max()) if q.size else 0.0


def estimate_rate_hz(q: np.ndarray, qd: np.ndarray, speed_bound_rad_s: np.ndarray | None = None) -> float | None:
    """The sample rate of evenly spaced samples, Hz, from their positions and velocities alone.

    q (N, m) rad, qd (N, m) rad/s. The sample period Δt is the least-squares solution of
    Δq_k = Δt (q̇_k + q̇_{k+1}) / 2 (the trapezoid rule) over every step k and joint:
    Δt = Σ Δq_k v̄_k / Σ v̄_k². None when it cannot be made: no joint spans :data:`MIN_MOTION_RAD`
    (the arm never moves), or Δq and v̄ correlate less than :data:`MIN_RATE_FIT_CORRELATION`
    (the velocities do not describe these positions). Steps with a non-finite value are left out;
    with ``speed_bound_rad_s`` (m,) so are the steps no motion explains at the estimate
    (:func:`jumps`: trajectories laid end to end), the estimate made again until they stay the same.
    """
    q = np.asarray(q, dtype=np.float64)
    qd = np.asarray(qd, dtype=np.float64)
    dq = np.diff(q, axis=0)
    v_mean = 0.5 * (qd[1:] + qd[:-1])
    finite = np.isfinite(dq) & np.isfinite(v_mean)
    if not finite.any() or _span_rad(q[np.isfinite(q).all(axis=1)]) < MIN_MOTION_RAD:
        return None
    kept = np.ones(len(dq), dtype=bool)
    for _ in range(_JUMP_ROUNDS):
        used = finite & kept[:, None]
        d, v = dq[used], v_mean[used]
        vv, dd = float(v @ v), float(d @ d)
        if vv == 0.0 or dd == 0.0:
            return None
        dq_v = float(d @ v)
        if dq_v <= 0.0 or speed_bound_rad_s is None:
            break
        now = np.ones(len(dq), dtype=bool)
        now[jumps(q, qd, dq_v / vv, speed_bound_rad_s)] = False
        if np.array_equal(now, kept):
            break
        kept = now
    if dq_v / np.sqrt(vv * dd) < MIN_RATE_FIT_CORRELATION:
        return None
    return vv / dq_v


def jumps(q: np.ndarray, qd: np.ndarray, period_s: float, speed_bound_rad_s: np.ndarray) -> np.ndarray:
    """Indices k (M,) of the steps from sample k to k+1 of evenly spaced samples that no motion
    explains: a joint's Δq differs from the trapezoid rule's Δt (q̇_k + q̇_{k+1}) / 2 by more than
    its plausible top speed covers in Δt — the join of two trajectories laid end to end.

    q (N, m) rad, qd (N, m) rad/s, period_s Δt, speed_bound_rad_s (m,) the plausible top speeds
    (:func:`~.plausibility.plausibility_bounds`). Steps with a non-finite value are none.
    """
    q = np.asarray(q, dtype=np.float64)
    qd = np.asarray(qd, dtype=np.float64)
    unexplained = np.abs(np.diff(q, axis=0) - period_s * 0.5 * (qd[1:] + qd[:-1]))
    return np.flatnonzero((unexplained > period_s * np.asarray(speed_bound_rad_s)).any(axis=1))


class OtherArm(NamedTuple):
    """What a file holds of an arm that was not chosen: q (N, k) rad and effort (N, k) N·m (None if
    absent) of those of its joints present (k ≤ 7), and the names of its missing columns / joints."""

    q: np.ndarray
    effort: np.ndarray | None
    missing: tuple[str, ...] = ()


def require_activity(side: str, q: np.ndarray, effort: np.ndarray, others: dict[str, OtherArm] | None = None) -> None:
    """Refuse the data of an arm that never moves or has no effort (RecordingError).

    side: the chosen arm; q (N, 7) rad, effort (N, 7) N·m its data. Moving means one joint angle
    spanning :data:`MIN_MOTION_RAD`; no effort, every value 0. others: the file's other arms, named
    in the error when they move and have effort (or what they lack), so that the user can choose.
    """
    hints = []
    for other, data in (others or {}).items():
        if _span_rad(data.q) < MIN_MOTION_RAD or data.effort is None or not np.any(data.effort):
            continue
        if data.missing:
            hints.append(f"the {other} arm moves, but {', '.join(data.missing)} is missing")
        else:
            hints.append(f"the {other} arm moves and has effort: pass --arm {other}")
    hint = "".join(f"; {h}" for h in hints)
    span = _span_rad(np.asarray(q))
    if span < MIN_MOTION_RAD:
        raise RecordingError(
            f"the {side} arm does not move here (no joint angle spans {MIN_MOTION_RAD} rad; at most {span:.4f}){hint}"
        )
    if not np.any(effort):
        raise RecordingError(f"the {side} arm has no effort here (every value is 0){hint}")


def require_length(recordings: Sequence[tuple[str, Recording]], what: str, total_s: float = 0.0) -> None:
    """Refuse (RecordingError) a recording shorter than :data:`MIN_RECORDING_S` or with fewer than
    :data:`MIN_RECORDING_SAMPLES` samples, and ``recordings`` (label, recording) shorter than
    ``total_s`` together; ``what`` names their use in the messages (e.g. "test"). Lengths are
    :attr:`Recording.span_s`."""
    for label, rec in recordings:
        short = length_shortfall(len(rec), rec.span_s, what)
        if short is not None:
            raise RecordingError(f"{label}: {short}")
    require_total_span([rec.span_s for _, rec in recordings], what, total_s)


def length_shortfall(samples: int, span_s: float, what: str = "") -> str | None:
    """Why a recording of ``samples`` spanning span_s (s) is too short for the offline methods
    ("N samples, T s; a [what ]recording needs at least …"), None when it is long enough."""
    if span_s >= MIN_RECORDING_S and samples >= MIN_RECORDING_SAMPLES:
        return None
    kind = f"{what} recording" if what else "recording"
    return f"{samples} samples, {span_s:.2f} s; a {kind} needs at least {MIN_RECORDING_SAMPLES} samples and {MIN_RECORDING_S:g} s"


def require_total_span(spans_s: Sequence[float], what: str, total_s: float) -> None:
    """Refuse (RecordingError) recordings of spans_s (s, :attr:`Recording.span_s`) shorter than total_s together."""
    total = sum(spans_s)
    if total < total_s:
        raise RecordingError(f"the {what} recordings hold {total:.2f} s together; at least {total_s:g} s are needed")


@dataclass(frozen=True)
class Recording:
    """Joint states of one arm, sample by sample.

    joint_names (7,) in model order; stamps_ns (N,) int64 strictly increasing, ns; q (N, 7) rad,
    qd (N, 7) rad/s, effort (N, 7) N·m (the torques the robot reported); side "right" or "left".
    Arrays are read-only copies; construction checks shapes, order and finiteness.
    """

    side: str
    joint_names: tuple[str, ...]
    stamps_ns: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray

    def __post_init__(self) -> None:
        names = tuple(self.joint_names)
        if names != arm_joint_names(self.side):
            raise RecordingError(
                f"joint_names must be the {self.side} arm's {arm_joint_names(self.side)}, got {names}"
            )
        object.__setattr__(self, "joint_names", names)
        stamps = np.array(self.stamps_ns, dtype=np.int64)
        if stamps.ndim != 1 or len(stamps) < 2:
            raise RecordingError(f"stamps_ns must be (N,) with N >= 2 samples, got shape {stamps.shape}")
        n = len(stamps)
        steps = np.diff(stamps)
        if np.any(steps <= 0):
            k = int(np.argmax(steps <= 0))
            raise RecordingError(
                f"stamps_ns must increase strictly; sample {k + 1} of {n} is at {stamps[k + 1]} ns "
                f"after {stamps[k]} ns ({int(np.sum(steps <= 0))} such steps)"
            )
        stamps.flags.writeable = False
        object.__setattr__(self, "stamps_ns", stamps)
        for field_name in ("q", "qd", "effort"):
            arr = np.array(getattr(self, field_name), dtype=np.float64)
            if arr.shape != (n, JOINTS):
                raise RecordingError(f"{field_name} must be ({n}, {JOINTS}) like stamps_ns, got {arr.shape}")
            bad = ~np.isfinite(arr)
            if bad.any():
                k, j = (int(i) for i in np.argwhere(bad)[0])
                raise RecordingError(
                    f"{field_name} has {int(bad.sum())} non-finite values, the first at sample {k} "
                    f"joint {names[j]} ({arr[k, j]})"
                )
            arr.flags.writeable = False
            object.__setattr__(self, field_name, arr)

    def __len__(self) -> int:
        return len(self.stamps_ns)

    @property
    def stamps_s(self) -> np.ndarray:
        """(N,) seconds since the first sample (float, for filters and plots)."""
        return (self.stamps_ns - self.stamps_ns[0]) * 1e-9

    @property
    def rate_hz(self) -> float:
        """The median sample rate in Hz."""
        return 1e9 / float(np.median(np.diff(self.stamps_ns)))

    @property
    def segments(self) -> tuple[tuple[int, int], ...]:
        """(start, stop) sample indices of the runs of evenly spaced samples: the recording split at
        every step longer than :data:`GAP_PERIODS` median periods and :data:`GAP_JITTER_SDS` robust
        SDs of the steps above the median. One run without gaps."""
        return even_runs(self.stamps_ns)

    @property
    def span_s(self) -> float:
        """The time the samples cover, s: N sample periods (the median one), one more than duration_s."""
        return len(self) / self.rate_hz

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample, s."""
        return (int(self.stamps_ns[-1]) - int(self.stamps_ns[0])) * 1e-9


@dataclass(frozen=True)
class ProcessedRecording:
    """A recording with the model's torques, all (N, 7), sample k of each array at stamps_ns[k].

    qdd: estimated q̈, rad/s²; gravity: G(q) of eq. (8), N·m; inverse_dynamics: τ = M q̈ + C + G of
    eq. (1), N·m; residual: recorded effort − τ, N·m (what the rigid-body model leaves unexplained).
    """

    recording: Recording
    qdd: np.ndarray
    gravity: np.ndarray
    inverse_dynamics: np.ndarray
    residual: np.ndarray

    def torques(self) -> dict[str, np.ndarray]:
        """The three computed torques by name: gravity, inverse_dynamics, residual, each (N, 7) N·m."""
        return {"gravity": self.gravity, "inverse_dynamics": self.inverse_dynamics, "residual": self.residual}
