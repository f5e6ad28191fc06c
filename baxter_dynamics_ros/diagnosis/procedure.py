"""Which unmodelled effect causes the sim-to-real gap, how far adding it shrinks the gap, and how far to trust that.

Method:

1. **Noise first, physics second.** The rigid-body residual r = effort − τ(q, q̇, q̈) depends on
   how q̈ is estimated. Physical effects are attributed in the *denoised* world only: q̇ low-passed
   forwards and backwards before differentiating, at each joint the cut-off that leaves the smallest
   rigid residual there on the training data (:func:`~baxter_dynamics_ros.diagnosis.statistics.choose_cutoff`).
   ``acceleration_noise`` is the share of the gap that this filtering alone removes against the
   paper's first difference; it is ranked with the others by its share, but no physical effect is
   ever fitted to differentiation noise.
2. **Candidates and statistics.** Every other effect is linear in its parameters (or, for the
   inertial ones, in the inertial parameters of whole links); each training recording is reduced to
   sufficient statistics per contiguous block (:mod:`~baxter_dynamics_ros.diagnosis.statistics`).
3. **Physically consistent fits** (:mod:`~baxter_dynamics_ros.diagnosis.fit`,
   :mod:`~baxter_dynamics_ros.diagnosis.inertial_fit`): payloads and link
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

This module is the pipeline (:func:`diagnose`) and each candidate's report; the result it returns is
:mod:`.result`, the inertial effects' physical report :mod:`.inertial_report`, the Shapley shares
and the step-by-step held-out error :mod:`.attribution`. Everything here is numpy and scipy; no ROS.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from functools import partial

import numpy as np

from ..core.arm_model import ArmModel
from ..core.effects import (
    EFFECTS,
    Armature,
    CoulombFriction,
    DahlFriction,
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
from ..core.joints import JOINT_SUFFIXES
from ..core.joints import JOINTS as N
from ..core.recording import MIN_FIT_S, Recording, require_total_span
from ..errors import DiagnosisError, RecordingError
from .attribution import Scoring, add_shares_and_steps
from .fit import MAX_OFFSET_DRIFT_NM, Fit, Model, Term
from .gap_analysis import GapSummary, angle_span, gap_summary, quantile_edges, share_outside, wanted_bins
from .inertial_report import inertial_params, inertial_quantities
from .passes import Reduction, Screening, TestFigures, reduce, screen, test_figures
from .result import DiagnosisResult, EffectReport, cutoff_text, hidden_torque, joint_list, verdict_of
from .selection import MIN_JOINT_GAIN, MIN_JOINT_GAIN_NM, Evaluation, Rivalry, explain_joints, explain_unselected, gain_lacks, rivalries, select
from .sources import InMemory, Mapper, Source, serial_map
from .statistics import Block, Candidate, ColumnLayout, Pool, active_columns, choose_cutoff, column_layout

__all__ = ["BLOCKS_PER_RECORDING", "CANDIDATE_NAMES", "MAX_SERIES_POINTS", "diagnose"]

#: The candidate effects: every effect of the library, in its order.
CANDIDATE_NAMES = tuple(EFFECTS)
#: Contiguous blocks each training recording is cut into (the statistics' unit).
BLOCKS_PER_RECORDING = 4
#: The report's residual series keep at most this many test samples (every k-th).
MAX_SERIES_POINTS = 20000


# ----------------------------------------------------------------------------- helpers
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
    if isinstance(t, DahlFriction):
        return DahlFriction(friction_nm=values, presliding_rad=t.presliding_rad)
    if isinstance(t, Armature):
        return Armature(inertia_kgm2=values)
    if isinstance(t, Delay):
        return Delay(delay_s=values)
    if isinstance(t, TorqueGain):
        return TorqueGain(gain=values)
    if isinstance(t, S1Spring):
        return S1Spring(preload_nm=values[0], linear_nm_rad=values[1], cosine_nm=values[2], sine_nm=values[3])
    if isinstance(t, Payload):
        m, c, inertia = inertial_quantities(phi[0])
        return Payload(mass_kg=m, com_m=c, inertia_kgm2=inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]])
    return InertialError(parameter_change=values)


# ----------------------------------------------------------------------------- the procedure
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
    cutoffs = choose_cutoff([s.scores for s in train_screens], min(s.rate_hz for s in screened))
    histogram = sum(s.histogram for s in test_screens)
    wanted = wanted_bins(histogram)
    covered = sum(s.histogram for s in train_screens)
    span = angle_span(covered)
    folds_outside = (
        {source.label: share_outside(own.histogram, angle_span(covered - own.histogram)) for source, own in zip(train_sources, train_screens)}
        if len(train_sources) > 1
        else {}
    )
    step()

    jobs = [(BLOCKS_PER_RECORDING, None, s) for s in train_sources] + [(1, wanted, s) for s in test_sources]
    reductions = mapper(partial(_reduce_one, arm, layout, active, cutoffs), jobs)
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
    ctx = Scoring(arm, layout, pool, test_pool, selection.fitter)
    fold_models = mapper(partial(_fold_model, arm, layout), pool.fold_blocks())
    step()

    rivals = rivalries(arm, layout, pool, selection.evaluation, ctx.fitter)
    reports = _selected_reports(ctx, selection.evaluation, fold_models, rivals)
    reports.append(_noise_report(ctx, cutoffs))
    reports += _unselected_reports(ctx, selection.evaluation, {r.name for r in reports if r.selected}, rivals)
    reports = add_shares_and_steps(ctx, final, reports)
    ordered = sorted(reports, key=lambda e: (not e.selected, -(e.share if e.selected else e.cv_gain)))
    ranked = tuple(replace(e, rank=i + 1) for i, e in enumerate(ordered))
    step()

    n_train, n_test = pool.samples, test_pool.samples
    final_rms = ctx.test_rms(final)
    stride = max(1, -(-n_test // max_series_points))
    figures = mapper(
        partial(test_figures, arm, layout, cutoffs, ctx.fitter.columns(final), ctx.fitter.fit(final).x, edges, stride), test_sources
    )
    gap, gap_filtered, series = _test_gap(arm, figures)
    tick(steps[1], steps[1])
    holdout = "leave one training recording out" if len(train) > 1 else f"{BLOCKS_PER_RECORDING} contiguous blocks of the training recording, one left out at a time"
    return DiagnosisResult(
        arm_side=arm.side,
        joint_names=tuple(arm.joint_names),
        train_files=tuple(s.label for s in train_sources),
        test_files=tuple(s.label for s in test_sources),
        holdout=holdout,
        folds=len(pool.groups),
        cutoff_hz=cutoffs,
        baseline_train_rms=_rms(pool.rr_raw, n_train),
        baseline_test_rms=_rms(test_pool.rr_raw, n_test),
        denoised_test_rms=_rms(test_pool.rr, n_test),
        final_test_rms=final_rms,
        effects=ranked,
        gap=gap,
        gap_filtered=gap_filtered,
        search=selection.moves,
        test_series=series,
        training_span_rad=span,
        test_outside=share_outside(histogram, span),
        folds_outside=folds_outside,
        angle_free=_angle_free(arm),
    )


def _angle_free(arm: ArmModel) -> tuple[bool, ...]:
    """(7,) per joint, whether no torque of the arm depends on its angle (on Baxter s0, whose axis
    is along gravity: turning it turns the whole arm about the vertical), from the model at random
    states with the angle changed by 1 rad."""
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1.0, 1.0, (3, 8, N))
    tau = arm.inverse_dynamics(q, qd, qdd)
    return tuple(bool(np.allclose(arm.inverse_dynamics(q + np.eye(N)[j], qd, qdd), tau, rtol=1e-9, atol=1e-9)) for j in range(N))


def _as_sources(items: Sequence[Source | tuple[str, Recording]]) -> list[Source]:
    return [InMemory(*item) if isinstance(item, tuple) else item for item in items]


def _fold_model(arm: ArmModel, layout: ColumnLayout, blocks: list[Block]) -> Model:
    """The model the selection picks on a cross-validation fold's training blocks."""
    return select(arm, layout, Pool.of(blocks)).model


