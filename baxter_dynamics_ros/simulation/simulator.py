"""A simulated Baxter arm with switchable unmodelled effects, recorded as the robot publishes it.

The plant is the core's rigid-body model (:mod:`baxter_dynamics_ros.core.lagrange_euler`) with the
physical effects of a :class:`SimulationSpec` acting on it:

    (M_true(q) + diag(armature)) q̈ = τ_act − C_true(q, q̇) − G_true(q) − τ_friction(q̇) − τ_spring_share(q_s1)

M_true, C_true, G_true use the arm's pseudo-inertias plus the changes of ``payload`` and
``inertial_error``; τ_friction sums ``viscous_friction``, ``coulomb_friction`` and
``stribeck_friction``; the spring's share is :class:`~baxter_dynamics_ros.core.effects.S1Spring`'s
(the spring carries part of the weight, so the actuators transmit less). Integration: fixed-step
RK4 at ``physics_rate_hz`` (default: the smallest multiple of the recording rate ≥ 1 kHz), τ_act
held over each step.

Controller (paper Fig. 2, eqs. 14–15), updated every step on the true state:

    q̇_d = q̇_r + K_p e + K_d ė,  e = q_r − q                       (eq. 14, plus the IK rate q̇_r)
    τ_act = K_v ε̇ + K_i ε + G_nominal(q),  ε̇ = q̇_d − q̇, ε = ∫ ε̇ dt   (eq. 15, plus gravity feed-forward)

with scalar K_p, K_d and inertia-scaled matrices K_v = ω_v M(q), K_i = (ω_v² / 10) M(q), ω_v the
inner bandwidth, M the simulated arm's own inertia (armature and load included: a robot's joint
controllers are tuned on the robot), so the loop stays stable whatever the posture or the load.
The feed-forward uses the nominal model only; the integrator absorbs what it misses. τ_act is
clipped to the effort limits. Before t = 0 the arm settles for ``settle_s`` at the reference's
start (not recorded). None of this changes what is recorded: the effort is the τ_act that
produced the motion, M q̈ + C + G + every effect's share, whatever the controller.

Collisions (``collisions``, :class:`Collision`): external torques τ_ext on the arm, added to τ_act
in the plant only (never to the recorded effort, which stays the actuators' torque), evaluated at
the start of each step and held over it. At the flange, τ_ext = J_v(q)ᵀ F for a force F (base
frame, N) at the flange origin, J_v the core's flange Jacobian; forces at other links are not
simulated: give their joint torques directly (``link: joints``, τ_ext = the torque vector). Each
is scaled by its time profile: ``impact`` a half-sine pulse over ``duration_s``, ``push`` raised-
cosine ramps of ``ramp_s`` at both ends and full force between. Then the recorded residual
(effort − rigid model with the true q̈) is −τ_ext.

Recording, every 1 / rate_hz from t = 0 (what Baxter's ``/robot/joint_states`` holds): q quantised
to ``position_step_rad`` (2π/16384); q̇ plus the white noise of ``acceleration_noise``; effort =
τ_act (the transmitted torque: rigid body + every effect's share, the spring's negative) delayed by
``delay`` (linear interpolation between steps), plus ``torque_offset``, plus white noise of
``effort_noise_nm``, quantised to ``effort_step_nm`` (0.004 N·m). Noise comes from
``numpy.random.default_rng([seed, 1])``; the random trajectory from ``[seed, 0]``: same spec, same
numbers, bit for bit.
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numba import njit

from ..core import lagrange_euler
from ..core.arm_model import ArmModel, load_arm_model
from ..core.effects import (
    AccelerationNoise,
    Armature,
    CoulombFriction,
    Delay,
    Effect,
    InertialChange,
    S1Spring,
    StribeckFriction,
    TorqueOffset,
    ViscousFriction,
    effects_from_dict,
    effects_to_dict,
    friction_law,
    s1_spring_law,
)
from ..core.joints import JOINTS as N
from ..core.joints import S1
from ..core.recording import Recording
from ..errors import EffectSpecError, SimulationError
from .trajectories import TRAJECTORIES, JointReference, make_reference, seed_posture

__all__ = [
    "BAXTER_JOINT_NAMES",
    "Collision",
    "external_torques",
    "START_STAMP_NS",
    "ControllerGains",
    "RobotJointStates",
    "SensorModel",
    "SimulationResult",
    "SimulationSpec",
    "read_spec_json",
    "simulate",
    "write_ground_truth",
]

#: The names on a real Baxter's /robot/joint_states, in its (alphabetical) order.
BAXTER_JOINT_NAMES = (
    "head_nod",
    "head_pan",
    "l_gripper_l_finger_joint",
    "l_gripper_r_finger_joint",
    *(f"left_{j}" for j in ("e0", "e1", "s0", "s1", "w0", "w1", "w2")),
    "r_gripper_l_finger_joint",
    "r_gripper_r_finger_joint",
    *(f"right_{j}" for j in ("e0", "e1", "s0", "s1", "w0", "w1", "w2")),
    "torso_t0",
)
#: Stamp of the first recorded sample, ns (a fixed epoch, 2023-11-14, so that files are reproducible).
START_STAMP_NS = 1_700_000_000_000_000_000
MIN_PHYSICS_RATE_HZ = 1000.0
#: Largest λ·Δt allowed, λ the fastest decay rate of the velocity dynamics (RK4 and the
#: sampled velocity loop stay stable and accurate below 2).
STABILITY_LIMIT = 2.0
#: K_i = K_v · ω_v / INTEGRAL_RATIO (eq. 15).
INTEGRAL_RATIO = 10.0


# ----------------------------------------------------------------------------- specification
def _positive(value: Any, where: str, *, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as err:
        raise EffectSpecError(f"{where}: expected a number, got {value!r}") from err
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise EffectSpecError(f"{where}: must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return x


def _fields_from(cls: type, raw: Any, where: str) -> dict[str, Any]:
    """raw as keyword arguments of a small dataclass, unknown keys refused."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise EffectSpecError(f"{where}: expected a mapping, got {raw!r}")
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = set(raw) - known
    if unknown:
        raise EffectSpecError(f"{where}: unknown keys {sorted(unknown)}; allowed: {', '.join(sorted(known))}")
    return dict(raw)


