"""Which candidate effects explain the residual: stepwise selection that does not depend on its order.

Score of a model M on a pool of training blocks, with the joint weights w_j = 1/σ_j² of the
current model (σ_j² its cross-validated mean squared error at joint j):

    S(M) = (n_eff / n) Σ_j w_j CV_j(M) + 2 df(M)

CV_j the held-out squared error at joint j summed over the leave-one-group-out folds, n the
training samples, n_eff the effective ones (``DECORRELATION_S`` apart), df the effective number of
parameters. This is Akaike's criterion for Gaussian errors of a different level at each joint,
with the likelihood measured on held-out data: a parameter must remove more held-out error than
twice an effective sample's worth of the residual it explains, wherever it acts.

Moves, each accepted only if it lowers S (all compared under the same weights):

- **add** a candidate: a whole effect (the s1 spring, a payload, the inertial change), or a
  per-joint effect at the joints where it pays — tried at every free joint, then kept only at
  those whose own weighted gain exceeds their own penalty, whose held-out error falls by
  ``MIN_JOINT_GAIN`` and ``MIN_JOINT_GAIN_NM``, and whose parameters differ from zero by more than
  their uncertainty;
- after each addition, **remove** a selected effect, or one joint of a per-joint effect, and
  **replace** an effect by its rival (``RIVALS``: ``payload`` ⇄ ``inertial_error``; any two of
  the friction laws ``coulomb_friction``, ``stribeck_friction``, ``dahl_friction``, any variant, at
  the same joints or at one of them — which law fits a joint is that joint's question; ``s1_spring``
  ⇄ the offset at s1), until no such move lowers S; the richer of two rivals must win by the folds'
  uncertainty. A per-joint family member never enters beside another at the same joint; a payload
  may enter beside inertial_error (or the reverse) if it wins by that uncertainty too: bounded to
  their physical ranges they are not nested (``FAMILIES``).

Rivals that the training data cannot tell apart (the swap changes S by less than that
uncertainty) are reported, with the motion that would separate them (:func:`rivalries`); so are
look-alikes of different kinds that the search never swaps (``LOOKALIKES``: ``torque_gain`` ⇄
``inertial_error``).

A term whose parameters are zero (at a bound) or within their uncertainty of zero at every joint
is never kept: the test is a Wald test at 95 % against the covariance of the fit (with effective
samples) plus the spread of the fold fits. Models once left are not entered again, so the search
ends.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from ..core.arm_model import ArmModel
from ..core.joints import JOINTS as N
from ..core.joints import S1
from .fit import DECORRELATION_S, Fit, Fitter, Model, Term
from .statistics import ColumnLayout, Pool

__all__ = ["Evaluation", "Rivalry", "Selection", "explain_joints", "explain_unselected", "gain_lacks", "rivalries", "select"]

#: A kept term must cut some joint's held-out squared error by this fraction and its held-out RMS
#: by MIN_JOINT_GAIN_NM (the effort's quantisation is 0.004 N·m).
MIN_JOINT_GAIN = 0.05
MIN_JOINT_GAIN_NM = 0.01
#: Significance level of the test that a term's parameters differ from zero.
SIGNIFICANCE = 0.95
#: Floor of a joint's σ², N·m² (the weights stay finite on a joint the model explains exactly).
SIGMA2_FLOOR = 1e-6
#: Effects that can explain the same torque on some data, and the motion that tells them apart.
RIVALS: dict[frozenset[str], str] = {
    frozenset({"payload", "inertial_error"}): "motion that loads the inner links in other ways than the hand does (each joint over its range, with accelerations)",
    frozenset({"coulomb_friction", "stribeck_friction"}): "slow motion through velocity reversals, below the Stribeck velocities",
    frozenset({"coulomb_friction", "dahl_friction"}): "reversals of amplitudes below and above the presliding angle (Dahl's friction builds up over that angle, Coulomb's at once)",
    frozenset({"stribeck_friction", "dahl_friction"}): "reversals at several speeds and amplitudes (Stribeck's friction depends on the speed, Dahl's on the angle turned since the reversal)",
    frozenset({"s1_spring", "torque_offset"}): "motion that spans s1's range (the spring's torque changes with q_s1, an offset's does not)",
}
#: Effects of different kinds (a sensor's and the arm's) that can explain the same torque on some
#: data, and the data that tells them apart. Neither is a simpler form of the other, so the search
#: never swaps them; :func:`rivalries` reports them when the data cannot tell them apart. At a joint
#: whose torque is all inertial (s0, whose axis is vertical) a gain is the same column as an error of
#: the inertia its links carry: three training files of the unit in ../shared/data/baxter_real
#: select inertial_error; two of the other unit's select a gain at s0, not told from it.
LOOKALIKES: dict[frozenset[str], str] = {
    frozenset({"torque_gain", "inertial_error"}): "a known load in the hand, or motion whose inertial and gravity torques change in other proportions (a gain scales the joint's whole torque, an inertia error only what its links carry, at every joint that carries them)",
}
MAX_MOVES = 60
#: A move must lower the score by this much (half of one parameter's penalty), so that the search
#: does not swap between alternatives that explain the data equally well.
MOVE_TOLERANCE = 1.0
#: Removals whose Wald statistic exceeds twice their parameters by more than this are not tried
#: (they would raise the score by about the excess; see ``_Search.wald``).
WALD_SCREEN = 25.0


@dataclass
class Evaluation:
    """A model's fit, cross-validated error per joint and score under the selection's current weights."""

    model: Model
    fit: Fit
    folds: list[Fit]
    cv: np.ndarray  # (7,) N·m², summed over the folds
    score: float
    per_fold: np.ndarray  # (folds, 7) N·m², each fold's held-out squared error


@dataclass(frozen=True)
class Selection:
    """The outcome of one selection run."""

    model: Model
    evaluation: Evaluation
    fitter: Fitter
    moves: tuple[str, ...]


@dataclass(frozen=True)
class Rivalry:
    """A selected effect and an unselected one the training data cannot tell from it.

    change: the score of the set with the rival in the selected one's place, minus the selected
    set's; margin: the folds' uncertainty of that difference (``_Search.margin``), ≥ |change|."""

    selected: str  # the selected effect's name
    rival: str  # the rival's name
    rival_label: str  # its best variant's label
    change: float
    margin: float
    separated_by: str  # the motion that would tell them apart

    def sentence(self, of: str) -> str:
        """Why ``of`` (either name) and the other are not told apart, in one clause."""
        other = self.rival_label if of == self.selected else self.selected
        return (
            f"not distinguishable on this data from {other} (with {self.rival_label} in {self.selected}'s place the score changes by "
            f"{self.change:+.3g}, within the folds' uncertainty of {self.margin:.3g}): {self.separated_by} would separate them"
        )


def gain_lacks(before: np.ndarray, after: np.ndarray, samples: int, *, of: str = "held-out") -> list[str]:
    """Per joint, what a fall of the squared error from ``before`` to ``after`` ((7,), N·m² summed
    over ``samples``) lacks of MIN_JOINT_GAIN and MIN_JOINT_GAIN_NM RMS, in words with the figures
    ("" where it has both); ``of`` names the error ("held-out", "training")."""
    rel = (before - after) / np.maximum(before, 1e-300)
    rms = np.sqrt(np.maximum(before, 0) / samples) - np.sqrt(np.maximum(after, 0) / samples)
    out = []
    for r, d in zip(rel, rms):
        if r < 0:
            out.append(f"raises the {of} squared error by {-r:.1%}")
        elif r < MIN_JOINT_GAIN:
            out.append(f"cuts the {of} squared error by {r:.1%}, not {MIN_JOINT_GAIN:.0%}")
        elif d < MIN_JOINT_GAIN_NM:
            out.append(f"cuts the {of} RMS by {d:.4f} N·m, not {MIN_JOINT_GAIN_NM:g}")
        else:
            out.append("")
    return out


class _Search:
    def __init__(self, arm: ArmModel, layout: ColumnLayout, pool: Pool) -> None:
        self.arm, self.layout, self.pool = arm, layout, pool
        n_eff = max(pool.duration_s / DECORRELATION_S, 1.0)
        self.lam = pool.samples / n_eff  # samples per effective sample
        self.fitter = Fitter(arm, layout, pool, np.ones(N), self.lam)
        self.visited: set[Model] = set()
        self.moves: list[str] = []

    @classmethod
    def judging(cls, arm: ArmModel, layout: ColumnLayout, pool: Pool, fitter: Fitter) -> _Search:
        """A search that judges moves under ``fitter``'s weights (those of a finished selection)."""
        search = cls(arm, layout, pool)
        search.fitter = fitter
        return search

    # -- evaluation
    def canonical(self, model: Model) -> Model:
        """With the s1 spring in a model, s1 has no offset or gain of its own (the spring spans them)."""
        return Model.of([Term(t.candidate, self.layout.acting_joints(model, t)) for t in model.terms])

    def reweight(self, model: Model) -> Evaluation:
        """Weights from the model's own held-out error (two passes: the fits depend on the weights)."""
        model = self.canonical(model)
        for _ in range(2):
            cv, _, _ = self.fitter.cv_sse(model)
            self.fitter = self.fitter.with_weights(1.0 / np.maximum(cv / self.pool.samples, SIGMA2_FLOOR))
        return self.evaluate(model)

    def evaluate(self, model: Model) -> Evaluation:
        """The model's fit, cross-validated error and score under the current weights."""
        fitter = self.fitter
        model = self.canonical(model)
        cv, folds, per_fold = fitter.cv_sse(model)
        fit = fitter.fit(model)
        score = float(fitter.weights @ cv) / self.lam + 2.0 * fit.df
        return Evaluation(model, fit, folds, cv, score, per_fold)

    def nominal_size(self, model: Model) -> int:
        """The model's parameters as written (per-joint effects at their joints, links × 10)."""
        return len(self.fitter.columns(model))

    def margin(self, current: Evaluation, trial: Evaluation) -> float:
        """How much lower a richer alternative's score must be for it to replace the current one:
        MOVE_TOLERANCE, or twice the standard error of the score difference estimated from the
        folds' own held-out errors when that is larger (one noisy fold does not decide)."""
        folds = len(current.per_fold)
        if folds < 2:
            return MOVE_TOLERANCE
        d = (trial.per_fold - current.per_fold) @ self.fitter.weights / self.lam
        return max(MOVE_TOLERANCE, 2.0 * float(np.sqrt(folds * np.var(d, ddof=1))))

    def preferred(self, current: Evaluation, trial: Evaluation, swap: bool = False) -> bool:
        """Whether the search moves from current to trial: its score must be lower by MOVE_TOLERANCE.
        Between alternatives of one family (inertial_error and payload, Stribeck and Coulomb) the
        richer is preferred only when it scores lower by the larger ``margin``: a swap to the richer
        needs that much, a swap to the simpler is taken unless the richer is that much better, so
        an alternative that fits only as well as the simpler one never keeps its place."""
        delta = trial.score - current.score
        if swap:
            richer = self.nominal_size(trial.model) - self.nominal_size(current.model)
            if richer > 0:
                return delta < -self.margin(current, trial)
            if richer < 0:
                return delta < self.margin(current, trial)
        return delta < -MOVE_TOLERANCE

    def beside_rival(self, model: Model, trial: Model) -> bool:
        """Whether ``trial`` adds to ``model`` an effect beside its rival of one family (a payload
        beside inertial_error, or the reverse): a move to the richer set, which must win by the
        folds' uncertainty as a swap to it would (:meth:`preferred`)."""
        have = {t.candidate for t in model.terms}
        names = {self.layout.candidates[c].name for c in have}
        added = [self.layout.candidates[t.candidate] for t in trial.terms if t.candidate not in have]
        return any(c.alternatives & names for c in added if c.kind != "joint")

    # -- tests on a term
    def significant(self, ev: Evaluation, positions: np.ndarray) -> bool:
        """Wald test at SIGNIFICANCE of the parameters at positions against zero (bounds count as zero)."""
        fit = ev.fit
        x = fit.x[positions]
        free = fit.free[positions]
        if not np.any(free):
            return False
        x = np.where(free, x, 0.0)
        folds = np.array([f.x[positions] for f in ev.folds])
        k = len(folds)
        jack = (k - 1) / k * (folds - folds.mean(axis=0)).T @ (folds - folds.mean(axis=0)) if k > 1 else 0.0
        cov = fit.cov_x[np.ix_(positions, positions)] + jack
        vals, vecs = np.linalg.eigh(cov)
        keep = vals > 1e-12 * max(float(vals.max()), 1e-300)
        if not np.any(keep):
            return bool(np.any(np.abs(x) > 0))
        proj = vecs[:, keep].T @ x
        stat = float(np.sum(proj**2 / vals[keep]))
        return stat > chi2.ppf(SIGNIFICANCE, int(keep.sum()))

    def joint_gain_ok(self, before: Evaluation, after: Evaluation) -> np.ndarray:
        """(7,) True where the held-out error falls by MIN_JOINT_GAIN and MIN_JOINT_GAIN_NM RMS, and
        falls in more than half of the folds (an effect that helps on one held-out recording and
        hurts on the other is not an effect of the robot)."""
        return ~np.array([bool(s) for s in self.gain_shortfalls(before, after)])

    def gain_shortfalls(self, before: Evaluation, after: Evaluation) -> list[str]:
        """Per joint (7), what the held-out gain from before to after lacks of :meth:`joint_gain_ok`,
        in words with the figures ("" where it has all)."""
        helped = np.sum(after.per_fold < before.per_fold, axis=0)
        folds = len(after.per_fold)
        out = []
        for j, lacks in enumerate(gain_lacks(before.cv, after.cv, self.pool.samples)):
            if not 2 * helped[j] > folds:
                lacks = "; ".join(filter(None, (lacks, f"helps on {helped[j]} of {folds} held-out folds, not more than half")))
            out.append(lacks)
        return out

    def joint_params(self, ev: Evaluation, term: Term, joint: int) -> np.ndarray:
        """Positions of a per-joint term's parameters at one joint."""
        cand = self.layout.candidates[term.candidate]
        index = ev.model.terms.index(term)
        positions = self.fitter.positions(ev.model)[term]
        cols = self.fitter.term_columns(ev.model)[index]
        wanted = set(cand.joint_columns([joint]).tolist())
        return positions[[k for k, c in enumerate(cols) if c in wanted]]

    def term_ok(self, ev: Evaluation, term: Term) -> bool:
        """The term's parameters are significant (per joint for the per-joint kinds: at every joint)."""
        cand = self.layout.candidates[term.candidate]
        if cand.kind != "joint":
            return self.significant(ev, self.fitter.positions(ev.model)[term])
        return all(len(p) == 0 or self.significant(ev, p) for p in (self.joint_params(ev, term, j) for j in term.joints))

    # -- moves
    def blocked_joints(self, model: Model, candidate: int) -> dict[int, str]:
        """Joints where another member of a per-joint candidate's family (or another variant) already
        acts, or the s1 spring spans it: joint -> what acts there, in words."""
        cand = self.layout.candidates[candidate]
        out: dict[int, str] = {}
        if cand.spanned_by_spring and self.layout.has_spring(model):
            out[S1] = "the s1 spring spans it there"
        for t in model.terms:
            other = self.layout.candidates[t.candidate]
            if t.candidate != candidate and (other.name == cand.name or other.name in cand.alternatives):
                out |= dict.fromkeys(t.joints if other.kind == "joint" else range(N), f"{other.label} acts there")
        return out

    def try_add(self, current: Evaluation, index: int) -> tuple[str | None, Evaluation | None, str]:
        """The add move of one candidate: (label, trial, "") when it pays; (None, the trial or None
        when none was fitted, why not) when it does not."""
        cand = self.layout.candidates[index]
        model = current.model
        names_in = {self.layout.candidates[t.candidate].name: t.candidate for t in model.terms}
        if cand.name in names_in and names_in[cand.name] != index:
            return None, None, "another variant of it is selected"
        have = model.term(index)
        if cand.kind != "joint":
            if have is not None:
                return None, None, "selected"
            trial = self.evaluate(model.with_term(Term(index, self._touched(index))))
            term = trial.model.term(index)
            if not self.joint_gain_ok(current, trial).any():
                return None, trial, f"improves no joint's held-out error by {MIN_JOINT_GAIN:.0%} and {MIN_JOINT_GAIN_NM:g} N·m RMS in most folds"
            if not self.term_ok(trial, term):
                return None, trial, "its fitted parameters are at their bounds or within their uncertainty of zero"
            return f"add {cand.label}", trial, ""
        blocked = self.blocked_joints(model, index)
        free = [j for j in range(N) if j not in blocked and (have is None or j not in have.joints)]
        if not free:
            return None, None, "selected at every joint it may act on" if have else "an alternative acts at every joint"
        existing = list(have.joints) if have else []
        wide, lacks = self.joint_shortfalls(current, index, existing, free)
        keep = [j for j in free if not any(lacks[j].values())]
        if not keep:
            if all(lack["significance"] for lack in lacks.values()):
                why = "its fitted parameters are at their bounds or within their uncertainty of zero at every joint"
            elif all(lack["gain"] or lack["penalty"] for lack in lacks.values()):
                why = f"at no joint does it remove {MIN_JOINT_GAIN:.0%} and {MIN_JOINT_GAIN_NM:g} N·m RMS of the held-out error, in most folds, and more than its penalty"
            else:
                why = "where it would pay, its parameters are within their uncertainty of zero"
            return None, wide, why
        trial = wide if keep == free else self.evaluate(model.with_term(Term(index, tuple(sorted(existing + keep)))))
        return f"add {cand.label} at {self._joint_names(keep)}", trial, ""

    def joint_shortfalls(self, current: Evaluation, index: int, existing: list[int], free: list[int]) -> tuple[Evaluation, dict[int, dict[str, str]]]:
        """Per-joint candidate ``index`` added at the joints ``free`` beside those it has (``existing``):
        the trial, and per free joint what it lacks to be kept there, in words ("" where it has it):
        "bound" (every parameter there held at its bound, e.g. an armature that would be negative),
        "gain" (:meth:`gain_shortfalls`), "penalty" (its weighted held-out gain against twice its
        parameters) and "significance" (its parameters there against zero)."""
        cand = self.layout.candidates[index]
        wide = self.evaluate(current.model.with_term(Term(index, tuple(sorted(existing + free)))))
        term = wide.model.term(index)
        gains = self.gain_shortfalls(current, wide)
        penalty = 2.0 * cand.p_joint
        out = {}
        for j in free:
            weighted_gain = self.fitter.weights[j] * (current.cv[j] - wide.cv[j]) / self.lam
            params = self.joint_params(wide, term, j)
            out[j] = {
                "bound": "" if not len(params) or wide.fit.free[params].any() else "its fitted parameters there are at their bounds",
                "gain": gains[j],
                "penalty": "" if weighted_gain > penalty else f"its weighted held-out gain {weighted_gain:.3g} is not above its penalty {penalty:g}",
                "significance": "" if len(params) and self.significant(wide, params) else "its parameters there are within their uncertainty of zero",
            }
        return wide, out

    def not_kept_at(self, current: Evaluation, index: int) -> dict[int, str]:
        """For per-joint candidate ``index``: why it is not at each joint where ``current`` does not
        have it (another member of its family there, or the first of :meth:`joint_shortfalls` that
        adding it there lacks)."""
        term = current.model.term(index)
        have = term.joints if term is not None else ()
        blocked = self.blocked_joints(current.model, index)
        free = [j for j in range(N) if j not in blocked and j not in have]
        out = {j: why for j, why in blocked.items() if j not in have}
        if free:
            _, lacks = self.joint_shortfalls(current, index, list(have), free)
            passes = "passes each per-joint check there, yet adding it there does not lower the score enough"
            out |= {j: next((v for v in lack.values() if v), passes) for j, lack in lacks.items()}
        return dict(sorted(out.items()))

    def add_moves(self, current: Evaluation) -> Iterator[tuple[str, Evaluation]]:
        for index in range(len(self.layout.candidates)):
            label, trial, _ = self.try_add(current, index)
            if label is not None:
                yield label, trial

    def wald(self, ev: Evaluation, positions: np.ndarray) -> float:
        """The Wald statistic of the parameters at positions against zero (fit covariance only).

        Removing them raises the score by about this minus twice their number (the training part
        of S moves by exactly this for a linear fit), so a removal is worth trying only below
        ``2 p + WALD_SCREEN``.
        """
        x = ev.fit.x[positions]
        cov = ev.fit.cov_x[np.ix_(positions, positions)]
        vals, vecs = np.linalg.eigh(cov)
        keep = vals > 1e-12 * max(float(vals.max()), 1e-300)
        proj = vecs[:, keep].T @ x
        return float(np.sum(proj**2 / vals[keep]))

    def backward_moves(self, current: Evaluation) -> Iterator[tuple[str, Evaluation]]:
        model = current.model
        positions = self.fitter.positions(model)
        for t in model.terms:
            cand = self.layout.candidates[t.candidate]
            if self.wald(current, positions[t]) < 2 * len(positions[t]) + WALD_SCREEN:
                yield f"remove {cand.label}", self.evaluate(model.without(t.candidate))
            if cand.kind == "joint" and len(t.joints) > 1:
                for j in t.joints:
                    at = self.joint_params(current, t, j)
                    if len(at) and self.wald(current, at) >= 2 * len(at) + WALD_SCREEN:
                        continue
                    yield f"remove {cand.label} at {self._joint_names([j])}", self.evaluate(model.with_term(Term(t.candidate, tuple(k for k in t.joints if k != j))))
            present = {self.layout.candidates[s.candidate].name: s.candidate for s in model.terms}
            for index, other in enumerate(self.layout.candidates):
                if frozenset({cand.name, other.name}) not in RIVALS:
                    continue
                if present.get(other.name, index) != index or (other.kind != "joint" and other.name in present):
                    continue  # that effect is in the model with another variant, or acts beside this one
                swapped = self.in_place_of(model, t, index)
                if swapped is not None:
                    yield f"replace {cand.label} by {other.label}", self.evaluate(swapped)
                if cand.kind == "joint" and other.kind == "joint" and len(t.joints) > 1:
                    for j in t.joints:
                        yield f"replace {cand.label} by {other.label} at {self._joint_names([j])}", self.evaluate(self.at_joint_in_place_of(model, t, j, index))

    def in_place_of(self, model: Model, term: Term, index: int) -> Model | None:
        """The model with candidate ``index`` in the place of ``term``: a family member at the
        term's joints (or all it touches), the spring in place of s1's offset and back; None where
        it cannot act."""
        cand, other = self.layout.candidates[term.candidate], self.layout.candidates[index]
        offset = self.layout.offset_term(model)
        if other.is_spring:  # the offset at s1 gives way to the spring's preload
            return model.with_term(Term(index, self._touched(index))) if cand.is_offset and S1 in term.joints else None
        if cand.is_spring:  # the spring gives way to an offset at s1
            joints = tuple(sorted(set(offset.joints if offset else ()) | {S1}))
            return model.without(term.candidate).with_term(Term(index, joints))
        if other.kind == "joint":
            joints = tuple(j for j in term.joints if j not in self.blocked_joints(model.without(term.candidate), index))
        else:
            joints = self._touched(index)
        return Model.of([s for s in model.terms if s.candidate != term.candidate] + [Term(index, joints)]) if joints else None

    def at_joint_in_place_of(self, model: Model, term: Term, joint: int, index: int) -> Model:
        """The model with per-joint candidate ``index`` in the place of per-joint ``term`` at one of
        its joints: which member of a family fits a joint is that joint's question."""
        have = model.term(index)
        joints = tuple(sorted((have.joints if have else ()) + (joint,)))
        rest = [s for s in model.terms if s.candidate not in (term.candidate, index)]
        return Model.of(rest + [Term(term.candidate, tuple(k for k in term.joints if k != joint)), Term(index, joints)])

    def _touched(self, index: int) -> tuple[int, ...]:
        """The joints a whole-effect candidate can act on."""
        cand = self.layout.candidates[index]
        cols = cand.columns
        return tuple(j for j in range(N) if np.any(self.pool.H[j][np.ix_(cols, cols)].diagonal() > 0))

    def _joint_names(self, joints) -> str:
        return ", ".join(self.arm.joint_names[j].split("_", 1)[-1] for j in joints)

    # -- pruning
    def prune(self, current: Evaluation) -> Evaluation:
        """Drop terms (or joints of per-joint terms) whose parameters are not significant."""
        while True:
            for t in current.model.terms:
                cand = self.layout.candidates[t.candidate]
                if cand.kind == "joint":
                    bad = [j for j in t.joints if not (len(p := self.joint_params(current, t, j)) and self.significant(current, p))]
                    if bad:
                        self.moves.append(f"drop {cand.label} at {self._joint_names(bad)}: parameters within their uncertainty of zero")
                        current = self.reweight(current.model.with_term(Term(t.candidate, tuple(j for j in t.joints if j not in bad))))
                        break
                elif not self.term_ok(current, t):
                    self.moves.append(f"drop {cand.label}: parameters within their uncertainty of zero")
                    current = self.reweight(current.model.without(t.candidate))
                    break
            else:
                return current

    def run(self) -> Selection:
        """The search from the empty model."""
        current = self.reweight(Model())
        self.visited.add(current.model)
        for _ in range(MAX_MOVES):
            options = [
                (ev.score, label, ev)
                for label, ev in self.add_moves(current)
                if ev.model not in self.visited and self.preferred(current, ev, swap=self.beside_rival(current.model, ev.model))
            ]
            best = min(options, key=lambda o: o[0], default=None)
            if best is None:
                break
            self.moves.append(best[1])
            current = self.reweight(best[2].model)
            self.visited.add(current.model)
            while True:
                options = [
                    (ev.score, label, ev)
                    for label, ev in self.backward_moves(current)
                    if ev.model not in self.visited and self.preferred(current, ev, swap=label.startswith("replace"))
                ]
                best = min(options, key=lambda o: o[0], default=None)
                if best is None:
                    break
                self.moves.append(best[1])
                # The weights stay those of the last addition through the backward phase, so that its
                # moves all improve one fixed criterion and cannot cycle.
                current = self.evaluate(best[2].model)
                self.visited.add(current.model)
        current = self.prune(current)
        return Selection(current.model, current, self.fitter, tuple(self.moves))


