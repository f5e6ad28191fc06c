"""Which unmodelled effect causes the sim-to-real gap, how far adding it shrinks the gap, and how far to trust that.

Method:

1. **Noise first, physics second.** The rigid-body residual r = effort − τ(q, q̇, q̈) depends on
   how q̈ is estimated. Physical effects are attributed in the *denoised* world only: q̇ low-passed
   forwards and backwards before differentiating, at the cut-off that leaves the smallest rigid
   residual on the training data (:func:`~baxter_dynamics_ros.diagnosis.statistics.choose_cutoff`).
   ``acceleration_noise`` is the share of the gap that this filtering alone removes against the
   paper's first difference; it is ranked with the others by its share, but no physical effect is
   ever fitted to differentiation noise.
2. **Candidates and statistics.** Every other effect is linear in its parameters (or, for the
   inertial ones, in the inertial parameters of whole links); each training recording is reduced to
   sufficient statistics per contiguous block (:mod:`~baxter_dynamics_ros.diagnosis.statistics`).
3. **Physically consistent fits** (:mod:`~baxter_dynamics_ros.diagnosis.fit`): payloads and link
   changes are fitted inside the physical set (log-Cholesky pseudo-inertias, bounded masses and
   centres of mass, a prior towards the paper's values), never fitted freely and then judged.
4. **Selection that does not depend on its order** (:mod:`~baxter_dynamics_ros.diagnosis.selection`):
   stepwise additions with removals and swaps within families after each, per-joint effects at the
   joints where they pay, cross-validated across training recordings (leave one out; a lone
   recording: its four blocks), nothing kept whose parameters are within their uncertainty of zero.
5. **How much to trust it.** Stability: the whole selection is run again, from nothing, on every
   cross-validation fold's training part; an effect chosen in fewer than ¾ of the folds is
   *uncertain* (and a per-joint effect's joints likewise). Held-out verdict: every figure "after" is measured on the test data, which no fit
   and no decision has seen; per effect and joint, whether it helped there; and in plain words when
   the selected set leaves a joint worse than the denoised rigid model. Offsets that differ between
   recordings are reported as drift, with each recording's value.

Everything here is numpy and scipy; no ROS.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ..core.arm_model import ArmModel, pseudo_inertia
from ..core.effects import (
    EFFECTS,
    Armature,
    CoulombFriction,
    Delay,
    Effect,
    InertialError,
    Payload,
    S1Spring,
    StribeckFriction,
    TorqueGain,
    TorqueOffset,
    ViscousFriction,
)
from ..core.joints import JOINTS as N
from ..core.log_cholesky import pseudo_from_log_cholesky
from ..core.recording import MIN_FIT_S, Recording, require_total_span
from ..errors import DiagnosisError, RecordingError
from .fit import MAX_OFFSET_DRIFT_NM, Fit, Fitter, Model, Term
from .gap_analysis import GapSummary, gap_summary, quantile_edges, wanted_bins
from .passes import Reduction, Screening, TestFigures, reduce, screen, test_figures
from .selection import FAMILY_OF, MIN_JOINT_GAIN, MIN_JOINT_GAIN_NM, Evaluation, Rivalry, rivalries, select
from .sources import InMemory, Mapper, Source, serial_map
from .statistics import Block, Candidate, ColumnLayout, Pool, active_columns, choose_cutoff, column_layout

__all__ = ["CANDIDATE_NAMES", "STABLE_FRACTION", "DiagnosisResult", "EffectReport", "diagnose"]

#: The candidate effects: every effect of the library, in its order.
CANDIDATE_NAMES = tuple(EFFECTS)
#: Contiguous blocks each training recording is cut into (the statistics' unit).
BLOCKS_PER_RECORDING = 4
#: Effects chosen in fewer than this fraction of the cross-validation folds are uncertain.
STABLE_FRACTION = 0.75
#: A joint's held-out RMS that changes by less than this fraction counts as unchanged.
VERDICT_TOLERANCE = 0.01
#: The report's residual series keep at most this many test samples (every k-th).
MAX_SERIES_POINTS = 20000


@dataclass(frozen=True)
class EffectReport:
    """One candidate's outcome. Arrays (7,) are per joint, N·m.

    params / params_std: the fitted parameters by name and their standard deviation (the fit's
    covariance with effective samples, plus the spread across the cross-validation folds);
    params_fold_spread: that spread alone (jackknife SD of the folds' fits; the inertial effects'
    parameters are in ``inertial``);
    share: the part of the gap it explains, N·m² per sample summed over the joints, the rank's key:
    for acceleration_noise the rigid residual's fall from raw to filtered q̈; for a physical effect
    its Shapley share of the training residual's fall from the denoised rigid model to the selected
    set (each subset of the selected effects refitted; what effects explain together is split
    equally among them, so no order of adding them matters); cv_gain: held-out (cross-validated) squared error it removes, N·m² per sample summed over the
    joints — for a selected effect, what removing it from the selected set would add back; for an
    unselected one, what adding it would remove. folds_selected of folds: the stability count;
    joint_folds: the same per joint for per-joint effects. test_verdict: per joint it acts on,
    the held-out RMS with and without it (both fitted on the training data) and "helped" / "hurt" /
    "no change". drift: per-recording offsets (torque_offset). inertial: the changed links'
    inertials before and after (payload, inertial_error).
    """

    name: str
    variant: str
    selected: bool
    rank: int
    reason: str
    params: dict[str, float]
    params_std: dict[str, float]
    joints: tuple[str, ...]
    cv_gain: float
    test_rms_before: np.ndarray
    test_rms_after: np.ndarray
    effect: Effect | None = None
    cutoff_hz: float | None = None
    folds_selected: int = 0
    folds: int = 0
    joint_folds: dict[str, int] = field(default_factory=dict)
    test_verdict: dict[str, dict] = field(default_factory=dict)
    drift: dict | None = None
    inertial: list[dict] | None = None
    share: float = 0.0
    params_fold_spread: dict[str, float] = field(default_factory=dict)
    alternative_folds: dict[str, int] = field(default_factory=dict)
    #: the effects the training data cannot tell from this one (:class:`~.selection.Rivalry`)
    not_distinguishable_from: tuple[str, ...] = ()

    @property
    def uncertain_joints(self) -> tuple[str, ...]:
        """Joints of a selected per-joint effect that fewer than ¾ of the folds chose."""
        if not self.selected or not self.folds:
            return ()
        return tuple(j for j, k in self.joint_folds.items() if k < STABLE_FRACTION * self.folds)

    @property
    def uncertain(self) -> bool:
        """Selected in fewer than ¾ of the cross-validation folds."""
        return self.selected and self.folds > 0 and self.folds_selected < STABLE_FRACTION * self.folds


@dataclass(frozen=True)
class DiagnosisResult:
    """Everything the report and diagnosis.json hold (see :meth:`to_dict`)."""

    arm_side: str
    joint_names: tuple[str, ...]
    train_files: tuple[str, ...]
    test_files: tuple[str, ...]
    holdout: str
    folds: int
    cutoff_hz: float
    baseline_train_rms: np.ndarray
    baseline_test_rms: np.ndarray
    denoised_test_rms: np.ndarray
    final_test_rms: np.ndarray
    effects: tuple[EffectReport, ...]
    gap: GapSummary  # where the gap lies, on the test data, rigid model with raw q̈
    gap_filtered: GapSummary  # the same with the denoised q̈
    search: tuple[str, ...]  # the selection's moves, in order
    test_series: dict[str, np.ndarray] = field(repr=False)

    def selected(self) -> tuple[EffectReport, ...]:
        return tuple(e for e in self.effects if e.selected)

    @property
    def worse_joints(self) -> tuple[str, ...]:
        """Joints whose held-out RMS with the selected effects exceeds the denoised rigid model's."""
        worse = self.final_test_rms > self.denoised_test_rms * (1.0 + VERDICT_TOLERANCE)
        return tuple(n for n, w in zip(self.joint_names, worse) if w)

    def warnings(self) -> list[str]:
        """Plain statements for the top of the report."""
        out = []
        if self.worse_joints:
            out.append(
                "The selected effects make the held-out residual WORSE than the denoised rigid-body model at "
                + ", ".join(self.worse_joints)
                + ": the fitted set does not carry over to the test data there."
            )
        offset = next((e for e in self.selected() if e.drift and e.drift["held_common"]), None)
        if offset is not None:
            out.append("Torque offsets: " + _hidden_torque(offset.drift["held_common"]) + ".")
        for e in self.selected():
            if e.not_distinguishable_from:
                out.append(f"{e.name} is not distinguishable on this data from {', '.join(e.not_distinguishable_from)} (see its reason).")
        uncertain = [e.name for e in self.selected() if e.uncertain]
        if uncertain:
            out.append(
                f"Uncertain (chosen in fewer than {STABLE_FRACTION:.0%} of the {self.folds} cross-validation folds): " + ", ".join(uncertain) + "."
            )
        partly = [f"{e.name} at {_short(e.uncertain_joints)}" for e in self.selected() if not e.uncertain and e.uncertain_joints]
        if partly:
            out.append(f"Uncertain at some joints (chosen there in fewer than {STABLE_FRACTION:.0%} of the folds): " + "; ".join(partly) + ".")
        if self.folds <= 2:
            out.append(f"Only {self.folds} cross-validation folds: a weak vote; more training recordings would make the selection firmer.")
        return out

    def to_dict(self) -> dict:
        """Plain JSON-ready form; the schema is documented in the README."""
        rms = lambda a: [round(float(x), 6) for x in a]  # noqa: E731
        return {
            "arm": self.arm_side,
            "joints": list(self.joint_names),
            "train_files": list(self.train_files),
            "test_files": list(self.test_files),
            "holdout": self.holdout,
            "folds": self.folds,
            "q_ddot_cutoff_hz": self.cutoff_hz,
            "baseline": {
                "q_ddot": "first difference of q̇ (the paper's)",
                "train_rms": rms(self.baseline_train_rms),
                "test_rms": rms(self.baseline_test_rms),
            },
            "denoised": {"q_ddot": f"zero-phase low-pass of q̇ at {self.cutoff_hz:g} Hz", "test_rms": rms(self.denoised_test_rms)},
            "effects": [
                {
                    "name": e.name,
                    "variant": e.variant,
                    "rank": e.rank,
                    "selected": e.selected,
                    "uncertain": e.uncertain,
                    "reason": e.reason,
                    "joints": list(e.joints),
                    "params": e.params,
                    "params_std": e.params_std,
                    "params_fold_spread": e.params_fold_spread,
                    "share_nm2": e.share,
                    "cv_gain_nm2": e.cv_gain,
                    "folds_selected": e.folds_selected,
                    "folds": e.folds,
                    "joint_folds": e.joint_folds,
                    "uncertain_joints": list(e.uncertain_joints),
                    "alternative_folds": e.alternative_folds,
                    "not_distinguishable_from": list(e.not_distinguishable_from),
                    "test_rms_before": rms(e.test_rms_before),
                    "test_rms_after": rms(e.test_rms_after),
                    "test_verdict": e.test_verdict,
                    **({"cutoff_hz": e.cutoff_hz} if e.cutoff_hz is not None else {}),
                    **({"drift": e.drift} if e.drift is not None else {}),
                    **({"inertial": e.inertial} if e.inertial is not None else {}),
                }
                for e in self.effects
            ],
            "final": {"test_rms": rms(self.final_test_rms)},
            "verdict": {"worse_than_denoised": list(self.worse_joints), "warnings": self.warnings()},
            "search": list(self.search),
            "gap": self.gap.to_dict(),
            "gap_filtered_q_ddot": self.gap_filtered.to_dict(),
        }


