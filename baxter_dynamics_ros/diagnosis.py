"""Which unmodelled effect causes the sim-to-real gap, and how far adding it shrinks the gap.

Method (forward selection over linear models, scored on held-out data):

1. Worlds. The rigid-body residual r = effort − τ(q, q̇, q̈) depends on how q̈ is estimated. The
   *raw* world uses the paper's first difference of q̇; the *filtered* world a zero-phase low-pass
   on q̇ before differentiating (cutoff chosen on the training data). Switching from raw to
   filtered is the candidate ``acceleration_noise``: the part of the gap that is noise of the
   differentiated q̈, not physics.
2. Candidates. Every other effect of :mod:`baxter_dynamics_ros.effects` is linear in its
   parameters θ for fixed shape parameters (friction velocity scales): its share of the effort is
   Φ θ with Φ = ``effect.regressor``. Shape parameters are searched on a small grid; each grid point
   is a variant of its effect.
3. Sufficient statistics. Per segment (a training file, or a contiguous block of a lone file) and
   per joint j, H_j = Σ Φ_jᵀ Φ_j, b_j = Σ Φ_jᵀ r_j and r_jᵀ r_j are accumulated once for all
   candidate columns. Any fit is then a small bounded least-squares problem (friction, armature and
   delay ≥ 0), and the squared error of any fit on any segment is exact: r·r − 2 θ·b + θᵀ H θ.
4. Selection. Starting from the rigid-body model in the raw world, each step adds the candidate
   with the largest cross-validated gain (leave one segment out) in total squared error, net of an
   AIC-like penalty of 2 σ̂² per parameter and effective sample (samples 0.1 s apart count as one).
   A candidate is selected only if it still gains after the penalty, cuts some joint's held-out
   error by ≥ 5 %, and its fitted parameters are physically plausible (see :func:`_plausibility`;
   a free inertial fit that moves a centre of mass by a metre to imitate the s1 spring is not).
5. Held-out figures. Selected effects are refitted on all training data and every "after"
   figure is measured on the test data, which no fit has seen.

Everything here is numpy (and scipy's bounded least squares); no ROS.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import lsq_linear

from .acceleration import first_difference, zero_phase_acceleration
from .arm_model import ArmModel, pseudo_inertia
from .effects import (
    EFFECTS,
    Armature,
    CoulombFriction,
    Delay,
    Effect,
    InertialError,
    Payload,
    S1Spring,
    StribeckFriction,
    TorqueOffset,
    ViscousFriction,
)
from .errors import DiagnosisError
from .gap_analysis import GapSummary, summarise_gap
from .lagrange_euler import inertial_basis
from .recording import Recording

__all__ = [
    "CANDIDATE_NAMES",
    "DiagnosisResult",
    "EffectReport",
    "diagnose",
]

N = 7
S1 = 1  # index of joint s1
#: The candidate effects: every effect of the library, in its order.
CANDIDATE_NAMES = tuple(EFFECTS)
#: Cut-offs (Hz) tried for the filtered world's zero-phase low-pass on q̇.
CUTOFF_GRID_HZ = (1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0)
#: Samples closer than this are counted as one in the complexity penalty.
DECORRELATION_S = 0.1
#: A selected effect must cut the held-out squared error of at least one joint by this fraction,
#: and its held-out RMS by MIN_JOINT_GAIN_NM (about the effort's quantisation and noise).
MIN_JOINT_GAIN = 0.05
MIN_JOINT_GAIN_NM = 0.01
#: Departures beyond which a fitted inertial change is not physical.
MAX_MASS_CHANGE = 0.5  # fraction of the link's mass
MAX_MASS_CHANGE_KG = 0.5
MAX_COM_SHIFT_M = 0.1
MAX_PAYLOAD_KG = 10.0
MAX_PAYLOAD_COM_M = 0.3
CHUNK = 8192
#: Relative ridge of every fit (on unit-norm columns).
RIDGE = 1e-7


@dataclass(frozen=True)
class _Candidate:
    """One variant of an effect: its template (shape parameters fixed) and how θ becomes an effect."""

    name: str
    variant: str
    template: Effect
    lower: np.ndarray  # (p,) lower bounds of θ
    build: Callable[[np.ndarray], Effect]
    prior_std: np.ndarray | None = None  # (p,) how far θ may plausibly stray from 0 (inertial effects)
    columns: slice | None = None  # where its θ sits among all candidates' columns

    @property
    def n_params(self) -> int:
        return len(self.lower)


def _joint_bound(value: float) -> np.ndarray:
    return np.full(N, value)


def _candidates(arm: ArmModel) -> list[_Candidate]:
    """Every linear candidate variant; acceleration_noise is the world switch, not a column set."""
    inf = -np.inf
    out = [
        _Candidate("torque_offset", "", TorqueOffset(offset_nm=0.0), _joint_bound(inf), lambda t: TorqueOffset(offset_nm=t)),
        _Candidate(
            "viscous_friction", "", ViscousFriction(damping_nm_s_rad=0.0), _joint_bound(0.0), lambda t: ViscousFriction(damping_nm_s_rad=t)
        ),
    ]
    for eps in (0.01, 0.05):
        out.append(
            _Candidate(
                "coulomb_friction",
                f"smoothing {eps:g} rad/s",
                CoulombFriction(friction_nm=0.0, smoothing_rad_s=eps),
                _joint_bound(0.0),
                lambda t, eps=eps: CoulombFriction(friction_nm=t, smoothing_rad_s=eps),
            )
        )
    for vs in (0.02, 0.05, 0.1, 0.2):
        out.append(
            _Candidate(
                "stribeck_friction",
                f"v_s {vs:g} rad/s",
                StribeckFriction(coulomb_nm=0.0, static_nm=0.0, stribeck_rad_s=vs),
                np.zeros(2 * N),
                lambda t, vs=vs: StribeckFriction(coulomb_nm=t[:N], static_nm=t[N:], stribeck_rad_s=vs),
            )
        )
    out += [
        _Candidate(
            "s1_spring", "", S1Spring(), np.full(3, inf), lambda t: S1Spring(preload_nm=t[0], cosine_nm=t[1], sine_nm=t[2])
        ),
        _Candidate("payload", "", Payload(mass_kg=1.0), np.full(10, inf), _payload_from, PAYLOAD_PRIOR_STD),
        _Candidate("inertial_error", "", InertialError(), np.full(10 * N, inf), _inertial_from, _inertial_prior_std(arm)),
        _Candidate("armature", "", Armature(inertia_kgm2=0.0), _joint_bound(0.0), lambda t: Armature(inertia_kgm2=t)),
        _Candidate("delay", "", Delay(delay_s=0.0), np.zeros(1), lambda t: Delay(delay_s=float(t[0]))),
    ]
    start = 0
    placed = []
    for c in out:
        p = c.n_params
        placed.append(dataclasses.replace(c, columns=slice(start, start + p)))
        start += p
    return placed


#: Prior standard deviations of a payload's inertial parameters (m, m·c, I about the flange).
PAYLOAD_PRIOR_STD = np.array([2.0, 0.2, 0.2, 0.2, 0.02, 0.02, 0.02, 0.02, 0.02, 0.02])


def _inertial_prior_std(arm: ArmModel) -> np.ndarray:
    """(70,) prior standard deviations of the links' parameter changes: "bounded departures from
    the paper's values", 25 % of each nominal parameter plus a floor (0.05 kg, 0.01 kg·m,
    0.002 kg·m²)."""
    floor = np.array([0.05, 0.01, 0.01, 0.01, 0.002, 0.002, 0.002, 0.002, 0.002, 0.002])
    return 0.25 * np.abs(arm.inertial_parameters) + np.tile(floor, N)


def _pseudo_from_parameters(theta: np.ndarray) -> np.ndarray:
    """(10,) inertial parameters (lagrange_euler.inertial_basis order) → pseudo-inertia change (4, 4)."""
    return np.tensordot(theta, inertial_basis(), axes=1)


def _payload_from(theta: np.ndarray) -> Effect:
    """The fitted load as a point mass at its centre of mass (its own inertia is not kept)."""
    j = _pseudo_from_parameters(theta)
    mass = j[3, 3]
    if not mass > 0:
        raise DiagnosisError(f"payload fit has a non-positive mass {mass:.4g} kg")
    return Payload(mass_kg=float(mass), com_m=j[:3, 3] / mass)


def _inertial_from(theta: np.ndarray) -> Effect:
    """The fitted change of the links' inertial parameters."""
    return InertialError(parameter_change=theta)


