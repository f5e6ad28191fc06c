"""A plain reference diagnosis, the yardstick of ``diagnose`` (issue 20 §1): never worse than this.

Independent of the package's fitting code on purpose: it reads recordings with the package's readers
(:mod:`msg_adapters.csv_io`, elsewhere) and takes the arm from Rethink's URDF through Pinocchio,
and everything else is written here, plainly:

- **Denoised rigid residual.** q̇ is low-passed by a 4th-order Butterworth filter run forwards and
  backwards (``scipy.signal.filtfilt``, zero phase) at ``CUTOFF_HZ`` (4 Hz); q̈ is the central
  difference (``np.gradient``) of the filtered q̇. Every regressor uses the filtered q̇ and this q̈.
  The residual is r = effort − τ_rigid(q, q̇_f, q̈_f) with τ_rigid = Y(q, q̇_f, q̈_f)·π_URDF,
  Y from ``pin.computeJointTorqueRegressor`` on the URDF's left or right arm (the other joints
  locked at 0; the joint angles go in as recorded: the URDF holds DH θ2 = q_s1 + π/2 itself).
- **Candidates, all linear least squares on r** (columns of one regressor, :data:`COLUMNS`):
  ``torque_offset`` (per recording and joint; on a held-out recording the training recordings'
  mean, as ``diagnose`` writes out their mean), ``viscous_friction`` q̇_j, ``coulomb_friction``
  sign(q̇_j), ``stribeck_friction`` sign(q̇_j) and sign(q̇_j)·exp(−(q̇_j/v_s)²) for v_s in
  :data:`STRIBECK_RAD_S` (one candidate each), ``s1_spring`` [1, q_s1, cos q_s1, sin q_s1] at s1,
  ``payload`` (the 10 inertial columns of the last link), ``inertial_error`` (all 70),
  ``armature`` q̈_j, ``delay`` −dτ_rigid,j/dt (first order in the delay: τ(t − d) ≈ τ − d·τ̇),
  ``torque_gain`` τ_rigid,j. ``acceleration_noise`` is not a linear effect (it is the filtering
  itself, which this fit always applies) and is omitted.
- **Selection.** Greedy forward: every step tries each per-joint candidate at each joint and each
  arm-wide one (``s1_spring``, ``payload``, ``inertial_error``) and takes the move with the lowest
  leave-one-recording-out (LORO) score S = Σ_j log MSE_j (the profile Gaussian likelihood with a
  noise level per joint, so that a joint's share does not depend on its scale); a move is taken
  only if it cuts S by at least −log 0.95, i.e. a per-joint effect must cut its joint's LORO mean
  squared error by ≥ 5 %. Joints are weighted 1/MSE_j of the current model (arm-wide columns are
  shared by all joints). Between nested alternatives (``coulomb_friction`` ⊂ ``stribeck_friction``,
  ``payload`` ⊂ ``inertial_error``) the larger is taken only when it beats the smaller by that 5 %
  too. Then the selected model is fitted on all training recordings.

Everything is computed from sufficient statistics per recording and joint (H = ΦᵀΦ, g = Φᵀr, r·r,
column sums, Σr, n), so a fit on any subset of recordings and columns is a small solve.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin
from scipy.signal import butter, filtfilt
from threadpoolctl import threadpool_limits

__all__ = [
    "COLUMNS",
    "CUTOFF_HZ",
    "DEFAULT_URDF",
    "JOINT_EFFECTS",
    "PlainResult",
    "RecordingStats",
    "UrdfArm",
    "denoise",
    "plain_diagnosis",
    "recording_stats",
    "select",
]

N = 7
JOINT_SUFFIXES = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
DEFAULT_URDF = Path(__file__).resolve().parents[1].parent / "shared" / "reference" / "baxter.urdf"
#: Low-pass cut-off on q̇ before differentiating, Hz (the effort's noise floor lies above 5 Hz).
CUTOFF_HZ = 4.0
#: Butterworth order of the q̇ low-pass (run twice: zero phase, order doubled in effect).
FILTER_ORDER = 4
#: Stribeck velocities tried, rad/s (one candidate each).
STRIBECK_RAD_S = (0.02, 0.05, 0.1, 0.2)
#: A move must cut Σ_j log(LORO MSE_j) by at least this much: a 5 % cut at one joint.
MIN_GAIN = -math.log(0.95)
#: Relative eigenvalue of the unit-scaled normal equations (singular value 1e-3 of the largest) below
#: which a direction is left at zero: truncated SVD, so that near-collinear columns (the spring basis
#: over a narrow s1 span) do not extrapolate by thousands of N·m to another recording.
RCOND = 1e-6


def _column_layout() -> dict[str, np.ndarray]:
    """Named blocks of the regressor's columns; per-joint blocks are (7,) arrays of column indices."""
    layout: dict[str, np.ndarray] = {}
    start = 0

    def block(name: str, width: int) -> None:
        nonlocal start
        layout[name] = np.arange(start, start + width)
        start += width

    block("inertial", 10 * N)
    block("viscous", N)
    block("sign", N)
    for vs in STRIBECK_RAD_S:
        block(f"stribeck_{vs:g}", N)
    block("spring", 4)
    block("armature", N)
    block("delay", N)
    block("gain", N)
    layout["_width"] = np.array([start])
    return layout


