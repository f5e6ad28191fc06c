"""Collision monitoring: the momentum observer, thresholds, the detector, the public scheme, calibrate,
and the simulator's collisions with their ground truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from reference_models import paper_reference, random_states

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.cli.main import main
from baxter_dynamics_ros.core.arm_model import ArmModel
from baxter_dynamics_ros.core.compensation import Compensation
from baxter_dynamics_ros.core.effect_specs import effects_from_dict
from baxter_dynamics_ros.errors import CollisionError, EffectSpecError
from baxter_dynamics_ros.monitoring.calibration import DEFAULT_MARGIN, calibrate, calibrate_thresholds, without_bias
from baxter_dynamics_ros.monitoring.detector import (
    DEFAULT_BIAS_TIME_CONSTANT_S,
    PUBLIC_THRESHOLDS_NM,
    CollisionDetector,
    detect,
    public_detector,
    public_residual,
)
from baxter_dynamics_ros.monitoring.observer import (
    MomentumObserver,
    estimate_effort_delay,
    momentum_terms,
    observe,
    observe_arrays,
)
from baxter_dynamics_ros.monitoring.thresholds import Thresholds, read_thresholds, write_thresholds
from baxter_dynamics_ros.simulation.plant import external_torques, simulate
from baxter_dynamics_ros.simulation.sensor import write_ground_truth
from baxter_dynamics_ros.simulation.spec import Collision, SensorModel, SimulationSpec, read_spec_json
from msg_adapters.recording_files import read_recording, write_joint_states

EXACT = SensorModel(position_step_rad=0.0, effort_step_nm=0.0)
GAIN = 30.0
#: Pushes on the joints directly (s0 3 N·m, e1 −3, w2 1) and on the flange (20 N down).
PUSHES = (
    Collision(1.0, 0.8, "push", "joints", torque_nm=(3.0, 0, 0, -3.0, 0, 0, 1.0)),
    Collision(2.2, 0.6, "push", "flange", force_n=(0.0, 0.0, -20.0)),
)


@pytest.fixture(scope="module")
def arm() -> ArmModel:
    return load_arm_model("right")


@pytest.fixture(scope="module")
def pushed():
    return simulate(SimulationSpec("random", 3.5, 100.0, seed=2, collisions=PUSHES))


def test_coriolis_transpose_term_matches_pinocchio(arm: ArmModel) -> None:
    """β − τ + G = Cᵀ(q, q̇) q̇ (Ṁ by central difference) against Pinocchio's Coriolis matrix."""
    ref = paper_reference(arm.side)
    q, qd, _ = random_states(arm, 20, 0, 5.0)
    tau = np.zeros_like(q)
    p, beta = momentum_terms(arm, np.arange(len(q)) * 10_000_000, q, qd, tau)
    for k in range(len(q)):
        c = pin.computeCoriolisMatrix(ref.model, ref.data, q[k], qd[k])
        np.testing.assert_allclose(beta[k] + ref.gravity(q[k]), c.T @ qd[k], atol=1e-7)
        np.testing.assert_allclose(p[k], ref.mass_matrix(q[k]) @ qd[k], atol=1e-10)


def test_per_sample_observer_gives_the_batch_numbers_wiring(arm: ArmModel, pushed) -> None:
    """Wiring only: the per-sample observer and the batch share their helpers (the independent check
    is test_observer_matches_an_independent_integration_of_its_equations)."""
    rec = pushed.recording()
    batch = observe(arm, rec, GAIN)
    observer = MomentumObserver(arm, GAIN)
    dt = np.diff(rec.stamps_ns, prepend=rec.stamps_ns[0]) * 1e-9
    one_by_one = np.array([observer.update(rec.q[k], rec.qd[k], rec.effort[k], dt[k]) for k in range(len(rec))])
    np.testing.assert_array_equal(one_by_one, batch)
    observer.reset()
    np.testing.assert_array_equal(observer.update(rec.q[5], rec.qd[5], rec.effort[5], 0.01), np.zeros(7))