# ----------------------------------------------------------------------------- statistics
@dataclass
class _Segment:
    """Sufficient statistics of one contiguous piece of data in one world, per joint."""

    label: str
    samples: int
    duration_s: float
    H: np.ndarray  # (7, P, P)
    b: np.ndarray  # (7, P)
    rr: np.ndarray  # (7,)

    def sse(self, cols: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """(7,) squared error per joint of the fit θ on the columns cols."""
        if len(cols) == 0:
            return self.rr.copy()
        hb = self.H[:, cols][:, :, cols]
        return self.rr - 2.0 * self.b[:, cols] @ theta + np.einsum("p,jpq,q->j", theta, hb, theta)


@dataclass(frozen=True)
class _Prepared:
    """A recording's arrays for one world: q̈, rigid residual and the time base."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    qdd_smooth: np.ndarray
    residual: np.ndarray
    stamps_s: np.ndarray


def _prepare(arm: ArmModel, rec: Recording, cutoff_hz: float | None) -> _Prepared:
    """Rigid residual with the raw (cutoff None) or zero-phase filtered q̈."""
    stamps = rec.stamps_s
    smooth = zero_phase_acceleration(rec.qd, rec.rate_hz, min(5.0, 0.4 * rec.rate_hz))
    qdd = first_difference(rec.qd, stamps) if cutoff_hz is None else zero_phase_acceleration(rec.qd, rec.rate_hz, cutoff_hz)
    residual = rec.effort - arm.inverse_dynamics(rec.q, rec.qd, qdd)
    return _Prepared(rec.q, rec.qd, qdd, smooth, residual, stamps)


def _regressor(arm: ArmModel, candidates: list[_Candidate], p: _Prepared, lo: int, hi: int, delay_column: np.ndarray) -> np.ndarray:
    """(n, 7, P) every candidate's columns on samples lo:hi."""
    q, qd, qdd = p.q[lo:hi], p.qd[lo:hi], p.qdd[lo:hi]
    blocks = []
    for c in candidates:
        if c.name == "delay":
            blocks.append(delay_column[lo:hi])
        else:
            blocks.append(c.template.regressor(arm, q, qd, qdd))
    return np.concatenate(blocks, axis=2)


def _active_columns(arm: ArmModel, candidates: list[_Candidate], n_cols: int) -> list[np.ndarray]:
    """Per joint, the columns that can be non-zero on it (probed on random states)."""
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower_rad, arm.upper_rad, (32, N))
    qd, qdd = rng.uniform(-1, 1, (2, 32, N))
    probe = _Prepared(q, qd, qdd, qdd, np.zeros_like(q), np.arange(32) * 0.01)
    phi = _regressor(arm, candidates, probe, 0, 32, np.ones((32, N, 1)))
    return [np.flatnonzero(np.any(phi[:, j, :] != 0.0, axis=0)) for j in range(N)]