def _screen_one(arm: ArmModel, job: tuple[str, Source]) -> Screening:
    return screen(arm, *job)


def _reduce_one(
    arm: ArmModel, layout: ColumnLayout, active: list[np.ndarray], cutoffs: tuple[float, ...], job: tuple[int, np.ndarray | None, Source]
) -> Reduction:
    return reduce(arm, layout, active, cutoffs, *job)


def _term_values(ctx: Scoring, model: Model, fit: Fit, term: Term) -> tuple[np.ndarray, np.ndarray]:
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


def _selected_reports(ctx: Scoring, ev: Evaluation, fold_models: list[Model], rivals: list[Rivalry]) -> list[EffectReport]:
    """Reports of the selected effects: parameters, drop-one gains, stability, verdict, drift, rivals."""
    final = ev.model
    n = ctx.pool.samples
    out = []
    final_test = ctx.test_rms(final)
    not_kept = explain_joints(ctx.arm, ctx.layout, ctx.pool, ev, ctx.fitter)
    for term in final.terms:
        cand = ctx.layout.candidates[term.candidate]
        not_at = {ctx.arm.joint_names[j]: why for j, why in not_kept.get(term.candidate, {}).items()}
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
            params, params_std, inertial = inertial_params(ctx.arm, ctx.fitter, cand, term, ev.fit)
        without = final.without(term.candidate)
        cv_without, _, _ = ctx.evaluate(without)
        gain = float(np.sum(cv_without - ev.cv)) / n
        test_without = ctx.test_rms(without)
        joints = tuple(ctx.arm.joint_names[j] for j in term.joints)
        verdict = {name: verdict_of(test_without[j], final_test[j]) for j, name in enumerate(ctx.arm.joint_names) if name in joints}
        same_effect = [next((t for t in fm.terms if ctx.layout.candidates[t.candidate].name == cand.name), None) for fm in fold_models]
        folds_selected = sum(t is not None for t in same_effect)
        joint_folds = {}
        if cand.kind == "joint":
            joint_folds = {ctx.arm.joint_names[j]: sum(t is not None and j in t.joints for t in same_effect) for j in term.joints}
        alternatives = {  # folds that chose the other member of its family instead of it
            other: sum(t is None and any(ctx.layout.candidates[u.candidate].name == other for u in fm.terms) for t, fm in zip(same_effect, fold_models))
            for other in sorted(cand.alternatives)
        }
        alternatives = {k: v for k, v in alternatives.items() if v}
        drift = _offset_drift(ctx, final, ev.fit, term) if cand.is_offset else None
        reason = f"removes {gain:.4g} N·m² per sample of held-out error (cross-validated); at {joint_list(joints)}"
        if alternatives:
            reason += "; in other folds its alternative " + ", ".join(f"{k} ({v} of {len(fold_models)})" for k, v in alternatives.items())
        if drift is not None and drift["drifting"]:
            reason += f"; drifts between recordings at {joint_list(drift['drifting'])} (see drift)"
        if drift is not None and drift["held_common"]:
            reason += "; " + hidden_torque(drift["held_common"])
        mine = [r for r in rivals if r.selected == cand.name]
        for r in mine:
            reason += "; " + r.sentence(cand.name)
        if not_at:
            reason += "; " + _not_at_text(not_at)
        out.append(
            EffectReport(
                name=cand.name, variant=cand.variant, selected=True, reason=reason, test_rms_before=final_test, test_rms_after=final_test,
                params=params, params_std=params_std, joints=joints, cv_gain=gain, effect=effect,
                folds_selected=folds_selected, folds=len(fold_models), joint_folds=joint_folds, test_verdict=verdict,
                drift=drift, inertial=inertial, params_fold_spread=params_fold_spread, alternative_folds=alternatives,
                not_distinguishable_from=tuple(r.rival for r in mine), not_at=not_at,
            )  # fmt: skip
        )
    return out