@pytest.mark.parametrize("effort_delay_s", [-0.013, 0.004, 0.02])
def test_aligned_observer_one_by_one_gives_the_batch_numbers_wiring(arm: ArmModel, pushed, effort_delay_s: float) -> None:
    """Wiring, and the alignment's pairing by interpolation, through the observer's own helpers."""
    rec = pushed.recording()
    keep = np.r_[0:150, 151:len(rec)]  # one sample lost: an uneven step to interpolate over
    stamps, q, qd, effort = rec.stamps_ns[keep], rec.q[keep], rec.qd[keep], rec.effort[keep]
    batch = observe_arrays(arm, stamps, q, qd, effort, gain_1_s=GAIN, effort_delay_s=effort_delay_s)
    observer = MomentumObserver(arm, GAIN, effort_delay_s=effort_delay_s)
    dt = np.diff(stamps, prepend=stamps[0]) * 1e-9
    one_by_one = np.array([observer.update(q[k], qd[k], effort[k], dt[k]) for k in range(len(q))])
    np.testing.assert_array_equal(one_by_one, batch)
    # The pairing: the state at t − max(d, 0) with the effort at t − max(−d, 0), linearly interpolated.
    t = (stamps - stamps[0]) * 1e-9
    state_t, effort_t = t - max(effort_delay_s, 0.0), t - max(-effort_delay_s, 0.0)
    interp = lambda x, at: np.stack([np.interp(at, t, x[:, j]) for j in range(7)], axis=1)  # noqa: E731
    expected = observe_arrays(arm, stamps, interp(q, state_t), interp(qd, state_t), interp(effort, effort_t), gain_1_s=GAIN)
    np.testing.assert_allclose(batch, expected, atol=1e-9)
    with pytest.raises(CollisionError, match="effort_delay_s"):
        MomentumObserver(arm, GAIN, effort_delay_s=0.2)


