"""Reference trajectories for the simulated arm: the paper's three Cartesian ones and a random one.

Cartesian targets are in Baxter's ``base`` (torso) frame, where Baxter's SDK reports the hand
pose: the paper's x = 0.6 + 0.1 sin t, y = −0.2 + 0.1 cos t, z = 0.1 + 0.1 cos 0.2t (Fig. 5) is a
circle in front of the robot on its right side, as the real recordings in
``../shared/data/baxter_real`` (left arm, hand at x ≈ 0.46–0.67, y ≈ +0.11–0.39, z ≈ −0.17–0.29 m)
confirm by symmetry. For the left arm, y is mirrored.

- ``paper_xyz`` (Fig. 3a / 5): the formula above.
- ``paper_y`` (Fig. 3b / 6): x = 0.6, z = 0.1, y switching between −0.1 and −0.3 every 2 s with
  0.7 s minimum-jerk transitions (period 4 s; s0 then peaks at 1.0 rad/s of its 1.5 limit).
- ``paper_z`` (Fig. 3c / 7): x = 0.6, y = −0.2, z = 0.1 + 0.1 cos 0.2t — slow, mostly e1.
- ``random``: smooth joint-space excitation, a seeded sum of five sinusoids per joint
  (0.1–0.5 Hz) around the start posture, inside the joint limits and below 60 % of the velocity
  limits.

The hand is kept pointing down (flange z axis along −z of the torso, as in the paper's Fig. 4).
Joint references come from the pseudo-inverse-Jacobian IK of eq. (13), q̇_r = J⁺ ẋ_r, with three
additions that keep a long run well behaved: position and orientation error feedback
(ẋ_r + K_x (x_r − F(q_r)), no drift), a small damping in J⁺ = Jᵀ(JJᵀ + λ²𝟙)⁻¹, and a null-space
pull (𝟙 − J⁺J) K_n (q_seed − q_r) towards the start posture on the arm's one redundant degree of
freedom, so that a cyclic target gives a cyclic joint motion.

Every trajectory starts at rest: time enters through a phase φ(t) whose rate ramps from 0 to 1
over ``ramp_s`` (smoothstep), so after the ramp the target is the formula at t − ramp_s / 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..core import lagrange_euler
from ..core.arm_model import ArmModel
from ..core.joints import JOINTS as N
from ..errors import SimulationError

__all__ = ["SEED_POSTURE_RAD", "TRAJECTORIES", "JointReference", "cartesian_target", "make_reference", "mirror_joints", "seed_posture"]

TRAJECTORIES = ("paper_xyz", "paper_y", "paper_z", "random")
#: The start posture of the right arm (rad): hand in front of the robot, pointing down.
SEED_POSTURE_RAD = np.array([0.0, -0.55, 0.0, 0.75, 0.0, 1.26, 0.0])
#: Joints whose angle changes sign between the right and the left arm (s0, e0, w0, w2).
_MIRRORED = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0])

# IK gains (1/s), damping of J⁺ and the margin kept from the joint limits (rad).
K_POSITION = 20.0
K_ORIENTATION = 20.0
K_NULL = 2.0
DAMPING = 1e-3
LIMIT_MARGIN_RAD = 0.02
# Paper Fig. 5 / 6 / 7 parameters (m, s).
CENTRE_M = np.array([0.6, -0.2, 0.1])
RADIUS_M = 0.1
SWITCH_HOLD_S = 1.3
SWITCH_MOVE_S = 0.7
# Random excitation: base frequency (Hz), harmonics, share of the joint range and velocity limit.
RANDOM_BASE_HZ = 0.1
RANDOM_HARMONICS = 5
RANDOM_RANGE_RAD = 0.5
RANDOM_VELOCITY_SHARE = 0.6


def mirror_joints(q: np.ndarray) -> np.ndarray:
    """The other arm's angles for the mirrored posture: s0, e0, w0, w2 change sign. (…, 7)."""
    return np.asarray(q) * _MIRRORED