# ----------------------------------------------------------------------------- helpers
def _short(names: Sequence[str]) -> str:
    return ", ".join(n.split("_", 1)[-1] for n in names)


def _rms(sse: np.ndarray, n: int) -> np.ndarray:
    return np.sqrt(np.maximum(sse, 0.0) / n)


def _effect_of(cand: Candidate, values: np.ndarray, phi: np.ndarray | None) -> Effect:
    """The effect of a fitted candidate: values its full parameter vector (per-joint: 7 per
    parameter, zero where it does not act), phi the payload's log-Cholesky coordinates."""
    t = cand.template
    if isinstance(t, TorqueOffset):
        return TorqueOffset(offset_nm=values)
    if isinstance(t, ViscousFriction):
        return ViscousFriction(damping_nm_s_rad=values)
    if isinstance(t, CoulombFriction):
        return CoulombFriction(friction_nm=values, smoothing_rad_s=t.smoothing_rad_s)
    if isinstance(t, StribeckFriction):
        return StribeckFriction(coulomb_nm=values[:N], static_nm=values[N:], stribeck_rad_s=t.stribeck_rad_s, smoothing_rad_s=t.smoothing_rad_s)
    if isinstance(t, Armature):
        return Armature(inertia_kgm2=values)
    if isinstance(t, Delay):
        return Delay(delay_s=values)
    if isinstance(t, TorqueGain):
        return TorqueGain(gain=values)
    if isinstance(t, S1Spring):
        return S1Spring(preload_nm=values[0], linear_nm_rad=values[1], cosine_nm=values[2], sine_nm=values[3])
    if isinstance(t, Payload):
        m, c, inertia = _inertial_quantities(phi[0])
        return Payload(mass_kg=m, com_m=c, inertia_kgm2=inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]])
    return InertialError(parameter_change=values)