def rk4_momentum_observer(stamps_s: np.ndarray, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, gain_1_s: float) -> np.ndarray:
    """r (N, 7) of the momentum observer's continuous equations, integrated here by RK4 over each
    sampling step with the inputs linearly interpolated, M, C, G from the paper's Pinocchio model
    (C the Coriolis matrix, Ṁ = C + Cᵀ):

        r = K_O (z − (p − p₀)),  ż = τ + Cᵀ(q, q̇) q̇ − G(q) − r,  p = M(q) q̇

    (De Luca's observer with the residual's sign), written from those equations, not the code's."""
    ref = paper_reference("right")

    def momentum_and_beta(x: np.ndarray, v: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        coriolis = pin.computeCoriolisMatrix(ref.model, ref.data, x, v)
        return ref.mass_matrix(x) @ v, tau + coriolis.T @ v - ref.gravity(x)

    ends = [momentum_and_beta(*s) for s in zip(q, qd, effort)]
    mids = [momentum_and_beta(*((a[k] + a[k + 1]) / 2.0 for a in (q, qd, effort))) for k in range(len(q) - 1)]
    p0 = ends[0][0]

    def z_dot(z: np.ndarray, at: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        p, beta = at
        return beta - gain_1_s * (z - (p - p0))

    z, r = np.zeros(7), [np.zeros(7)]
    for k, h in enumerate(np.diff(stamps_s)):
        k1 = z_dot(z, ends[k])
        k2 = z_dot(z + 0.5 * h * k1, mids[k])
        k3 = z_dot(z + 0.5 * h * k2, mids[k])
        k4 = z_dot(z + h * k3, ends[k + 1])
        z = z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        r.append(gain_1_s * (z - (ends[k + 1][0] - p0)))
    return np.array(r)


def test_observer_matches_an_independent_integration_of_its_equations(arm: ArmModel) -> None:
    """The observer's r against :func:`rk4_momentum_observer` on the same pushed motion at 100 Hz and
    1 kHz: the code's backward-Euler step converges to the equations at first order. Measured: max
    |Δr| 0.84 N·m at 100 Hz, 0.105 N·m at 1 kHz (ratio 0.124; r up to 14.2 N·m), at the pushes'
    20 ms ramps."""
    errors = {}
    for rate_hz in (100.0, 1000.0):
        rec = simulate(SimulationSpec("random", 3.0, rate_hz, seed=2, collisions=PUSHES, sensor=EXACT)).recording()
        expected = rk4_momentum_observer(rec.stamps_s, rec.q, rec.qd, rec.effort, GAIN)
        assert np.abs(expected).max() > 10.0, "the pushes should show"
        errors[rate_hz] = float(np.abs(observe(arm, rec, GAIN) - expected).max())
    assert errors[1000.0] <= 0.15, f"max |r − r_ODE| at 1 kHz: {errors[1000.0]:.3g} N·m (100 Hz: {errors[100.0]:.3g})"
    assert errors[1000.0] <= 0.2 * errors[100.0], f"not first order: {errors}"


def test_effort_delay_is_estimated_from_collision_free_motion(arm: ArmModel) -> None:
    """A recording whose effort is 15 ms late: the estimate is 15 ms later than that of the same motion
    without it (which makes up for the observer's step alone), and the aligned r is much smaller."""
    late = effects_from_dict({"delay": {"delay_s": 0.015}})
    plain, delayed = (simulate(SimulationSpec("random", 8.0, 100.0, seed=4, effects=e)).recording() for e in ((), late))
    d_plain = estimate_effort_delay(arm, [plain], GAIN)
    d_late = estimate_effort_delay(arm, [delayed], GAIN)
    assert -0.0075 < d_plain < -0.0025
    assert d_late - d_plain == pytest.approx(0.015, abs=0.002)
    rms = lambda r: float(np.sqrt(np.mean(r**2)))  # noqa: E731
    assert rms(observe(arm, delayed, GAIN, None, d_late)) < 0.5 * rms(observe(arm, delayed, GAIN))
    thresholds = calibrate(arm, [delayed], gain_1_s=GAIN)
    assert thresholds.effort_delay_s == d_late and thresholds.bias_time_constant_s == DEFAULT_BIAS_TIME_CONSTANT_S
    with pytest.raises(CollisionError, match="at least one recording"):
        estimate_effort_delay(arm, [], GAIN)


def test_detector_removes_a_slow_bias_but_not_a_contact() -> None:
    n = 6000  # 60 s at 100 Hz
    stamps_ns = np.arange(n) * 10_000_000
    t = stamps_ns * 1e-9
    r, qd = np.zeros((n, 7)), np.zeros((n, 7))
    r[:, 6] = 0.3 * t / 60.0  # a sensor offset drifting by 0.3 N·m in a minute, against a 0.2 N·m threshold
    tracked = Thresholds(np.full(7, 0.2), consecutive=2, bias_time_constant_s=DEFAULT_BIAS_TIME_CONSTANT_S)
    fixed = Thresholds(np.full(7, 0.2), consecutive=2)
    assert detect(CollisionDetector(fixed), r, qd, stamps_ns).any()
    assert not detect(CollisionDetector(tracked), r, qd, stamps_ns).any()
    pushed = r.copy()
    push = (t >= 40.0) & (t < 50.0)
    pushed[push, 6] -= 1.0  # a 10 s push of 1 N·m: on throughout (the bias is held), off after it
    on = detect(CollisionDetector(tracked), pushed, qd, stamps_ns)
    assert on[push][2:].all() and not on[t >= 50.5].any() and not on[t < 40.0].any()
    # The calibration removes the same bias: the drift sets the threshold at its rate × T_b (0.1 N·m), not 0.3.
    calibrated = calibrate_thresholds(
        [r], [qd], stamps_ns=[stamps_ns], bias_time_constant_s=DEFAULT_BIAS_TIME_CONSTANT_S, margin=1.0, consecutive=1
    )  # fmt: skip
    assert calibrated.offset_nm[6] == np.abs(without_bias(r, stamps_ns, DEFAULT_BIAS_TIME_CONSTANT_S)[:, 6]).max()
    assert 0.09 < calibrated.offset_nm[6] < 0.1
    with pytest.raises(CollisionError, match="stamps"):
        calibrate_thresholds([r], [qd], bias_time_constant_s=20.0)
    with pytest.raises(CollisionError, match="bias_time_constant_s"):
        Thresholds(np.full(7, 0.2), bias_time_constant_s=-1.0)


def test_observer_recovers_the_external_torque(arm: ArmModel, pushed) -> None:
    """r = −τ_ext once the push has lasted a few time constants (1/K_O = 33 ms); 0 before and after."""
    r = observe(arm, pushed.recording(), GAIN)
    t = pushed.recording().stamps_s
    truth = -pushed.tau_external
    on_joints = (t > 1.25) & (t < 1.75)  # a constant torque: r settles on it (discrete pole 1/(1 + K_O Δt) per sample)
    np.testing.assert_allclose(truth[on_joints], np.tile([-3.0, 0, 0, 3.0, 0, 0, -1.0], (on_joints.sum(), 1)))
    np.testing.assert_allclose(r[on_joints], truth[on_joints], atol=0.05)
    at_flange = (t > 2.35) & (t < 2.75)  # J_vᵀF turns with the arm: r lags it by 1/K_O
    peak = np.abs(truth[at_flange]).max()
    assert peak > 10.0
    np.testing.assert_allclose(r[at_flange], truth[at_flange], atol=0.03 * peak)
    np.testing.assert_allclose(r[(t < 0.95) | (t > 3.1)], 0.0, atol=0.1)
    # The first-order lag: 1 − e^{-1} of the step one time constant into the ramped push (ramp 20 ms).
    k = int(np.searchsorted(t, 1.0 + 0.02 + 1.0 / GAIN))
    assert 0.5 < r[k, 0] / truth[k, 0] < 0.8


def test_observer_stays_near_zero_without_external_torque(arm: ArmModel) -> None:
    result = simulate(SimulationSpec("random", 4.0, 100.0, seed=4, sensor=EXACT))
    rec = result.recording()
    r = observe(arm, rec, GAIN)
    assert np.abs(r).max() < 0.1
    # The public scheme (q̈ = 0) on the same motion: its residual is the missing M q̈, large.
    public = public_residual(arm, rec)
    np.testing.assert_allclose(public, rec.effort - arm.inverse_dynamics(rec.q, rec.qd, np.zeros_like(rec.q)), atol=1e-12)
    assert np.abs(public).max(axis=0)[1] > 10 * np.abs(r).max(axis=0)[1]


def test_compensated_effects_leave_no_residual(arm: ArmModel) -> None:
    """Dahl's friction too: the plant integrates its state with the motion (RK4), the observer follows
    it along the recording, per sample as in batch."""
    effects = effects_from_dict({
        "s1_spring": {}, "viscous_friction": {"damping_nm_s_rad": 0.5},
        "dahl_friction": {"friction_nm": {"s1": 1.0, "e0": 0.6, "w1": 0.2}, "presliding_rad": 0.05},
    })  # fmt: skip
    result = simulate(SimulationSpec("random", 3.0, 100.0, seed=5, effects=effects, sensor=EXACT))
    rec = result.recording()
    assert np.abs(observe(arm, rec, GAIN)).max() > 5.0
    compensation = Compensation(arm, effects)
    r = observe(arm, rec, GAIN, compensation)
    assert np.abs(r).max() < 0.1
    steady = Compensation(arm, tuple(e for e in effects if e.name != "dahl_friction") + effects_from_dict(
        {"coulomb_friction": {"friction_nm": {"s1": 1.0, "e0": 0.6, "w1": 0.2}, "smoothing_rad_s": 1e-6}}))
    assert np.abs(observe(arm, rec, GAIN, steady)).max() > 3 * np.abs(r).max(), "its state, not sign(q̇), is what leaves none"
    observer = MomentumObserver(arm, GAIN, compensation)
    dt = np.diff(rec.stamps_ns, prepend=rec.stamps_ns[0]) * 1e-9
    np.testing.assert_allclose([observer.update(rec.q[k], rec.qd[k], rec.effort[k], dt[k]) for k in range(len(rec))], r, atol=1e-12)


def test_public_scheme_thresholds_and_detector() -> None:
    assert PUBLIC_THRESHOLDS_NM == (10.0, 10.0, 5.0, 4.5, 2.0, 2.0, 1.0)
    detector = public_detector()
    qd = np.zeros(7)
    assert not detector.update(np.array([9.99, -9.99, 4.99, 4.49, 1.99, -1.99, 0.99]), qd, 0.01).collision
    state = detector.update(np.array([0, 0, 0, -4.6, 0, 0, 0.0]), qd, 0.01)
    assert state.collision and state.joints == (3,)
    assert not detector.update(np.zeros(7), qd, 0.01).collision


def test_detector_hysteresis() -> None:
    thresholds = Thresholds(np.full(7, 2.0), slope_nm_s_rad=np.full(7, 1.0), consecutive=3)
    detector = CollisionDetector(thresholds, release_fraction=0.5, hold_s=0.05)
    n = 40
    r, qd = np.zeros((n, 7)), np.zeros((n, 7))
    r[5:7, 2] = 3.0  # two samples above: not enough
    r[7, 3] = 3.0  # a third sample above, on another joint: still not enough
    r[10:20, 2] = 3.0  # on at the third sample (12)
    r[14:20, 4] = -2.5
    r[20:24, 2] = 1.5  # below the threshold but above half of it: stays on
    r[30:33, 1] = 2.5
    qd[30:33, 1] = 1.0  # the speed raises the threshold to 3 N·m: no detection
    stamps_ns = np.arange(n) * 10_000_000
    on = detect(detector, r, qd, stamps_ns)
    expected = np.zeros(n, dtype=bool)
    expected[12:28] = True  # quiet from sample 24: off after 50 ms, at sample 28 (24, 25, 26, 27, 28 → 5 × 10 ms)
    expected[28] = False
    np.testing.assert_array_equal(on, expected)
    detector.reset()
    for k in range(16):
        state = detector.update(r[k], qd[k], 0.01)
    assert state.collision and state.joints == (2, 4)
    with pytest.raises(CollisionError, match="consecutive"):
        Thresholds(np.full(7, 2.0), consecutive=0)
    # By default it turns off below the level the calibration data stayed under: threshold / margin.
    assert CollisionDetector(Thresholds(np.full(7, 2.0), margin=1.5)).release_fraction == pytest.approx(1 / 1.5)
    assert CollisionDetector(Thresholds(np.full(7, 2.0))).release_fraction == 1.0


def test_thresholds_yaml_round_trip_and_errors(tmp_path: Path) -> None:
    thresholds = Thresholds(
        np.arange(1.0, 8.0), np.linspace(0, 1, 7), np.full(7, 25.0), 1.5, ("a.bag",), consecutive=3, effort_delay_s=-0.0125, bias_time_constant_s=20.0
    )  # fmt: skip
    path = tmp_path / "thresholds.yaml"
    write_thresholds(path, thresholds)
    back = read_thresholds(path)
    for name in ("offset_nm", "slope_nm_s_rad", "gain_1_s"):
        np.testing.assert_array_equal(getattr(back, name), getattr(thresholds, name))
    assert back.margin == 1.5 and back.files == ("a.bag",) and back.consecutive == 3
    assert back.effort_delay_s == -0.0125 and back.bias_time_constant_s == 20.0
    assert "s0: 1.0" in path.read_text()
    path.write_text("offset_nm: {s0: 1, s1: 1}\n")
    with pytest.raises(CollisionError, match="thresholds.yaml: offset_nm: expected the joints"):
        read_thresholds(path)
    with pytest.raises(CollisionError, match="> 0"):
        Thresholds(np.zeros(7))


def test_calibrated_thresholds_cover_the_data_with_the_margin() -> None:
    rng = np.random.default_rng(1)
    qd = rng.uniform(-1.0, 1.0, (500, 7))
    qd[:50] = 0.01
    r = (0.2 + 0.5 * np.abs(qd)) * rng.uniform(-1, 1, (500, 7))
    thresholds = calibrate_thresholds([r[:250], r[250:]], [qd[:250], qd[250:]], margin=1.5, consecutive=1)
    assert np.all(thresholds.at(qd) >= 1.5 * np.abs(r) - 1e-12)
    assert np.all(thresholds.slope_nm_s_rad > 0.3) and np.all(thresholds.offset_nm <= 1.5 * (0.2 + 0.5 * 0.05))
    constant = calibrate_thresholds([r], [qd], margin=2.0, speed_dependent=False, consecutive=1)
    np.testing.assert_allclose(constant.offset_nm, 2.0 * np.abs(r).max(axis=0))
    assert np.all(constant.slope_nm_s_rad == 0)
    with pytest.raises(CollisionError, match="margin: expected a number >= 1"):
        calibrate_thresholds([r], [qd], margin=0.5)


@pytest.mark.parametrize("consecutive", [2, 3, 5])
def test_thresholds_for_runs_never_fire_on_their_calibration_data(consecutive: int) -> None:
    # Spiky residuals: single samples far above the rest, which a run of `consecutive` samples ignores.
    rng = np.random.default_rng(consecutive)
    qd = rng.uniform(-1.0, 1.0, (2000, 7))
    r = (0.2 + 0.5 * np.abs(qd)) * rng.uniform(-1, 1, (2000, 7))
    r[rng.integers(0, 2000, 40)] *= 10.0
    parts = [slice(0, 700), slice(700, 2000)]
    for margin in (1.0, 1.5):
        thresholds = calibrate_thresholds([r[p] for p in parts], [qd[p] for p in parts], margin=margin, consecutive=consecutive)
        assert thresholds.consecutive == consecutive
        stamps_ns = np.arange(2000) * 10_000_000
        for p in parts:
            # The rule's promise at margin m: no run of `consecutive` samples is above the threshold / m throughout.
            scaled = Thresholds(thresholds.offset_nm / margin, thresholds.slope_nm_s_rad / margin, consecutive=consecutive)
            assert not detect(CollisionDetector(scaled), r[p], qd[p], stamps_ns[p]).any()
    single = calibrate_thresholds([r], [qd], consecutive=1)
    assert thresholds.at(qd).mean() < 0.5 * single.at(qd).mean()  # the spikes no longer set the thresholds
    with pytest.raises(CollisionError, match="consecutive: expected a whole number >= 1"):
        calibrate_thresholds([r], [qd], consecutive=0)
    with pytest.raises(CollisionError, match="at least 5 samples"):
        calibrate_thresholds([r[:4]], [qd[:4]], consecutive=5)


def test_simulated_collisions_ground_truth(arm: ArmModel, pushed, tmp_path: Path) -> None:
    # Recorded effort − rigid body with the true q̈ = −τ_ext (the effort is the actuators' torque).
    rigid = arm.inverse_dynamics(pushed.q_true, pushed.qd_true, pushed.qdd_true)
    np.testing.assert_allclose(pushed.effort - rigid, -pushed.tau_external, atol=0.002 + 1e-9)
    t = pushed.recording().stamps_s
    at_flange = (t > 2.25) & (t < 2.75)
    jv = arm.jacobian(pushed.q_true[at_flange])[:, :3]
    np.testing.assert_allclose(pushed.tau_external[at_flange], np.einsum("nij,i->nj", jv, [0.0, 0.0, -20.0]), atol=0.05)
    assert np.all(pushed.tau_external[(t < 1.0) | ((t > 1.8) & (t < 2.2)) | (t > 2.8)] == 0)
    np.testing.assert_allclose(external_torques(arm, PUSHES, t, pushed.q_true), pushed.tau_external, atol=1e-9)
    path = tmp_path / "sim.truth.json"
    write_ground_truth(path, pushed)
    truth = json.loads(path.read_text())
    first, second = truth["collisions"]
    assert (first["start_s"], first["end_s"], first["link"], first["profile"]) == (1.0, 1.8, "joints", "push")
    np.testing.assert_allclose(first["peak_joint_torque_nm"], [3, 0, 0, 3, 0, 0, 1], atol=1e-12)
    assert second["link"] == "flange" and max(second["peak_joint_torque_nm"]) > 5
    assert read_spec_json(path) == pushed.spec
    with pytest.raises(EffectSpecError, match="forces act at the flange only"):
        Collision(0.0, 0.1, link="e1")


def test_an_impact_is_a_half_sine(arm: ArmModel) -> None:
    spec = SimulationSpec("paper_y", 1.0, 1000.0, collisions=(Collision(0.2, 0.05, "impact", "joints", torque_nm=(0, 0, 0, 0, 4.0, 0, 0)),))
    tau = simulate(spec).tau_external[:, 4]
    t = np.arange(len(tau)) / 1000.0
    np.testing.assert_allclose(tau, np.where((t >= 0.2) & (t <= 0.25), 4.0 * np.sin(np.pi * (t - 0.2) / 0.05), 0.0), atol=1e-9)


def test_calibrate_cli(tmp_path: Path, pushed, capsys: pytest.CaptureFixture[str]) -> None:
    free = simulate(SimulationSpec("random", 10.0, 100.0, seed=6))  # calibrate takes 10 s at least
    bag = tmp_path / "free.csv"
    rec = free.recording()
    write_joint_states(bag, rec.stamps_ns, rec.joint_names, rec.q, rec.qd, rec.effort)
    out = tmp_path / "thresholds.yaml"
    assert main(["calibrate", str(bag), "--out", str(out), "--margin", "2", "--consecutive", "1"]) == 0
    thresholds = read_thresholds(out)
    assert thresholds.files == (str(bag),) and thresholds.margin == 2.0 and thresholds.consecutive == 1
    assert thresholds.bias_time_constant_s == DEFAULT_BIAS_TIME_CONSTANT_S
    # Simultaneous effort and state: the alignment only makes up for the observer's step (β_k Δt
    # integrates over the step ending at t_k), about half a step early.
    assert -0.0075 < thresholds.effort_delay_s < -0.0025
    recorded = read_recording(bag)
    r = observe(load_arm_model("right"), recorded, thresholds.gain_1_s, None, thresholds.effort_delay_s)
    rho = without_bias(r, recorded.stamps_ns, thresholds.bias_time_constant_s)
    assert np.all(thresholds.at(rec.qd) >= 2 * np.abs(rho) - 1e-9)
    plain = tmp_path / "plain.yaml"
    assert main(["calibrate", str(bag), "--out", str(plain), "--effort-delay", "0", "--bias-time-constant", "0", "--gain", "30"]) == 0
    expected = calibrate_thresholds([observe(load_arm_model("right"), recorded, GAIN)], [recorded.qd], gain_1_s=GAIN)
    np.testing.assert_allclose(read_thresholds(plain).offset_nm, expected.offset_nm, rtol=1e-12)
    assert main(["calibrate", str(bag), "--out", str(tmp_path / "bad.yaml"), "--effort-delay", "0.5"]) == 1
    assert "effort_delay_s" in capsys.readouterr().err
    before = out.read_text()
    assert main(["calibrate", str(bag), "--out", str(out)]) == 1
    assert "exists already" in capsys.readouterr().err and out.read_text() == before
    assert main(["calibrate", str(bag), "--out", str(bag.with_suffix(".yaml")), "--effects", str(tmp_path / "none.yaml")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ERROR: ") and "none.yaml" in err[0]
    assert main(["calibrate", str(bag), "--out", str(bag)]) == 1
    assert "refusing to overwrite the input" in capsys.readouterr().err and bag.exists()



# ----------------------------------------------------------------------------- the node's monitor (no ROS)
def test_monitor_calibrates_on_the_last_window_only_and_reports_collisions() -> None:
    from baxter_dynamics_ros.core.samples import Health, HealthReport
    from baxter_dynamics_ros.monitoring.collision_monitor import MAX_RATE_HZ, CollisionMonitor

    names = load_arm_model("right").joint_names
    monitor = CollisionMonitor(names, window_s=1.0, gain_1_s=30.0)
    ok = HealthReport(Health.OK, "publishing", ())
    with pytest.raises(CollisionError, match="too little data"):
        monitor.calibrate()
    step_ns = int(1e9 / MAX_RATE_HZ)
    n = int(3 * MAX_RATE_HZ)  # 3 s at the highest rate: the ring buffer wraps round twice
    r = np.zeros((n, 7))
    r[: n - int(MAX_RATE_HZ) - 10, 3] = 50.0  # large, but older than the last second
    r[-5:, 3] = 0.4  # the largest in the last second
    for k in range(n):
        assert monitor.update(k * step_ns, r[k], np.zeros(7)) is None  # no thresholds: nothing detected
    thresholds, source = monitor.calibrate()
    # The default margin times the window's max (less the slow bias, which hardly moves in 5 ms).
    np.testing.assert_allclose(thresholds.offset_nm[3], DEFAULT_MARGIN * 0.4, rtol=1e-4)
    assert thresholds.bias_time_constant_s == DEFAULT_BIAS_TIME_CONSTANT_S
    assert "~/calibrate" in source
    assert not monitor.set_thresholds(thresholds, source)
    t = n * step_ns
    assert monitor.update(t, np.full(7, 0.01), np.zeros(7)) is None  # below every threshold
    assert monitor.update(t + step_ns, np.array([0, 0, 0, -1.5, 0, 0, 0]), np.zeros(7)) is None  # 1 of 2 samples
    assert monitor.update(t + 2 * step_ns, np.array([0, 0, 0, -1.5, 0, 0, 0]), np.zeros(7)) is True
    with pytest.raises(CollisionError, match="collision is detected now"):
        monitor.calibrate()
    report = monitor.report(ok)
    assert report.level == Health.ERROR and report.message.startswith("collision at right_e1")
    assert dict(report.values)["collision"] == "true"
    assert monitor.set_monitoring(False) and not monitor.collision  # off: the collision ends
    assert monitor.update(t + 3 * step_ns, np.full(7, -9.0), np.zeros(7)) is None
    report = monitor.report(ok)
    assert report.level == Health.ERROR  # the window still held the collision
    report = monitor.report(ok)
    assert report.level == Health.OK and dict(report.values)["monitoring"] == "off"


def test_monitor_computes_r_at_calibration_when_the_observer_did_not_run() -> None:
    """Samples buffered without r (observer off): ~/calibrate runs the observer over the window,
    its first settling time constants left out, and gets the thresholds of that r."""
    import functools

    from baxter_dynamics_ros.monitoring.calibration import calibrate_thresholds
    from baxter_dynamics_ros.monitoring.collision_monitor import SETTLE_TIME_CONSTANTS, CollisionMonitor
    from baxter_dynamics_ros.monitoring.observer import observe_arrays

    arm = load_arm_model("right")
    rng = np.random.default_rng(5)
    n, step_ns = 300, 10_000_000
    stamps = np.arange(n, dtype=np.int64) * step_ns
    t = stamps * 1e-9
    q = 0.2 * np.sin(np.outer(t, np.arange(1, 8) * 0.7))
    qd = 0.2 * np.cos(np.outer(t, np.arange(1, 8) * 0.7)) * np.arange(1, 8) * 0.7
    effort = arm.gravity(q) + rng.normal(0, 0.05, (n, 7))
    observe_window = functools.partial(observe_arrays, arm, gain_1_s=30.0)
    monitor = CollisionMonitor(arm.joint_names, window_s=2.0, gain_1_s=30.0, observe_window=observe_window)
    for k in range(n):
        assert monitor.update(int(stamps[k]), None, qd[k], q[k], effort[k]) is None
    thresholds, _ = monitor.calibrate()
    window = stamps >= stamps[-1] - 2_000_000_000
    r = observe_arrays(arm, stamps[window], q[window], qd[window], effort[window], gain_1_s=30.0)
    settled = stamps[window] >= stamps[window][0] + int(SETTLE_TIME_CONSTANTS / 30.0 * 1e9)
    expected = calibrate_thresholds(
        [r[settled]], [qd[window][settled]], gain_1_s=30.0, stamps_ns=[stamps[window][settled]], bias_time_constant_s=DEFAULT_BIAS_TIME_CONSTANT_S
    )  # fmt: skip
    np.testing.assert_allclose(thresholds.offset_nm, expected.offset_nm)
    np.testing.assert_allclose(thresholds.slope_nm_s_rad, expected.slope_nm_s_rad)
