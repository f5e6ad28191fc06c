"""The diagnosis' work on one recording at a time: what each pass over the sources keeps of a file.

Each function reads one :class:`~baxter_dynamics_ros.diagnosis.sources.Source`, reduces the
recording to what the procedure needs and lets it go, so that memory is bounded by one recording
plus statistics, whatever the number of files; they are module-level (picklable) so that worker
processes or a cluster can run them (:data:`~baxter_dynamics_ros.diagnosis.sources.Mapper`).

1. :func:`screen`: the checks of one recording, its angle histogram, the training files' cut-off
   scores;
2. :func:`reduce`: at the chosen cut-offs, the sufficient statistics per block (and the test files'
   angle values near the quantiles of the gap summary's bins);
3. :func:`test_figures`: on a test file with the selected effects fitted, the gap summary's sums and
   the report's residual series (every ``stride``-th sample).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.acceleration import zero_phase_acceleration
from ..core.arm_model import ArmModel
from ..core.joints import S1
from ..core.recording import Recording, require_length
from ..errors import DiagnosisError, RecordingError
from .gap_analysis import GapSums, angle_histogram, gap_sums, values_in_bins
from .sources import Source
from .statistics import CHUNK, CUTOFF_GRID_HZ, MAX_CUTOFF_OF_RATE, Block, ColumnLayout, cutoff_grid, cutoff_scores, explained, prepare, recording_blocks

__all__ = ["Reduction", "Screening", "TestFigures", "check_recording", "reduce", "screen", "test_figures"]

#: The effort must follow the rigid-body torque at one joint at least this well (correlation):
#: on the real recordings the best joint reaches 0.99 in every file, pure noise stays below 0.1.
#: A correlation as strong the other way (but at s1, where the spring's torque is of gravity's size:
#: down to −0.60 on the real recordings) says the effort's sign is not the model's.
MIN_MODEL_CORRELATION = 0.5


def check_recording(arm: ArmModel, label: str, rec: Recording, what: str) -> None:
    """Refuse (DiagnosisError) what the method cannot diagnose: a recording of another arm, shorter
    than it needs (:func:`require_length`; ``what``: "training" or "test"), sampled too slowly for
    the q̈ filter's lowest cut-off (:func:`~.statistics.cutoff_grid`), with a joint whose effort
    never changes, or whose effort follows the rigid-body torque at no joint (not this arm's torque,
    not in N·m, or noise) or runs against it at one (of the opposite sign)."""
    if rec.side != arm.side:
        raise DiagnosisError(f"{label}: a {rec.side}-arm recording, but the model is of the {arm.side} arm")
    try:
        require_length([(label, rec)], what)
    except RecordingError as err:
        raise DiagnosisError(str(err)) from err
    if not cutoff_grid(rec.rate_hz):
        raise DiagnosisError(
            f"{label}: sampled at {rec.rate_hz:.3g} Hz; the diagnosis low-passes q̇ at {CUTOFF_GRID_HZ[0]:g} Hz or more, "
            f"which needs a rate above {CUTOFF_GRID_HZ[0] / MAX_CUTOFF_OF_RATE:.3g} Hz"
        )
    flat = [n for n, span in zip(arm.joint_names, np.ptp(rec.effort, axis=0)) if span == 0.0]
    if flat:
        raise DiagnosisError(
            f"{label}: the effort of {', '.join(flat)} is the same in every sample: "
            "a torque sensor that does not respond; the diagnosis needs every joint's effort"
        )
    tau = arm.inverse_dynamics(rec.q, rec.qd, zero_phase_acceleration(rec.qd, rec.rate_hz, min(4.0, 0.4 * rec.rate_hz), segments=rec.segments))
    corr = {j: float(np.corrcoef(rec.effort[:, j], tau[:, j])[0, 1]) for j in np.flatnonzero(np.ptp(tau, axis=0) > 0.0)}
    best = max(map(abs, corr.values()), default=0.0)
    if best < MIN_MODEL_CORRELATION:
        raise DiagnosisError(
            f"{label}: the effort follows the rigid-body torque at no joint (largest correlation "
            f"{best:.2f}, at least {MIN_MODEL_CORRELATION:g} expected): is it this arm's joint torque, in N·m?"
        )
    against = {arm.joint_names[j]: c for j, c in corr.items() if c <= -MIN_MODEL_CORRELATION and j != S1}
    if against:
        raise DiagnosisError(
            f"{label}: the effort of {', '.join(against)} runs against the rigid-body torque (correlation "
            f"{', '.join(f'{c:.2f}' for c in against.values())}): its sign is the opposite of the model's, which is positive about "
            "each joint's axis, as Baxter publishes it on /robot/joint_states; negate it (or check the joints' order)"
        )


@dataclass(frozen=True)
class Screening:
    """What the first pass keeps of one recording.

    samples, span_s (s), rate_hz (Hz): its size; scores: a training file's
    :func:`~baxter_dynamics_ros.diagnosis.statistics.cutoff_scores`; histogram: its
    :func:`~baxter_dynamics_ros.diagnosis.gap_analysis.angle_histogram` (a test file's bins the gap's
    angle regimes; every file's, the range the training data cover).
    """

    samples: int
    span_s: float
    rate_hz: float
    scores: np.ndarray | None
    histogram: np.ndarray


def screen(arm: ArmModel, what: str, source: Source) -> Screening:
    """Pass 1 on one source: checked (:func:`check_recording`), binned, and scored ("training")."""
    rec = source.read()
    check_recording(arm, source.label, rec, what)
    training = what == "training"
    return Screening(
        len(rec), rec.span_s, rec.rate_hz, cutoff_scores(arm, rec) if training else None, angle_histogram(rec.q)
    )


@dataclass(frozen=True)
class Reduction:
    """What the second pass keeps of one recording: its blocks' statistics, and for a test file its
    angle values in the bins that hold a quantile (:func:`~baxter_dynamics_ros.diagnosis.gap_analysis.values_in_bins`)."""

    blocks: list[Block]
    angle_values: list[list[np.ndarray]] | None


def reduce(
    arm: ArmModel, layout: ColumnLayout, active: list[np.ndarray], cutoffs_hz: tuple[float, ...], parts: int, wanted: np.ndarray | None, source: Source
) -> Reduction:
    """Pass 2 on one source: the statistics of ``parts`` contiguous blocks with q̇ low-passed at
    cutoffs_hz (7,: joint j's rows at cutoffs_hz[j]); wanted (test files): the histogram bins whose
    angle values to keep."""
    rec = source.read()
    blocks = recording_blocks(arm, layout, active, source.label, prepare(arm, rec, cutoffs_hz), parts)
    return Reduction(blocks, None if wanted is None else values_in_bins(rec.q, wanted))


@dataclass(frozen=True)
class TestFigures:
    """What the last pass keeps of one test recording.

    raw, filtered: the gap summary's sums of the rigid residual with raw and with denoised q̈;
    series: every stride-th sample of t_s (from the recording's first sample), baseline, filtered
    and final residuals (N·m, (n, 7)); end_s: the time after its last sample (one period on).
    """

    raw: GapSums
    filtered: GapSums
    series: dict[str, np.ndarray]
    end_s: float


def test_figures(
    arm: ArmModel,
    layout: ColumnLayout,
    cutoffs_hz: tuple[float, ...],
    columns: np.ndarray,
    x: np.ndarray,
    angle_edges: np.ndarray,
    stride: int,
    source: Source,
) -> TestFigures:
    """Pass 3 on one test source: the residuals before and after the fitted effects (columns of the
    layout and their values x; q̇ low-passed at cutoffs_hz, (7,) per joint), summed for the gap
    summary with the bins' angle_edges."""
    rec = source.read()
    p = prepare(arm, rec, cutoffs_hz)
    effects = np.zeros_like(rec.q)
    if len(columns):
        for a in range(0, len(rec), CHUNK):
            b = min(len(rec), a + CHUNK)
            effects[a:b] = explained(arm, layout, p, columns, x, a, b)
    qdd = zero_phase_acceleration(rec.qd, rec.rate_hz, min(5.0, 0.4 * rec.rate_hz), segments=rec.segments)
    raw = gap_sums(p.residual_raw, rec.q, rec.qd, qdd, rec.rate_hz, angle_edges, segments=rec.segments)
    filtered = gap_sums(p.residual, rec.q, rec.qd, qdd, rec.rate_hz, angle_edges, segments=rec.segments)
    pick = slice(None, None, stride)
    series = {"t_s": p.stamps_s[pick], "baseline": p.residual_raw[pick], "filtered": p.residual[pick], "final": (p.residual - effects)[pick]}
    return TestFigures(raw, filtered, series, float(p.stamps_s[-1] + 1.0 / rec.rate_hz))
