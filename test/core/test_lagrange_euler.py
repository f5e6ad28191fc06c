"""The Lagrange-Euler core against Pinocchio, the URDF, the paper's literal equations and physics."""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import pytest
from reference_models import (
    URDF_PATH,
    LiteralLagrangeEuler,
    PinocchioArm,
    assert_close,
    paper_reference,
    pinocchio_from_urdf,
    potential_energy,
    random_states,
)

from baxter_dynamics_ros import ArmModel, InputShapeError, load_arm_model
from baxter_dynamics_ros.core import lagrange_euler

N_STATES = 1000
#: Relative tolerances against the paper's Pinocchio model, 2.5 orders or more above the errors
#: measured over the 1000 states (both arms): M, G, τ up to 2.8e-15, the flange pose and Jacobian
#: 4.4e-16, C 2.8e-14, q̈ by aba 3.3e-13 (its M⁻¹ amplifies rounding); the literal equations 2.1e-15.
RTOL = 1e-12
RTOL_C = 1e-11
RTOL_ABA = 1e-10


@pytest.fixture(scope="module", params=["right", "left"])
def arm(request: pytest.FixtureRequest) -> ArmModel:
    return load_arm_model(request.param)


@dataclass(frozen=True)
class PinocchioCase:
    """Random states within the limits and Pinocchio's answers for them, (N_STATES, ...) arrays."""

    arm: ArmModel
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau_in: np.ndarray
    tau: np.ndarray
    tau_no_qdd: np.ndarray
    gravity: np.ndarray
    mass: np.ndarray
    pose: np.ndarray
    jacobian: np.ndarray
    qdd_aba: np.ndarray


@pytest.fixture(scope="module")
def case(arm: ArmModel) -> PinocchioCase:
    """Pinocchio on the paper's tables and the URDF's lengths (not the package's model), per sample."""
    ref = paper_reference(arm.side)
    q, qd, qdd = random_states(arm, N_STATES, seed=2, qdd_max_rad_s2=10.0)
    tau_in = np.random.default_rng(3).uniform(-arm.effort_limit_nm, arm.effort_limit_nm, (N_STATES, 7))

    def each(f, *arrays):
        return np.array([f(*row) for row in zip(*arrays)])

    return PinocchioCase(
        arm=arm,
        q=q,
        qd=qd,
        qdd=qdd,
        tau_in=tau_in,
        tau=each(ref.rnea, q, qd, qdd),
        tau_no_qdd=each(ref.rnea, q, qd, np.zeros_like(qdd)),
        gravity=each(ref.gravity, q),
        mass=each(ref.mass_matrix, q),
        pose=each(ref.flange_pose, q),
        jacobian=each(ref.flange_jacobian, q),
        qdd_aba=each(ref.forward_dynamics, q, qd, tau_in),
    )


# ----------------------------------------------------------------------------- Pinocchio, the paper's parameters
def test_mass_matrix_matches_crba(case: PinocchioCase) -> None:
    assert_close(case.arm.mass_matrix(case.q), case.mass, "M vs crba", rtol=RTOL)


def test_gravity_matches_pinocchio(case: PinocchioCase) -> None:
    assert_close(case.arm.gravity(case.q), case.gravity, "G vs computeGeneralizedGravity", rtol=RTOL)


def test_inverse_dynamics_matches_rnea(case: PinocchioCase) -> None:
    assert_close(case.arm.inverse_dynamics(case.q, case.qd, case.qdd), case.tau, "tau vs rnea", rtol=RTOL)


def test_coriolis_matches_rnea_without_acceleration_and_gravity(case: PinocchioCase) -> None:
    expected = case.tau_no_qdd - case.gravity
    assert_close(case.arm.coriolis(case.q, case.qd), expected, "C vs rnea(q, qd, 0) - G", rtol=RTOL_C)


def test_forward_dynamics_matches_aba(case: PinocchioCase) -> None:
    assert_close(case.arm.forward_dynamics(case.q, case.qd, case.tau_in), case.qdd_aba, "qdd vs aba", rtol=RTOL_ABA)