def _offset_drift(ctx: Scoring, model: Model, fit: Fit, term: Term) -> dict:
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


def _noise_report(ctx: Scoring, cutoffs: tuple[float, ...]) -> EffectReport:
    """acceleration_noise: the share of the gap that the zero-phase filter of q̇ alone removes."""
    pool = ctx.pool
    n = pool.samples
    gain_joint = (pool.rr_raw - pool.rr) / n
    gain = float(gain_joint.sum())
    lacks = gain_lacks(pool.rr_raw, pool.rr, n, of="training")
    joints = tuple(name for name, why in zip(ctx.arm.joint_names, lacks) if not why)
    not_at = {name: why for name, why in zip(ctx.arm.joint_names, lacks) if why}
    votes = sum(not all(gain_lacks(pool.group_rr_raw[g], pool.group_rr[g], pool.group_samples[g])) for g in range(len(pool.groups)))
    raw_test = _rms(ctx.test.rr_raw, ctx.test.samples)
    den_test = _rms(ctx.test.rr, ctx.test.samples)
    verdict = {name: verdict_of(raw_test[j], den_test[j]) for j, name in enumerate(ctx.arm.joint_names)}
    selected = bool(joints)
    where = cutoff_text(ctx.arm.joint_names, cutoffs)
    reason = (
        f"filtering q̇ ({where}) before differentiating removes {gain:.4g} N·m² per sample of the training residual (no fit)"
        if selected
        else f"filtering q̇ removes no joint's error by {MIN_JOINT_GAIN:.0%} and {MIN_JOINT_GAIN_NM:g} N·m RMS"
    )
    if not_at:
        reason += "; " + _not_at_text(not_at)
    return EffectReport(
        name="acceleration_noise", variant=f"zero-phase low-pass {where}", selected=selected, reason=reason,
        test_rms_before=raw_test, test_rms_after=den_test, params={f"cutoff_hz[{s}]": c for s, c in zip(JOINT_SUFFIXES, cutoffs)}, joints=joints, cv_gain=gain,
        cutoff_hz=dict(zip(ctx.arm.joint_names, cutoffs)), folds_selected=votes if selected else 0, folds=len(pool.groups), test_verdict=verdict, share=gain,
        not_at=not_at,
    )  # fmt: skip