def rivalries(arm: ArmModel, layout: ColumnLayout, pool: Pool, final: Evaluation, fitter: Fitter) -> list[Rivalry]:
    """Each selected effect's unselected rivals (``RIVALS``, ``LOOKALIKES``) that explain the training data as well:
    put in its place (at its joints; the spring's rival, the offset, at s1) they change the score by
    no more than the folds' uncertainty of the difference. The best variant of each rival is tried."""
    search = _Search.judging(arm, layout, pool, fitter)
    names = {layout.candidates[t.candidate].name: t for t in final.model.terms}
    out = []
    for term in final.model.terms:
        name = layout.candidates[term.candidate].name
        for pair, separated_by in (RIVALS | LOOKALIKES).items():
            if name not in pair:
                continue
            (rival,) = pair - {name}
            held = names.get(rival)
            if held is not None and not (layout.candidates[held.candidate].is_offset and S1 not in held.joints):
                continue  # both selected: the data told them apart
            swaps = (search.in_place_of(final.model, term, index) for index, c in enumerate(layout.candidates) if c.name == rival)
            trials = [search.evaluate(m) for m in swaps if m is not None]
            if not trials:
                continue
            best = min(trials, key=lambda ev: ev.score)
            change, margin = best.score - final.score, search.margin(final, best)
            if abs(change) <= margin:
                index = next(t.candidate for t in best.model.terms if layout.candidates[t.candidate].name == rival)
                out.append(Rivalry(name, rival, layout.candidates[index].label, change, margin, separated_by))
    return out


