"""Fitting a set of candidate effects on sufficient statistics, inside the physical set.

A *model* is a set of terms: a candidate effect (:class:`~baxter_dynamics_ros.diagnosis.statistics.Candidate`)
and, for the per-joint kinds, the joints it acts on. Its fit minimises the weighted squared error

    Σ_j w_j ‖r_j − Φ_j x‖² + λ ‖(φ − φ₀) / σ_φ‖²

over the model's parameters, from the statistics alone (r·r − 2 x·b + xᵀ H x per joint). w_j = 1/σ_j²
weighs each joint by the residual level it has to explain (a wrist at 0.05 N·m counts as much as a
shoulder at 1 N·m); λ = samples per effective sample (samples closer than ``DECORRELATION_S`` carry
one sample's information between them), so the prior weighs like one effective observation.

Linear kinds are solved as bounded linear least squares (friction, armature ≥ 0). Inertial kinds
(``payload``, ``inertial_error``) are fitted *inside the physical set*: each link's pseudo-inertia is
written in log-Cholesky coordinates φ (:mod:`~baxter_dynamics_ros.core.log_cholesky`), so it stays
positive definite whatever the data say; its mass and centre of mass are box bounds on φ (``MASS_RANGE``
and ``COM_BOX_M`` about the paper's values; the payload's in ``PAYLOAD_MASS_KG`` and
``PAYLOAD_COM_BOX_M`` at the flange); and a Gaussian prior on φ about the paper's values pulls the
directions the data do not see back to them. The problem is solved by a bounded damped
Newton iteration with Levenberg-Marquardt damping (:func:`_box_newton`, exact derivatives): the data term is written as ‖R x − R⁻ᵀ b‖² with RᵀR the
Cholesky factorisation of the weighted H, so the residual vector has only as many rows as the model
has columns, whatever the length of the recordings. Why not an SDP (cvxpy, as FloBaRoID): the
log-Cholesky form needs no extra solver, handles the bounds and a prior in one smooth problem, and
a warm-started fit of a cross-validation fold takes a few milliseconds.

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

from ..core.arm_model import ArmModel, pseudo_inertia
from ..core.joints import JOINTS as N
from ..core.joints import S1
from ..core.log_cholesky import contraction_hessian, log_cholesky_from_pseudo, parameters_from_log_cholesky
from ..errors import DiagnosisError
from .statistics import Candidate, ColumnLayout, Pool

__all__ = ["DECORRELATION_S", "Fit", "Fitter", "Model", "Term"]

#: Samples closer than this are counted as one in the prior's weight and the uncertainties.
DECORRELATION_S = 0.1
#: A link's mass stays within this factor range of the paper's.
MASS_RANGE = (0.5, 1.5)
#: A link's centre of mass stays within this distance of the paper's along each axis of its DH frame, m.
COM_BOX_M = 0.05
#: Prior standard deviations of a link's log-Cholesky coordinates about the paper's values:
#: α (½ ln m: 0.1 is 20 % of mass), d (ln of a radius of gyration: 20 %), s (relative to the
#: link's mean radius of gyration), t (centre of mass, m).
LINK_PRIOR_STD = {"alpha": 0.1, "d": 0.2, "s": 0.2, "t": 0.02}
#: The payload: mass range (kg), centre-of-mass box in the flange frame (m, per axis lower/upper).
PAYLOAD_MASS_KG = (0.01, 5.0)
PAYLOAD_COM_BOX_M = ((-0.1, 0.1), (-0.1, 0.1), (-0.05, 0.3))
#: The payload's prior: 1 kg, centre of mass 5 cm out along the flange's z, radii of gyration 3 cm,
#: all broad (the data decide mass and centre of mass; the prior only what they cannot see).
PAYLOAD_PRIOR_MEAN = {"mass_kg": 1.0, "com_m": (0.0, 0.0, 0.05), "gyration_m": 0.03}
PAYLOAD_PRIOR_STD = {"alpha": 1.0, "d": 0.7, "s": 1.0, "t": 0.1}
#: Relative ridge on unit-norm columns: keeps directions the data never excite at zero.
RIDGE = 1e-9
#: Newton steps of a fit at most (a warm-started fit takes a few; a fold starts at the whole
#: pool's optimum; the iteration stops when it promises less than 1e-12 of the cost).
MAX_NEWTON_STEPS = 100
#: A parameter within this fraction of its range's width of a bound is at the bound.
AT_BOUND = 1e-9
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
        self._warm: dict[int, np.ndarray] = {}  # last exact full fit's φ per inertial candidate
        self._warm_x: dict[int, float] = {}  # and its linear parameters, by column
        self._setups: dict[str, tuple] = {}
        self._cache: dict[tuple[Model, int], Fit] = {}

    def with_weights(self, weights: np.ndarray) -> Fitter:
        """A fitter of the same pool with other joint weights (it starts its fits where this one ended)."""
        other = Fitter(self.arm, self.layout, self.pool, weights, self.lam)
        other._warm, other._warm_x, other._setups = self._warm, self._warm_x, self._setups
        return other

    # -- columns
    def term_columns(self, model: Model) -> list[np.ndarray]:
        """Each term's columns in the model (a spring takes the place of s1's offset and gain)."""
        spring = self.layout.has_spring(model)
        out = []
        for t in model.terms:
            cand = self.layout.candidates[t.candidate]
            if cand.kind == "joint":
                joints = [j for j in t.joints if not (spring and cand.spanned_by_spring and j == S1)]
                out.append(cand.joint_columns(joints))
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
        offset = next((t for t in model.terms if self.layout.candidates[t.candidate].name == "torque_offset"), None)
        joints = [] if offset is None else [j for j in offset.joints if not (j == S1 and self.layout.has_spring(model))]
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
        where = {int(c): k for k, c in enumerate(cols)}
        x = np.zeros(len(cols))
        free = np.ones(len(cols), dtype=bool)
        cov = np.zeros((len(cols), len(cols)))
        inner_at = np.array([where[int(c)] for c in inner_cols], dtype=int)
        x[inner_at] = inner.x
        free[inner_at] = inner.free
        cov[np.ix_(inner_at, inner_at)] = inner.cov_x
        off_at = np.array([where[int(c)] for c in off_cols], dtype=int)
        x[off_at] = constant
        n = self.pool.samples
        between = per_recording.var(axis=0, ddof=1) / len(per_recording) if len(per_recording) > 1 else 0.0
        cov[off_at, off_at] = self.lam / (self.weights[joints] * n) + between
        names = list(self.pool.recordings_without(fold))
        return Fit(
            model, x, cov, free, inner.df + len(joints), inner.phi, inner.phi_cov, inner.z,
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

    # -- inertial terms (log-Cholesky)
    def link_setup(self, cand: Candidate) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(φ₀ (L, 10), σ_φ (L, 10), lower (L, 10), upper (L, 10), π_reference (L, 10)) of an inertial candidate."""
        if cand.name not in self._setups:
            self._setups[cand.name] = self._make_link_setup(cand)
        return self._setups[cand.name]

    def _make_link_setup(self, cand: Candidate) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if cand.name == "payload":
            m0, c0, g0 = PAYLOAD_PRIOR_MEAN["mass_kg"], np.array(PAYLOAD_PRIOR_MEAN["com_m"]), PAYLOAD_PRIOR_MEAN["gyration_m"]
            phi0 = np.concatenate([[0.5 * np.log(m0)], np.full(3, np.log(g0)), np.zeros(3), c0])[None]
            std = _prior_std(PAYLOAD_PRIOR_STD, g0)[None]
            lo = np.full((1, 10), -np.inf)
            hi = np.full((1, 10), np.inf)
            lo[0, 0], hi[0, 0] = (0.5 * np.log(m) for m in PAYLOAD_MASS_KG)
            for k, (a, bnd) in enumerate(PAYLOAD_COM_BOX_M):
                lo[0, 7 + k], hi[0, 7 + k] = a, bnd
            return phi0, std, lo, hi, np.zeros((1, 10))
        links = [self.arm.links[i] for i in cand.links]
        J0 = np.stack([pseudo_inertia(link) for link in links])
        phi0 = log_cholesky_from_pseudo(J0)
        std = np.stack([_prior_std(LINK_PRIOR_STD, float(np.mean(np.exp(p[1:4])))) for p in phi0])
        lo = np.full_like(phi0, -np.inf)
        hi = np.full_like(phi0, np.inf)
        for i, link in enumerate(links):
            lo[i, 0], hi[i, 0] = (0.5 * np.log(f * link.mass_kg) for f in MASS_RANGE)
            lo[i, 7:10], hi[i, 7:10] = link.com_m - COM_BOX_M, link.com_m + COM_BOX_M
        pi0, _ = parameters_from_log_cholesky(phi0)
        return phi0, std, lo, hi, pi0

    def _fit_inertial(
        self, model: Model, cols: np.ndarray, Hw: np.ndarray, bw: np.ndarray, constant: float, fold: int | None, start: np.ndarray | None
    ) -> Fit:
        cands = self.layout.candidates
        c = len(cols)
        # Variables z = [linear parameters the data see, φ of each inertial term's links];
        # x = [linear, π(φ) − π_ref]. The data term in unit-norm columns y = x ⊙ scale is
        # yᵀ Hs y − 2 bsᵀ y (+ Σ_j w_j r_j·r_j), Hs = D⁻¹ H D⁻¹.
        blocks, lin_idx = [], []
        for t, where in self.positions(model).items():
            cand = cands[t.candidate]
            if cand.kind == "inertial":
                blocks.append((t.candidate, int(where[0]), *self.link_setup(cand)))
            else:
                lin_idx.extend(where.tolist())
        diag = np.diag(Hw).copy()
        seen = diag > 1e-14 * max(float(diag.max()), 1e-300)
        row = np.full(c, -1)
        row[seen] = np.arange(int(seen.sum()))
        scale = np.sqrt(diag[seen])
        Hs = Hw[np.ix_(seen, seen)] / np.outer(scale, scale) + RIDGE * np.eye(int(seen.sum()))
        bs = bw[seen] / scale
        lin_pos = np.array([k for k in lin_idx if seen[k]], dtype=int)
        lin_rows = row[lin_pos]
        lin_low = self.lower(model)[lin_pos]
        n_lin = len(lin_pos)
        # Per link of every inertial term: its φ's place in z, its x positions seen by the data.
        links = []  # (z slice start, rows in y, which of the link's 10 parameters they are, π_ref)
        k = n_lin
        for _, first_col, phi0_b, _, _, _, pi_ref in blocks:
            for i in range(len(phi0_b)):
                pos = first_col + 10 * i + np.arange(10)
                sel = seen[pos]
                links.append((k, row[pos[sel]], np.flatnonzero(sel), pi_ref[i]))
                k += 10
        n_z = k
        phi0 = np.concatenate([blk[2].ravel() for blk in blocks])
        prior_w = self.lam / np.concatenate([blk[3].ravel() for blk in blocks]) ** 2
        lo = np.concatenate([lin_low, np.concatenate([blk[4].ravel() for blk in blocks])])
        hi = np.concatenate([np.full(n_lin, np.inf), np.concatenate([blk[5].ravel() for blk in blocks])])

        link_z = np.array([kz for kz, *_ in links], dtype=int)

        def derivatives(z: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
            """Cost, half its gradient, its Gauss-Newton and second-order curvature (halves)."""
            phis = z[link_z[:, None] + np.arange(10)]
            pis, jacs = parameters_from_log_cholesky(phis)
            y = np.zeros(len(bs))
            y[lin_rows] = z[:n_lin] * scale[lin_rows]
            dys = []  # ∂y/∂φ of each link on its rows, (rows, 10)
            for (kz, rows, sel, pi_ref), pi, jac in zip(links, pis, jacs):
                y[rows] = (pi - pi_ref)[sel] * scale[rows]
                dys.append(jac[sel] * scale[rows, None])
            resid = Hs @ y - bs
            dphi = z[n_lin:] - phi0
            cost = constant + float(y @ (resid - bs)) + float(np.sum(prior_w * dphi**2))
            # H_s ∂y/∂z, column block by column block (∂y/∂z is the identity on the linear part).
            hdy = np.empty((len(bs), n_z))
            hdy[:, :n_lin] = Hs[:, lin_rows] * scale[lin_rows]
            for (kz, rows, _, _), dy in zip(links, dys):
                hdy[:, kz : kz + 10] = Hs[:, rows] @ dy
            grad = np.empty(n_z)
            gauss = np.empty((n_z, n_z))
            grad[:n_lin] = resid[lin_rows] * scale[lin_rows]
            gauss[:n_lin] = hdy[lin_rows] * scale[lin_rows, None]
            gamma_y = resid * scale  # ∂(data cost / 2)/∂x on the seen positions
            gammas = np.zeros((len(links), 10))
            for i, ((kz, rows, sel, _), dy) in enumerate(zip(links, dys)):
                grad[kz : kz + 10] = dy.T @ resid[rows]
                gauss[kz : kz + 10] = dy.T @ hdy[rows]
                gammas[i, sel] = gamma_y[rows]
            second = np.zeros((n_z, n_z))
            for (kz, *_), h in zip(links, contraction_hessian(phis, gammas)):
                second[kz : kz + 10, kz : kz + 10] = h
            grad[n_lin:] += prior_w * dphi
            gauss[n_lin:, n_lin:] += np.diag(prior_w)
            return cost, grad, gauss, second

        if start is not None and len(start) == n_z:
            z0 = start  # a fold starts from the whole pool's fit (unless it holds other offsets common)
        else:
            # The last fit of each term (a neighbouring model's), else zero and the paper's values.
            start_lin = np.array([self._warm_x.get(int(col), 0.0) for col in cols[lin_pos]])
            z0 = np.concatenate([np.maximum(lin_low, start_lin)] + [self._warm.get(blk[0], blk[2]).ravel() for blk in blocks])
        with np.errstate(over="ignore", invalid="ignore"):  # a rejected trial step may overflow exp(φ)
            z, gauss, second = _box_newton(derivatives, z0, lo, hi, MAX_NEWTON_STEPS)
        if not np.all(np.isfinite(z)):
            raise DiagnosisError(f"the inertial fit of {', '.join(cands[t.candidate].name for t in model.terms)} did not converge")
        x = np.zeros(c)
        x[lin_pos] = z[:n_lin]
        dx = np.zeros((c, n_z))
        dx[lin_pos, np.arange(n_lin)] = 1.0
        phis, spans = {}, {}  # per inertial candidate: its φ (links, 10), and its slice of z
        kz = n_lin
        for cand_index, first_col, phi0_b, *_, pi_ref in blocks:
            links_b = len(phi0_b)
            spans[cand_index] = slice(kz, kz + 10 * links_b)
            phis[cand_index] = z[spans[cand_index]].reshape(links_b, 10)
            pis, jacs = parameters_from_log_cholesky(phis[cand_index])
            for i in range(links_b):
                rows = slice(first_col + 10 * i, first_col + 10 * i + 10)
                x[rows] = pis[i] - pi_ref[i]
                dx[rows, kz + 10 * i : kz + 10 * i + 10] = jacs[i]
            kz += 10 * links_b
        if fold is not None:
            return Fit(model, x, np.zeros((c, c)), np.ones(c, dtype=bool), 0.0, phis, z=z)
        self._warm.update(phis)
        self._warm_x.update(zip(cols[lin_pos].tolist(), z[:n_lin].tolist()))
        width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
        active = (np.isfinite(lo) & (z - lo <= AT_BOUND * width)) | (np.isfinite(hi) & (hi - z <= AT_BOUND * width))
        freev = ~active
        prior_curv = np.zeros(n_z)
        prior_curv[n_lin:] = prior_w
        K = (gauss + second)[np.ix_(freev, freev)]
        if np.linalg.eigvalsh(K)[0] <= 0:  # not a strict minimum in every direction: the Gauss-Newton curvature
            K = gauss[np.ix_(freev, freev)]
            second = np.zeros_like(second)
        Kd = K - np.diag(prior_curv[freev])
        inv = np.linalg.inv(K)
        df = float(np.einsum("ij,ji->", inv, Kd))  # tr((K_d + P)⁻¹ K_d): what the data decide
        cov_z = np.zeros((n_z, n_z))
        cov_z[np.ix_(freev, freev)] = self.lam * inv
        free = np.zeros(c, dtype=bool)
        free[lin_pos] = freev[:n_lin]
        phi_cov = {}
        for cand_index, first_col, phi0_b, *_ in blocks:
            phi_cov[cand_index] = cov_z[spans[cand_index], spans[cand_index]]
            free[first_col : first_col + 10 * len(phi0_b)] = True
        return Fit(model, x, dx @ cov_z @ dx.T, free, df, phis, phi_cov, z)


def _prior_std(spec: dict[str, float], gyration_m: float) -> np.ndarray:
    """(10,) prior standard deviations of φ from a spec of α, d, s (relative to gyration_m), t."""
    return np.concatenate([[spec["alpha"]], np.full(3, spec["d"]), np.full(3, spec["s"] * gyration_m), np.full(3, spec["t"])])


def _box_newton(fun, z0: np.ndarray, lo: np.ndarray, hi: np.ndarray, max_iter: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """min C(z) over lo ≤ z ≤ hi; fun(z) → (C, g, G, S) with g = ½∇C, G + S = ½∇²C (G the Gauss-Newton
    part, positive semi-definite). Returns z and G, S there.

    Damped Newton steps (G + S plus Levenberg-Marquardt damping μ diag(G), raised where G + S is not
    positive definite or a step does not pay) on the variables not held at a bound: held are those at a bound whose
    gradient points out of the box, and those a step would carry past one (the step is then solved
    again without them, a Newton step on the face). A step is taken only if it lowers the cost; the
    iteration stops when the model promises less than 1e-12 of the cost. Gauss-Newton alone converges
    only linearly here (the residual at the optimum is large and π(φ) is curved); scipy's
    trust-region solver took 40 times longer for the same optimum.
    """
    z = np.clip(z0, lo, hi)
    cost, g, gauss, second = fun(z)
    mu = 0.0
    for _ in range(max_iter):
        K = gauss + second
        scale = np.maximum(np.diag(gauss), 1e-300)
        held = ((z <= lo) & (g > 0)) | ((z >= hi) & (g < 0))
        step = np.zeros_like(z)
        while True:
            f = ~held
            try:
                factor = np.linalg.cholesky(K[np.ix_(f, f)] + mu * np.diag(scale[f]))
            except np.linalg.LinAlgError:
                mu = max(10.0 * mu, 1e-8)  # not convex here: damp until it is
                continue
            step[:] = 0.0
            step[f] = -np.linalg.solve(factor.T, np.linalg.solve(factor, g[f]))
            past = f & ((z + step < lo) | (z + step > hi))
            if not past.any():
                break
            held = held | past
            z = np.where(past, np.clip(z + step, lo, hi), z)  # those variables go to their bound
        predicted = -(2.0 * g @ step + step @ K @ step)
        new = fun(z + step)
        if np.isfinite(new[0]) and new[0] < cost:
            z = z + step
            cost, g, gauss, second = new
            mu = mu / 10.0 if mu > 1e-10 else 0.0
            if predicted <= 1e-12 * abs(cost):
                break
        else:
            cost, g, gauss, second = fun(z)  # z may have moved variables to their bounds
            if predicted <= 1e-12 * abs(cost):
                break
            mu = max(10.0 * mu, 1e-8)
            if mu > 1e12:
                break
    return z, gauss, second
