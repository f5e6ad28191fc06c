"""Fitting a set of candidate effects on sufficient statistics, inside the physical set.

A *model* is a set of terms: a candidate effect (:class:`~baxter_dynamics_ros.diagnosis.statistics.Candidate`)
and, for the per-joint kinds, the joints it acts on. Its fit minimises the weighted squared error

    Σ_j w_j ‖r_j − Φ_j x‖² + λ ‖(φ − φ₀) / σ_φ‖²

over the model's parameters, from the statistics alone (r·r − 2 x·b + xᵀ H x per joint). w_j = 1/σ_j²
weighs each joint by the residual level it has to explain (a wrist at 0.05 N·m counts as much as a
shoulder at 1 N·m); λ = samples per effective sample (samples closer than ``DECORRELATION_S`` carry
one sample's information between them), so the prior weighs like one effective observation.

Linear kinds are solved as bounded linear least squares (friction, armature ≥ 0). Inertial kinds
(``payload``, ``inertial_error``) are fitted *inside the physical set* (:mod:`.inertial_fit`:
log-Cholesky coordinates, bounded masses and centres of mass, a prior towards the paper's values,
a bounded damped Newton solver). Torque offsets are each training recording's own, profiled out
within a sensor's drift (``MAX_OFFSET_DRIFT_NM``).

Uncertainty: the posterior covariance (n / n_eff)(JᵀJ)⁻¹ of the Gauss-Newton Jacobian J at the
solution (parameters at an active bound are held fixed), and the effective number of parameters
tr((K_d + P)⁻¹ K_d), K_d the data's and P the prior's curvature, so that a direction the prior
decides does not count as fitted.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from ..core.arm_model import ArmModel
from ..core.joints import JOINTS as N
from .inertial_fit import AT_BOUND, RIDGE, LinkSetup, WarmStart, fit_inertial, link_setup
from .statistics import Candidate, ColumnLayout, Pool

__all__ = ["DECORRELATION_S", "Fit", "Fitter", "Model", "Term"]

#: Samples closer than this are counted as one in the prior's weight and the uncertainties.
DECORRELATION_S = 0.1
#: How far one recording's torque-sensor offset may depart from the recordings' mean, N·m. A sensor
#: drifts by tenths of a N·m between sessions (0.09 N·m at w2 in ../shared/data/baxter_real); a
#: larger "drift" is a state-dependent torque that per-recording offsets would hide (two recordings
#: over different ranges of s1 gave s1 "offsets" of 21 and 33 N·m: the spring), so at such a joint
#: the offset is one constant shared by all recordings.
MAX_OFFSET_DRIFT_NM = 0.5


@dataclass(frozen=True, order=True)
class Term:
    """A candidate (index into the layout) and the joints it acts on (per-joint kinds; else all it touches)."""

    candidate: int
    joints: tuple[int, ...]


@dataclass(frozen=True)
class Model:
    """A set of terms, in a canonical order (so that equal models compare and hash equal)."""

    terms: tuple[Term, ...] = ()

    @staticmethod
    def of(terms: Sequence[Term]) -> Model:
        """The model of terms; terms of one candidate merge (their joints join)."""
        joints: dict[int, set[int]] = {}
        for t in terms:
            joints.setdefault(t.candidate, set()).update(t.joints)
        return Model(tuple(Term(c, tuple(sorted(j))) for c, j in sorted(joints.items()) if j))

    def with_term(self, term: Term) -> Model:
        return Model.of([t for t in self.terms if t.candidate != term.candidate] + [term])

    def without(self, candidate: int) -> Model:
        return Model.of([t for t in self.terms if t.candidate != candidate])

    def term(self, candidate: int) -> Term | None:
        return next((t for t in self.terms if t.candidate == candidate), None)


@dataclass
class Fit:
    """A model fitted on some data: parameters, their uncertainty and effective number.

    x: (c,) values of the model's columns (``Fitter.columns``); inertial terms also keep their
    log-Cholesky coordinates phi per candidate, (links, 10). cov_x: (c, c) posterior covariance of
    x; free: (c,) False where a linear parameter sits at its bound; df: effective parameters.
    """

    model: Model
    x: np.ndarray
    cov_x: np.ndarray
    free: np.ndarray
    df: float
    phi: dict[int, np.ndarray] = field(default_factory=dict)
    phi_cov: dict[int, np.ndarray] = field(default_factory=dict)
    z: np.ndarray | None = None  # the inertial fit's variables (linear parameters, then φ)
    offsets: dict[str, np.ndarray] = field(default_factory=dict)  # each training recording's own offsets at offset_joints
    offset_joints: tuple[int, ...] = ()  # the joints whose offsets are each recording's own
    #: joints whose recordings' own offsets would depart from their mean by more than
    #: MAX_OFFSET_DRIFT_NM, and that departure (N·m): their offset is held common.
    held_common: dict[int, float] = field(default_factory=dict)


class Fitter:
    """Fits models of one layout on a pool's statistics with fixed joint weights."""

    def __init__(
        self, arm: ArmModel, layout: ColumnLayout, pool: Pool, weights: np.ndarray, samples_per_effective: float
    ) -> None:
        self.arm = arm
        self.layout = layout
        self.pool = pool
        self.weights = np.asarray(weights, dtype=float)
        self.lam = float(samples_per_effective)
        self._warm = WarmStart()  # where the next exact inertial fit starts (shared with with_weights' fitters)
        self._setups: dict[str, LinkSetup] = {}
        self._cache: dict[tuple[Model, int], Fit] = {}

    def with_weights(self, weights: np.ndarray) -> Fitter:
        """A fitter of the same pool with other joint weights (it starts its fits where this one ended)."""
        other = Fitter(self.arm, self.layout, self.pool, weights, self.lam)
        other._warm, other._setups = self._warm, self._setups
        return other

    # -- columns
    def term_columns(self, model: Model) -> list[np.ndarray]:
        """Each term's columns in the model (a spring takes the place of s1's offset and gain)."""
        out = []
        for t in model.terms:
            cand = self.layout.candidates[t.candidate]
            if cand.kind == "joint":
                out.append(cand.joint_columns(self.layout.acting_joints(model, t)))
            else:
                out.append(np.asarray(cand.columns, dtype=int))
        return out

    def columns(self, model: Model) -> np.ndarray:
        """The model's columns, term by term."""
        cols = self.term_columns(model)
        return np.concatenate(cols).astype(int) if cols else np.zeros(0, int)

    def positions(self, model: Model) -> dict[Term, np.ndarray]:
        """Where each term's parameters sit in the model's column list."""
        out, start = {}, 0
        for t, cols in zip(model.terms, self.term_columns(model)):
            out[t] = np.arange(start, start + len(cols))
            start += len(cols)
        return out

    def lower(self, model: Model) -> np.ndarray:
        """Lower bounds of the model's columns."""
        lows = []
        for t, cols in zip(model.terms, self.term_columns(model)):
            cand = self.layout.candidates[t.candidate]
            lows.append(np.full(len(cols), cand.lower[0]))
        return np.concatenate(lows) if lows else np.zeros(0)

    # -- statistics
    def weighted(self, H: np.ndarray, b: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Σ_j w_j H_j, Σ_j w_j b_j on cols."""
        Hc = np.einsum("j,jpq->pq", self.weights, H[:, cols][:, :, cols])
        bc = self.weights @ b[:, cols]
        return Hc, bc

    def sse(self, cols: np.ndarray, x: np.ndarray, H: np.ndarray, b: np.ndarray, rr: np.ndarray) -> np.ndarray:
        """(7,) unweighted squared error per joint of the fit x on statistics (H, b, rr)."""
        if len(cols) == 0:
            return rr.copy()
        Hc = H[:, cols][:, :, cols]
        return rr - 2.0 * b[:, cols] @ x + np.einsum("p,jpq,q->j", x, Hc, x)

    # -- fits
    def fit(self, model: Model, fold: int | None = None) -> Fit:
        """The model fitted on the whole pool (fold None) or on every group but ``fold``."""
        key = (model, -1 if fold is None else fold)
        if key in self._cache:
            return self._cache[key]
        full = None if fold is None else self._cache.get((model, -1))
        start = full.z if full is not None else None
        offset = self.layout.offset_term(model)
        joints = [] if offset is None else list(self.layout.acting_joints(model, offset))
        if joints:
            result = self._fit_with_offsets(model, offset, joints, fold, start)
        else:
            result = self._fit_on(model, *self._statistics(fold), fold, start)
        self._cache[key] = result
        return result

    def _statistics(self, fold: int | None) -> tuple[np.ndarray, np.ndarray, float]:
        """H (7, C, C), b (7, C) of the whole pool (fold None) or of every group but ``fold``, and
        the weighted Σ_j w_j r_j·r_j of the same samples."""
        H, b = (self.pool.H, self.pool.b) if fold is None else self.pool.without_group(fold)[:2]
        rr = self.pool.rr if fold is None else self.pool.rr - self.pool.group_rr[fold]
        return H, b, float(self.weights @ rr)

    def prior_precision(self, model: Model) -> np.ndarray:
        """(c,) λ / σ² of the linear columns' zero-mean Gaussian priors (0 where a column has none)."""
        sd = [self.layout.candidates[t.candidate].prior_std[: len(cols)] if self.layout.candidates[t.candidate].kind == "linear" else np.full(len(cols), np.inf)
              for t, cols in zip(model.terms, self.term_columns(model))]  # fmt: skip
        return self.lam / np.concatenate(sd) ** 2 if sd else np.zeros(0)

    def _fit_on(self, model: Model, H: np.ndarray, b: np.ndarray, constant: float, fold: int | None, start: np.ndarray | None) -> Fit:
        cols = self.columns(model)
        Hw, bw = self.weighted(H, b, cols)
        prior = np.where(np.diag(Hw) > 0, self.prior_precision(model), 0.0)
        if any(self.layout.candidates[t.candidate].kind == "inertial" for t in model.terms):
            return self._fit_inertial(model, cols, Hw + np.diag(prior), bw, constant, fold, start)
        return self._fit_linear(model, cols, Hw, bw, prior)

    def _fit_with_offsets(self, model: Model, offset: Term, joints: list[int], fold: int | None, start: np.ndarray | None) -> Fit:
        """Sensor offsets as each recording's own (they drift between sessions), within a sensor's drift.

        Fitted with every joint's offsets free per recording (:meth:`_profiled_offsets`); a joint
        whose recordings' offsets then depart from their mean by more than ``MAX_OFFSET_DRIFT_NM``
        has one offset shared by all recordings instead, and the fit is made again (until none does).
        """
        held: dict[int, float] = {}
        while True:
            fit = self._profiled_offsets(model, offset, joints, tuple(held), fold, start)
            per_recording = np.array(list(fit.offsets.values()))
            departure = np.max(np.abs(per_recording - per_recording.mean(axis=0)), axis=0)
            wide = {j: float(d) for j, d in zip(joints, departure) if d > MAX_OFFSET_DRIFT_NM}
            if not wide:
                fit.held_common = held
                return fit
            held.update(wide)
            joints = [j for j in joints if j not in wide]
            if not joints:
                fit = self._fit_on(model, *self._statistics(fold), fold, start)
                fit.held_common = held
                return fit

    def _profiled_offsets(
        self, model: Model, offset: Term, joints: list[int], held: tuple[int, ...], fold: int | None, start: np.ndarray | None
    ) -> Fit:
        """The fit with each recording's own offsets at ``joints`` and one shared offset at ``held``.

        The per-recording offsets are profiled out: at their joints every recording's statistics are
        centred on its own means (H − s sᵀ/n, b − s t/n, with s = Σφ and t = Σr the recording's sums),
        the other terms are fitted on the centred statistics, and each recording's offset follows
        as (t − s·x)/n. The offset the model predicts with — on held-out data, and in effects.yaml —
        is their mean over the training recordings (each recording counts once).
        """
        cand = self.layout.candidates[offset.candidate]
        off_cols = cand.columns[joints]
        recordings = self.pool.recording_sums(fold)
        H = (self.pool.H if fold is None else self.pool.without_group(fold)[0]).copy()
        b = (self.pool.b if fold is None else self.pool.without_group(fold)[1]).copy()
        rr = (self.pool.rr if fold is None else self.pool.rr - self.pool.group_rr[fold]).copy()
        for j, oc in zip(joints, off_cols):
            H[j] = 0.0
            b[j] = 0.0
            rr[j] = 0.0
            for Hr, br, rrr in recordings:
                n_r = Hr[j, oc, oc]
                s_r, t_r = Hr[j, oc], br[j, oc]
                H[j] += Hr[j] - np.outer(s_r, s_r) / n_r
                b[j] += br[j] - s_r * t_r / n_r
                rr[j] += rrr[j] - t_r**2 / n_r
        inner_model = model.without(offset.candidate)
        if held:
            inner_model = inner_model.with_term(Term(offset.candidate, held))
        inner = self._fit_on(inner_model, H, b, float(self.weights @ rr), fold, start)
        inner_cols = self.columns(inner_model)
        per_recording = np.array(
            [[(br[j, oc] - Hr[j, oc, inner_cols] @ inner.x) / Hr[j, oc, oc] for j, oc in zip(joints, off_cols)] for Hr, br, _ in recordings]
        )
        constant = per_recording.mean(axis=0)
        cols = self.columns(model)
        # Each column's positions in the model, in order: a payload shares link 7's columns with
        # inertial_error, and the two terms keep their order in both models (canonical).
        where: dict[int, list[int]] = {}
        for k, c in enumerate(cols):
            where.setdefault(int(c), []).append(k)
        x = np.zeros(len(cols))
        free = np.ones(len(cols), dtype=bool)
        cov = np.zeros((len(cols), len(cols)))
        unused = {c: iter(at) for c, at in where.items()}
        inner_at = np.array([next(unused[int(c)]) for c in inner_cols], dtype=int)
        x[inner_at] = inner.x
        free[inner_at] = inner.free
        cov[np.ix_(inner_at, inner_at)] = inner.cov_x
        off_at = np.array([where[int(c)][0] for c in off_cols], dtype=int)
        x[off_at] = constant
        n = self.pool.samples
        between = per_recording.var(axis=0, ddof=1) / len(per_recording) if len(per_recording) > 1 else 0.0
        cov[off_at, off_at] = self.lam / (self.weights[joints] * n) + between
        names = list(self.pool.recordings_without(fold))
        return Fit(
            model, x, cov, free, inner.df + len(joints), phi=inner.phi, phi_cov=inner.phi_cov, z=inner.z,
            offsets={name: row for name, row in zip(names, per_recording)}, offset_joints=tuple(joints),
        )  # fmt: skip

    def cv_sse(self, model: Model) -> tuple[np.ndarray, list[Fit], np.ndarray]:
        """Held-out squared error per joint summed over the leave-one-group-out folds (7,), the fold
        fits, and each fold's own (folds, 7)."""
        cols = self.columns(model)
        fits = []
        self.fit(model)  # the full fit first: the folds start from it
        per_fold = np.zeros((len(self.pool.groups), N))
        for g in range(len(self.pool.groups)):
            f = self.fit(model, g)
            fits.append(f)
            per_fold[g] = self.sse(cols, f.x, self.pool.group_H[g], self.pool.group_b[g], self.pool.group_rr[g])
        return per_fold.sum(axis=0), fits, per_fold

    def _fit_linear(self, model: Model, cols: np.ndarray, Hw: np.ndarray, bw: np.ndarray, prior: np.ndarray) -> Fit:
        """Bounded least squares of the linear columns; prior (c,) the precision of their zero-mean
        priors, which the effective number of parameters tr((H + P)⁻¹ H) discounts."""
        c = len(cols)
        x = np.zeros(c)
        cov = np.zeros((c, c))
        free = np.zeros(c, dtype=bool)
        if c == 0:
            return Fit(model, x, cov, free, 0.0)
        lower = self.lower(model)
        diag = np.diag(Hw).copy()
        seen = diag > 1e-14 * max(float(diag.max()), 1e-300)
        scale = np.sqrt(diag[seen])
        data = Hw[np.ix_(seen, seen)] / np.outer(scale, scale)
        Hs = data + np.diag(prior[seen] / scale**2) + RIDGE * np.eye(int(seen.sum()))
        bs = bw[seen] / scale
        low = lower[seen] * scale
        if np.all(~np.isfinite(low)):
            ys = np.linalg.solve(Hs, bs)
            active = np.zeros(len(ys), dtype=bool)
        else:
            L = np.linalg.cholesky(Hs)
            result = lsq_linear(L.T, np.linalg.solve(L, bs), bounds=(low, np.full(len(low), np.inf)), method="bvls")
            ys = result.x
            active = np.isfinite(low) & (ys - low <= AT_BOUND * np.maximum(1.0, np.abs(low)))
            ys = np.where(active, low, ys)
        x[seen] = ys / scale
        idx = np.flatnonzero(seen)[~active]
        free[idx] = True
        df = 0.0
        if len(idx):
            inv = np.linalg.inv(Hs[np.ix_(~active, ~active)])
            s = scale[~active]
            cov[np.ix_(idx, idx)] = self.lam * inv / np.outer(s, s)
            df = float(np.einsum("ij,ji->", inv, data[np.ix_(~active, ~active)]))
        return Fit(model, x, cov, free, df)

    # -- inertial terms (log-Cholesky: inertial_fit)
    def link_setup(self, cand: Candidate) -> LinkSetup:
        """An inertial candidate's :class:`~.inertial_fit.LinkSetup` (computed once per fitter family)."""
        if cand.name not in self._setups:
            self._setups[cand.name] = link_setup(self.arm, cand)
        return self._setups[cand.name]

    def _fit_inertial(
        self, model: Model, cols: np.ndarray, Hw: np.ndarray, bw: np.ndarray, constant: float, fold: int | None, start: np.ndarray | None
    ) -> Fit:
        terms = [(self.layout.candidates[t.candidate], t.candidate, where) for t, where in self.positions(model).items()]
        solution = fit_inertial(
            terms, self.link_setup, self.lower(model), cols, Hw, bw, constant, lam=self.lam, warm=self._warm, exact=fold is None, start=start
        )
        return Fit(model, solution.x, solution.cov_x, solution.free, solution.df, phi=solution.phi, phi_cov=solution.phi_cov, z=solution.z)