class _Section:
    """A spec section of numbers, each validated by :func:`_positive`; ``section`` names it in errors
    and ``may_be_zero`` lists the fields allowed to be 0."""

    section: ClassVar[str] = ""
    may_be_zero: ClassVar[tuple[str, ...]] = ()

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = _positive(getattr(self, f.name), f"{self.section}.{f.name}", allow_zero=f.name in self.may_be_zero)
            object.__setattr__(self, f.name, value)

    @classmethod
    def from_dict(cls, raw: Any, where: str = ""):
        return cls(**_fields_from(cls, raw, where or cls.section))

    def to_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class SensorModel(_Section):
    """How the robot reports its state: quantisation steps (rad, N·m; 0 disables) and the standard
    deviation of the white noise on the effort (N·m). q̇ noise is the ``acceleration_noise`` effect."""

    section: ClassVar[str] = "sensor"
    may_be_zero: ClassVar[tuple[str, ...]] = ("position_step_rad", "effort_step_nm", "effort_noise_nm")
    position_step_rad: float = 2.0 * np.pi / 16384
    effort_step_nm: float = 0.004
    effort_noise_nm: float = 0.0


@dataclass(frozen=True)
class ControllerGains(_Section):
    """Gains of the dual-loop controller (module docstring): outer K_p (1/s) and K_d (-) of eq. 14,
    inner bandwidth ω_v (rad/s) setting K_v = ω_v M(q) and K_i = ω_v² M(q) / 10 of eq. 15."""

    section: ClassVar[str] = "controller"
    may_be_zero: ClassVar[tuple[str, ...]] = ("outer_kd",)
    outer_kp_1_s: float = 20.0
    outer_kd: float = 0.0
    inner_bandwidth_rad_s: float = 150.0


COLLISION_PROFILES = ("impact", "push")
COLLISION_LINKS = ("flange", "joints")


