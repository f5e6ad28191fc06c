"""The diagnosis' result: what the report, diagnosis.json and effects.yaml are written from.

:class:`DiagnosisResult` holds the whole outcome of :func:`~.procedure.diagnose`, one
:class:`EffectReport` per candidate effect among it; :meth:`DiagnosisResult.to_dict` is the schema of
diagnosis.json (documented in the README). Only data and the plain sentences made of it live here;
the numbers come from :mod:`.procedure`, :mod:`.inertial_report` and :mod:`.attribution`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.effects import Effect
from .fit import MAX_OFFSET_DRIFT_NM
from .gap_analysis import GapSummary

__all__ = ["EXTRAPOLATION_SHARE", "STABLE_FRACTION", "VERDICT_TOLERANCE", "DiagnosisResult", "EffectReport", "cutoff_text", "hidden_torque", "joint_list", "verdict_of"]

#: Effects chosen in fewer than this fraction of the cross-validation folds are uncertain.
STABLE_FRACTION = 0.75
#: A joint's held-out RMS that changes by less than this fraction counts as unchanged.
VERDICT_TOLERANCE = 0.01
#: Held-out data with more than this share of its samples outside the range the fit's data cover
#: at a joint are said to measure extrapolation there.
EXTRAPOLATION_SHARE = 0.1


@dataclass(frozen=True, kw_only=True)
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
    variant: str | None  # the shape parameter's value; None where the effect has one form
    selected: bool
    reason: str
    test_rms_before: np.ndarray
    test_rms_after: np.ndarray
    rank: int = 0
    params: dict[str, float] = field(default_factory=dict)
    params_std: dict[str, float] = field(default_factory=dict)
    joints: tuple[str, ...] = ()
    cv_gain: float = 0.0
    effect: Effect | None = None
    cutoff_hz: dict[str, float] | None = None  # acceleration_noise: joint name -> its q̇ low-pass, Hz
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
    #: a per-joint effect's joints where it is not applied (selected: its other joints; not selected:
    #: every joint, where it pays at none): joint name -> why
    not_at: dict[str, str] = field(default_factory=dict)

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


@dataclass(frozen=True, kw_only=True)
class DiagnosisResult:
    """Everything the report and diagnosis.json hold (see :meth:`to_dict`)."""

    arm_side: str
    joint_names: tuple[str, ...]
    train_files: tuple[str, ...]
    test_files: tuple[str, ...]
    holdout: str
    folds: int
    cutoff_hz: tuple[float, ...]  # (7,) each joint's q̇ low-pass in the denoised world, Hz
    baseline_train_rms: np.ndarray
    baseline_test_rms: np.ndarray
    denoised_test_rms: np.ndarray
    final_test_rms: np.ndarray
    effects: tuple[EffectReport, ...]
    gap: GapSummary  # where the gap lies, on the test data, rigid model with raw q̈
    gap_filtered: GapSummary  # the same with the denoised q̈
    search: tuple[str, ...]  # the selection's moves, in order
    test_series: dict[str, np.ndarray] = field(repr=False)
    #: recordings found but too short to use (label: why), left out before the diagnosis
    passed_over: dict[str, str] = field(default_factory=dict)
    #: (2, 7) rad: per joint the lowest and highest angle of the training data (to 3 mrad)
    training_span_rad: np.ndarray
    #: (7,) per joint the share of the test samples outside training_span_rad
    test_outside: np.ndarray
    #: leave-one-recording-out only: per training recording, (7,) the share of its samples outside
    #: the range of the other training recordings (what its fold extrapolates to)
    folds_outside: dict[str, np.ndarray]
    #: (7,) per joint, whether no torque of the arm depends on its angle (s0 on Baxter): its range
    #: covered does not matter, and no extrapolation is said there
    angle_free: tuple[bool, ...]

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
            out.append("Torque offsets: " + hidden_torque(offset.drift["held_common"]) + ".")
        for e in self.selected():
            if e.not_distinguishable_from:
                out.append(f"{e.name} is not distinguishable on this data from {', '.join(e.not_distinguishable_from)} (see its reason).")
        uncertain = [e.name for e in self.selected() if e.uncertain]
        if uncertain:
            out.append(
                f"Uncertain (chosen in fewer than {STABLE_FRACTION:.0%} of the {self.folds} cross-validation folds): " + ", ".join(uncertain) + "."
            )
        partly = [f"{e.name} at {joint_list(e.uncertain_joints)}" for e in self.selected() if not e.uncertain and e.uncertain_joints]
        if partly:
            out.append(f"Uncertain at some joints (chosen there in fewer than {STABLE_FRACTION:.0%} of the folds): " + "; ".join(partly) + ".")
        if self.folds <= 2:
            out.append(f"Only {self.folds} cross-validation folds: a weak vote; more training recordings would make the selection firmer.")
        out += self.extrapolation_warnings()
        return out

    def extrapolation_warnings(self) -> list[str]:
        """Where the held-out data, or a cross-validation fold's held-out recording, lie outside the
        range of the data fitted on by more than EXTRAPOLATION_SHARE of their samples (not at a joint
        whose angle no torque depends on)."""
        short = [n.split("_", 1)[-1] for n in self.joint_names]
        out = []
        far = [k for k, share in enumerate(self.test_outside) if share > EXTRAPOLATION_SHARE and not self.angle_free[k]]
        if far:
            where = ", ".join(f"{short[k]} ({self.test_outside[k]:.0%}; training {self.training_span_rad[0, k]:+.2f}…{self.training_span_rad[1, k]:+.2f} rad)" for k in far)
            out.append(
                f"The test data leave the range of the training data at {where}: the held-out figures there measure how the fitted effects extrapolate."
            )
        folds = [
            f"{Path(label).name} at " + ", ".join(f"{short[k]} ({share[k]:.0%})" for k in far_k)
            for label, share in self.folds_outside.items()
            if (far_k := [k for k, v in enumerate(share) if v > EXTRAPOLATION_SHARE and not self.angle_free[k]])
        ]
        if folds:
            out.append(
                "Cross-validation extrapolates: held out, " + "; ".join(folds) + " lie outside the other training recordings' range, "
                "so the folds judge the effects at those joints by how they carry beyond the data they were fitted on."
            )
        return out

    def to_dict(self) -> dict:
        """Plain JSON-ready form; the schema is documented in the README."""
        rms = lambda a: [round(float(x), 6) for x in a]  # noqa: E731
        return {
            "arm": self.arm_side,
            "joints": list(self.joint_names),
            "train_files": list(self.train_files),
            "test_files": list(self.test_files),
            "passed_over": dict(self.passed_over),
            "holdout": self.holdout,
            "folds": self.folds,
            "q_ddot_cutoff_hz": dict(zip(self.joint_names, self.cutoff_hz)),
            "baseline": {
                "q_ddot": "first difference of q̇ (the paper's)",
                "train_rms": rms(self.baseline_train_rms),
                "test_rms": rms(self.baseline_test_rms),
            },
            "denoised": {"q_ddot": f"zero-phase low-pass of q̇ at {cutoff_text(self.joint_names, self.cutoff_hz)}", "test_rms": rms(self.denoised_test_rms)},
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
                    "not_at": e.not_at,
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
            "coverage": {
                "training_range_rad": {n: [round(float(lo), 6), round(float(hi), 6)] for n, lo, hi in zip(self.joint_names, *self.training_span_rad)},
                "test_outside_share": dict(zip(self.joint_names, rms(self.test_outside))),
                "folds_outside_share": {label: dict(zip(self.joint_names, rms(share))) for label, share in self.folds_outside.items()},
                "angle_free": [n for n, free in zip(self.joint_names, self.angle_free) if free],
            },
            "gap": self.gap.to_dict(),
            "gap_filtered_q_ddot": self.gap_filtered.to_dict(),
        }


def cutoff_text(names: Sequence[str], cutoffs_hz: Sequence[float]) -> str:
    """"8 Hz" when every joint has it, else "6 Hz at s0, e0; 8 Hz at e1, w0": each joint's cut-off in words."""
    values = sorted(set(cutoffs_hz))
    if len(values) == 1:
        return f"{values[0]:g} Hz"
    return "; ".join(f"{v:g} Hz at {joint_list([n for n, c in zip(names, cutoffs_hz) if c == v])}" for v in values)


def joint_list(names: Sequence[str]) -> str:
    """"s0, e1" for ("left_s0", "left_e1"): joint names without the arm's prefix."""
    return ", ".join(n.split("_", 1)[-1] for n in names)


def verdict_of(without: float, with_: float) -> dict:
    """A joint's held-out verdict: "helped", "hurt" or "no change" (within VERDICT_TOLERANCE), with both RMS, N·m."""
    change = (with_ - without) / max(without, 1e-300)
    word = "helped" if change < -VERDICT_TOLERANCE else ("hurt" if change > VERDICT_TOLERANCE else "no change")
    return {"verdict": word, "rms_without": float(without), "rms_with": float(with_)}


def hidden_torque(held: dict[str, float]) -> str:
    """The sentence for offsets held common: a state-dependent torque, not a sensor's drift."""
    where = ", ".join(f"{n.split('_', 1)[-1]} ({d:.3g} N·m)" for n, d in held.items())
    return (
        f"each recording's own offset would depart from their mean by more than a sensor drifts ({MAX_OFFSET_DRIFT_NM:g} N·m) at {where}: "
        "a state-dependent torque the selected effects lack, not drift; one offset is held for all recordings there"
    )