COLUMNS = _column_layout()
P = int(COLUMNS["_width"][0])

#: Per-joint candidates: name → the column blocks they use at joint j (torque_offset is separate).
JOINT_EFFECTS: dict[str, tuple[str, ...]] = {
    "viscous_friction": ("viscous",),
    "coulomb_friction": ("sign",),
    **{f"stribeck_friction(v_s={vs:g})": ("sign", f"stribeck_{vs:g}") for vs in STRIBECK_RAD_S},
    "armature": ("armature",),
    "delay": ("delay",),
    "torque_gain": ("gain",),
}
#: Arm-wide candidates: name → their columns.
ARM_EFFECTS: dict[str, np.ndarray] = {
    "s1_spring": COLUMNS["spring"],
    "payload": COLUMNS["inertial"][60:70],
    "inertial_error": COLUMNS["inertial"],
}


# ----------------------------------------------------------------------------- the arm from the URDF
def _unique_frame_names(xml: str) -> str:
    """The URDF text with each fixed joint that shares its name with a link renamed ``<name>_joint``
    (baxter.urdf has a joint and a link both called ``left_hand``, which Pinocchio's model reduction
    refuses as ambiguous frames). Nothing else changes."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(xml)
    links = {link.get("name") for link in root.iter("link")}
    for joint in root.iter("joint"):
        if joint.get("type") == "fixed" and joint.get("name") in links:
            joint.set("name", joint.get("name") + "_joint")
    return ET.tostring(root, encoding="unicode")


@dataclass(frozen=True)
class UrdfArm:
    """One Baxter arm as a Pinocchio model reduced to its 7 joints (the rest locked at 0).

    model: 7 revolute joints in the order s0 … w2; pi: (70,) the URDF's inertial parameters in
    Pinocchio's order per joint (m, m·c, I about the joint frame's origin: xx, xy, yy, xz, yz, zz).
    """

    model: pin.Model
    data: pin.Data
    pi: np.ndarray

    @classmethod
    def from_urdf(cls, side: str = "left", urdf: str | Path = DEFAULT_URDF) -> UrdfArm:
        """The ``side`` arm of ``urdf`` (Rethink's baxter.urdf); gravity −9.81 m/s² along the base z."""
        full = pin.buildModelFromXML(_unique_frame_names(Path(urdf).read_text()))
        keep = [f"{side}_{j}" for j in JOINT_SUFFIXES]
        missing = [name for name in keep if not full.existJointName(name)]
        if missing:
            raise ValueError(f"{urdf}: has no joints {missing}; expected Rethink's baxter.urdf")
        lock = [full.getJointId(full.names[i]) for i in range(1, full.njoints) if full.names[i] not in keep]
        model = pin.buildReducedModel(full, lock, pin.neutral(full))
        if list(model.names[1:]) != keep:
            raise ValueError(f"{urdf}: reduced model's joints {list(model.names[1:])}, expected {keep}")
        pi = np.concatenate([model.inertias[i].toDynamicParameters() for i in range(1, model.njoints)])
        return cls(model, model.createData(), pi)

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """(n, 7, 70) joint-torque regressor Y with τ = Y·π; q, qd, qdd (n, 7) in rad, rad/s, rad/s²."""
        out = np.empty((len(q), N, 10 * N))
        for k in range(len(q)):
            out[k] = pin.computeJointTorqueRegressor(self.model, self.data, q[k], qd[k], qdd[k])
        return out

    def torque(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """(n, 7) rigid-body torque, N·m, by RNEA (a check of the regressor: equals Y·π)."""
        return np.array([pin.rnea(self.model, self.data, q[k], qd[k], qdd[k]) for k in range(len(q))])


def denoise(qd: np.ndarray, rate_hz: float, cutoff_hz: float = CUTOFF_HZ) -> tuple[np.ndarray, np.ndarray]:
    """(q̇_f, q̈_f), each (n, 7): q̇ (n, 7) rad/s low-passed at cutoff_hz, zero phase, and its central difference, rad/s²."""
    if not 0.0 < cutoff_hz < 0.5 * rate_hz:
        raise ValueError(f"a low-pass cut-off of {cutoff_hz:g} Hz needs a sample rate above {2 * cutoff_hz:g} Hz, not {rate_hz:g}")
    b, a = butter(FILTER_ORDER, cutoff_hz / (0.5 * rate_hz))
    qd_f = filtfilt(b, a, qd, axis=0)
    return qd_f, np.gradient(qd_f, 1.0 / rate_hz, axis=0)


# ----------------------------------------------------------------------------- sufficient statistics
@dataclass(frozen=True)
class RecordingStats:
    """One recording reduced per joint j: H (7, P, P) = Σ Φ_jᵀΦ_j, g (7, P) = Σ Φ_jᵀ r_j,
    rr (7,) = Σ r_j² in N·m², s (7, P) = Σ Φ_j (column sums), rs (7,) = Σ r_j, n samples."""

    name: str
    n: int
    H: np.ndarray
    g: np.ndarray
    rr: np.ndarray
    s: np.ndarray
    rs: np.ndarray

    @cached_property
    def centred(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(H, g, rr) with a free offset per joint profiled out (each column and r minus its mean)."""
        H = self.H - np.einsum("jp,jq->jpq", self.s, self.s) / self.n
        return H, self.g - self.s * (self.rs / self.n)[:, None], self.rr - self.rs**2 / self.n


def regressor_rows(Y: np.ndarray, tau: np.ndarray, tau_dot: np.ndarray, q: np.ndarray, qd_f: np.ndarray, qdd_f: np.ndarray) -> np.ndarray:
    """Φ (n, 7, P) in the layout :data:`COLUMNS` for n samples: Y (n, 7, 70) the inertial regressor,
    τ_rigid and its time derivative (n, 7) N·m and N·m/s, q, q̇_f, q̈_f (n, 7) rad, rad/s, rad/s²."""
    n = len(q)
    phi = np.zeros((n, N, P))
    phi[:, :, COLUMNS["inertial"]] = Y
    j = np.arange(N)
    sign = np.sign(qd_f)
    phi[:, j, COLUMNS["viscous"]] = qd_f
    phi[:, j, COLUMNS["sign"]] = sign
    for vs in STRIBECK_RAD_S:
        phi[:, j, COLUMNS[f"stribeck_{vs:g}"]] = sign * np.exp(-((qd_f / vs) ** 2))
    s1 = q[:, 1]
    phi[:, 1, COLUMNS["spring"]] = np.column_stack([np.ones(n), s1, np.cos(s1), np.sin(s1)])
    phi[:, j, COLUMNS["armature"]] = qdd_f
    phi[:, j, COLUMNS["delay"]] = -tau_dot
    phi[:, j, COLUMNS["gain"]] = tau
    return phi


def recording_stats(
    arm: UrdfArm, name: str, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, rate_hz: float,
    *, cutoff_hz: float = CUTOFF_HZ, chunk: int = 2048,
) -> RecordingStats:
    """Sufficient statistics of one recording: q (n, 7) rad, qd (n, 7) rad/s, effort (n, 7) N·m at rate_hz."""
    q, qd, effort = (np.asarray(x, dtype=float) for x in (q, qd, effort))
    qd_f, qdd_f = denoise(qd, rate_hz, cutoff_hz)
    Y = arm.regressor(q, qd_f, qdd_f)
    tau = Y @ arm.pi
    tau_dot = np.gradient(tau, 1.0 / rate_hz, axis=0)
    r = effort - tau
    H, g, s = np.zeros((N, P, P)), np.zeros((N, P)), np.zeros((N, P))
    for lo in range(0, len(q), chunk):
        sl = slice(lo, lo + chunk)
        phi = regressor_rows(Y[sl], tau[sl], tau_dot[sl], q[sl], qd_f[sl], qdd_f[sl])
        H += np.einsum("njp,njq->jpq", phi, phi)
        g += np.einsum("njp,nj->jp", phi, r[sl])
        s += phi.sum(axis=0)
    return RecordingStats(name, len(q), H, g, np.sum(r**2, axis=0), s, r.sum(axis=0))


# ----------------------------------------------------------------------------- fits
@dataclass(frozen=True)
class Model:
    """A candidate model: columns (sorted indices into the layout) and the joints with per-recording offsets."""

    columns: tuple[int, ...] = ()
    offsets: tuple[int, ...] = ()
    effects: tuple[str, ...] = ()  # what was added, in order: "name" or "name@joint"


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Minimum-norm solution of the symmetric normal equations A x = b (columns scaled to unit diagonal)."""
    if len(b) == 0:
        return b.copy()
    d = np.sqrt(np.clip(np.diag(A), 0.0, None))
    d[d == 0] = 1.0
    As = A / d[:, None] / d[None, :]
    w, V = np.linalg.eigh(As)
    keep = w > RCOND * max(w.max(), 1e-300)
    z = V[:, keep] @ ((V[:, keep].T @ (b / d)) / w[keep])
    return z / d


@dataclass(frozen=True)
class Fit:
    """θ on a model's columns and each training recording's offsets (7,), N·m (0 where none)."""

    theta: np.ndarray
    offsets: dict[str, np.ndarray]

    def test_offset(self) -> np.ndarray:
        """(7,) offsets applied to a recording not trained on: the training recordings' mean, N·m."""
        return np.mean(list(self.offsets.values()), axis=0)


def fit(train: Sequence[RecordingStats], model: Model, weights: np.ndarray) -> Fit:
    """Weighted least squares of ``model`` on the training recordings (joint j's rows weighted weights[j])."""
    c = np.array(model.columns, dtype=int)
    off = np.zeros(N, dtype=bool)
    off[list(model.offsets)] = True
    A, b = np.zeros((len(c), len(c))), np.zeros(len(c))
    cc = np.ix_(np.arange(N), c, c)
    for rec in train:
        Hc, gc, _ = rec.centred
        H = np.where(off[:, None, None], Hc[cc], rec.H[cc])
        g = np.where(off[:, None], gc[:, c], rec.g[:, c])
        A += np.einsum("j,jpq->pq", weights, H)
        b += weights @ g
    theta = _solve(A, b)
    offsets = {rec.name: np.where(off, (rec.rs - rec.s[:, c] @ theta) / rec.n, 0.0) for rec in train}
    return Fit(theta, offsets)


def sse(rec: RecordingStats, model: Model, result: Fit, offset: np.ndarray) -> np.ndarray:
    """(7,) Σ of squared residual of ``rec`` after the fit, offsets (7,) N·m applied, N·m²."""
    c = np.array(model.columns, dtype=int)
    th = result.theta
    Hcc = rec.H[np.ix_(np.arange(N), c, c)]
    pred_r = rec.g[:, c] @ th
    quad = np.einsum("p,jpq,q->j", th, Hcc, th)
    lin = rec.s[:, c] @ th
    return rec.rr - 2 * pred_r + quad - 2 * offset * (rec.rs - lin) + rec.n * offset**2


def loro_mse(train: Sequence[RecordingStats], model: Model, weights: np.ndarray) -> np.ndarray:
    """(7,) leave-one-recording-out mean squared error per joint, N·m² (every training recording held out once)."""
    total, count = np.zeros(N), 0
    for k, held in enumerate(train):
        rest = [r for i, r in enumerate(train) if i != k]
        result = fit(rest, model, weights)
        total += sse(held, model, result, result.test_offset())
        count += held.n
    return np.maximum(total / count, 1e-12)


def _moves(model: Model) -> list[tuple[str, Model]]:
    """Every model one candidate away from ``model`` (those that add something)."""
    out: list[tuple[str, Model]] = []
    have = set(model.columns)
    for name, cols in ARM_EFFECTS.items():
        new = have | set(cols.tolist())
        if new != have:
            out.append((name, Model(tuple(sorted(new)), model.offsets, model.effects + (name,))))
    for j in range(N):
        label = f"@{JOINT_SUFFIXES[j]}"
        if j not in model.offsets:
            out.append(("torque_offset" + label, Model(model.columns, tuple(sorted(model.offsets + (j,))), model.effects + ("torque_offset" + label,))))
        for name, blocks in JOINT_EFFECTS.items():
            new = have | {int(COLUMNS[b][j]) for b in blocks}
            if new != have:
                out.append((name + label, Model(tuple(sorted(new)), model.offsets, model.effects + (name + label,))))
    return out


#: Per-joint effects that are ≥ 0 in physics (a rotor's inertia; friction that opposes motion, at
#: rest and sliding alike); :func:`physical_levels` gives the values that must be.
NON_NEGATIVE = frozenset({"viscous_friction", "coulomb_friction", "stribeck_friction", "armature"})


def effect_values(model: Model, result: Fit, label: str) -> tuple[float, ...]:
    """The fitted parameters of a per-joint effect ``"name@joint"`` of ``model``, in its blocks' order
    (:data:`JOINT_EFFECTS`; Stribeck: Coulomb friction F_c, then the bump F_s − F_c at rest): N·m,
    N·m·s/rad, kg·m², s or dimensionless; ``torque_offset@joint``: the offset applied to a recording
    not trained on (the training recordings' mean), N·m."""
    name, _, suffix = label.partition("@")
    j = JOINT_SUFFIXES.index(suffix)
    if name == "torque_offset":
        return (float(result.test_offset()[j]),)
    theta = dict(zip(model.columns, result.theta))
    return tuple(float(theta[int(COLUMNS[block][j])]) for block in JOINT_EFFECTS[name])


def effect_name(label: str) -> str:
    """The effect a move's label names: "stribeck_friction" of "stribeck_friction(v_s=0.02)@s1"."""
    return label.split("@")[0].split("(")[0]


def physical_levels(label: str, values: tuple[float, ...]) -> tuple[float, ...]:
    """What must be ≥ 0 of a per-joint effect's values for it to be physical: a NON_NEGATIVE
    effect's values (Stribeck's as sliding and breakaway friction, F_c and F_c + bump); () for the
    others (an offset, a delay or a gain may take either sign)."""
    name = effect_name(label)
    if name not in NON_NEGATIVE:
        return ()
    return (values[0], values[0] + values[1]) if name == "stribeck_friction" else values


def is_physical(model: Model, result: Fit) -> bool:
    """Whether every per-joint effect of ``model`` has physical values in ``result``."""
    return all(min(physical_levels(e, effect_values(model, result, e)), default=0.0) >= 0.0 for e in model.effects if "@" in e)


@dataclass(frozen=True)
class Step:
    """One accepted move: what was added and the LORO MSE per joint after it, N·m²."""

    effect: str
    loro_mse: np.ndarray


def select(
    train: Sequence[RecordingStats], *, min_gain: float = MIN_GAIN, max_steps: int = 80, exclude: frozenset[str] = frozenset(),
    physical: bool = False,
) -> tuple[Model, np.ndarray, list[Step]]:
    """Greedy forward selection (module docstring), never taking a move labelled in ``exclude`` (e.g.
    ``"armature@s1"``), nor with ``physical`` one after which a per-joint effect's values fitted on
    all of ``train`` (at that step's weights) are not physical (:func:`is_physical`); returns the
    model, its joint weights (7,), the steps."""
    if len(train) < 2:
        raise ValueError("leave-one-recording-out needs at least 2 training recordings")
    model = Model()
    weights = np.ones(N)
    mse = loro_mse(train, model, weights)
    weights = 1.0 / mse
    steps: list[Step] = []
    for _ in range(max_steps):
        tried = []
        for label, candidate in _moves(model):
            if label in exclude or (physical and not is_physical(candidate, fit(train, candidate, weights))):
                continue
            m = loro_mse(train, candidate, weights)
            tried.append((float(np.sum(np.log(mse) - np.log(m))), label, candidate, m))
        if not tried:
            break
        best = max(tried, key=lambda t: t[0])
        # Parsimony between nested alternatives (coulomb ⊂ stribeck, payload ⊂ inertial_error): the
        # larger is taken only if its extra columns pay the 5 % too, i.e. it beats the best nested
        # smaller move by MIN_GAIN; otherwise that smaller one (the rest may be added at a later step).
        added = set(best[2].columns) - set(model.columns)
        smaller = [t for t in tried if t[2].offsets == best[2].offsets and set(t[2].columns) - set(model.columns) < added
                   and t[0] > best[0] - min_gain]
        if smaller:
            best = max(smaller, key=lambda t: t[0])
        if best[0] < min_gain:
            break
        _, label, model, mse = best
        weights = 1.0 / mse
        # The current model's LORO error under its own weights, the baseline of the next step.
        mse = loro_mse(train, model, weights)
        steps.append(Step(label, mse))
    return model, weights, steps


@dataclass(frozen=True)
class PlainResult:
    """The plain diagnosis of one split: selected effects (in order), held-out RMS per joint (7,) N·m
    of the denoised rigid residual (``rigid_test_rms``) and after the selected effects (``test_rms``)."""

    selected: tuple[str, ...]
    test_rms: np.ndarray
    rigid_test_rms: np.ndarray
    steps: list[Step] = field(default_factory=list)
    model: Model = field(default_factory=Model)
    fit: Fit | None = None

    def joint_values(self, label: str) -> tuple[float, ...]:
        """:func:`effect_values` of a selected per-joint effect ``"name@joint"`` (one of :attr:`selected`)."""
        if label not in self.selected or "@" not in label or self.fit is None:
            raise ValueError(f"{label!r} is no per-joint effect of this fit (selected: {', '.join(self.selected)})")
        return effect_values(self.model, self.fit, label)


def plain_diagnosis(
    train: Sequence[RecordingStats], test: Sequence[RecordingStats], *, exclude: frozenset[str] = frozenset(), physical: bool = False,
) -> PlainResult:
    """Select on ``train`` by LORO (never the moves in ``exclude``; with ``physical`` none that
    leaves a per-joint effect with values no physical effect has), fit the selection on all of
    ``train``, measure on ``test``.

    Runs with BLAS on one thread: thousands of ~100×100 solves, which threads only slow down (by
    twenty times on a busy machine).
    """
    with threadpool_limits(1):
        model, weights, steps = select(train, exclude=exclude, physical=physical)
        result = fit(train, model, weights)
    offset = result.test_offset()
    total = sum(sse(t, model, result, offset) for t in test)
    count = sum(t.n for t in test)
    rigid = sum(t.rr for t in test)
    return PlainResult(model.effects, np.sqrt(np.maximum(total, 0) / count), np.sqrt(rigid / count), steps, model, result)