def _inertial_quantities(phi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass (kg), centre of mass (3,) m and inertia tensor about it (3, 3) kg·m² of one link's φ."""
    j = pseudo_from_log_cholesky(phi)
    m = float(j[3, 3])
    c = j[:3, 3] / m
    sigma = j[:3, :3] - m * np.outer(c, c)
    return m, c, np.trace(sigma) * np.eye(3) - sigma


#: The physical quantities of a link reported, with the flat index they take in
#: [m, c (3), inertia about the centre of mass (xx xy xz yy yz zz)].
_QUANTITY_NAMES = ("mass", "com x", "com y", "com z", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


def _quantity_vector(phi: np.ndarray) -> np.ndarray:
    m, c, inertia = _inertial_quantities(phi)
    return np.concatenate([[m], c, inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]])


#: φ's coordinates with a bound, and the quantity each is: α the mass, t the centre of mass.
_BOUNDED = {0: "mass", 7: "com x", 8: "com y", 9: "com z"}


def _link_report(name: str, phi: np.ndarray, cov: np.ndarray, setup: tuple[np.ndarray, ...], before: tuple | None) -> dict:
    """One link's (or the payload's) inertials after the fit, their SD, and what the data decided.

    setup: the link's (prior std (10,), lower (10,), upper (10,)) of φ. A quantity is *decided by
    the data* when its posterior variance is less than half its prior variance (linearised at the
    fit); the others are set by the prior (the paper's values). A mass or centre-of-mass coordinate
    held at its bound is listed under ``at_bound`` (its SD is then null): the bound decided it, not
    the data — the sign of a link made to absorb what another effect would explain.
    """
    prior_std, lo, hi = setup
    value = _quantity_vector(phi)
    jac = np.empty((10, 10))
    for k in range(10):
        step = np.zeros(10)
        step[k] = 1e-6
        jac[:, k] = (_quantity_vector(phi + step) - _quantity_vector(phi - step)) / 2e-6
    post = np.diag(jac @ cov @ jac.T)
    prior = np.diag(jac @ np.diag(prior_std**2) @ jac.T)
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    pinned = [q for k, q in _BOUNDED.items() if min(phi[k] - lo[k], hi[k] - phi[k]) <= 1e-6 * width[k]]
    undecided = [q for q, a, b in zip(_QUANTITY_NAMES, post, prior) if q not in pinned and b > 0 and a > 0.5 * b]
    std = {q: (None if q in pinned else float(np.sqrt(max(v, 0.0)))) for q, v in zip(_QUANTITY_NAMES, post)}
    out = {
        "link": name,
        "mass_kg": float(value[0]),
        "com_m": value[1:4].tolist(),
        "inertia_about_com_kgm2": value[4:].tolist(),
        "std": std,
        "set_by_prior": undecided,
        "at_bound": pinned,
    }
    if before is not None:
        m, c, inertia = before
        out["before"] = {"mass_kg": m, "com_m": list(c), "inertia_about_com_kgm2": inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist()}
    return out


# ----------------------------------------------------------------------------- the procedure
@dataclass
class _Context:
    arm: ArmModel
    layout: ColumnLayout
    pool: Pool
    test: Pool
    fitter: Fitter  # of the final model's weights, exact

    def evaluate(self, model: Model) -> tuple[np.ndarray, Fit, list[Fit]]:
        cv, folds, _ = self.fitter.cv_sse(model)
        return cv, self.fitter.fit(model), folds

    def test_sse(self, model: Model, fit: Fit) -> np.ndarray:
        return self.fitter.sse(self.fitter.columns(model), fit.x, self.test.H, self.test.b, self.test.rr)

    def test_rms(self, model: Model) -> np.ndarray:
        return _rms(self.test_sse(model, self.fitter.fit(model)), self.test.samples)


def diagnose(
    arm: ArmModel,
    train: Sequence[Source | tuple[str, Recording]],
    test: Sequence[Source | tuple[str, Recording]],
    *,
    progress: Callable[[int, int], None] | None = None,
    mapper: Mapper = serial_map,
    max_series_points: int = MAX_SERIES_POINTS,
) -> DiagnosisResult:
    """Diagnose the gap of ``arm``'s rigid model on recordings: fit on ``train``, measure on ``test``.

    train, test: sources (:class:`~baxter_dynamics_ros.diagnosis.sources.Source`, each read when a
    pass needs it and let go) or (label, Recording) pairs, of the arm's side, each at least
    :data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_SAMPLES` samples and ``MIN_RECORDING_S``
    long, the training ones ``MIN_FIT_S`` together. Cross-validation leaves one training recording out; with a
    single one, one of its four contiguous blocks. mapper: runs each pass's per-file work
    (:mod:`~baxter_dynamics_ros.diagnosis.passes`) and the folds' selections (serial by default); its results are added in the
    sources' order, so that any mapper gives the same result. max_series_points: the report's
    residual series keep every k-th test sample, k the least that keeps at most this many.
    """
    tick = progress or (lambda _done, _total: None)
    if not train or not test:
        raise DiagnosisError("need at least one training and one test recording")
    train_sources, test_sources = _as_sources(train), _as_sources(test)
    sources = [*train_sources, *test_sources]
    kinds = ["training"] * len(train_sources) + ["test"] * len(test_sources)
    steps = [0, 6]

    def step() -> None:
        steps[0] += 1
        tick(*steps)

    screened = mapper(partial(_screen_one, arm), list(zip(kinds, sources)))
    train_screens, test_screens = screened[: len(train_sources)], screened[len(train_sources) :]
    try:
        require_total_span([s.span_s for s in train_screens], "training", MIN_FIT_S)
    except RecordingError as err:
        raise DiagnosisError(str(err)) from err
    layout = column_layout()
    active = active_columns(arm, layout)
    cutoff = choose_cutoff([s.scores for s in train_screens])
    histogram = sum(s.histogram for s in test_screens)
    wanted = wanted_bins(histogram)
    step()

    jobs = [(BLOCKS_PER_RECORDING, None, s) for s in train_sources] + [(1, wanted, s) for s in test_sources]
    reductions = mapper(partial(_reduce_one, arm, layout, active, cutoff), jobs)
    train_blocks = [b for r in reductions[: len(train_sources)] for b in r.blocks]
    test_reductions = reductions[len(train_sources) :]
    pool = Pool.of(train_blocks)
    test_blocks = [b for r in test_reductions for b in r.blocks]
    test_pool = Pool(test_blocks, [list(range(len(test_blocks)))])
    edges = quantile_edges(histogram, wanted, [r.angle_values for r in test_reductions])
    step()

    selection = select(arm, layout, pool)
    step()
    final = selection.model
    ctx = _Context(arm, layout, pool, test_pool, selection.fitter)
    fold_models = mapper(partial(_fold_model, arm, layout), pool.fold_blocks())
    step()

    rivals = rivalries(arm, layout, pool, selection.evaluation, ctx.fitter)
    reports = _selected_reports(ctx, selection.evaluation, fold_models, rivals)
    reports.append(_noise_report(ctx, cutoff))
    reports += _unselected_reports(ctx, selection.evaluation, {r.name for r in reports if r.selected}, rivals)
    reports = _cumulative(ctx, final, reports)
    ordered = sorted(reports, key=lambda e: (not e.selected, -(e.share if e.selected else e.cv_gain)))
    ranked = tuple(replace(e, rank=i + 1) for i, e in enumerate(ordered))
    step()

    n_train, n_test = pool.samples, test_pool.samples
    final_rms = ctx.test_rms(final)
    stride = max(1, -(-n_test // max_series_points))
    figures = mapper(
        partial(test_figures, arm, layout, cutoff, ctx.fitter.columns(final), ctx.fitter.fit(final).x, edges, stride), test_sources
    )
    gap, gap_filtered, series = _test_gap(arm, figures)
    tick(steps[1], steps[1])
    holdout = "leave one training recording out" if len(train) > 1 else f"{BLOCKS_PER_RECORDING} contiguous blocks of the training recording, one left out at a time"
    return DiagnosisResult(
        arm.side, tuple(arm.joint_names), tuple(s.label for s in train_sources), tuple(s.label for s in test_sources), holdout, len(pool.groups), cutoff,
        _rms(pool.rr_raw, n_train), _rms(test_pool.rr_raw, n_test), _rms(test_pool.rr, n_test), final_rms,
        ranked, gap, gap_filtered, selection.moves, series,
    )  # fmt: skip


def _as_sources(items: Sequence[Source | tuple[str, Recording]]) -> list[Source]:
    return [InMemory(*item) if isinstance(item, tuple) else item for item in items]


def _fold_model(arm: ArmModel, layout: ColumnLayout, blocks: list[Block]) -> Model:
    """The model the selection picks on a cross-validation fold's training blocks."""
    return select(arm, layout, Pool.of(blocks)).model


def _screen_one(arm: ArmModel, job: tuple[str, Source]) -> Screening:
    return screen(arm, *job)


def _reduce_one(arm: ArmModel, layout: ColumnLayout, active: list[np.ndarray], cutoff: float, job: tuple[int, np.ndarray | None, Source]) -> Reduction:
    return reduce(arm, layout, active, cutoff, *job)


def _term_values(ctx: _Context, model: Model, fit: Fit, term: Term) -> tuple[np.ndarray, np.ndarray]:
    """(values, positions): the candidate's full parameter vector (zeros off its joints) from a fit,
    and for each entry its position in the fit's x (−1 where it does not act)."""
    cand = ctx.layout.candidates[term.candidate]
    index = model.terms.index(term)
    where = ctx.fitter.positions(model)[term]
    cols = ctx.fitter.term_columns(model)[index]
    values = np.zeros(len(cand.columns))
    position = np.full(len(cand.columns), -1)
    local = {int(c): k for k, c in enumerate(cand.columns)}
    for p, col in zip(where, cols):
        values[local[int(col)]] = fit.x[p]
        position[local[int(col)]] = p
    return values, position


def _fold_spread(folds: list[Fit], positions: np.ndarray) -> np.ndarray:
    """Jackknife SD of the parameters at positions across the cross-validation folds' fits."""
    if len(folds) < 2:
        return np.zeros(len(positions))
    xs = np.array([f.x[positions] for f in folds])
    k = len(folds)
    return np.sqrt((k - 1) / k * np.sum((xs - xs.mean(axis=0)) ** 2, axis=0))


def _spread(fit: Fit, folds: list[Fit], positions: np.ndarray) -> np.ndarray:
    """SD of the parameters at positions: fit covariance plus the spread of the folds."""
    return np.sqrt(np.diag(fit.cov_x)[positions] + _fold_spread(folds, positions) ** 2)


def _selected_reports(ctx: _Context, ev: Evaluation, fold_models: list[Model], rivals: list[Rivalry]) -> list[EffectReport]:
    """Reports of the selected effects: parameters, drop-one gains, stability, verdict, drift, rivals."""
    final = ev.model
    n = ctx.pool.samples
    out = []
    final_test = ctx.test_rms(final)
    for term in final.terms:
        cand = ctx.layout.candidates[term.candidate]
        values, position = _term_values(ctx, final, ev.fit, term)
        names = cand.template.parameter_names()
        acting = position >= 0
        std = np.zeros(len(values))
        std[acting] = _spread(ev.fit, ev.folds, position[acting])
        held = acting.copy()
        held[acting] = ~ev.fit.free[position[acting]]
        std[held] = np.nan  # at its bound: no uncertainty to state
        fold_std = np.zeros(len(values))
        fold_std[acting] = _fold_spread(ev.folds, position[acting])
        phi = ev.fit.phi.get(term.candidate)
        effect = _effect_of(cand, values, phi)
        params = {k: float(v) for k, v in zip(names, values)}
        params_std = {k: float(s) for k, s, a in zip(names, std, acting) if a}
        params_fold_spread = {k: float(s) for k, s, a in zip(names, fold_std, acting) if a}
        inertial = None
        if cand.kind == "inertial":
            params, params_std, inertial = _inertial_params(ctx, cand, term, ev.fit)
        without = final.without(term.candidate)
        cv_without, _, _ = ctx.evaluate(without)
        gain = float(np.sum(cv_without - ev.cv)) / n
        test_without = ctx.test_rms(without)
        joints = tuple(ctx.arm.joint_names[j] for j in term.joints)
        verdict = {name: _verdict(test_without[j], final_test[j]) for j, name in enumerate(ctx.arm.joint_names) if name in joints}
        same_effect = [next((t for t in fm.terms if ctx.layout.candidates[t.candidate].name == cand.name), None) for fm in fold_models]
        folds_selected = sum(t is not None for t in same_effect)
        joint_folds = {}
        if cand.kind == "joint":
            joint_folds = {ctx.arm.joint_names[j]: sum(t is not None and j in t.joints for t in same_effect) for j in term.joints}
        alternatives = {
            other: sum(any(ctx.layout.candidates[t.candidate].name == other for t in fm.terms) for fm in fold_models)
            for other in sorted(FAMILY_OF.get(cand.name, ()))
        }
        alternatives = {k: v for k, v in alternatives.items() if v}
        drift = _offset_drift(ctx, final, ev.fit, term) if cand.name == "torque_offset" else None
        reason = f"removes {gain:.4g} N·m² per sample of held-out error (cross-validated); at {_short(joints)}"
        if alternatives:
            reason += "; in other folds its alternative " + ", ".join(f"{k} ({v} of {len(fold_models)})" for k, v in alternatives.items())
        if drift is not None and drift["drifting"]:
            reason += f"; drifts between recordings at {_short(drift['drifting'])} (see drift)"
        if drift is not None and drift["held_common"]:
            reason += "; " + _hidden_torque(drift["held_common"])
        mine = [r for r in rivals if r.selected == cand.name]
        for r in mine:
            reason += "; " + r.sentence(cand.name)
        out.append(
            EffectReport(
                cand.name, cand.variant, True, 0, reason, params, params_std, joints, gain, final_test, final_test, effect,
                folds_selected=folds_selected, folds=len(fold_models), joint_folds=joint_folds, test_verdict=verdict,
                drift=drift, inertial=inertial, params_fold_spread=params_fold_spread, alternative_folds=alternatives,
                not_distinguishable_from=tuple(r.rival for r in mine),
            )  # fmt: skip
        )
    return out


def _verdict(without: float, with_: float) -> dict:
    change = (with_ - without) / max(without, 1e-300)
    word = "helped" if change < -VERDICT_TOLERANCE else ("hurt" if change > VERDICT_TOLERANCE else "no change")
    return {"verdict": word, "rms_without": float(without), "rms_with": float(with_)}


def _inertial_params(ctx: _Context, cand: Candidate, term: Term, fit: Fit) -> tuple[dict, dict, list[dict]]:
    """Payload / inertial change: physical parameters, their SD and the per-link report."""
    phi = fit.phi[term.candidate]
    cov = fit.phi_cov[term.candidate]
    _, prior_std, lower, upper, _ = ctx.fitter.link_setup(cand)
    links = []
    if cand.name == "payload":
        rep = _link_report("payload", phi[0], cov, (prior_std[0], lower[0], upper[0]), None)
        params = {"mass_kg": rep["mass_kg"], **{f"com_m[{a}]": v for a, v in zip("xyz", rep["com_m"])}}
        params.update({f"inertia_kgm2[{q}]": v for q, v in zip(("xx", "xy", "xz", "yy", "yz", "zz"), rep["inertia_about_com_kgm2"])})
        std = {k: _nan_if_none(v) for k, v in zip(params, rep["std"].values())}
        return params, std, [rep]
    params, std = {}, {}
    for i, link_index in enumerate(cand.links):
        link = ctx.arm.links[link_index]
        j0 = pseudo_inertia(link)
        m0 = float(j0[3, 3])
        before = (m0, link.com_m, link.inertia_kgm2)
        rep = _link_report(
            f"link {link_index + 1} ({link.name})", phi[i], cov[10 * i : 10 * i + 10, 10 * i : 10 * i + 10], (prior_std[i], lower[i], upper[i]), before
        )
        sd = np.array([rep["std"][q] if rep["std"][q] is not None else 0.0 for q in ("mass", "com x", "com y", "com z")])
        change = np.abs(np.concatenate([[rep["mass_kg"] - m0], np.array(rep["com_m"]) - link.com_m]))
        rep["changed"] = bool(rep["at_bound"]) or bool(np.any(change > 2 * sd))
        links.append(rep)
        params[f"link{link_index + 1}.mass_kg"] = rep["mass_kg"]
        std[f"link{link_index + 1}.mass_kg"] = _nan_if_none(rep["std"]["mass"])
        for a, v, q in zip("xyz", rep["com_m"], ("com x", "com y", "com z")):
            params[f"link{link_index + 1}.com_m[{a}]"] = v
            std[f"link{link_index + 1}.com_m[{a}]"] = _nan_if_none(rep["std"][q])
    return params, std, links


def _nan_if_none(value: float | None) -> float:
    return float("nan") if value is None else float(value)


def _offset_drift(ctx: _Context, model: Model, fit: Fit, term: Term) -> dict:
    """Each training recording's own offsets (fitted as such: ``Fitter`` profiles them out), their
    spread, and the joints where the spread exceeds twice the uncertainty of one recording's own
    offset (its residual level over its effective samples) and 0.01 N·m.

    held_common: the joints whose recordings' own offsets would depart from their mean by more than
    a sensor drifts (``MAX_OFFSET_DRIFT_NM``), with that departure: a state-dependent torque the
    selected effects lack, not drift; the offset there is one constant of all recordings.
    The test recordings' own offsets (the other parameters held at the fit) are listed too, as a
    held-out check; they change nothing."""
    cols = ctx.fitter.columns(model)
    cand = ctx.layout.candidates[term.candidate]
    position = {int(cols[p]): int(p) for p in ctx.fitter.positions(model)[term]}
    joints = list(fit.offset_joints)
    own = np.array([position[int(cand.columns[j])] for j in joints], dtype=int)
    others = np.setdiff1d(np.arange(len(cols)), own)
    test_offsets = {}
    for blk in ctx.test.blocks:
        test_offsets[blk.recording] = [
            float((blk.b[j, cols[p]] - blk.H[j, cols[p], cols[others]] @ fit.x[others]) / blk.H[j, cols[p], cols[p]]) for j, p in zip(joints, own)
        ]
    values = np.array(list(fit.offsets.values())).reshape(-1, len(joints))
    spread = values.std(axis=0, ddof=1) if len(values) > 1 else np.full(len(joints), np.nan)
    # How well one recording fixes its own offset: its residual level over its effective samples.
    samples = np.array([[H[j, cols[p], cols[p]] for j, p in zip(joints, own)] for H, _, _ in ctx.pool.recording_sums(None)])
    within = np.sqrt(np.mean(ctx.fitter.lam / (samples * ctx.fitter.weights[joints]), axis=0))
    names = [ctx.arm.joint_names[j] for j in joints]
    drifting = [n for n, s, u in zip(names, spread, within) if np.isfinite(s) and s > max(2 * u, 0.01)]
    return {
        "joints": names,
        "constant_nm": fit.x[own].tolist(),
        "per_recording_nm": {k: v.tolist() for k, v in fit.offsets.items()},
        "spread_nm": [None if not np.isfinite(s) else float(s) for s in spread],
        "test_recordings_nm": test_offsets,
        "drifting": drifting,
        "held_common": {ctx.arm.joint_names[j]: d for j, d in fit.held_common.items()},
        "max_drift_nm": MAX_OFFSET_DRIFT_NM,
        "note": "one training recording: drift between recordings cannot be measured" if len(values) < 2 else "",
    }


def _hidden_torque(held: dict[str, float]) -> str:
    """The sentence for offsets held common: a state-dependent torque, not a sensor's drift."""
    where = ", ".join(f"{n.split('_', 1)[-1]} ({d:.3g} N·m)" for n, d in held.items())
    return (
        f"each recording's own offset would depart from their mean by more than a sensor drifts ({MAX_OFFSET_DRIFT_NM:g} N·m) at {where}: "
        "a state-dependent torque the selected effects lack, not drift; one offset is held for all recordings there"
    )


def _noise_report(ctx: _Context, cutoff: float) -> EffectReport:
    """acceleration_noise: the share of the gap that the zero-phase filter of q̇ alone removes."""
    pool = ctx.pool
    n = pool.samples
    gain_joint = (pool.rr_raw - pool.rr) / n
    gain = float(gain_joint.sum())
    ok = _gain_ok(pool.rr_raw, pool.rr, n)
    joints = tuple(ctx.arm.joint_names[j] for j in np.flatnonzero(ok))
    votes = sum(bool(_gain_ok(pool.group_rr_raw[g], pool.group_rr[g], pool.group_samples[g]).any()) for g in range(len(pool.groups)))
    raw_test = _rms(ctx.test.rr_raw, ctx.test.samples)
    den_test = _rms(ctx.test.rr, ctx.test.samples)
    verdict = {name: _verdict(raw_test[j], den_test[j]) for j, name in enumerate(ctx.arm.joint_names)}
    selected = bool(ok.any())
    reason = (
        f"filtering q̇ at {cutoff:g} Hz before differentiating removes {gain:.4g} N·m² per sample of the training residual (no fit)"
        if selected
        else f"filtering q̇ removes no joint's error by {MIN_JOINT_GAIN:.0%} and {MIN_JOINT_GAIN_NM:g} N·m RMS"
    )
    return EffectReport(
        "acceleration_noise", f"zero-phase low-pass {cutoff:g} Hz", selected, 0, reason, {"cutoff_hz": cutoff}, {}, joints, gain,
        raw_test, den_test, None, cutoff, folds_selected=votes if selected else 0, folds=len(pool.groups), test_verdict=verdict,
        share=gain,
    )  # fmt: skip


def _gain_ok(before: np.ndarray, after: np.ndarray, n: int) -> np.ndarray:
    rel = (before - after) / np.maximum(before, 1e-300)
    return (rel >= MIN_JOINT_GAIN) & (_rms(before, n) - _rms(after, n) >= MIN_JOINT_GAIN_NM)


def _unselected_reports(ctx: _Context, ev: Evaluation, selected_names: set[str], rivals: list[Rivalry]) -> list[EffectReport]:
    """Every candidate not selected: what adding it (its best variant) to the selected set would do,
    or, for a rival the data cannot tell from a selected effect, that."""
    from .selection import explain_unselected

    out = []
    n = ctx.pool.samples
    final_test = ctx.test_rms(ev.model)
    for name, (variant, trial, why) in explain_unselected(ctx.arm, ctx.layout, ctx.pool, ev, ctx.fitter).items():
        if name in selected_names:
            continue
        rivalry = next((r for r in rivals if r.rival == name), None)
        tie = (rivalry.selected,) if rivalry is not None else ()
        if rivalry is not None:
            why = rivalry.sentence(name) + f"; the selection keeps {rivalry.selected}"
        if trial is None:
            out.append(EffectReport(name, variant, False, 0, why, {}, {}, (), 0.0, final_test, final_test, not_distinguishable_from=tie))
            continue
        gain = float(np.sum(ev.cv - trial.cv)) / n
        after = ctx.test_rms(trial.model)
        out.append(EffectReport(name, variant, False, 0, why, {}, {}, (), gain, final_test, after, not_distinguishable_from=tie))
    return out


#: Above this many selected physical effects, Shapley shares are estimated from random orders.
EXACT_SHAPLEY_MAX = 8
SHAPLEY_ORDERS = 64


def _shapley(ctx: _Context, final: Model) -> dict[int, float]:
    """Shapley share (N·m² per sample) of each selected term in the training residual's fall."""
    terms = list(final.terms)
    n = ctx.pool.samples
    values: dict[frozenset[int], float] = {}

    def value(subset: frozenset[int]) -> float:
        if subset not in values:
            model = Model.of([terms[i] for i in subset])
            fit = ctx.fitter.fit(model)
            sse = ctx.fitter.sse(ctx.fitter.columns(model), fit.x, ctx.pool.H, ctx.pool.b, ctx.pool.rr)
            values[subset] = float(np.sum(ctx.pool.rr - sse)) / n
        return values[subset]

    k = len(terms)
    share = {t.candidate: 0.0 for t in terms}
    if k <= EXACT_SHAPLEY_MAX:
        from itertools import combinations
        from math import factorial

        for i, t in enumerate(terms):
            others = [o for o in range(k) if o != i]
            for size in range(k):
                w = factorial(size) * factorial(k - size - 1) / factorial(k)
                for subset in combinations(others, size):
                    base = frozenset(subset)
                    share[t.candidate] += w * (value(base | {i}) - value(base))
        return share
    rng = np.random.default_rng(0)
    for _ in range(SHAPLEY_ORDERS):
        order = rng.permutation(k)
        have: frozenset[int] = frozenset()
        for i in order:
            share[terms[i].candidate] += (value(have | {int(i)}) - value(have)) / SHAPLEY_ORDERS
            have = have | {int(i)}
    return share


def _cumulative(ctx: _Context, final: Model, reports: list[EffectReport]) -> list[EffectReport]:
    """Shapley shares, and test_rms_before/after of the selected effects added one by one: the q̈
    filter first, then the physical effects by their share (each set refitted on the training data)."""
    terms = {ctx.layout.candidates[t.candidate].name: t for t in final.terms}
    shares = _shapley(ctx, final)
    reports = [replace(r, share=shares[terms[r.name].candidate]) if r.selected and r.name in terms else r for r in reports]
    chosen = sorted((r for r in reports if r.selected and r.name != "acceleration_noise"), key=lambda r: -r.share)
    noise = next(r for r in reports if r.name == "acceleration_noise")
    before = noise.test_rms_after  # the denoised rigid model
    have: list[Term] = []
    updated = {noise.name: noise}
    for r in chosen:
        have.append(terms[r.name])
        after = ctx.test_rms(Model.of(have))
        updated[r.name] = replace(r, test_rms_before=before, test_rms_after=after)
        before = after
    return [updated.get(r.name, r) if r.selected else r for r in reports]


def _test_gap(arm: ArmModel, figures: Sequence[TestFigures]) -> tuple[GapSummary, GapSummary, dict[str, np.ndarray]]:
    """Gap summaries of the test data (raw and denoised q̈) and the residual series before/after the
    selected effects, the test recordings one after the other, from each one's figures in order."""
    raw, filtered = figures[0].raw, figures[0].filtered
    for f in figures[1:]:
        raw, filtered = raw + f.raw, filtered + f.filtered
    offsets = np.concatenate([[0.0], np.cumsum([f.end_s for f in figures[:-1]])])
    series = {k: np.concatenate([f.series[k] for f in figures]) for k in ("baseline", "filtered", "final")}
    series["t_s"] = np.concatenate([f.series["t_s"] + offset for f, offset in zip(figures, offsets)])
    return gap_summary(arm.joint_names, raw), gap_summary(arm.joint_names, filtered), series