def _not_at_text(not_at: dict[str, str]) -> str:
    """An effect's ``not_at`` (joint name -> why not there) as the end of its reason."""
    return "not at " + "; ".join(f"{name.split('_', 1)[-1]} ({why})" for name, why in not_at.items())


def _unselected_reports(ctx: Scoring, ev: Evaluation, selected_names: set[str], rivals: list[Rivalry]) -> list[EffectReport]:
    """Every candidate not selected: what adding it (its best variant) to the selected set would do,
    or, for a rival the data cannot tell from a selected effect, that."""
    out = []
    n = ctx.pool.samples
    final_test = ctx.test_rms(ev.model)
    for name, (variant, trial, why, not_kept) in explain_unselected(ctx.arm, ctx.layout, ctx.pool, ev, ctx.fitter).items():
        if name in selected_names:
            continue
        not_at = {ctx.arm.joint_names[j]: reason for j, reason in not_kept.items()}
        rivalry = next((r for r in rivals if r.rival == name), None)
        tie = (rivalry.selected,) if rivalry is not None else ()
        if rivalry is not None:
            why = rivalry.sentence(name) + f"; the selection keeps {rivalry.selected}"
        if trial is None:
            out.append(
                EffectReport(
                    name=name, variant=variant, selected=False, reason=why, test_rms_before=final_test, test_rms_after=final_test, not_distinguishable_from=tie
                )
            )
            continue
        gain = float(np.sum(ev.cv - trial.cv)) / n
        after = ctx.test_rms(trial.model)
        if not_at:
            why += "; " + _not_at_text(not_at)
        out.append(
            EffectReport(
                name=name, variant=variant, selected=False, reason=why, test_rms_before=final_test, test_rms_after=after, cv_gain=gain,
                not_distinguishable_from=tie, not_at=not_at,
            )  # fmt: skip
        )
    return out


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