def test_forward_kinematics_matches_pinocchio(case: PinocchioCase) -> None:
    assert_close(case.arm.forward_kinematics(case.q), case.pose, "flange pose", rtol=RTOL)


def test_jacobian_matches_pinocchio(case: PinocchioCase) -> None:
    assert_close(case.arm.jacobian(case.q), case.jacobian, "flange Jacobian (v, w)", rtol=RTOL)


# ----------------------------------------------------------------------------- the URDF
@pytest.fixture(scope="module")
def urdf(arm: ArmModel) -> PinocchioArm:
    if not URDF_PATH.is_file():
        pytest.skip(f"reference URDF not found at {URDF_PATH}")
    return pinocchio_from_urdf(arm)


def test_base_frame_matches_urdf(arm: ArmModel, urdf: PinocchioArm) -> None:
    """DH frame 0 placed by the model file's mount is the URDF's arm mount + s0 offset (torso = world)."""
    np.testing.assert_allclose(arm.base_in_torso, urdf.base.homogeneous, atol=1e-12)


def test_flange_position_matches_urdf(arm: ArmModel, urdf: PinocchioArm) -> None:
    """Measured: 1.2e-11 m and 2.3e-11 (rotation entries) over 200 states: rounding of the URDF's
    π/2 rpy (1.57079632679). Tolerance 1e-9: a 0.1 mm error of any DH length fails."""
    q, _, _ = random_states(arm, 200, seed=4, qdd_max_rad_s2=0.0)
    expected = np.array([urdf.flange_pose(x) for x in q])
    assert_close(arm.forward_kinematics(q)[:, :3, 3], expected[:, :3, 3], "flange position [m]", atol=1e-9)
    assert_close(arm.forward_kinematics(q)[:, :3, :3], expected[:, :3, :3], "flange rotation", atol=1e-9)


def test_gravity_torque_and_mass_matrix_match_urdf(arm: ArmModel, urdf: PinocchioArm) -> None:
    """Over the whole velocity range (|qd| up to the limits, |qdd| <= 5 rad/s², 300 states).

    What remains is the paper's centres of mass, 0.07 mm off the URDF's on links 3-7, and the
    URDF's 0.1 g sensor links: measured G 0.00076 N·m, τ 0.0012 N·m, M 1.1e-4 kg·m². The tolerances
    sit at about twice that, below what a 20 % error of link 7's tensor gives (τ 0.0080 N·m, M
    3.5e-4 kg·m²).
    """
    q, qd, qdd = random_states(arm, 300, seed=5, qdd_max_rad_s2=5.0)
    gravity = np.array([urdf.gravity(x) for x in q])
    tau = np.array([urdf.rnea(*s) for s in zip(q, qd, qdd)])
    mass = np.array([urdf.mass_matrix(x) for x in q])
    assert_close(arm.gravity(q), gravity, "G vs URDF [N·m]", atol=0.0015)
    assert_close(arm.inverse_dynamics(q, qd, qdd), tau, "tau vs URDF [N·m]", atol=0.0025)
    assert_close(arm.mass_matrix(q), mass, "M vs URDF [kg·m²]", atol=2e-4)


# Holding torques of the URDF model (right arm, no gripper), from ../shared/reference/README.md.
HOLDING = [
    (np.zeros(7), [0.0, -52.876, 0.030, -15.609, 0.201, -1.819, 0.005]),
    (np.array([0.0, -0.55, 0.0, 0.75, 0.0, 1.26, 0.0]), [0.0, -47.582, 0.026, -13.539, 0.197, -0.065, 0.001]),
]


@pytest.mark.parametrize(("q", "expected"), HOLDING, ids=["zero", "neutral"])
def test_holding_torques(arm: ArmModel, q: np.ndarray, expected: list[float]) -> None:
    """Both arms: the mount is a rotation about the vertical, so joint-space torques are the same."""
    assert_close(arm.gravity(q)[None], np.array([expected]), f"{arm.side} holding torque [N·m]", atol=0.01)
    at_rest = arm.inverse_dynamics(q, np.zeros(7), np.zeros(7))
    assert_close(at_rest[None], np.array([expected]), f"{arm.side} tau(q, 0, 0) [N·m]", atol=0.01)