def _segment(
    arm: ArmModel, candidates: list[_Candidate], active: list[np.ndarray], n_cols: int, p: _Prepared, lo: int, hi: int, label: str, delay_column: np.ndarray
) -> _Segment:
    H = np.zeros((N, n_cols, n_cols))
    b = np.zeros((N, n_cols))
    rr = np.zeros(N)
    for start in range(lo, hi, CHUNK):
        stop = min(hi, start + CHUNK)
        phi = _regressor(arm, candidates, p, start, stop, delay_column)
        r = p.residual[start:stop]
        for j in range(N):
            idx = active[j]
            x = phi[:, j, idx]
            H[j][np.ix_(idx, idx)] += x.T @ x
            b[j, idx] += x.T @ r[:, j]
        rr += np.sum(r**2, axis=0)
    return _Segment(label, hi - lo, float(p.stamps_s[hi - 1] - p.stamps_s[lo]), H, b, rr)


# ----------------------------------------------------------------------------- fitting
@dataclass(frozen=True)
class _Model:
    """A set of selected candidates in a world.

    With both ``s1_spring`` and ``torque_offset``, the offset of s1 is left out: the spring's
    preload is that constant, and two columns for one number would split it arbitrarily.
    """

    world: str  # "raw" or "filtered"
    members: tuple[_Candidate, ...]
    prior_weight: float = 0.0  # σ² of the residual × samples per effective sample, N·m²

    def _mask(self) -> list[np.ndarray]:
        spring = any(c.name == "s1_spring" for c in self.members)
        masks = []
        for c in self.members:
            keep = np.ones(c.n_params, dtype=bool)
            if spring and c.name == "torque_offset":
                keep[S1] = False
            masks.append(keep)
        return masks

    def columns(self) -> np.ndarray:
        cols = [np.arange(c.columns.start, c.columns.stop)[m] for c, m in zip(self.members, self._mask())]
        return np.concatenate(cols).astype(int) if cols else np.zeros(0, int)

    def lower(self) -> np.ndarray:
        lows = [c.lower[m] for c, m in zip(self.members, self._mask())]
        return np.concatenate(lows) if lows else np.zeros(0)

    def n_params(self, segments: Sequence[_Segment]) -> float:
        """Effective number of parameters: a column under a prior counts by how much the data
        decides it, H (H + P)⁻¹ on its diagonal; the filter's cut-off counts one."""
        precision = self.prior_precision()
        free = float(np.sum(precision == 0))
        prior_cols = self.columns()[precision > 0]
        if len(prior_cols):
            H = sum(s.H[:, prior_cols][:, :, prior_cols].sum(axis=0) for s in segments)
            P = np.diag(precision[precision > 0])
            free += float(np.trace(np.linalg.solve(H + P, H)))
        return free + (1 if self.world == "filtered" else 0)

    def prior_precision(self) -> np.ndarray:
        """Per column, the weight of the prior's Σ (θ_k / std_k)² in squared-error units."""
        out = []
        for c, keep in zip(self.members, self._mask()):
            std = c.prior_std if c.prior_std is not None else np.full(c.n_params, np.inf)
            out.append(self.prior_weight / std[keep] ** 2)
        return np.concatenate(out) if out else np.zeros(0)

    def split(self, theta: np.ndarray) -> list[np.ndarray]:
        """θ per member, in its full parameter layout (left-out columns are 0)."""
        out, k = [], 0
        for c, keep in zip(self.members, self._mask()):
            full = np.zeros(c.n_params)
            n = int(keep.sum())
            full[keep] = theta[k : k + n]
            out.append(full)
            k += n
        return out