def seed_posture(side: str) -> np.ndarray:
    """(7,) rad: :data:`SEED_POSTURE_RAD` for the right arm, its mirror image for the left."""
    return SEED_POSTURE_RAD.copy() if side == "right" else mirror_joints(SEED_POSTURE_RAD)


@dataclass(frozen=True)
class JointReference:
    """A joint-space reference sampled every dt_s seconds from t = 0 s.

    q (M, 7) rad and qd (M, 7) rad/s: the reference and its rate (Hermite-interpolated between
    samples by the simulator); x_m (M, 3): the Cartesian target in the torso frame, m, or None
    for joint-space trajectories.
    """

    name: str
    dt_s: float
    q: np.ndarray
    qd: np.ndarray
    x_m: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.dt_s) and self.dt_s > 0):
            raise SimulationError(f"reference {self.name}: dt_s must be positive, got {self.dt_s}")
        if self.q.ndim != 2 or self.q.shape[1] != N or self.qd.shape != self.q.shape or len(self.q) < 2:
            raise SimulationError(f"reference {self.name}: q and qd must be (M, 7), M >= 2, got {self.q.shape}, {self.qd.shape}")

    @property
    def duration_s(self) -> float:
        """Time covered by the samples, s."""
        return (len(self.q) - 1) * self.dt_s


def _phase(t_s: np.ndarray, ramp_s: float) -> tuple[np.ndarray, np.ndarray]:
    """φ(t) and φ̇(t): φ̇ rises from 0 to 1 over ramp_s by a smoothstep, then φ = t − ramp_s/2."""
    if ramp_s <= 0:
        return t_s.copy(), np.ones_like(t_s)
    u = np.clip(t_s / ramp_s, 0.0, 1.0)
    rate = u * u * (3.0 - 2.0 * u)
    ramp_phase = ramp_s * (u**3 - 0.5 * u**4)
    return np.where(t_s < ramp_s, ramp_phase, t_s - 0.5 * ramp_s), rate


def _minimum_jerk(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """10s³ − 15s⁴ + 6s⁵ and its derivative, s in [0, 1]."""
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2), 30.0 * s**2 * (1.0 - s) ** 2