@dataclass(frozen=True)
class Collision:
    """An external force or torque on the arm from start_s for duration_s (s, recording time).

    profile: "impact" (half-sine pulse) or "push" (ramps of ramp_s, then held); link: "flange"
    with force_n (3,) N in the arm's base frame, or "joints" with torque_nm (7,) N·m directly.
    """

    start_s: float
    duration_s: float
    profile: str = "push"
    link: str = "flange"
    force_n: tuple[float, ...] = (0.0, 0.0, 0.0)
    torque_nm: tuple[float, ...] = (0.0,) * N
    ramp_s: float = 0.02

    def __post_init__(self) -> None:
        where = "collision"
        _positive(self.start_s, f"{where}.start_s", allow_zero=True)
        object.__setattr__(self, "start_s", float(self.start_s))
        object.__setattr__(self, "duration_s", _positive(self.duration_s, f"{where}.duration_s"))
        object.__setattr__(self, "ramp_s", _positive(self.ramp_s, f"{where}.ramp_s"))
        if self.profile not in COLLISION_PROFILES:
            raise EffectSpecError(f"{where}.profile must be one of {', '.join(COLLISION_PROFILES)}, got {self.profile!r}")
        if self.link not in COLLISION_LINKS:
            raise EffectSpecError(f"{where}.link must be one of {', '.join(COLLISION_LINKS)} (forces act at the flange only), got {self.link!r}")
        for name, size in (("force_n", 3), ("torque_nm", N)):
            arr = np.array(getattr(self, name), dtype=np.float64)
            if arr.shape != (size,) or not np.all(np.isfinite(arr)):
                raise EffectSpecError(f"{where}.{name}: expected {size} finite numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(float(x) for x in arr))
        if self.profile == "push" and 2 * self.ramp_s > self.duration_s:
            raise EffectSpecError(f"{where}: a push needs duration_s >= 2 ramp_s, got {self.duration_s} and {self.ramp_s}")

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s

    def to_dict(self) -> dict[str, Any]:
        out = {"start_s": self.start_s, "duration_s": self.duration_s, "profile": self.profile, "link": self.link}
        if self.link == "flange":
            out["force_n"] = list(self.force_n)
        else:
            out["torque_nm"] = list(self.torque_nm)
        if self.profile == "push":
            out["ramp_s"] = self.ramp_s
        return out

    @classmethod
    def from_dict(cls, raw: Any, where: str = "collision") -> Collision:
        return cls(**_fields_from(cls, raw, where))


@dataclass(frozen=True)
class SimulationSpec:
    """Everything that determines a simulated recording (written beside it as JSON).

    side: "right" | "left"; trajectory: one of :data:`~baxter_dynamics_ros.simulation.trajectories.TRAJECTORIES`;
    duration_s, rate_hz: the recording; seed: noise and random trajectory; effects: the unmodelled
    effects; physics_rate_hz: RK4 rate (None: the smallest multiple of rate_hz ≥ 1 kHz);
    settle_s: unrecorded time at the start posture before t = 0; collisions: external forces or
    torques on the arm (:class:`Collision`).
    """

    trajectory: str
    duration_s: float
    rate_hz: float
    seed: int = 0
    side: str = "right"
    effects: tuple[Effect, ...] = ()
    sensor: SensorModel = field(default_factory=SensorModel)
    controller: ControllerGains = field(default_factory=ControllerGains)
    physics_rate_hz: float | None = None
    settle_s: float = 1.0
    collisions: tuple[Collision, ...] = ()

    def __post_init__(self) -> None:
        if self.trajectory not in TRAJECTORIES:
            raise SimulationError(f"trajectory must be one of {', '.join(TRAJECTORIES)}, got {self.trajectory!r}")
        if self.side not in ("right", "left"):
            raise SimulationError(f"arm must be 'right' or 'left', got {self.side!r}")
        for name in ("duration_s", "rate_hz", "settle_s"):
            object.__setattr__(self, name, _positive(getattr(self, name), name))
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise SimulationError(f"seed must be a non-negative integer, got {self.seed!r}")
        object.__setattr__(self, "seed", int(self.seed))
        object.__setattr__(self, "effects", tuple(self.effects))
        object.__setattr__(self, "collisions", tuple(self.collisions))
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            raise SimulationError(f"each effect may appear once, got {names}")
        rate = self.rate_hz
        physics = self.physics_rate_hz
        if physics is None:
            physics = rate * np.ceil(MIN_PHYSICS_RATE_HZ / rate)
        physics = _positive(physics, "physics_rate_hz")
        ratio = physics / rate
        if physics < MIN_PHYSICS_RATE_HZ or abs(ratio - round(ratio)) > 1e-9:
            raise SimulationError(
                f"physics_rate_hz must be >= {MIN_PHYSICS_RATE_HZ:g} and a whole multiple of rate_hz ({rate:g}), got {physics:g}"
            )
        object.__setattr__(self, "physics_rate_hz", float(physics))
        delay = self.effect(Delay)
        if delay is not None and (np.any(delay.delay_s < 0) or np.any(delay.delay_s > self.settle_s)):
            raise SimulationError(
                f"delay.delay_s ({delay.delay_s.tolist()} s) must lie in [0, settle_s = {self.settle_s} s] at every joint: "
                "the simulator delays the effort causally"
            )

    def effect(self, cls: type[Effect]) -> Any:
        """The spec's effect of class ``cls``, or None."""
        return next((e for e in self.effects if isinstance(e, cls)), None)

    @property
    def samples(self) -> int:
        """Number of recorded samples."""
        return int(round(self.duration_s * self.rate_hz))

    def to_dict(self) -> dict[str, Any]:
        out = {
            "trajectory": self.trajectory,
            "duration_s": self.duration_s,
            "rate_hz": self.rate_hz,
            "seed": self.seed,
            "side": self.side,
            "effects": effects_to_dict(self.effects),
            "sensor": self.sensor.to_dict(),
            "controller": self.controller.to_dict(),
            "physics_rate_hz": self.physics_rate_hz,
            "settle_s": self.settle_s,
        }
        if self.collisions:  # absent without collisions: earlier ground truths stay as they were
            out["collisions"] = [c.to_dict() for c in self.collisions]
        return out

    @classmethod
    def from_dict(cls, raw: Any) -> SimulationSpec:
        kwargs = _fields_from(cls, raw, "simulation spec")
        kwargs["effects"] = effects_from_dict(kwargs.get("effects"))
        kwargs["sensor"] = SensorModel.from_dict(kwargs.get("sensor"))
        kwargs["controller"] = ControllerGains.from_dict(kwargs.get("controller"))
        collisions = kwargs.get("collisions") or []
        if not isinstance(collisions, list):
            raise EffectSpecError(f"simulation spec: collisions must be a list, got {collisions!r}")
        kwargs["collisions"] = tuple(Collision.from_dict(c, f"collisions[{i}]") for i, c in enumerate(collisions))
        missing = [k for k in ("trajectory", "duration_s", "rate_hz") if k not in kwargs]
        if missing:
            raise EffectSpecError(f"simulation spec: missing {', '.join(missing)}")
        return cls(**kwargs)


# ----------------------------------------------------------------------------- results
class RobotJointStates(NamedTuple):
    """Joint states as on Baxter's /robot/joint_states: names (J,), stamps_ns (N,), position,
    velocity, effort (N, J) in rad, rad/s, N·m."""

    names: tuple[str, ...]
    stamps_ns: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray


@dataclass(frozen=True)
class SimulationResult:
    """A simulated recording with its ground truth, all (N, 7) at stamps_ns (N,) unless said.

    q, qd, effort: as recorded (quantised, noisy, delayed, offset); q_true, qd_true: the state;
    qdd_true: the acceleration right after the sample (the step's first RK4 stage, rad/s²);
    tau_actuator: τ_act as applied (no delay, offset, noise or quantisation), N·m; q_ref: the
    reference; x_target (N, 3) the Cartesian target (torso frame, m) or None; other_q,
    other_effort (7,): the other arm, at rest; saturated_steps: steps with τ_act clipped;
    tau_external: the collisions' τ_ext on the arm right after each sample (zeros without).
    """

    spec: SimulationSpec
    joint_names: tuple[str, ...]
    stamps_ns: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray
    q_true: np.ndarray
    qd_true: np.ndarray
    qdd_true: np.ndarray
    tau_actuator: np.ndarray
    q_ref: np.ndarray
    x_target: np.ndarray | None
    other_q: np.ndarray
    other_effort: np.ndarray
    saturated_steps: int
    tau_external: np.ndarray

    def recording(self) -> Recording:
        """The simulated arm's joint states as a :class:`~baxter_dynamics_ros.core.recording.Recording`."""
        return Recording(self.spec.side, self.joint_names, self.stamps_ns, self.q, self.qd, self.effort)

    def robot_joint_states(self) -> RobotJointStates:
        """All 21 joints of Baxter (:data:`BAXTER_JOINT_NAMES`); the other arm, head, grippers and
        torso at rest (their efforts: the other arm's holding torque, zeros elsewhere)."""
        n = len(self.stamps_ns)
        position = np.zeros((n, len(BAXTER_JOINT_NAMES)))
        velocity = np.zeros_like(position)
        effort = np.zeros_like(position)
        other = "left" if self.spec.side == "right" else "right"
        index = {name: k for k, name in enumerate(BAXTER_JOINT_NAMES)}
        for j, name in enumerate(self.joint_names):
            k = index[name]
            position[:, k], velocity[:, k], effort[:, k] = self.q[:, j], self.qd[:, j], self.effort[:, j]
        for j, name in enumerate(self.joint_names):
            k = index[name.replace(self.spec.side, other, 1)]
            position[:, k], effort[:, k] = self.other_q[j], self.other_effort[:, j]
        return RobotJointStates(BAXTER_JOINT_NAMES, self.stamps_ns, position, velocity, effort)

    def ground_truth(self) -> dict[str, Any]:
        """The spec and summary figures, for the JSON written beside the recording."""
        error = self.q_ref - self.q_true
        return {
            "format": "baxter_dynamics_ros simulation ground truth, version 1",
            "spec": self.spec.to_dict(),
            "joint_names": list(self.joint_names),
            "samples": len(self.stamps_ns),
            "start_stamp_ns": int(self.stamps_ns[0]),
            "sign_convention": "recorded effort = rigid-body M q̈ + C + G of the nominal arm + Σ effect torques "
            "(each effect's share; the s1 spring's share is minus the torque it applies)",
            "tracking_rms_rad": np.sqrt(np.mean(error**2, axis=0)).tolist(),
            "saturated_steps": self.saturated_steps,
            **({"collisions": self.collision_truth()} if self.spec.collisions else {}),
        }

    def collision_truth(self) -> list[dict[str, Any]]:
        """Per collision: start_s, end_s, link, profile and the peak |τ_ext| per joint over the
        recorded samples in its window (N·m, 7; the torque on the arm, −residual)."""
        t = (self.stamps_ns - self.stamps_ns[0]) * 1e-9
        truth = []
        for c in self.spec.collisions:
            inside = (t >= c.start_s) & (t <= c.end_s)
            peak = np.abs(self.tau_external[inside]).max(axis=0) if inside.any() else np.zeros(N)
            truth.append({"start_s": c.start_s, "end_s": c.end_s, "link": c.link, "profile": c.profile,
                          "peak_joint_torque_nm": peak.tolist()})  # fmt: skip
        return truth


def write_ground_truth(path: str | os.PathLike[str], result: SimulationResult) -> None:
    """Write :meth:`SimulationResult.ground_truth` as indented JSON at ``path``."""
    with open(path, "w", encoding="utf-8") as stream:
        json.dump(result.ground_truth(), stream, indent=2, ensure_ascii=False)
        stream.write("\n")


def read_spec_json(path: str | os.PathLike[str]) -> SimulationSpec:
    """The :class:`SimulationSpec` of a ground-truth JSON file written by :func:`write_ground_truth`."""
    try:
        with open(path, encoding="utf-8") as stream:
            raw = json.load(stream)
    except (OSError, json.JSONDecodeError) as err:
        raise EffectSpecError(f"{path}: cannot read the ground-truth JSON ({err})") from err
    if not isinstance(raw, dict) or "spec" not in raw:
        raise EffectSpecError(f"{path}: no 'spec' in this file; is it a simulation's ground truth?")
    return SimulationSpec.from_dict(raw["spec"])


# ----------------------------------------------------------------------------- compiled plant and loop
@njit(cache=True)
def _plant_share(q, qd, viscous, friction, spring, out):
    """Σ of the state-dependent effect shares (friction, spring), N·m, into out (7,).

    friction (2, 4, 7): for the Coulomb and the Stribeck effect, rows F_c, F_s, v_s, v_ε.
    spring (3,): preload, cosine, sine coefficients (zeros when off).
    """
    for j in range(N):
        s = viscous[j] * qd[j]
        for f in range(2):
            s += friction_law(qd[j], friction[f, 0, j], friction[f, 1, j], friction[f, 2, j], friction[f, 3, j])
        out[j] = s
    out[S1] += s1_spring_law(q[S1], spring[0], spring[1], spring[2])


@njit(cache=True)
def _acceleration(dh, J, g, armature, viscous, friction, spring, q, qd, tau, out):
    """Plant q̈ = (M + diag(armature))⁻¹ (τ − C − G − shares), rad/s²; q, qd, tau, out (1, 7).

    Calls the core's compiled batch kernels on one-sample batches.
    """
    rhs = np.empty((1, N))
    _plant_share(q[0], qd[0], viscous, friction, spring, rhs[0])
    rhs[0] = tau[0] - rhs[0]
    if not np.any(armature):
        lagrange_euler.batch_forward_dynamics(dh, J, g, q, qd, rhs, out)
        return
    m = np.empty((1, N, N))
    h = np.empty((1, N))
    lagrange_euler.batch_mass_matrix(dh, J, q, m)
    lagrange_euler.batch_inverse_dynamics(dh, J, g, q, qd, np.zeros((1, N)), True, h)
    for j in range(N):
        m[0, j, j] += armature[j]
    lagrange_euler.cholesky_solve(m[0], rhs[0] - h[0], np.empty((N, N)), out[0])


@njit(cache=True)
def _reference(ref_q, ref_qd, ref_dt, t, q_out, qd_out):
    """Cubic Hermite interpolation of the reference at t ≥ 0 s (held at its start for t < 0)."""
    if t <= 0.0:
        q_out[:] = ref_q[0]
        qd_out[:] = 0.0
        return
    x = t / ref_dt
    i = min(int(x), ref_q.shape[0] - 2)
    s = x - i
    s2, s3 = s * s, s * s * s
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    d00, d10, d01, d11 = 6 * s2 - 6 * s, 3 * s2 - 4 * s + 1, -6 * s2 + 6 * s, 3 * s2 - 2 * s
    for j in range(N):
        a, b = ref_q[i, j], ref_q[i + 1, j]
        va, vb = ref_qd[i, j] * ref_dt, ref_qd[i + 1, j] * ref_dt
        q_out[j] = h00 * a + h10 * va + h01 * b + h11 * vb
        qd_out[j] = (d00 * a + d10 * va + d01 * b + d11 * vb) / ref_dt


@njit(cache=True)
def _external_torque(dh, coll_time, coll_force, coll_torque, t, q, pose, jac, out):
    """Σ of the collisions' τ_ext at time t (s) and posture q (1, 7), N·m, into out (7,)."""
    out[:] = 0.0
    for c in range(coll_time.shape[0]):
        start, duration, ramp, profile = coll_time[c, 0], coll_time[c, 1], coll_time[c, 2], coll_time[c, 3]
        s = t - start
        if s < 0.0 or s > duration:
            continue
        if profile == 0.0:
            scale = np.sin(np.pi * s / duration)
        else:
            edge = min(s, duration - s)
            scale = 1.0 if edge >= ramp else 0.5 - 0.5 * np.cos(np.pi * edge / ramp)
        lagrange_euler.batch_kinematics(dh, q, pose, jac)
        for j in range(N):
            out[j] += scale * (coll_torque[c, j] + jac[0, 0, j] * coll_force[c, 0] + jac[0, 1, j] * coll_force[c, 1] + jac[0, 2, j] * coll_force[c, 2])


@njit(cache=True)
def _run(
    dh, j_true, j_nominal, g, armature, viscous, friction, spring,
    kp, kd, bandwidth, tau_limit, ref_q, ref_qd, ref_dt, q_init, dt, n_settle, every, delay_steps,
    coll_time, coll_force, coll_torque,
    out_q, out_qd, out_qdd, out_tau, out_tau_late, out_qref, out_ext,
):  # fmt: skip
    """Settle, then control, integrate (RK4) and record; returns (failed step or −1, saturated steps).

    coll_time (C, 4): start, duration, ramp (s) and profile (0 impact, 1 push) of each collision;
    coll_force (C, 3) at the flange, coll_torque (C, 7) on the joints.
    """
    q = q_init.copy().reshape(1, N)
    qd = np.zeros((1, N))
    eps = np.zeros(N)
    qr, qdr, grav, tau = np.empty(N), np.empty(N), np.empty((1, N)), np.empty((1, N))
    inertia, pi = np.empty((1, N, N)), np.empty(N)
    ki = bandwidth * bandwidth / INTEGRAL_RATIO
    a1, a2, a3, a4 = np.empty((1, N)), np.empty((1, N)), np.empty((1, N)), np.empty((1, N))
    ring_len = int(delay_steps.max()) + 2
    ring = np.zeros((ring_len, N))
    n_record = out_q.shape[0]
    total = n_settle + (n_record - 1) * every + 1
    saturated = 0
    ext = np.zeros((1, N))
    plant_tau = np.empty((1, N))
    pose, jac = np.empty((1, 4, 4)), np.empty((1, 6, N))
    for step in range(total):
        t = (step - n_settle) * dt
        _reference(ref_q, ref_qd, ref_dt, t, qr, qdr)
        lagrange_euler.batch_gravity(dh, j_nominal, g, q, grav)
        lagrange_euler.batch_mass_matrix(dh, j_true, q, inertia)
        for j in range(N):
            inertia[0, j, j] += armature[j]
            eps_dot = qdr[j] + kp * (qr[j] - q[0, j]) + kd * (qdr[j] - qd[0, j]) - qd[0, j]  # eq. 14: q̇_d − q̇
            eps[j] += eps_dot * dt
            pi[j] = bandwidth * eps_dot + ki * eps[j]
        clipped = False
        for j in range(N):
            u = grav[0, j]  # eq. 15 with K_v = ω_v M, K_i = ω_v² M / 10, + gravity feed-forward
            for c in range(N):
                u += inertia[0, j, c] * pi[c]
            if u > tau_limit[j] or u < -tau_limit[j]:
                u = min(max(u, -tau_limit[j]), tau_limit[j])
                clipped = True
            tau[0, j] = u
        saturated += clipped
        ring[step % ring_len] = tau[0]
        act = tau
        if coll_time.shape[0] > 0:
            _external_torque(dh, coll_time, coll_force, coll_torque, t, q, pose, jac, ext[0])
            plant_tau[0] = tau[0] + ext[0]
            act = plant_tau
        _acceleration(dh, j_true, g, armature, viscous, friction, spring, q, qd, act, a1)
        if step >= n_settle and (step - n_settle) % every == 0:
            k = (step - n_settle) // every
            out_q[k] = q[0]
            out_qd[k] = qd[0]
            out_qdd[k] = a1[0]
            out_tau[k] = tau[0]
            out_qref[k] = qr
            out_ext[k] = ext[0]
            for j in range(N):
                s = step - delay_steps[j]
                i0 = int(np.floor(s))
                frac = s - i0
                out_tau_late[k, j] = (1.0 - frac) * ring[i0 % ring_len, j] + frac * ring[(i0 + 1) % ring_len, j]
        _acceleration(dh, j_true, g, armature, viscous, friction, spring,
                      q + 0.5 * dt * qd, qd + 0.5 * dt * a1, act, a2)  # fmt: skip
        _acceleration(dh, j_true, g, armature, viscous, friction, spring,
                      q + 0.5 * dt * qd + 0.25 * dt * dt * a1, qd + 0.5 * dt * a2, act, a3)  # fmt: skip
        _acceleration(dh, j_true, g, armature, viscous, friction, spring,
                      q + dt * qd + 0.5 * dt * dt * a2, qd + dt * a3, act, a4)  # fmt: skip
        q = q + dt * qd + dt * dt / 6.0 * (a1 + a2 + a3)
        qd = qd + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        if not np.all(np.isfinite(qd)):
            return step, saturated
    return -1, saturated


# ----------------------------------------------------------------------------- assembling a run
def _collision_arrays(collisions: tuple[Collision, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The compiled loop's (C, 4) timing, (C, 3) flange force and (C, 7) joint torque arrays."""
    timing = np.array([[c.start_s, c.duration_s, c.ramp_s, COLLISION_PROFILES.index(c.profile)] for c in collisions]).reshape(-1, 4)
    force = np.array([c.force_n if c.link == "flange" else (0.0,) * 3 for c in collisions]).reshape(-1, 3)
    torque = np.array([c.torque_nm if c.link == "joints" else (0.0,) * N for c in collisions]).reshape(-1, N)
    return timing, force, torque


def external_torques(arm: ArmModel, collisions: tuple[Collision, ...], t_s: np.ndarray, q: np.ndarray) -> np.ndarray:
    """τ_ext (N, 7) N·m of ``collisions`` at times t_s (N,) s and postures q (N, 7) rad, as the plant gets it."""
    timing, force, torque = _collision_arrays(tuple(collisions))
    q = np.ascontiguousarray(q, dtype=np.float64).reshape(-1, N)
    out = np.zeros_like(q)
    pose, jac = np.empty((1, 4, 4)), np.empty((1, 6, N))
    dh = np.ascontiguousarray(arm.dh)
    for k in range(len(q)):
        _external_torque(dh, timing, force, torque, float(t_s[k]), q[k : k + 1], pose, jac, out[k])
    return out



class _Plant(NamedTuple):
    j_true: np.ndarray
    armature: np.ndarray
    viscous: np.ndarray
    friction: np.ndarray
    spring: np.ndarray


def _plant(arm: ArmModel, spec: SimulationSpec) -> _Plant:
    """The physical effects of the spec as the compiled loop's arrays."""
    j_true = arm.pseudo_inertias.copy()
    for effect in spec.effects:
        if isinstance(effect, InertialChange):
            j_true += effect.pseudo_inertia_change(arm)
    armature = spec.effect(Armature)
    viscous = spec.effect(ViscousFriction)
    friction = np.zeros((2, 4, N))
    friction[:, 2:] = 1.0  # harmless scales for an absent law (its forces are 0)
    coulomb = spec.effect(CoulombFriction)
    if coulomb is not None:
        friction[0] = [coulomb.friction_nm, coulomb.friction_nm, np.ones(N), np.full(N, coulomb.smoothing_rad_s)]
    stribeck = spec.effect(StribeckFriction)
    if stribeck is not None:
        friction[1] = [
            stribeck.coulomb_nm,
            stribeck.static_nm,
            np.full(N, stribeck.stribeck_rad_s),
            np.full(N, stribeck.smoothing_rad_s),
        ]
    spring = spec.effect(S1Spring)
    return _Plant(
        j_true,
        np.zeros(N) if armature is None else armature.inertia_kgm2.copy(),
        np.zeros(N) if viscous is None else viscous.damping_nm_s_rad.copy(),
        friction,
        np.zeros(3) if spring is None else np.array([spring.preload_nm, spring.cosine_nm, spring.sine_nm]),
    )


def _check_stability(arm: ArmModel, plant: _Plant, bandwidth: float, reference: JointReference, dt_s: float) -> None:
    """Refuse a run whose velocity dynamics are too stiff for the step anywhere on the reference.

    The fastest rate is ω_v + the largest eigenvalue of M⁻¹ D, D the friction slopes at q̇ = 0,
    on postures sampled every 0.5 s; RK4 and the sampled loop need λ·Δt < :data:`STABILITY_LIMIT`.
    """
    from scipy.linalg import eigh

    postures = reference.q[:: max(1, int(round(0.5 / reference.dt_s)))]
    masses = lagrange_euler.mass_matrix(arm.dh, plant.j_true, postures) + np.diag(plant.armature)
    slope = plant.viscous + (plant.friction[:, 1] / plant.friction[:, 3]).sum(axis=0)
    rates = [bandwidth + float(eigh(np.diag(slope), m, eigvals_only=True)[-1]) for m in masses]
    worst = int(np.argmax(rates))
    if rates[worst] * dt_s > STABILITY_LIMIT:
        inertia = 1.0 / np.diag(np.linalg.inv(masses[worst]))
        j = int(np.argmax(slope / inertia))
        raise SimulationError(
            f"the arm's velocity dynamics are too stiff for a {dt_s * 1e3:g} ms step: {arm.joint_names[j]} has "
            f"friction slope {slope[j]:.3g} N·m·s/rad (F_s / smoothing at q̇ = 0) against an effective inertia of "
            f"{inertia[j]:.3g} kg·m² (and the controller's {bandwidth:g} rad/s); raise smoothing_rad_s, lower the "
            f"friction, or raise physics_rate_hz above {rates[worst] / STABILITY_LIMIT:.0f} Hz"
        )


def simulate(spec: SimulationSpec, arm: ArmModel | None = None, reference: JointReference | None = None) -> SimulationResult:
    """Simulate and record ``spec`` (module docstring). arm: the nominal model (default: the
    package's model of spec.side); reference: a precomputed reference of spec's trajectory."""
    arm = load_arm_model(spec.side) if arm is None else arm
    if arm.side != spec.side:
        raise SimulationError(f"the spec simulates the {spec.side} arm but the model is of the {arm.side} arm")
    if reference is None:
        reference = make_reference(arm, spec.trajectory, spec.duration_s, seed=spec.seed)
    n = spec.samples
    if n < 2 or (n - 1) / spec.rate_hz > reference.duration_s:
        raise SimulationError(f"{spec.duration_s} s at {spec.rate_hz} Hz: need >= 2 samples inside the reference's {reference.duration_s} s")
    dt = 1.0 / spec.physics_rate_hz
    every = int(round(spec.physics_rate_hz / spec.rate_hz))
    plant = _plant(arm, spec)
    q_init = np.ascontiguousarray(reference.q[0])
    gains = spec.controller
    _check_stability(arm, plant, gains.inner_bandwidth_rad_s, reference, dt)
    delay = spec.effect(Delay)
    delay_steps = np.zeros(N) if delay is None else delay.delay_s / dt
    out = {k: np.empty((n, N)) for k in ("q", "qd", "qdd", "tau", "tau_late", "qref")}
    out["ext"] = np.zeros((n, N))
    coll_time, coll_force, coll_torque = _collision_arrays(spec.collisions)
    failed, saturated = _run(
        np.ascontiguousarray(arm.dh), plant.j_true, np.ascontiguousarray(arm.pseudo_inertias), np.array(arm.gravity_m_s2),
        plant.armature, plant.viscous, plant.friction, plant.spring,
        gains.outer_kp_1_s, gains.outer_kd, gains.inner_bandwidth_rad_s, np.array(arm.effort_limit_nm), np.ascontiguousarray(reference.q), np.ascontiguousarray(reference.qd),
        reference.dt_s, q_init, dt, int(round(spec.settle_s / dt)), every, delay_steps,
        coll_time, coll_force, coll_torque,
        out["q"], out["qd"], out["qdd"], out["tau"], out["tau_late"], out["qref"], out["ext"],
    )  # fmt: skip
    if failed >= 0:
        raise SimulationError(f"the simulation diverged at t = {failed * dt - spec.settle_s:.3f} s; lower the effects' stiffness or raise physics_rate_hz")
    return _record(arm, spec, reference, out, saturated)


def _quantise(x: np.ndarray, step: float) -> np.ndarray:
    return np.round(x / step) * step if step > 0 else x


def _record(arm: ArmModel, spec: SimulationSpec, reference: JointReference, out: dict[str, np.ndarray], saturated: int) -> SimulationResult:
    """Sensor side: noise, offset, quantisation; the other arm at rest."""
    n = spec.samples
    rng = np.random.default_rng([spec.seed, 1])
    velocity_noise = rng.standard_normal((n, N))
    effort_noise = rng.standard_normal((n, N))
    other_noise = rng.standard_normal((n, N))
    noise = spec.effect(AccelerationNoise)
    qd = out["qd"] + (0.0 if noise is None else velocity_noise * noise.velocity_noise_rad_s)
    offset = spec.effect(TorqueOffset)
    effort = out["tau_late"] + (0.0 if offset is None else offset.offset_nm) + effort_noise * spec.sensor.effort_noise_nm
    other_arm = load_arm_model("left" if spec.side == "right" else "right")
    other_q = _quantise(seed_posture(other_arm.side), spec.sensor.position_step_rad)
    other_hold = other_arm.gravity(other_q)
    spring = spec.effect(S1Spring)
    if spring is not None:
        other_hold = other_hold + spring.torque(other_arm, other_q, np.zeros(N), np.zeros(N))
    other_effort = other_hold + other_noise * spec.sensor.effort_noise_nm
    step_nm = spec.sensor.effort_step_nm
    x_target = None
    if reference.x_m is not None:
        t_ref = np.arange(len(reference.x_m)) * reference.dt_s
        t = np.arange(n) / spec.rate_hz
        x_target = np.stack([np.interp(t, t_ref, reference.x_m[:, c]) for c in range(3)], axis=1)
    return SimulationResult(
        spec=spec,
        joint_names=arm.joint_names,
        stamps_ns=START_STAMP_NS + np.round(np.arange(n) * (1e9 / spec.rate_hz)).astype(np.int64),
        q=_quantise(out["q"], spec.sensor.position_step_rad),
        qd=qd,
        effort=_quantise(effort, step_nm),
        q_true=out["q"],
        qd_true=out["qd"],
        qdd_true=out["qdd"],
        tau_actuator=out["tau"],
        q_ref=out["qref"],
        x_target=x_target,
        other_q=other_q,
        other_effort=_quantise(other_effort, step_nm),
        saturated_steps=int(saturated),
        tau_external=out["ext"],
    )