def _fit(segments: Sequence[_Segment], model: _Model) -> np.ndarray:
    """Bounded least squares θ ≥ lower on the model's columns, from summed statistics.

    The model's prior (inertial effects) adds Σ w_k θ_k² to the squared error: a Gaussian prior
    θ_k ~ N(0, std_k²) weighed against the data's noise. Columns are scaled to unit norm, and a
    ridge of RIDGE (relative) keeps directions the data cannot see at zero. Columns the data
    never excites are left at zero.
    """
    cols, lower = model.columns(), model.lower()
    theta = np.zeros(len(cols))
    if len(cols) == 0:
        return theta
    H = sum(s.H[:, cols][:, :, cols].sum(axis=0) for s in segments) + np.diag(model.prior_precision())
    b = sum(s.b[:, cols].sum(axis=0) for s in segments)
    diag = np.diag(H)
    seen = diag > 1e-14 * max(float(diag.max()), 1e-300)
    scale = np.sqrt(diag[seen])
    Hs = H[np.ix_(seen, seen)] / np.outer(scale, scale) + RIDGE * np.eye(int(seen.sum()))
    bs = b[seen] / scale
    low = lower[seen] * scale
    if np.all(~np.isfinite(low)):
        theta[seen] = np.linalg.solve(Hs, bs) / scale
        return theta
    L = np.linalg.cholesky(Hs)
    result = lsq_linear(L.T, np.linalg.solve(L, bs), bounds=(low, np.full(len(low), np.inf)), method="bvls")
    theta[seen] = result.x / scale
    return theta


def _cv_sse(model: _Model, segments: dict[str, list[_Segment]]) -> tuple[np.ndarray, list[np.ndarray]]:
    """Held-out squared error per joint, summed over leave-one-segment-out folds; and the fold fits."""
    segs = segments[model.world]
    cols = model.columns()
    total = np.zeros(N)
    fits = []
    for k, held in enumerate(segs):
        train = [s for i, s in enumerate(segs) if i != k]
        theta = _fit(train, model)
        fits.append(theta)
        total += held.sse(cols, theta)
    return total, fits