def _switching(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A smooth square wave in [−1, 1] starting at +1 and its derivative in phase, (M,) each."""
    hold, move = SWITCH_HOLD_S, SWITCH_MOVE_S
    u = np.mod(p, 2.0 * (hold + move))
    first = np.clip((u - hold) / move, 0.0, 1.0)
    second = np.clip((u - 2.0 * hold - move) / move, 0.0, 1.0)
    (m1, d1), (m2, d2) = _minimum_jerk(first), _minimum_jerk(second)
    in1 = (u > hold) & (u < hold + move)
    in2 = u > 2.0 * hold + move
    return 1.0 - 2.0 * m1 + 2.0 * m2, (-2.0 * d1 * in1 + 2.0 * d2 * in2) / move


def cartesian_target(name: str, t_s: np.ndarray, side: str = "right", ramp_s: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The hand target x (M, 3) m and ẋ (M, 3) m/s of a paper trajectory, torso frame (module docstring)."""
    t_s = np.asarray(t_s, dtype=float)
    p, rate = _phase(t_s, ramp_s)
    x = np.tile(CENTRE_M, (len(t_s), 1))
    dx = np.zeros_like(x)  # derivative in phase
    if name == "paper_xyz":
        x[:, 0] += RADIUS_M * np.sin(p)
        x[:, 1] += RADIUS_M * np.cos(p)
        x[:, 2] += RADIUS_M * np.cos(0.2 * p)
        dx[:, 0] = RADIUS_M * np.cos(p)
        dx[:, 1] = -RADIUS_M * np.sin(p)
        dx[:, 2] = -0.2 * RADIUS_M * np.sin(0.2 * p)
    elif name == "paper_y":
        wave, dwave = _switching(p)
        x[:, 1] += RADIUS_M * wave
        dx[:, 1] = RADIUS_M * dwave
    elif name == "paper_z":
        x[:, 2] += RADIUS_M * np.cos(0.2 * p)
        dx[:, 2] = -0.2 * RADIUS_M * np.sin(0.2 * p)
    else:
        raise SimulationError(f"no Cartesian trajectory {name!r}; choose one of paper_xyz, paper_y, paper_z")
    if side == "left":
        x[:, 1] *= -1.0
        dx[:, 1] *= -1.0
    return x, dx * rate[:, None]


# ----------------------------------------------------------------------------- IK (eq. 13), compiled
@njit(cache=True)
def _ik_velocity(dh, base, q, x_d, xd_d, rot_d, q_seed, pose, jac, qd_out):
    """q̇ = J⁺(ẋ_d + K_x e) + (𝟙 − J⁺J) K_n (q_seed − q); J⁺ = Jᵀ(JJᵀ + λ²𝟙)⁻¹; torso-frame task."""
    lagrange_euler.batch_kinematics(dh, q.reshape(1, N), pose, jac)
    rb = base[:3, :3].copy()
    rot = rb @ pose[0, :3, :3].copy()
    pos = rb @ pose[0, :3, 3].copy() + base[:3, 3]
    task = np.empty(6)
    task[:3] = xd_d + K_POSITION * (x_d - pos)
    e_o = np.zeros(3)
    for c in range(3):
        e_o += 0.5 * np.cross(rot[:, c].copy(), rot_d[:, c].copy())
    task[3:] = K_ORIENTATION * e_o
    j = np.empty((6, N))
    j[:3] = rb @ jac[0, :3].copy()
    j[3:] = rb @ jac[0, 3:].copy()
    a = j @ j.T + DAMPING**2 * np.eye(6)
    pinv = j.T @ np.linalg.inv(a)  # (7, 6)
    null = np.eye(N) - pinv @ j
    qd_out[:] = pinv @ task + null @ (K_NULL * (q_seed - q))


@njit(cache=True)
def _ik_track(dh, base, x, xd, rot_d, q_start, q_seed, dt, q_out, qd_out):
    """Integrate eq. (13) by Heun's method over the M targets x, ẋ (M, 3), dt apart."""
    pose = np.empty((1, 4, 4))
    jac = np.empty((1, 6, N))
    f0 = np.empty(N)
    f1 = np.empty(N)
    q = q_start.copy()
    for k in range(x.shape[0]):
        _ik_velocity(dh, base, q, x[k], xd[k], rot_d, q_seed, pose, jac, f0)
        q_out[k] = q
        qd_out[k] = f0
        if k + 1 < x.shape[0]:
            trial = q + dt * f0
            _ik_velocity(dh, base, trial, x[k + 1], xd[k + 1], rot_d, q_seed, pose, jac, f1)
            q = q + 0.5 * dt * (f0 + f1)


def _hand_down(arm: ArmModel, q_seed: np.ndarray) -> np.ndarray:
    """The hand orientation (3, 3) in the torso frame with the flange z axis straight down and
    its x axis along the horizontal part of the seed posture's."""
    rot = arm.base_in_torso[:3, :3] @ arm.forward_kinematics(q_seed)[:3, :3]
    x_axis = np.array([rot[0, 0], rot[1, 0], 0.0])
    x_axis /= np.linalg.norm(x_axis)
    z_axis = np.array([0.0, 0.0, -1.0])
    return np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis])


def _ik_reference(arm: ArmModel, name: str, t_s: np.ndarray, dt_s: float, ramp_s: float) -> JointReference:
    x, xd = cartesian_target(name, t_s, arm.side, ramp_s)
    q_seed = seed_posture(arm.side)
    rot_d = _hand_down(arm, q_seed)
    base = np.ascontiguousarray(arm.base_in_torso)
    dh = np.ascontiguousarray(arm.dh)
    # Converge on the first target from the seed posture (10 s of the same law, target at rest).
    settle = int(round(10.0 / dt_s))
    q_tmp, qd_tmp = np.empty((settle, N)), np.empty((settle, N))
    still = np.zeros((settle, 3))
    _ik_track(dh, base, np.repeat(x[:1], settle, axis=0), still, rot_d, q_seed, q_seed, dt_s, q_tmp, qd_tmp)
    q, qd = np.empty((len(t_s), N)), np.empty((len(t_s), N))
    _ik_track(dh, base, x, xd, rot_d, q_tmp[-1], q_seed, dt_s, q, qd)
    return JointReference(name, dt_s, q, qd, x)


