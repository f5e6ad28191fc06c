"""The simulated Baxter arm: the plant with its unmodelled effects, and the controller that drives it.

The plant is the core's rigid-body model (:mod:`baxter_dynamics_ros.core.lagrange_euler`) with the
physical effects of a :class:`SimulationSpec` acting on it:

    (M_true(q) + diag(armature)) q̈ = τ_act − C_true(q, q̇) − G_true(q) − τ_friction(q̇) − τ_spring_share(q_s1)

M_true, C_true, G_true use the arm's pseudo-inertias plus the changes of ``payload`` and
``inertial_error``; τ_friction sums ``viscous_friction``, ``coulomb_friction``,
``stribeck_friction`` and ``dahl_friction`` (F ⊙ z, its state z integrated with the motion:
ż = (q̇ − z |q̇|) / θ_p, the rate of :func:`~baxter_dynamics_ros.core.effects.presliding_state`'s
exact step, z = 0 at the start of the settling); the spring's share is :class:`~baxter_dynamics_ros.core.effects.S1Spring`'s
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

:func:`simulate` runs a :class:`~.spec.SimulationSpec` and hands the motion to :func:`.sensor.record`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ..core import lagrange_euler
from ..core.arm_model import ArmModel, load_arm_model
from ..core.effects import (
    Armature,
    CoulombFriction,
    DahlFriction,
    Delay,
    InertialChange,
    S1Spring,
    StribeckFriction,
    ViscousFriction,
    friction_law,
    s1_spring_law,
)
from ..core.joints import JOINTS as N
from ..core.joints import S1
from ..errors import SimulationError
from .sensor import SimulationResult, record
from .spec import COLLISION_PROFILES, Collision, SimulationSpec
from .trajectories import JointReference, make_reference

__all__ = [
    "INTEGRAL_RATIO",
    "STABILITY_LIMIT",
    "external_torques",
    "simulate",
]

#: Largest λ·Δt allowed, λ the fastest decay rate of the velocity dynamics (RK4 and the
#: sampled velocity loop stay stable and accurate below 2).
STABILITY_LIMIT = 2.0
#: K_i = K_v · ω_v / INTEGRAL_RATIO (eq. 15).
INTEGRAL_RATIO = 10.0


@njit(cache=True)
def _plant_share(q, qd, viscous, friction, spring, out):
    """Σ of the state-dependent effect shares (friction, spring), N·m, into out (7,).

    friction (2, 4, 7): for the Coulomb and the Stribeck effect, rows F_c, F_s, v_s, v_ε.
    spring (4,): preload, linear, cosine, sine coefficients (zeros when off).
    """
    for j in range(N):
        s = viscous[j] * qd[j]
        for f in range(2):
            s += friction_law(qd[j], friction[f, 0, j], friction[f, 1, j], friction[f, 2, j], friction[f, 3, j])
        out[j] = s
    out[S1] += s1_spring_law(q[S1], spring[0], spring[1], spring[2], spring[3])


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
def _presliding_rate(qd, z, angle, out):
    """Dahl's ż = (q̇ − z |q̇|) / θ_p, 1/s, into out (7,); qd, z (7,)."""
    for j in range(N):
        out[j] = (qd[j] - z[j] * abs(qd[j])) / angle


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
    dh, j_true, j_nominal, g, armature, viscous, friction, spring, dahl_nm, dahl_rad,
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
    z = np.zeros(N)  # Dahl's friction state
    z1, z2, z3, z4 = np.empty(N), np.empty(N), np.empty(N), np.empty(N)
    stage = np.empty((1, N))
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
        stage[0] = act[0] - dahl_nm * z
        _presliding_rate(qd[0], z, dahl_rad, z1)
        _acceleration(dh, j_true, g, armature, viscous, friction, spring, q, qd, stage, a1)
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
        stage[0] = act[0] - dahl_nm * (z + 0.5 * dt * z1)
        _presliding_rate(qd[0] + 0.5 * dt * a1[0], z + 0.5 * dt * z1, dahl_rad, z2)
        _acceleration(dh, j_true, g, armature, viscous, friction, spring,
                      q + 0.5 * dt * qd, qd + 0.5 * dt * a1, stage, a2)  # fmt: skip
        stage[0] = act[0] - dahl_nm * (z + 0.5 * dt * z2)
        _presliding_rate(qd[0] + 0.5 * dt * a2[0], z + 0.5 * dt * z2, dahl_rad, z3)
        _acceleration(dh, j_true, g, armature, viscous, friction, spring,
                      q + 0.5 * dt * qd + 0.25 * dt * dt * a1, qd + 0.5 * dt * a2, stage, a3)  # fmt: skip
        stage[0] = act[0] - dahl_nm * (z + dt * z3)
        _presliding_rate(qd[0] + dt * a3[0], z + dt * z3, dahl_rad, z4)
        _acceleration(dh, j_true, g, armature, viscous, friction, spring,
                      q + dt * qd + 0.5 * dt * dt * a2, qd + dt * a3, stage, a4)  # fmt: skip
        q = q + dt * qd + dt * dt / 6.0 * (a1 + a2 + a3)
        qd = qd + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        z = np.minimum(np.maximum(z + dt / 6.0 * (z1 + 2.0 * z2 + 2.0 * z3 + z4), -1.0), 1.0)
        if not np.all(np.isfinite(qd)):
            return step, saturated
    return -1, saturated


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
    dahl_nm: np.ndarray  # (7,) Dahl's friction F, N·m (zeros when off)
    dahl_rad: float  # its presliding angle θ_p, rad (1 when off: harmless)


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
    dahl = spec.effect(DahlFriction)
    return _Plant(
        j_true,
        np.zeros(N) if armature is None else armature.inertia_kgm2.copy(),
        np.zeros(N) if viscous is None else viscous.damping_nm_s_rad.copy(),
        friction,
        np.zeros(4) if spring is None else spring.parameter_vector(arm),
        np.zeros(N) if dahl is None else dahl.friction_nm.copy(),
        1.0 if dahl is None else dahl.presliding_rad,
    )