def _plausibility(candidate: _Candidate, theta: np.ndarray, arm: ArmModel) -> str:
    """'' if the fitted parameters are physical, else why not."""
    if candidate.name == "payload":
        j = _pseudo_from_parameters(theta)
        mass = j[3, 3]
        if not 0 < mass <= MAX_PAYLOAD_KG:
            return f"payload mass {mass:.3g} kg outside (0, {MAX_PAYLOAD_KG:g}] kg"
        com = j[:3, 3] / mass
        if np.linalg.norm(com) > MAX_PAYLOAD_COM_M:
            return f"payload centre of mass {np.linalg.norm(com):.2f} m from the flange (> {MAX_PAYLOAD_COM_M:g} m)"
    if candidate.name == "inertial_error":
        # Only what the data sees is fitted (the ridge keeps the rest at the paper's values), so
        # the check is on the changes that matter: mass and centre of mass of each link.
        for i, link in enumerate(arm.links):
            j = pseudo_inertia(link) + _pseudo_from_parameters(theta[10 * i : 10 * i + 10])
            mass = j[3, 3]
            if abs(mass - link.mass_kg) > max(MAX_MASS_CHANGE * link.mass_kg, MAX_MASS_CHANGE_KG):
                return f"needs link {i + 1}'s mass {link.mass_kg:.3f} → {mass:.3f} kg (beyond ±{MAX_MASS_CHANGE:.0%})"
            shift = np.linalg.norm(j[:3, 3] / mass - link.com_m) if mass > 0 else np.inf
            if shift > MAX_COM_SHIFT_M:
                return f"needs link {i + 1}'s centre of mass moved {shift:.2f} m (beyond {MAX_COM_SHIFT_M:g} m)"
    return ""


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class EffectReport:
    """One candidate's outcome. Arrays (7,) are per joint, N·m."""

    name: str
    variant: str
    selected: bool
    rank: int
    reason: str  # why it was (not) selected
    params: dict[str, float]
    params_std: dict[str, float]  # jackknife standard deviation across training segments
    joints: tuple[str, ...]
    cv_gain: float  # cross-validated squared error it removed, N·m² per sample summed over joints
    test_rms_before: np.ndarray
    test_rms_after: np.ndarray
    effect: Effect | None = None
    cutoff_hz: float | None = None


@dataclass(frozen=True)
class DiagnosisResult:
    """Everything the report and diagnosis.json hold (see :meth:`to_dict`)."""

    arm_side: str
    joint_names: tuple[str, ...]
    train_files: tuple[str, ...]
    test_files: tuple[str, ...]
    holdout: str
    cutoff_hz: float
    baseline_train_rms: np.ndarray
    baseline_test_rms: np.ndarray
    final_test_rms: np.ndarray
    effects: tuple[EffectReport, ...]
    gap: GapSummary  # where the gap lies, on the test data, rigid model with raw q̈
    gap_filtered: GapSummary  # the same with filtered q̈
    test_series: dict[str, np.ndarray] = field(repr=False)  # time, baseline and final residuals of the test data

    def selected(self) -> tuple[EffectReport, ...]:
        return tuple(e for e in self.effects if e.selected)

    def to_dict(self) -> dict:
        """Plain JSON-ready form; the schema is documented in the README."""
        rms = lambda a: [round(float(x), 6) for x in a]  # noqa: E731
        return {
            "arm": self.arm_side,
            "joints": list(self.joint_names),
            "train_files": list(self.train_files),
            "test_files": list(self.test_files),
            "holdout": self.holdout,
            "baseline": {"q_ddot": "first difference of q̇ (the paper's)", "train_rms": rms(self.baseline_train_rms), "test_rms": rms(self.baseline_test_rms)},
            "effects": [
                {
                    "name": e.name,
                    "variant": e.variant,
                    "rank": e.rank,
                    "selected": e.selected,
                    "reason": e.reason,
                    "joints": list(e.joints),
                    "params": e.params,
                    "params_std": e.params_std,
                    "cv_gain_nm2": e.cv_gain,
                    "test_rms_before": rms(e.test_rms_before),
                    "test_rms_after": rms(e.test_rms_after),
                    **({"cutoff_hz": e.cutoff_hz} if e.cutoff_hz is not None else {}),
                }
                for e in self.effects
            ],
            "final": {"test_rms": rms(self.final_test_rms)},
            "gap": self.gap.to_dict(),
            "gap_filtered_q_ddot": self.gap_filtered.to_dict(),
        }