def _random_reference(arm: ArmModel, t_s: np.ndarray, dt_s: float, seed: int, ramp_s: float) -> JointReference:
    """Σ_k a_jk (sin(ω_k φ + ψ_jk) − sin ψ_jk) around the seed posture (module docstring)."""
    rng = np.random.default_rng([seed, 0])
    centre = seed_posture(arm.side)
    room = np.minimum(centre - arm.lower_rad, arm.upper_rad - centre) - LIMIT_MARGIN_RAD
    half_range = np.minimum(room, RANDOM_RANGE_RAD)
    omega = 2.0 * np.pi * RANDOM_BASE_HZ * np.arange(1, RANDOM_HARMONICS + 1)
    weights = rng.uniform(0.5, 1.0, (N, RANDOM_HARMONICS))
    phases = rng.uniform(0.0, 2.0 * np.pi, (N, RANDOM_HARMONICS))
    # |Σ a_k (sin − sin ψ)| ≤ 2 Σ a_k ≤ half_range; peak speed ≤ Σ a_k ω_k ≤ share · limit.
    amplitude = weights * (half_range / (2.0 * weights.sum(axis=1)))[:, None]
    speed = (amplitude * omega).sum(axis=1)
    amplitude *= np.minimum(1.0, RANDOM_VELOCITY_SHARE * arm.velocity_limit_rad_s / speed)[:, None]
    p, rate = _phase(t_s, ramp_s)
    arg = p[:, None, None] * omega + phases  # (M, 7, K)
    q = centre + (amplitude * (np.sin(arg) - np.sin(phases))).sum(axis=2)
    qd = (amplitude * omega * np.cos(arg)).sum(axis=2) * rate[:, None]
    return JointReference("random", dt_s, q, qd)


def _check_limits(arm: ArmModel, ref: JointReference) -> None:
    """Raise SimulationError when the reference leaves the joint or velocity limits."""
    low = ref.q < arm.lower_rad + LIMIT_MARGIN_RAD
    high = ref.q > arm.upper_rad - LIMIT_MARGIN_RAD
    fast = np.abs(ref.qd) > arm.velocity_limit_rad_s
    for bad, what in ((low | high, "position"), (fast, "velocity")):
        if bad.any():
            k, j = (int(i) for i in np.argwhere(bad)[0])
            raise SimulationError(
                f"trajectory {ref.name} leaves the {what} limits of {arm.joint_names[j]} at t = {k * ref.dt_s:.3f} s "
                f"(q = {ref.q[k, j]:.3f} rad, q̇ = {ref.qd[k, j]:.3f} rad/s); choose another trajectory or arm"
            )


def make_reference(
    arm: ArmModel, name: str, duration_s: float, *, dt_s: float = 0.005, seed: int = 0, ramp_s: float = 1.0
) -> JointReference:
    """The joint reference of trajectory ``name`` (:data:`TRAJECTORIES`) for ``duration_s`` seconds.

    Sampled every dt_s from t = 0 to at least duration_s + dt_s; ``seed`` only matters for
    ``random``. Raises SimulationError if the reference leaves the joint or velocity limits.
    """
    if name not in TRAJECTORIES:
        raise SimulationError(f"unknown trajectory {name!r}; choose one of {', '.join(TRAJECTORIES)}")
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise SimulationError(f"duration must be positive, got {duration_s} s")
    t_s = np.arange(int(np.ceil(duration_s / dt_s)) + 2) * dt_s
    if name == "random":
        ref = _random_reference(arm, t_s, dt_s, seed, ramp_s)
    else:
        ref = _ik_reference(arm, name, t_s, dt_s, ramp_s)
    _check_limits(arm, ref)
    return ref
