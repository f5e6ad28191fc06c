"""The diagnosis' data side: candidate effects as regressor columns, and sufficient statistics.

Every candidate effect except ``acceleration_noise`` is linear in its parameters θ for fixed shape
parameters (friction velocity scales, Dahl's presliding angle): its share of the effort is Φ θ with Φ = ``effect.regressor``.
Shape parameters take a few values; each is a *variant* of its effect. All candidates' columns sit
side by side in one layout (:class:`ColumnLayout`); ``payload`` shares link 7's columns of
``inertial_error`` (they are the same regressor, and the two never enter one model).

A recording is reduced to sufficient statistics per contiguous block and joint j:
H_j = Σ Φ_jᵀ Φ_j, b_j = Σ Φ_jᵀ r_j and r_jᵀ r_j, with r the rigid-body residual in the *denoised*
world (q̈ from a zero-phase low-pass on q̇, each joint's cut-off chosen on the training data: joint
j's rows — its residual and every column at j, the inertial ones with all joints' q̈ — are those of
its own cut-off), plus r_jᵀ r_j of
the raw world (the paper's first difference of q̇) for the ``acceleration_noise`` share. Friction's
columns take q̇ through the same low-pass: friction acts on the true speed, and the measured q̇'s
noise flips the sign of a Coulomb column around every reversal, which biases its coefficient towards
zero (errors in variables; on the other unit's 525 Hz data held-out e0 0.524 → 0.331 N·m). Dahl's
friction state, which needs each recording's whole history, is computed once per recording from the
same low-passed q̇ (:attr:`Prepared.dahl_states`). The squared
error of any fit x on any block is then exact: r·r − 2 x·b + xᵀ H x.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.acceleration import first_difference, zero_phase_acceleration, zero_phase_lowpass
from ..core.arm_model import ArmModel
from ..core.effects import (
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
from ..core.joints import JOINTS as N
from ..core.joints import S1
from ..core.recording import Recording

__all__ = [
    "CUTOFF_GRID_HZ",
    "FAMILIES",
    "MAX_CUTOFF_OF_RATE",
    "SPANNED_BY_SPRING",
    "Block",
    "Candidate",
    "ColumnLayout",
    "Pool",
    "Prepared",
    "choose_cutoff",
    "column_layout",
    "cutoff_grid",
    "cutoff_scores",
    "explained",
    "joint_regressors",
    "prepare",
    "recording_blocks",
]

#: Cut-offs (Hz) tried for the denoised world's zero-phase low-pass on q̇.
CUTOFF_GRID_HZ = (1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0)
#: A cut-off is tried only below this fraction of a recording's rate (a margin under Nyquist's 0.5).
MAX_CUTOFF_OF_RATE = 0.45
#: Prior standard deviation of the s1 spring's shape coefficients (linear N·m/rad, cosine, sine N·m)
#: about zero; its preload has none. Two real units' springs have them within ±30 N·m when the
#: recordings span s1 widely; on a narrow span the four terms trade off, and without the prior a
#: fit on one recording reached thousands of N·m and missed the next recording by as much.
SPRING_PRIOR_STD_NM = 50.0
#: The effects whose argument is the low-passed q̇ (:class:`Prepared`).
_FRICTION = (ViscousFriction, CoulombFriction, StribeckFriction)
#: Families of effects that are alternatives of each other, the simpler nested in the richer. A
#: per-joint family has at most one member at a joint; payload and inertial_error may act together:
#: bounded, they are not nested (a gripper of kilograms at the flange is no change of link 7 within
#: 50–150 % of its 0.54 kg, and an error of the arm's own links no load in its hand).
FAMILIES = (frozenset({"payload", "inertial_error"}), frozenset({"coulomb_friction", "stribeck_friction", "dahl_friction"}))
#: Presliding angles θ_p (rad) of dahl_friction's variants.
DAHL_PRESLIDING_RAD = (0.02, 0.05)
#: Per-joint effects the s1 spring spans at s1: its preload is an offset, and its cosine and sine
#: carry the shape of s1's gravity load, which a torque gain scales. With the spring in a model
#: neither acts at s1 (on the other unit's recordings a gain at s1 took the spring's share over one
#: range of s1 and missed a square's range by 2 N·m more).
SPANNED_BY_SPRING = frozenset({"torque_offset", "torque_gain"})
#: Regressor rows evaluated at once (bounds the memory of the statistics pass).
CHUNK = 8192


@dataclass(frozen=True)
class Candidate:
    """One variant of an effect and where its parameters sit among all candidates' columns.

    kind: "joint" — p_joint parameters per joint, each acting on its own joint only (column
    ``columns[k * 7 + j]`` is parameter k at joint j); "linear" — a fixed set of columns (the s1
    spring); "inertial" — inertial parameters of whole links, fitted through the log-Cholesky
    parametrisation (:mod:`baxter_dynamics_ros.core.log_cholesky`), ``links`` the link indices.
    lower: (p,) lower bounds of the linear kinds' parameters; variant: the shape parameter's value
    (None where the effect has one form); prior_std: (p,) standard deviations of
    the zero-mean Gaussian priors of a "linear" kind's parameters (inf: none). alternatives: the
    effects it is an alternative of (:data:`FAMILIES`; a per-joint one's: at most one of them per joint);
    spanned_by_spring: with the s1 spring in a model it does not act at s1 (:data:`SPANNED_BY_SPRING`).
    """

    name: str
    kind: str
    template: Effect
    columns: np.ndarray
    lower: np.ndarray
    variant: str | None = None
    p_joint: int = 0
    links: tuple[int, ...] = ()
    prior_std: np.ndarray = field(default_factory=lambda: np.zeros(0))
    alternatives: frozenset[str] = frozenset()
    spanned_by_spring: bool = False

    @property
    def is_spring(self) -> bool:
        return isinstance(self.template, S1Spring)

    @property
    def is_offset(self) -> bool:
        return isinstance(self.template, TorqueOffset)

    @property
    def is_payload(self) -> bool:
        return isinstance(self.template, Payload)

    @property
    def label(self) -> str:
        return f"{self.name} ({self.variant})" if self.variant else self.name

    def joint_columns(self, joints: Sequence[int]) -> np.ndarray:
        """The columns of the parameters at ``joints`` (kind "joint"), parameter-major."""
        return np.array([self.columns[k * N + j] for k in range(self.p_joint) for j in sorted(joints)], dtype=int)


@dataclass(frozen=True)
class ColumnLayout:
    """Every candidate and the total number of distinct columns."""

    candidates: tuple[Candidate, ...]
    n_columns: int
    #: The distinct column blocks: (template, first column, width); payload has none of its own.
    blocks: tuple[tuple[Effect, int, int], ...]

    def has_spring(self, model) -> bool:
        """Whether the s1 spring is among a model's terms (:class:`~.fit.Model`)."""
        return any(self.candidates[t.candidate].is_spring for t in model.terms)

    def acting_joints(self, model, term) -> tuple[int, ...]:
        """The joints where a term (:class:`~.fit.Term`) of a model acts: its joints, without s1 for
        an effect the s1 spring spans when the spring is in the model (:data:`SPANNED_BY_SPRING`)."""
        if self.candidates[term.candidate].spanned_by_spring and self.has_spring(model):
            return tuple(j for j in term.joints if j != S1)
        return term.joints

    def offset_term(self, model):
        """The model's torque-offset term (:class:`~.fit.Term`), or None."""
        return next((t for t in model.terms if self.candidates[t.candidate].is_offset), None)


def column_layout() -> ColumnLayout:
    """The candidates of the diagnosis, in the order of :data:`~baxter_dynamics_ros.core.effects.EFFECTS`."""
    specs: list[tuple[str, str | None, str, Effect, int]] = [
        ("torque_offset", None, "joint", TorqueOffset(offset_nm=0.0), 1),
        ("viscous_friction", None, "joint", ViscousFriction(damping_nm_s_rad=0.0), 1),
    ]
    for eps in (0.01, 0.05):
        specs.append(("coulomb_friction", f"smoothing {eps:g} rad/s", "joint", CoulombFriction(friction_nm=0.0, smoothing_rad_s=eps), 1))
    for vs in (0.02, 0.05, 0.1, 0.2):
        specs.append(("stribeck_friction", f"v_s {vs:g} rad/s", "joint", StribeckFriction(coulomb_nm=0.0, static_nm=0.0, stribeck_rad_s=vs), 2))
    for angle in DAHL_PRESLIDING_RAD:
        specs.append(("dahl_friction", f"presliding {angle:g} rad", "joint", DahlFriction(friction_nm=0.0, presliding_rad=angle), 1))
    specs.append(("s1_spring", None, "linear", S1Spring(), 4))
    specs.append(("inertial_error", None, "inertial", InertialError(), 70))
    specs.append(("armature", None, "joint", Armature(inertia_kgm2=0.0), 1))
    specs.append(("delay", None, "joint", Delay(delay_s=0.0), 1))
    specs.append(("torque_gain", None, "joint", TorqueGain(gain=0.0), 1))
    candidates, blocks, start = [], [], 0
    inertial_start = 0
    for name, variant, kind, template, p in specs:
        width = p * N if kind == "joint" else p
        columns = np.arange(start, start + width)
        # Each parameter's bound is its effect's own (armature, friction ≥ 0; a gain > −1: a sensor
        # that reads nothing, or the opposite, has no gain error); an inertial change's are free.
        lower = template.parameter_lower_bounds()
        if kind == "inertial":
            inertial_start = start
            candidates.append(Candidate(name, kind, template, columns, lower, variant=variant, links=tuple(range(N))))
        else:
            prior = np.array((np.inf,) + (SPRING_PRIOR_STD_NM,) * (p - 1)) if kind == "linear" else np.zeros(0)
            candidates.append(Candidate(name, kind, template, columns, lower, variant=variant, p_joint=p if kind == "joint" else 0, prior_std=prior))
        blocks.append((template, start, width))
        start += width
    # The payload: a change of link 7's inertial parameters, the last 10 of inertial_error's columns.
    template = Payload(mass_kg=1.0)
    payload = Candidate("payload", "inertial", template, np.arange(inertial_start + 60, inertial_start + 70), template.parameter_lower_bounds(), links=(N - 1,))
    index = [c.name for c in candidates].index("inertial_error")
    candidates.insert(index, payload)
    related = [
        replace(c, alternatives=frozenset().union(*(f - {c.name} for f in FAMILIES if c.name in f)), spanned_by_spring=c.name in SPANNED_BY_SPRING)
        for c in candidates
    ]
    return ColumnLayout(tuple(related), start, tuple(blocks))


# ----------------------------------------------------------------------------- one recording
@dataclass(frozen=True, kw_only=True)
class Prepared:
    """A recording's arrays in the denoised world, joint j's at its own cut-off ``cutoffs_hz[j]``:
    per distinct cut-off c, the low-passed q̇ (friction's argument) and q̈ of every joint; rigid
    torques and residuals, delay columns (−dτ_rigid/dt with the same q̈, so that a fitted delay
    means what :class:`Delay` says), column j at c_j."""

    q: np.ndarray  # (n, 7) rad
    qd: np.ndarray  # (n, 7) rad/s, as measured
    cutoffs_hz: tuple[float, ...]  # (7,) each joint's cut-off, Hz
    qd_lowpassed: dict[float, np.ndarray]  # cut-off -> (n, 7) rad/s, zero-phase low-passed there
    qdd: dict[float, np.ndarray]  # cut-off -> (n, 7) rad/s², its derivative
    rigid_torque: np.ndarray  # (n, 7) N·m, τ_rigid with the filtered q̈ (the torque gain's columns)
    residual: np.ndarray  # (n, 7) N·m, effort − τ_rigid with the filtered q̈
    residual_raw: np.ndarray  # (n, 7) N·m, effort − τ_rigid with the first difference of q̇
    delay_columns: np.ndarray  # (n, 7) −dτ_rigid/dt, N·m/s
    stamps_s: np.ndarray  # (n,) s
    dahl_states: dict[float, np.ndarray]  # presliding angle -> (n, 7) Dahl's friction state of the low-passed q̇

    def joints_by_cutoff(self) -> list[tuple[float, np.ndarray]]:
        """(cut-off, the joints at it) per distinct cut-off, ascending."""
        return _joints_by_cutoff(self.cutoffs_hz)


def _joints_by_cutoff(cutoffs_hz: Sequence[float]) -> list[tuple[float, np.ndarray]]:
    """(cut-off, the joints at it) per distinct cut-off of cutoffs_hz (7,), ascending."""
    c = np.asarray(cutoffs_hz, dtype=float)
    return [(float(v), np.flatnonzero(c == v)) for v in sorted(set(c.tolist()))]


def prepare(arm: ArmModel, rec: Recording, cutoffs_hz: Sequence[float]) -> Prepared:
    """The arrays of ``rec`` with q̇ low-passed before differentiating, joint j's at cutoffs_hz[j] (7,)."""
    stamps = rec.stamps_s
    cutoffs = tuple(float(c) for c in cutoffs_hz)
    qd_lowpassed, qdd = {}, {}
    tau = np.empty_like(rec.q)
    friction_qd = np.empty_like(rec.qd)  # each joint's q̇ low-passed at its own cut-off
    for c, joints in _joints_by_cutoff(cutoffs):
        qd_lowpassed[c] = zero_phase_lowpass(rec.qd, rec.rate_hz, c, segments=rec.segments)
        qdd[c] = zero_phase_acceleration(qd_lowpassed[c], rec.rate_hz, None, segments=rec.segments)
        tau[:, joints] = arm.inverse_dynamics(rec.q, rec.qd, qdd[c])[:, joints]
        friction_qd[:, joints] = qd_lowpassed[c][:, joints]
    residual = rec.effort - tau
    delay_columns = np.gradient(tau, stamps, axis=0)
    np.negative(delay_columns, out=delay_columns)
    residual_raw = rec.effort - arm.inverse_dynamics(rec.q, rec.qd, first_difference(rec.qd, stamps))
    # Dahl's state from z = 0 in each piece: across a gap the motion, and so the state, is unknown.
    dahl_states = {a: np.zeros_like(friction_qd) for a in DAHL_PRESLIDING_RAD}
    for lo, hi in rec.segments:
        if hi - lo > 1:
            for a, z in dahl_states.items():
                z[lo:hi] = DahlFriction(friction_nm=0.0, presliding_rad=a).state(friction_qd[lo:hi], stamps[lo:hi])
    return Prepared(
        q=rec.q, qd=rec.qd, cutoffs_hz=cutoffs, qd_lowpassed=qd_lowpassed, qdd=qdd, rigid_torque=tau, residual=residual,
        residual_raw=residual_raw, delay_columns=delay_columns, stamps_s=stamps, dahl_states=dahl_states,
    )  # fmt: skip


def _block_parts(arm: ArmModel, template: Effect, width: int, p: Prepared, lo: int, hi: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """One column block of the layout on samples lo:hi (denoised world), as (joints, (hi − lo, 7, width))
    pairs: the block's rows at those joints are the array's there; the joints of all pairs are the 7."""
    if isinstance(template, (Delay, TorqueGain, DahlFriction)):
        out = np.zeros((hi - lo, N, width))
        idx = np.arange(N)
        if isinstance(template, DahlFriction):
            columns = p.dahl_states[template.presliding_rad]
        else:
            columns = p.delay_columns if isinstance(template, Delay) else p.rigid_torque
        out[:, idx, idx] = columns[lo:hi]
        return [(idx, out)]
    parts = []
    for c, joints in p.joints_by_cutoff():
        qd = p.qd_lowpassed[c] if isinstance(template, _FRICTION) else p.qd
        parts.append((joints, template.regressor(arm, p.q[lo:hi], qd[lo:hi], p.qdd[c][lo:hi])))
    return parts


def _block_regressor(arm: ArmModel, template: Effect, width: int, p: Prepared, lo: int, hi: int) -> np.ndarray:
    """(hi − lo, 7, width) one column block of the layout on samples lo:hi (denoised world)."""
    parts = _block_parts(arm, template, width, p, lo, hi)
    if len(parts) == 1:
        return parts[0][1]
    out = np.empty_like(parts[0][1])
    for joints, phi in parts:
        out[:, joints] = phi[:, joints]
    return out


def regressor(arm: ArmModel, layout: ColumnLayout, p: Prepared, lo: int, hi: int) -> np.ndarray:
    """(hi − lo, 7, P) every distinct column on samples lo:hi (denoised world)."""
    out = np.zeros((hi - lo, N, layout.n_columns))
    for template, start, width in layout.blocks:
        out[:, :, start : start + width] = _block_regressor(arm, template, width, p, lo, hi)
    return out


def joint_regressors(arm: ArmModel, layout: ColumnLayout, active: list[np.ndarray], p: Prepared, lo: int, hi: int) -> list[np.ndarray]:
    """Per joint j, (hi − lo, len(active[j])) its active columns on samples lo:hi: the rows of
    :func:`regressor` at joint j, without the columns that are zero there (the statistics pass)."""
    out = [np.empty((hi - lo, len(columns))) for columns in active]
    for template, start, width in layout.blocks:
        for joints, phi in _block_parts(arm, template, width, p, lo, hi):
            for j in joints:
                columns = active[j]
                a, b = np.searchsorted(columns, (start, start + width))
                if b > a:
                    out[j][:, a:b] = phi[:, j, columns[a:b] - start]
    return out


def explained(arm: ArmModel, layout: ColumnLayout, p: Prepared, columns: np.ndarray, x: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """(hi − lo, 7) N·m, the effects of parameters x at the layout's distinct ``columns`` on samples
    lo:hi: ``regressor(...)[:, :, columns] @ x``, evaluating only the column blocks that hold them."""
    order = np.argsort(columns, kind="stable")
    columns, x = columns[order], x[order]
    out = np.zeros((hi - lo, N))
    for template, start, width in layout.blocks:
        a, b = np.searchsorted(columns, (start, start + width))
        if b > a:
            out += _block_regressor(arm, template, width, p, lo, hi)[:, :, columns[a:b] - start] @ x[a:b]
    return out


def active_columns(arm: ArmModel, layout: ColumnLayout) -> list[np.ndarray]:
    """Per joint, the columns that can be non-zero on it (probed on random states)."""
    rng = np.random.default_rng(0)
    q = rng.uniform(arm.lower_rad, arm.upper_rad, (32, N))
    qd, qdd = rng.uniform(-1, 1, (2, 32, N))
    ones = np.ones((32, N))
    probe = Prepared(
        q=q, qd=qd, cutoffs_hz=(1.0,) * N, qd_lowpassed={1.0: qd}, qdd={1.0: qdd}, rigid_torque=ones, residual=qdd,
        residual_raw=qdd, delay_columns=ones, stamps_s=np.arange(32) * 0.01, dahl_states=dict.fromkeys(DAHL_PRESLIDING_RAD, ones),
    )  # fmt: skip
    phi = regressor(arm, layout, probe, 0, 32)
    return [np.flatnonzero(np.any(phi[:, j, :] != 0.0, axis=0)) for j in range(N)]


@dataclass(frozen=True)
class Block:
    """Sufficient statistics of one contiguous block of one recording, per joint."""

    recording: str
    index: int
    samples: int
    duration_s: float
    H: np.ndarray  # (7, P, P)
    b: np.ndarray  # (7, P)
    rr: np.ndarray  # (7,) denoised world
    rr_raw: np.ndarray  # (7,) raw world


def recording_blocks(
    arm: ArmModel, layout: ColumnLayout, active: list[np.ndarray], label: str, p: Prepared, parts: int
) -> list[Block]:
    """The statistics of ``parts`` contiguous blocks of one prepared recording."""
    n = len(p.q)
    edges = np.linspace(0, n, parts + 1).astype(int)
    out = []
    P = layout.n_columns
    for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        H = np.zeros((N, P, P))
        b = np.zeros((N, P))
        for start in range(lo, hi, CHUNK):
            stop = min(hi, start + CHUNK)
            r = p.residual[start:stop]
            for j, x in enumerate(joint_regressors(arm, layout, active, p, start, stop)):
                idx = active[j]
                H[j][np.ix_(idx, idx)] += x.T @ x
                b[j, idx] += x.T @ r[:, j]
        rr = np.sum(p.residual[lo:hi] ** 2, axis=0)
        rr_raw = np.sum(p.residual_raw[lo:hi] ** 2, axis=0)
        duration = float(p.stamps_s[hi - 1] - p.stamps_s[lo]) if hi - lo > 1 else 0.0
        out.append(Block(label, k, int(hi - lo), duration, H, b, rr, rr_raw))
    return out


def cutoff_grid(rate_hz: float) -> tuple[float, ...]:
    """The cut-offs of :data:`CUTOFF_GRID_HZ` that a recording at rate_hz (Hz) can be filtered at:
    those below :data:`MAX_CUTOFF_OF_RATE` · rate_hz (none below 3.3 Hz)."""
    return tuple(c for c in CUTOFF_GRID_HZ if c < MAX_CUTOFF_OF_RATE * rate_hz)


def cutoff_scores(arm: ArmModel, rec: Recording) -> np.ndarray:
    """One training recording's part of the cut-off choice: (k, 7) per joint the squared rigid
    residual with q̇ low-passed at each of the k cut-offs of :func:`cutoff_grid` at its rate, less
    the part that torque no filter can change explains: the recording's own offset at every joint,
    and at s1 the s1 spring's torque (its columns 1, q, cos q, sin q of q_s1), least squares.

    Without that, s1's choice followed the spring: its tens of N·m, correlated with the motion, made
    the residual dip wherever the filter cut the motion's own acceleration, lowest at the grid's
    floor (with a floor of 0.75 Hz one real rotation took 1 Hz at s1 and its held-out s1 went
    0.79 → 3.25 N·m); with it the choice does not move when the grid is widened to 0.75–24 Hz.
    """
    offset = np.ones((len(rec), 1))
    spring = S1Spring().regressor(arm, rec.q, rec.qd, rec.qd)[:, S1, :]  # the candidate's own columns
    sse = []
    for cutoff in cutoff_grid(rec.rate_hz):
        qdd = zero_phase_acceleration(rec.qd, rec.rate_hz, cutoff, segments=rec.segments)
        residual = rec.effort - arm.inverse_dynamics(rec.q, rec.qd, qdd)
        left = np.empty(N)
        for joint in range(N):
            basis = spring if joint == S1 else offset
            coef, *_ = np.linalg.lstsq(basis, residual[:, joint], rcond=None)
            left[joint] = np.sum((residual[:, joint] - basis @ coef) ** 2)
        sse.append(left)
    return np.array(sse).reshape(-1, N)


def choose_cutoff(scores: Sequence[np.ndarray], lowest_rate_hz: float) -> tuple[float, ...]:
    """(7,) Hz, per joint the cut-off whose denoised rigid residual there is smallest on the training
    data, from each training recording's :func:`cutoff_scores` (added in the recordings' order; the
    lower cut-off on a tie); only the cut-offs of :func:`cutoff_grid` at lowest_rate_hz, the lowest
    rate of every recording, training and test, are tried (every recording is filtered at them).

    Per joint, because what q̈'s noise costs differs by joint: every joint's noise enters joint j's
    torque through row j of M(q), heaviest at the shoulder, while the motion's own acceleration,
    which a low cut-off smooths away, is fastest at the wrist (on the real recordings the shoulder's
    choices are 4 or 6 Hz, w0's 8 or 12 Hz; one cut-off for all had to trade one joint against another).
    """
    sse = np.zeros((min(len(cutoff_grid(lowest_rate_hz)), *(len(s) for s in scores)), N))
    for s in scores:
        sse += s[: len(sse)]
    return tuple(CUTOFF_GRID_HZ[k] for k in np.argmin(sse, axis=0))


# ----------------------------------------------------------------------------- pools of blocks
class Pool:
    """Blocks with a grouping for cross-validation (leave one group out), and their sums.

    groups: lists of block indices; every block in exactly one group.
    """

    def __init__(self, blocks: Sequence[Block], groups: Sequence[Sequence[int]]) -> None:
        self.blocks = tuple(blocks)
        self.groups = tuple(tuple(g) for g in groups)
        if sorted(i for g in self.groups for i in g) != list(range(len(self.blocks))):
            raise ValueError("every block must be in exactly one group")

        def total(indices, attr):
            return sum(getattr(self.blocks[i], attr) for i in indices)

        self.group_H = [total(g, "H") for g in self.groups]
        self.group_b = [total(g, "b") for g in self.groups]
        self.group_rr = [total(g, "rr") for g in self.groups]
        self.group_rr_raw = [total(g, "rr_raw") for g in self.groups]
        self.group_samples = [sum(self.blocks[i].samples for i in g) for g in self.groups]
        self.H = sum(self.group_H)
        self.b = sum(self.group_b)
        self.rr = sum(self.group_rr)
        self.rr_raw = sum(self.group_rr_raw)
        self.samples = sum(self.group_samples)
        self.duration_s = sum(b.duration_s for b in self.blocks)
        self._recording_sums: dict[tuple[str, int | None], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    @property
    def recordings(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(b.recording for b in self.blocks))

    def recordings_without(self, g: int | None) -> tuple[str, ...]:
        """The recordings with blocks outside group g (all of them for g None)."""
        out = set() if g is None else set(self.groups[g])
        return tuple(dict.fromkeys(b.recording for i, b in enumerate(self.blocks) if i not in out))

    def recording_sums(self, g: int | None) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(H, b, rr) of each recording (``recordings_without(g)`` order) over its blocks outside group g."""
        out = set() if g is None else set(self.groups[g])
        sums = []
        for name in self.recordings_without(g):
            own = [i for i, b in enumerate(self.blocks) if b.recording == name]
            idx = [i for i in own if i not in out]
            key = (name, None if len(idx) == len(own) else g)  # untouched by group g: its whole sums, made once
            if key not in self._recording_sums:
                self._recording_sums[key] = tuple(sum(getattr(self.blocks[i], a) for i in idx) for a in ("H", "b", "rr"))
            sums.append(self._recording_sums[key])
        return sums

    def without_group(self, g: int) -> tuple[np.ndarray, np.ndarray, int]:
        """(H, b, samples) of every group but g."""
        return self.H - self.group_H[g], self.b - self.group_b[g], self.samples - self.group_samples[g]

    def fold_blocks(self) -> list[list[Block]]:
        """Per group g, the training data of the fold without it, for ``Pool.of``: the blocks of
        every other group, each recording's summed into one when two recordings or more remain (that
        pool groups by recording, and only the groups' and recordings' sums enter it: the same sums,
        a quarter of the size to send to a worker; the sums are made once and shared by the folds)."""
        merged: dict[str, Block] = {}
        for name in self.recordings:
            own = [b for b in self.blocks if b.recording == name]
            merged[name] = Block(name, 0, *(sum(getattr(b, a) for b in own) for a in ("samples", "duration_s", "H", "b", "rr", "rr_raw")))
        folds = []
        for g in range(len(self.groups)):
            blocks = [self.blocks[i] for k, grp in enumerate(self.groups) if k != g for i in grp]
            names = list(dict.fromkeys(b.recording for b in blocks))
            folds.append([merged[name] for name in names] if len(names) > 1 else blocks)
        return folds

    @classmethod
    def of(cls, blocks: Sequence[Block]) -> Pool:
        """Blocks grouped by recording (by block if they are of one recording): :func:`default_groups`."""
        return cls(blocks, default_groups(blocks))


def default_groups(blocks: Sequence[Block]) -> list[list[int]]:
    """Leave one recording out with two or more recordings; with one, leave one block out."""
    names = list(dict.fromkeys(b.recording for b in blocks))
    if len(names) > 1:
        return [[i for i, b in enumerate(blocks) if b.recording == name] for name in names]
    return [[i] for i in range(len(blocks))]