# ----------------------------------------------------------------------------- the procedure
def _split_blocks(rec: Recording, parts: int) -> list[tuple[int, int]]:
    edges = np.linspace(0, len(rec), parts + 1).astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def _choose_cutoff(arm: ArmModel, train: Sequence[Recording]) -> float:
    """The cut-off whose filtered rigid residual is smallest on the training data (no fit involved)."""
    best, best_sse = CUTOFF_GRID_HZ[0], np.inf
    for cutoff in CUTOFF_GRID_HZ:
        sse = 0.0
        for rec in train:
            if cutoff >= 0.45 * rec.rate_hz:
                break
            sse += float(np.sum(_prepare(arm, rec, cutoff).residual ** 2))
        else:
            if sse < best_sse:
                best, best_sse = cutoff, sse
    return best


def _param_names(c: _Candidate) -> tuple[str, ...]:
    return tuple(c.template.parameter_names())


def diagnose(
    arm: ArmModel,
    train: Sequence[tuple[str, Recording]],
    test: Sequence[tuple[str, Recording]],
    *,
    progress: Callable[[int, int], None] | None = None,
) -> DiagnosisResult:
    """Diagnose the gap of ``arm``'s rigid model on recordings: fit on ``train``, measure on ``test``.

    train, test: (label, Recording) pairs of the arm's side. With one training recording, its
    four contiguous quarters are the cross-validation segments; otherwise each file is one.
    """
    tick = progress or (lambda _done, _total: None)
    if not train or not test:
        raise DiagnosisError("need at least one training and one test recording")
    for label, rec in (*train, *test):
        if rec.side != arm.side:
            raise DiagnosisError(f"{label}: a {rec.side}-arm recording, but the model is of the {arm.side} arm")
    candidates = _candidates(arm)
    n_cols = candidates[-1].columns.stop
    active = _active_columns(arm, candidates, n_cols)
    cutoff = _choose_cutoff(arm, [r for _, r in train])

    pieces: list[tuple[str, Recording, int, int]] = []
    if len(train) == 1:
        label, rec = train[0]
        pieces = [(f"{label}[{k + 1}/4]", rec, a, b) for k, (a, b) in enumerate(_split_blocks(rec, 4))]
    else:
        pieces = [(label, rec, 0, len(rec)) for label, rec in train]

    def statistics(items: Sequence[tuple[str, Recording, int, int]], world_cutoff: float | None) -> list[_Segment]:
        out, cache = [], {}
        for label, rec, a, b in items:
            if id(rec) not in cache:  # the blocks of a lone training file share its arrays
                prepared = _prepare(arm, rec, world_cutoff)
                delay = Delay(delay_s=0.0).regressor(arm, rec.q, rec.qd, prepared.qdd_smooth, stamps_s=prepared.stamps_s)
                cache[id(rec)] = prepared, delay
            prepared, delay = cache[id(rec)]
            out.append(_segment(arm, candidates, active, n_cols, prepared, a, b, label, delay))
            steps[0] += 1
            tick(*steps)
        return out

    steps = [0, 2 * (len(pieces) + len(test)) + len(CANDIDATE_NAMES)]
    segments = {"raw": statistics(pieces, None), "filtered": statistics(pieces, cutoff)}
    tests = {
        "raw": statistics([(label, rec, 0, len(rec)) for label, rec in test], None),
        "filtered": statistics([(label, rec, 0, len(rec)) for label, rec in test], cutoff),
    }
    n_train = sum(s.samples for s in segments["raw"])
    duration = sum(s.duration_s for s in segments["raw"])
    n_eff = max(duration / DECORRELATION_S, 1.0)

    def test_rms(model: _Model, theta: np.ndarray) -> np.ndarray:
        sse = sum(s.sse(model.columns(), theta) for s in tests[model.world])
        return np.sqrt(sse / sum(s.samples for s in tests[model.world]))

    current = _Model("raw", ())
    current_cv, _ = _cv_sse(current, segments)
    remaining = list(candidates) + ["acceleration_noise"]
    reports: dict[str, EffectReport] = {}
    rank = 0
    while remaining:
        # AIC in squared-error terms: 2 σ̂² per parameter and effective sample (σ̂² = SSE / n_train),
        # per sample like the gains.
        penalty_per_param = 2.0 * float(current_cv.sum()) / n_eff / n_train
        # The inertial priors weigh against the current residual: σ² per joint-sample, times the
        # samples that make one effective (independent) sample.
        prior_weight = float(current_cv.sum()) / (N * n_train) * (n_train / n_eff)
        options = []
        for cand in remaining:
            if cand == "acceleration_noise":
                if current.world == "filtered":
                    continue
                trial = _Model("filtered", current.members, prior_weight)
                name = "acceleration_noise"
            else:
                if any(m.name == cand.name for m in current.members) or _nested(cand, current):
                    continue
                trial = _Model(current.world, current.members + (cand,), prior_weight)
                name = cand.name
            cv, fits = _cv_sse(trial, segments)
            gain = float(current_cv.sum() - cv.sum()) / n_train  # N·m² per sample
            extra = trial.n_params(segments[trial.world]) - current.n_params(segments[current.world])
            net = gain - penalty_per_param * extra
            joint_gain = (current_cv - cv) / np.maximum(current_cv, 1e-300)
            rms_gain = np.sqrt(current_cv / n_train) - np.sqrt(np.maximum(cv, 0.0) / n_train)
            joint_gain = np.where(rms_gain >= MIN_JOINT_GAIN_NM, joint_gain, 0.0)
            reason = ""
            if cand != "acceleration_noise":
                theta_all = _fit(segments[trial.world], trial)
                reason = _plausibility(cand, trial.split(theta_all)[-1], arm)
            options.append((net, gain, name, cand, trial, cv, fits, joint_gain, reason))
        if not options:
            break
        options.sort(key=lambda o: -o[0])
        chosen = None
        for opt in options:
            net, gain, name, cand, trial, cv, fits, joint_gain, reason = opt
            if reason or net <= 0 or joint_gain.max() < MIN_JOINT_GAIN:
                continue
            chosen = opt
            break
        if chosen is None:
            for opt in options:
                net, gain, name, cand, trial, cv, fits, joint_gain, reason = opt
                if name in reports:
                    continue
                why = reason or (
                    "does not improve the held-out error after the complexity penalty"
                    if net <= 0
                    else f"improves no joint's held-out error by {MIN_JOINT_GAIN:.0%} and {MIN_JOINT_GAIN_NM:g} N·m RMS"
                )
                reports[name] = _unselected_report(arm, cand, name, why, gain, trial, segments, current, test_rms)
            break
        net, gain, name, cand, trial, cv, fits, joint_gain, reason = chosen
        rank += 1
        theta_before = _fit(segments[current.world], current)
        before = test_rms(current, theta_before)
        theta = _fit(segments[trial.world], trial)
        after = test_rms(trial, theta)
        joints = tuple(arm.joint_names[j] for j in np.flatnonzero(joint_gain >= MIN_JOINT_GAIN))
        if cand == "acceleration_noise":
            reports[name] = EffectReport(
                name, f"zero-phase low-pass {cutoff:g} Hz", True, rank,
                f"held-out gain {gain:.4g} N·m² per sample (filtering q̇ before differentiating)", {"cutoff_hz": cutoff}, {}, joints, gain, before, after, None, cutoff,
            )
            remaining.remove("acceleration_noise")
        else:
            reports[name] = EffectReport(
                name, cand.variant, True, rank, f"held-out gain {gain:.4g} N·m² per sample", {}, {}, joints, gain, before, after
            )
            remaining = [r for r in remaining if r == "acceleration_noise" or r.name != cand.name]
        current, current_cv = trial, cv
        steps[0] += 1
        tick(*steps)

    tick(steps[1], steps[1])
    theta_final = _fit(segments[current.world], current)
    _, final_folds = _cv_sse(current, segments)
    for cand, own, folds in zip(current.members, current.split(theta_final), zip(*[current.split(f) for f in final_folds])):
        reports[cand.name] = _with_final_parameters(reports[cand.name], cand, own, np.array(folds))
    final = test_rms(current, theta_final)
    baseline_test = test_rms(_Model("raw", ()), np.zeros(0))
    baseline_train = np.sqrt(sum(s.rr for s in segments["raw"]) / n_train)
    for name in ("acceleration_noise", *dict.fromkeys(c.name for c in candidates)):
        if name not in reports:
            reports[name] = EffectReport(name, "", False, 0, "not tried: nested in a selected effect", {}, {}, (), 0.0, final, final)
    ordered = sorted(reports.values(), key=lambda e: (not e.selected, e.rank if e.selected else -e.cv_gain))
    ranked = tuple(dataclasses.replace(e, rank=i + 1) for i, e in enumerate(ordered))
    gap, gap_filtered, series = _test_gap(arm, test, cutoff, current, theta_final, candidates)
    return DiagnosisResult(
        arm.side, tuple(arm.joint_names), tuple(l for l, _ in train), tuple(l for l, _ in test),
        "leave one training file out" if len(train) > 1 else "four contiguous blocks of the training file",
        cutoff, baseline_train, baseline_test, final, ranked, gap, gap_filtered, series,
    )