def _check_stability(arm: ArmModel, plant: _Plant, bandwidth: float, reference: JointReference, dt_s: float) -> None:
    """Refuse a run whose velocity dynamics are too stiff for the step anywhere on the reference.

    The fastest rate is ω_v + the largest eigenvalue of M⁻¹ D, D the friction slopes at q̇ = 0,
    on postures sampled every 0.5 s; RK4 and the sampled loop need λ·Δt < :data:`STABILITY_LIMIT`.
    Dahl's friction adds the presliding spring's frequency √λ_max(M⁻¹ F/θ_p) and its state's rate
    1.5 max|q̇_ref| / θ_p, each held to the same limit.
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
    if np.any(plant.dahl_nm > 0.0):
        # Within its presliding angle Dahl's friction is a spring F/θ_p; its state moves at |q̇|/θ_p.
        stiffness = np.diag(plant.dahl_nm / plant.dahl_rad)
        rate = max(
            max(float(np.sqrt(max(eigh(stiffness, m, eigvals_only=True)[-1], 0.0))) for m in masses),
            1.5 * float(np.abs(reference.qd).max()) / plant.dahl_rad,
        )
        if rate * dt_s > STABILITY_LIMIT:
            raise SimulationError(
                f"dahl_friction is too stiff for a {dt_s * 1e3:g} ms step (presliding angle {plant.dahl_rad:g} rad): raise "
                f"presliding_rad, lower the friction, or raise physics_rate_hz above {rate / STABILITY_LIMIT:.0f} Hz"
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
        plant.armature, plant.viscous, plant.friction, plant.spring, plant.dahl_nm, plant.dahl_rad,
        gains.outer_kp_1_s, gains.outer_kd, gains.inner_bandwidth_rad_s, np.array(arm.effort_limit_nm), np.ascontiguousarray(reference.q), np.ascontiguousarray(reference.qd),
        reference.dt_s, q_init, dt, int(round(spec.settle_s / dt)), every, delay_steps,
        coll_time, coll_force, coll_torque,
        out["q"], out["qd"], out["qdd"], out["tau"], out["tau_late"], out["qref"], out["ext"],
    )  # fmt: skip
    if failed >= 0:
        raise SimulationError(f"the simulation diverged at t = {failed * dt - spec.settle_s:.3f} s; lower the effects' stiffness or raise physics_rate_hz")
    return record(arm, spec, reference, out, saturated)