# ----------------------------------------------------------------------------- the paper, literally
def test_recursions_match_literal_equations(arm: ArmModel) -> None:
    oracle = LiteralLagrangeEuler(arm)
    q, qd, qdd = random_states(arm, 4, seed=6, qdd_max_rad_s2=10.0)
    assert_close(arm.mass_matrix(q), np.array([oracle.mass_matrix(x) for x in q]), "M vs eq. (6)", rtol=RTOL)
    assert_close(arm.coriolis(q, qd), np.array([oracle.coriolis(*s) for s in zip(q, qd)]), "C vs eq. (7)", rtol=RTOL)
    assert_close(arm.gravity(q), np.array([oracle.gravity(x) for x in q]), "G vs eq. (8)", rtol=RTOL)
    expected = np.array([oracle.inverse_dynamics(*s) for s in zip(q, qd, qdd)])
    assert_close(arm.inverse_dynamics(q, qd, qdd), expected, "tau vs eq. (1)", rtol=RTOL)


# ----------------------------------------------------------------------------- physics
def test_mass_matrix_symmetric_positive_definite(case: PinocchioCase) -> None:
    """M's columns from the τ recursion, M e_k = τ(q, 0, e_k) − G(q), which computes every entry (the
    mass-matrix kernel fills one triangle and mirrors it): symmetric, and its lower triangle is the
    mass-matrix kernel's; positive definite. Measured (200 states, both arms): asymmetry 3.0e-14, lower
    triangle 2.8e-14 kg·m²."""
    arm, q = case.arm, case.q[:200]
    zero, grav = np.zeros_like(q), arm.gravity(q)
    columns = [arm.inverse_dynamics(q, zero, np.broadcast_to(e, q.shape)) - grav for e in np.eye(7)]
    from_tau = np.stack(columns, axis=-1)  # [n, i, k] = M_ik
    assert_close(from_tau, np.swapaxes(from_tau, -1, -2), "M from τ vs its transpose [kg·m²]", atol=1e-11)
    lower = np.tril_indices(7)
    mass = arm.mass_matrix(q)
    assert_close(from_tau[:, lower[0], lower[1]], mass[:, lower[0], lower[1]], "M from τ vs mass_matrix, lower triangle", atol=1e-11)
    assert np.linalg.eigvalsh(mass).min() > 0.0