def _with_final_parameters(report: EffectReport, cand: _Candidate, own: np.ndarray, folds: np.ndarray) -> EffectReport:
    """The report with the parameters of the final fit on all training data, their jackknife
    standard deviation across the cross-validation folds, and the effect they make."""
    k = len(folds)
    std = np.sqrt((k - 1) / k * np.sum((folds - folds.mean(axis=0)) ** 2, axis=0)) if k > 1 else np.full(len(own), np.nan)
    names = _param_names(cand)
    try:
        effect = cand.build(own)
    except DiagnosisError:  # a fit with no effect form (see the candidate's builder)
        effect = None
    return dataclasses.replace(
        report,
        params={n: float(v) for n, v in zip(names, own)},
        params_std={n: float(v) for n, v in zip(names, std)},
        effect=effect,
    )


def _nested(cand: _Candidate, current: _Model) -> bool:
    """Friction laws contain each other; a payload is part of the inertial change."""
    have = {m.name for m in current.members}
    families = ({"coulomb_friction", "stribeck_friction"}, {"payload", "inertial_error"})
    return any(cand.name in fam and have & (fam - {cand.name}) for fam in families)


def _unselected_report(arm, cand, name, why, gain, trial, segments, current, test_rms) -> EffectReport:
    theta_before = _fit(segments[current.world], current)
    before = test_rms(current, theta_before)
    theta = _fit(segments[trial.world], trial)
    after = test_rms(trial, theta)
    params: dict[str, float] = {}
    variant = ""
    if cand != "acceleration_noise":
        params = {n: float(v) for n, v in zip(_param_names(cand), trial.split(theta)[-1])}
        variant = cand.variant
    return EffectReport(name, variant, False, 0, why, params, {}, (), gain, before, after)


