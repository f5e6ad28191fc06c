"""Small recordings for the diagnosis' unit tests, made without the package's dynamics or simulator.

The joints follow sums of slow sinusoids inside their limits (q, q̇, q̈ in closed form); the effort is
Pinocchio's RNEA of the arm (or of the arm carrying a payload) at the exact q̈, plus injected friction
written out here (viscous b q̇, Coulomb f tanh(q̇/ε)), white effort noise, and the effort's 0.004 N·m
quantisation. A few seconds of 100 Hz data build in milliseconds, so that the tests stay fast.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import numpy as np
from reference_models import dahl_state, pinocchio_from_arm

from baxter_dynamics_ros.core.arm_model import ArmModel
from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.diagnosis.procedure import diagnose
from baxter_dynamics_ros.diagnosis.result import DiagnosisResult
from baxter_dynamics_ros.diagnosis.statistics import Block, active_columns, column_layout, prepare, recording_blocks
from baxter_dynamics_ros.diagnosis.validation import validation_arm

N = 7
EFFORT_QUANTUM_NM = 0.004


def motion(arm: ArmModel, seed: int, seconds: float, rate_hz: float = 100.0) -> tuple[np.ndarray, ...]:
    """(t, q, q̇, q̈) of a smooth excitation: per joint two sinusoids of 0.1–0.6 Hz about mid-range."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * rate_hz))) / rate_hz
    mid = 0.5 * (arm.lower_rad + arm.upper_rad)
    half = 0.5 * (arm.upper_rad - arm.lower_rad)
    q = np.tile(mid, (len(t), 1))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for _ in range(2):
        w = 2 * np.pi * rng.uniform(0.1, 0.6, N)
        a = 0.25 * half * rng.uniform(0.6, 1.0, N)
        ph = rng.uniform(0, 2 * np.pi, N)
        arg = np.outer(t, w) + ph
        q += a * np.sin(arg)
        qd += a * w * np.cos(arg)
        qdd -= a * w**2 * np.sin(arg)
    return t, q, qd, qdd