def select(arm: ArmModel, layout: ColumnLayout, pool: Pool) -> Selection:
    """Run the stepwise selection on a pool of training blocks (module docstring)."""
    return _Search(arm, layout, pool).run()


def explain_joints(arm: ArmModel, layout: ColumnLayout, pool: Pool, final: Evaluation, fitter: Fitter) -> dict[int, dict[int, str]]:
    """For each selected per-joint effect (its candidate index): why it is not at each joint it could
    act on but does not (joint index -> words with the figures), judged as the search would, under
    the final model's weights."""
    search = _Search.judging(arm, layout, pool, fitter)
    return {t.candidate: search.not_kept_at(final, t.candidate) for t in final.model.terms if layout.candidates[t.candidate].kind == "joint"}


def explain_unselected(
    arm: ArmModel, layout: ColumnLayout, pool: Pool, final: Evaluation, fitter: Fitter
) -> dict[str, tuple[str | None, Evaluation | None, str, dict[int, str]]]:
    """For each effect not in the final model: (variant, the trial of adding its best variant or
    None, why it is not selected, and for a per-joint effect that pays at no joint why not at each
    (joint index -> words, :meth:`_Search.not_kept_at`)), judged as the search would, under the
    final model's weights."""
    search = _Search.judging(arm, layout, pool, fitter)
    selected = {layout.candidates[t.candidate].name for t in final.model.terms}
    best: dict[str, tuple[int, str | None, Evaluation | None, str]] = {}
    for index, cand in enumerate(layout.candidates):
        if cand.name in selected:
            continue
        label, trial, why = search.try_add(final, index)
        if label is not None:
            change = trial.score - final.score
            beside = search.beside_rival(final.model, trial.model)
            if search.preferred(final, trial, swap=beside):
                why = (
                    f"adding it to the selected set would lower the score by {-change:.3g}, yet the search, "
                    "which tried it in other company, ended without it"
                )
            elif beside:
                why = (
                    f"adding it beside its rival would {'lower' if change < 0 else 'raise'} the score by {abs(change):.3g}, "
                    f"not the folds' uncertainty {search.margin(final, trial):.3g} that a move to the richer set must gain"
                )
            else:
                why = f"adding it to the selected set would {'lower' if change < 0 else 'raise'} the score by {abs(change):.3g}, not the {MOVE_TOLERANCE:g} a move must gain"
        previous = best.get(cand.name)
        score = trial.score if trial is not None else np.inf
        if previous is None or (previous[2] is None and trial is not None) or (trial is not None and previous[2] is not None and score < previous[2].score):
            best[cand.name] = (index, label, trial, why)
    out = {}
    for name, (index, label, trial, why) in best.items():
        per_joint = layout.candidates[index].kind == "joint" and label is None and trial is not None
        out[name] = (layout.candidates[index].variant, trial, why, search.not_kept_at(final, index) if per_joint else {})
    return out