def _test_gap(arm, test, cutoff, model, theta, candidates):
    """Gap summaries of the test data and the residual series before/after the selected effects."""
    raws, filts, finals, times, offset = [], [], [], [], 0.0
    states = []
    for _, rec in test:
        raw = _prepare(arm, rec, None)
        chosen = _prepare(arm, rec, cutoff if model.world == "filtered" else None)
        delay = Delay(delay_s=0.0).regressor(arm, rec.q, rec.qd, raw.qdd_smooth, stamps_s=raw.stamps_s)
        explained = np.zeros_like(rec.q)
        if len(theta):
            phi = np.concatenate([_regressor(arm, candidates, chosen, a, min(len(rec), a + CHUNK), delay)[:, :, model.columns()] for a in range(0, len(rec), CHUNK)])
            explained = phi @ theta
        raws.append(raw.residual)
        filts.append(_prepare(arm, rec, cutoff).residual)
        finals.append(chosen.residual - explained)
        times.append(raw.stamps_s + offset)
        offset = times[-1][-1] + 1.0 / rec.rate_hz
        states.append((rec.q, rec.qd, raw.qdd, raw.qdd_smooth))
    cat = lambda xs: np.concatenate(xs)  # noqa: E731
    q, qd, qdd, qdd_smooth = (cat([s[k] for s in states]) for k in range(4))
    rate = test[0][1].rate_hz
    gap = summarise_gap(arm.joint_names, cat(raws), q, qd, qdd_smooth, rate)
    gap_filtered = summarise_gap(arm.joint_names, cat(filts), q, qd, qdd_smooth, rate)
    series = {"t_s": cat(times), "baseline": cat(raws), "filtered": cat(filts), "final": cat(finals), "q": q}
    return gap, gap_filtered, series