def _mass_matrix_gradient(arm: ArmModel, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """∂M/∂q_k (7, 7, 7), index k first, by central differences of mass_matrix."""
    steps = h * np.eye(7)
    return (arm.mass_matrix(q + steps) - arm.mass_matrix(q - steps)) / (2.0 * h)


def test_christoffel_structure(arm: ArmModel) -> None:
    """With N_ij = Σ_k c_ijk q̇_k (Christoffel symbols of M by finite differences): C = N q̇. And the
    power balance of the kernel's C against M along the motion: q̇ᵀ (Ṁ − 2 C(q, q̇)) = 0, Ṁ by a
    central difference of M at q ± h q̇ (what Ṁ − 2N skew-symmetric says, with the code's C, not N).
    Measured (20 states, both arms): C vs N q̇ 3.2e-9 relative, the balance 6.6e-9 W against
    |q̇ᵀ Ṁ q̇| up to 8.9 W (both limited by the differences' rounding)."""
    q, qd, _ = random_states(arm, 20, seed=7, qdd_max_rad_s2=0.0)
    h = 1e-6
    worst = 0.0
    for qi, qdi in zip(q, qd):
        dm = _mass_matrix_gradient(arm, qi)
        christoffel = 0.5 * (dm.transpose(1, 2, 0) + dm.transpose(1, 0, 2) - dm)  # c[i, j, k]
        n_matrix = christoffel @ qdi
        assert_close(arm.coriolis(qi, qdi)[None], (n_matrix @ qdi)[None], "C vs N qd", rtol=1e-6)
        m_dot = (arm.mass_matrix(qi + h * qdi) - arm.mass_matrix(qi - h * qdi)) / (2.0 * h)
        power = qdi @ m_dot @ qdi - 2.0 * qdi @ arm.coriolis(qi, qdi)
        worst = max(worst, abs(power))
    assert worst <= 1e-6, f"q̇ᵀ(Ṁ − 2C)q̇ up to {worst:.3g} W"


def test_gravity_is_gradient_of_potential(arm: ArmModel) -> None:
    q, _, _ = random_states(arm, 5, seed=8, qdd_max_rad_s2=0.0)
    h = 1e-6
    for qi in q:
        grad = [(potential_energy(arm, qi + h * e) - potential_energy(arm, qi - h * e)) / (2 * h) for e in np.eye(7)]
        assert_close(arm.gravity(qi)[None], np.array([grad]), "G vs dP/dq", atol=1e-6)


def test_free_motion_conserves_energy(arm: ArmModel) -> None:
    """τ = 0 with gravity, RK4 at 0.25 ms for 2 s, 4 initial states integrated as one batch."""
    q, qd, _ = random_states(arm, 4, seed=9, qdd_max_rad_s2=0.0)
    qd = 0.5 * qd
    tau = np.zeros_like(q)
    dt_s, steps = 2.5e-4, 8000

    def rates(x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return v, arm.forward_dynamics(x, v, tau)

    def energy(x: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        kinetic = 0.5 * np.einsum("ni,nij,nj->n", v, arm.mass_matrix(x), v)
        return kinetic, kinetic + np.array([potential_energy(arm, xi) for xi in x])

    kinetic, e0 = energy(q, qd)
    kinetic_max, drift = kinetic, np.zeros(len(q))
    for step in range(1, steps + 1):
        k1 = rates(q, qd)
        k2 = rates(q + 0.5 * dt_s * k1[0], qd + 0.5 * dt_s * k1[1])
        k3 = rates(q + 0.5 * dt_s * k2[0], qd + 0.5 * dt_s * k2[1])
        k4 = rates(q + dt_s * k3[0], qd + dt_s * k3[1])
        q = q + dt_s / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        qd = qd + dt_s / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
        if step % 100 == 0:
            kinetic, e = energy(q, qd)
            kinetic_max = np.maximum(kinetic_max, kinetic)
            drift = np.maximum(drift, np.abs(e - e0))
    assert np.all(kinetic_max > 10.0), "the arm should swing: too little energy exchanged to test anything"
    relative = drift / kinetic_max
    assert np.all(relative <= 1e-6), f"energy drift relative to peak kinetic energy: {relative}"


# ----------------------------------------------------------------------------- batches and shapes
def _all_outputs(arm: ArmModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> dict[str, np.ndarray]:
    return {
        "gravity": arm.gravity(q),
        "mass_matrix": arm.mass_matrix(q),
        "coriolis": arm.coriolis(q, qd),
        "inverse_dynamics": arm.inverse_dynamics(q, qd, qdd),
        "forward_dynamics": arm.forward_dynamics(q, qd, qdd),
        "forward_kinematics": arm.forward_kinematics(q),
        "jacobian": arm.jacobian(q),
    }


TRAILING = {"mass_matrix": (7, 7), "forward_kinematics": (4, 4), "jacobian": (6, 7)}


@pytest.mark.parametrize("lead", [(), (5,), (2, 3), (0,)], ids=["single", "batch", "2d-batch", "empty"])
def test_outputs_keep_leading_shape_and_match_per_sample(lead: tuple[int, ...]) -> None:
    arm = load_arm_model("right")
    n = int(np.prod(lead, dtype=int))
    q, qd, qdd = (x.reshape(lead + (7,)) for x in random_states(arm, n, seed=10, qdd_max_rad_s2=5.0))
    batched = _all_outputs(arm, q, qd, qdd)
    flat = [x.reshape(-1, 7) for x in (q, qd, qdd)]
    for name, out in batched.items():
        assert out.shape == lead + TRAILING.get(name, (7,)), name
        singles = [_all_outputs(arm, *s)[name] for s in zip(*flat)]
        expected = np.array(singles).reshape(out.shape)
        np.testing.assert_allclose(out, expected, rtol=1e-13, atol=1e-13, err_msg=name)


def test_accepts_lists_and_integer_arrays() -> None:
    arm = load_arm_model("right")
    np.testing.assert_array_equal(arm.gravity([0, 0, 0, 0, 0, 0, 0]), arm.gravity(np.zeros(7)))


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda arm: arm.gravity(np.zeros(6)), r"q: expected shape \(7,\) or \(N, 7\), got \(6,\)"),
        (lambda arm: arm.mass_matrix(np.float64(0.0)), r"q: expected shape \(7,\) or \(N, 7\), got \(\)"),
        (lambda arm: arm.jacobian(np.zeros((3, 6))), r"q: expected shape .* got \(3, 6\)"),
        (lambda arm: arm.forward_kinematics(np.zeros((7, 3))), r"q: expected shape .* got \(7, 3\)"),
        (lambda arm: arm.coriolis(np.zeros(7), np.zeros(8)), r"qd: expected shape .* got \(8,\)"),
        (
            lambda arm: arm.inverse_dynamics(np.zeros((5, 7)), np.zeros((4, 7)), np.zeros((5, 7))),
            r"inputs must have the same shape, got q \(5, 7\), qd \(4, 7\), qdd \(5, 7\)",
        ),
        (lambda arm: arm.forward_dynamics(np.zeros(7), np.zeros(7), np.zeros((1, 7))), r"tau \(1, 7\)"),
    ],
    ids=["short", "scalar", "batch-of-6", "transposed", "qd-long", "batch-mismatch", "single-vs-batch"],
)
def test_wrong_shapes_raise_input_shape_error(call, match: str) -> None:
    with pytest.raises(InputShapeError, match=match):
        call(load_arm_model("right"))


# ----------------------------------------------------------------------------- blocks, lanes and threads
def _pinocchio_answers(ref: PinocchioArm, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray):
    """τ, G and M of Pinocchio, sample by sample."""
    tau = np.array([ref.rnea(a, b, c) for a, b, c in zip(q, qd, qdd)])
    grav = np.array([ref.gravity(a) for a in q])
    mass = np.array([ref.mass_matrix(a) for a in q])
    return tau, grav, mass


@pytest.mark.parametrize(
    "n",
    [1, lagrange_euler.LANES - 1, lagrange_euler.LANES + 1,
     lagrange_euler.PARALLEL_MIN_SAMPLES - 1, lagrange_euler.PARALLEL_MIN_SAMPLES + 3 * lagrange_euler.LANES + 5],
)
def test_every_batch_size_matches_pinocchio_to_1e12(n: int) -> None:
    """Partial blocks, the serial path and the path split over threads: all rows to 1e-12 relative."""
    arm = load_arm_model("right")
    q, qd, qdd = random_states(arm, n, seed=n, qdd_max_rad_s2=10.0)
    tau, grav, mass = _pinocchio_answers(paper_reference(arm.side), q, qd, qdd)
    assert_close(arm.inverse_dynamics(q, qd, qdd), tau, f"tau, {n} samples", rtol=1e-12)
    assert_close(arm.gravity(q), grav, f"G, {n} samples", rtol=1e-12)
    assert_close(arm.mass_matrix(q), mass, f"M, {n} samples", rtol=1e-12)


def test_threads_change_no_bit_of_the_results() -> None:
    """A batch past the parallel threshold gives the same bits on one thread and on all of them."""
    arm = load_arm_model("right")
    q, qd, qdd = random_states(arm, 2 * lagrange_euler.PARALLEL_MIN_SAMPLES + 7, seed=3, qdd_max_rad_s2=10.0)
    threads = numba.config.NUMBA_NUM_THREADS
    results = {}
    try:
        for n_threads in (1, threads):
            numba.set_num_threads(n_threads)
            results[n_threads] = (arm.inverse_dynamics(q, qd, qdd), arm.gravity(q), arm.mass_matrix(q))
    finally:
        numba.set_num_threads(threads)
    for one, every, what in zip(results[1], results[threads], ("tau", "G", "M")):
        np.testing.assert_array_equal(one, every, err_msg=what)


def test_a_bad_sample_stays_in_its_lane() -> None:
    """NaN, inf and angles past the sine polynomial's range (libm there) in one block: the other lanes
    keep their single-sample values, the far angles match Pinocchio, the non-finite rows are NaN."""
    arm = load_arm_model("right")
    n = 2 * lagrange_euler.LANES
    q, qd, qdd = random_states(arm, n, seed=5, qdd_max_rad_s2=10.0)
    q[3, 2], q[4, 0], qd[5, 6] = np.nan, np.inf, np.nan
    # Beyond 1e5 rad libm, within it the polynomial; on joints without a θ offset, so that θ = q exactly
    # (q + offset would round by up to ulp(q), 3e-11 rad at 2.5e5 rad, in both implementations alike).
    q[6, 2], q[7, 4], q[8, 3] = 2.5e5, -4.0e4, 1.0e6
    tau, grav, mass = arm.inverse_dynamics(q, qd, qdd), arm.gravity(q), arm.mass_matrix(q)
    ref = paper_reference(arm.side)
    good = [i for i in range(n) if i not in (3, 4, 5)]
    one_by_one = np.array([arm.inverse_dynamics(q[i], qd[i], qdd[i]) for i in good])
    assert_close(tau[good], one_by_one, "tau of the finite rows, batch vs one by one", rtol=1e-14)
    far = [6, 7, 8]
    want_tau, want_grav, want_mass = _pinocchio_answers(ref, q[far], qd[far], qdd[far])
    assert_close(tau[far], want_tau, "tau at far angles", rtol=1e-12)
    assert_close(grav[far], want_grav, "G at far angles", rtol=1e-12)
    assert_close(mass[far], want_mass, "M at far angles", rtol=1e-12)
    assert np.isnan(tau[[3, 4, 5]]).any(axis=1).all()
    assert np.isnan(grav[[3, 4]]).any(axis=1).all() and np.isnan(mass[[3, 4]]).any(axis=(1, 2)).all()
    assert np.isfinite(grav[5]).all() and np.isfinite(mass[5]).all()  # q̇ plays no part in G and M


def test_one_workspace_serves_every_sample_with_the_batch_kernels_bits() -> None:
    """sample_torques over 300 samples with one workspace, a NaN and an inf sample among them: each
    sample's τ and G are the bits of the batch kernel on (q, q̇, q̈) and (q, 0, 0), and Pinocchio's
    to 1e-12; nothing of a sample (the non-finite ones included) stays in the scratch for the next."""
    arm = load_arm_model("left")
    q, qd, qdd = random_states(arm, 300, seed=11, qdd_max_rad_s2=10.0)
    q[40, 3], qd[41, 5], qdd[42, 0] = np.nan, np.inf, np.nan
    K, P, B = lagrange_euler.sample_workspace(arm.dh, arm.pseudo_inertias)
    got = np.empty((len(q), 2, 7))
    for k in range(len(q)):
        lagrange_euler.sample_torques(K, P, B, arm.gravity_m_s2, q[k], qd[k], qdd[k], got[k])
    batch_tau, batch_grav = np.empty_like(q), np.empty_like(q)
    lagrange_euler.batch_inverse_dynamics(arm.dh, arm.pseudo_inertias, arm.gravity_m_s2, q, qd, qdd, True, batch_tau)
    zero = np.zeros_like(q)
    lagrange_euler.batch_inverse_dynamics(arm.dh, arm.pseudo_inertias, arm.gravity_m_s2, q, zero, zero, True, batch_grav)
    np.testing.assert_array_equal(got[:, 0], batch_tau)
    np.testing.assert_array_equal(got[:, 1], batch_grav)
    finite = [k for k in range(len(q)) if k not in (40, 41, 42)]
    tau, grav, _ = _pinocchio_answers(paper_reference(arm.side), q[finite], qd[finite], qdd[finite])
    assert_close(got[finite, 0], tau, "tau, one sample at a time", rtol=1e-12)
    assert_close(got[finite, 1], grav, "G, one sample at a time", rtol=1e-12)
    assert not np.isfinite(got[40:43, 0]).all(axis=1).any()