def rigid_torque(arm: ArmModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """(n, 7) N·m, Pinocchio's RNEA of ``arm`` sample by sample."""
    model = pinocchio_from_arm(arm)
    return np.array([model.rnea(a, b, c) for a, b, c in zip(q, qd, qdd)])


def recording(
    arm: ArmModel,
    seed: int,
    seconds: float = 12.0,
    *,
    rate_hz: float = 100.0,
    viscous: Sequence[float] | float = 0.0,
    coulomb: Sequence[float] | float = 0.0,
    coulomb_eps: float = 0.05,
    armature: Sequence[float] | float = 0.0,
    carried: ArmModel | None = None,
    effort_noise_nm: float = 0.02,
    velocity_noise_rad_s: float = 0.0,
    dahl: tuple[Sequence[float] | float, float] | None = None,
) -> Recording:
    """A recording of ``arm``'s side: RNEA of ``carried`` (default the arm itself) + viscous q̇ +
    Coulomb tanh(q̇/ε) + armature q̈ + Dahl's friction F·z (``dahl`` = (F, θ_p): ``reference_models.dahl_state``) + noise,
    quantised; q̇ noise (if any) added to the recorded q̇ only."""
    rng = np.random.default_rng(seed + 1000)
    t, q, qd, qdd = motion(arm, seed, seconds, rate_hz)
    effort = rigid_torque(carried or arm, q, qd, qdd)
    effort += np.asarray(viscous, dtype=float) * qd + np.asarray(coulomb, dtype=float) * np.tanh(qd / coulomb_eps)
    effort += np.asarray(armature, dtype=float) * qdd
    if dahl is not None:
        effort += np.asarray(dahl[0], dtype=float) * dahl_state(q, dahl[1])
    effort += rng.normal(0.0, effort_noise_nm, effort.shape)
    effort = np.round(effort / EFFORT_QUANTUM_NM) * EFFORT_QUANTUM_NM
    qd_recorded = qd + rng.normal(0.0, velocity_noise_rad_s, qd.shape) if velocity_noise_rad_s else qd
    stamps_ns = 1_700_000_000_000_000_000 + np.round(t * 1e9).astype(np.int64)
    return Recording(arm.side, tuple(arm.joint_names), stamps_ns, q, qd_recorded, effort)


def blocks_of(arm: ArmModel, named: Sequence[tuple[str, Recording]], cutoffs_hz: tuple[float, ...], parts: int = 4) -> list[Block]:
    """Each recording's statistics in ``parts`` contiguous blocks, q̇ low-passed at cutoffs_hz (7,), as the diagnosis makes them."""
    layout = column_layout()
    active = active_columns(arm, layout)
    return [b for label, rec in named for b in recording_blocks(arm, layout, active, label, prepare(arm, rec, cutoffs_hz), parts)]


def block_edges(n: int, parts: int) -> list[tuple[int, int]]:
    """The contiguous blocks' sample ranges, by integer arithmetic: block k is ⌊k n / parts⌋ up to ⌊(k+1) n / parts⌋."""
    return [((k * n) // parts, ((k + 1) * n) // parts) for k in range(parts)]


#: Friction of the shared scenario, N·m s/rad and N·m (twice a real Baxter's).
VISCOUS = 2.0 * np.array([1.0, 1.5, 0.6, 0.6, 0.15, 0.15, 0.05])
COULOMB = 2.0 * np.array([0.5, 0.8, 0.4, 0.4, 0.1, 0.06, 0.03])


def friction_scenario(arm: ArmModel) -> tuple[list[tuple[str, Recording]], list[tuple[str, Recording]]]:
    """(train, test): viscous friction everywhere; Coulomb friction in training recordings A and B and
    in the test recordings, not in C, so that the folds disagree about it."""
    train = [
        ("A", recording(arm, 1, viscous=VISCOUS, coulomb=COULOMB)),
        ("B", recording(arm, 2, viscous=VISCOUS, coulomb=COULOMB)),
        ("C", recording(arm, 3, viscous=VISCOUS)),
    ]
    test = [("T1", recording(arm, 4, viscous=VISCOUS, coulomb=COULOMB)), ("T2", recording(arm, 5, 9.0, viscous=VISCOUS, coulomb=COULOMB))]
    return train, test


@cache
def friction_diagnosis() -> tuple[DiagnosisResult, list[tuple[str, Recording]], list[tuple[str, Recording]]]:
    """(result, train, test): diagnose on :func:`friction_scenario` of the validation arm, run once
    for every test module that reads it."""
    arm = validation_arm()
    train, test = friction_scenario(arm)
    return diagnose(arm, train, test), train, test


def _per_joint(cutoffs_hz: float | Sequence[float]) -> list[float]:
    return [float(cutoffs_hz)] * 7 if np.isscalar(cutoffs_hz) else [float(c) for c in cutoffs_hz]


def lowpassed_velocity(rec: Recording, cutoffs_hz: float | Sequence[float]) -> np.ndarray:
    """(n, 7) rad/s, the recording's q̇ low-passed forwards and backwards by scipy (Butterworth,
    order 2; column j at cutoffs_hz[j], or one cut-off for all): the denoised world's q̇."""
    from scipy.signal import butter, sosfiltfilt

    cutoffs = _per_joint(cutoffs_hz)
    return np.stack([sosfiltfilt(butter(2, c, fs=rec.rate_hz, output="sos"), rec.qd[:, j]) for j, c in enumerate(cutoffs)], axis=1)


def reference_residuals(arm: ArmModel, rec: Recording, cutoffs_hz: float | Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """(raw, denoised) rigid residuals (n, 7) N·m of a recording, without the package's dynamics:
    Pinocchio's RNEA with q̈ the first difference of q̇ (q̈_0 = 0), and, for joint j, with every
    joint's q̈ the central difference of q̇ low-passed forwards and backwards by scipy (Butterworth,
    order 2) at joint j's cut-off cutoffs_hz[j] (or one cut-off for all)."""
    t = rec.stamps_s
    qdd_raw = np.zeros_like(rec.qd)
    qdd_raw[1:] = np.diff(rec.qd, axis=0) / np.diff(t)[:, None]
    cutoffs = _per_joint(cutoffs_hz)
    tau = np.empty_like(rec.qd)
    for c in set(cutoffs):
        qdd = np.gradient(lowpassed_velocity(rec, c), 1.0 / rec.rate_hz, axis=0)
        at = [j for j in range(7) if cutoffs[j] == c]
        tau[:, at] = rigid_torque(arm, rec.q, rec.qd, qdd)[:, at]
    return rec.effort - rigid_torque(arm, rec.q, rec.qd, qdd_raw), rec.effort - tau
