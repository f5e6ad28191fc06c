"""The node's per-sample pipeline, health report and settings, without ROS.

The pipeline is checked against the core called directly (and Pinocchio for τ), the estimators
against their batch forms, every skip cause against its documented effect on the estimator.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from repo_paths import REPO
from reference_models import assert_close, dahl_state_of_steps, paper_reference, random_states

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.acceleration import FirstDifference, LowPassDifferentiator, first_difference
from baxter_dynamics_ros.core.samples import ArmSample, Health, ModelTorques, ResetCause, SkipReason
from baxter_dynamics_ros.errors import SettingsError
from baxter_dynamics_ros.monitoring.health import HealthMonitor
from baxter_dynamics_ros.monitoring.pipeline import ResidualPipeline, make_estimator
from baxter_dynamics_ros.ros.node_settings import NodeSettings

ARM = load_arm_model("right")
N = 60
DT_NS = 10_000_000  # 100 Hz
T0_NS = 1_700_000_000_000_000_000
TOL = 1e-9


@pytest.fixture(scope="module")
def states() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """stamps_ns (N,) with jitter, q, qd, effort (N, 7)."""
    q, qd, _ = random_states(ARM, N, seed=0, qdd_max_rad_s2=1.0)
    rng = np.random.default_rng(1)
    stamps = T0_NS + np.cumsum(rng.integers(8_000_000, 12_000_000, N))
    return stamps, q, qd, rng.normal(0.0, 5.0, (N, 7))


def run(pipeline: ResidualPipeline, stamps, q, qd, effort) -> list[ModelTorques | SkipReason]:
    return [
        pipeline.process(ArmSample(int(stamps[k]), q[k], None if qd is None else qd[k], None if effort is None else effort[k]))
        for k in range(len(stamps))
    ]


def stacked(results: list, field: str) -> np.ndarray:
    return np.array([getattr(r, field) for r in results])


def test_outputs_are_the_core_with_the_lowpass_estimator_on_the_stamps(states) -> None:
    stamps, q, qd, effort = states
    results = run(ResidualPipeline(ARM, "lowpass", 7.0), stamps, q, qd, effort)
    qdd = LowPassDifferentiator(7.0).run(qd, (stamps - stamps[0]) * 1e-9)
    tau = ARM.inverse_dynamics(q, qd, qdd)
    assert_close(stacked(results, "qdd"), qdd, "q̈", atol=1e-9)
    assert_close(stacked(results, "gravity"), ARM.gravity(q), "G", atol=TOL)
    assert_close(stacked(results, "tau"), tau, "τ", atol=TOL)
    assert_close(stacked(results, "residual"), effort - tau, "residual", atol=TOL)
    np.testing.assert_array_equal(stacked(results, "stamp_ns"), stamps)
    np.testing.assert_array_equal(stacked(results, "qd"), qd)
    np.testing.assert_array_equal(stacked(results, "effort"), effort)
    assert not any(r.qd_from_positions for r in results)


def test_tau_and_gravity_agree_with_pinocchio(states) -> None:
    stamps, q, qd, effort = states
    results = run(ResidualPipeline(ARM), stamps, q, qd, effort)
    pin_arm = paper_reference(ARM.side)  # the paper's tables, not the package's model file
    qdd = stacked(results, "qdd")
    assert_close(stacked(results, "tau"), np.array([pin_arm.rnea(*x) for x in zip(q, qd, qdd)]), "τ", rtol=1e-12)
    assert_close(stacked(results, "gravity"), np.array([pin_arm.gravity(x) for x in q]), "G", rtol=1e-12)


def test_first_difference_estimator_is_the_papers_difference(states) -> None:
    stamps, q, qd, effort = states
    results = run(ResidualPipeline(ARM, "first_difference"), stamps, q, qd, effort)
    expected = first_difference(qd, (stamps - stamps[0]) * 1e-9)
    assert_close(stacked(results, "qdd"), expected, "q̈", rtol=1e-9)
    fd = FirstDifference()
    assert np.all(fd.update(qd[0], 0.0) == 0)
    with pytest.raises(ValueError, match="dt_s"):
        fd.update(qd[1], 0.0)


def test_without_effort_there_is_no_residual(states) -> None:
    stamps, q, qd, _ = states
    results = run(ResidualPipeline(ARM), stamps[:5], q, qd, None)
    assert all(isinstance(r, ModelTorques) and r.residual is None for r in results)


def smooth_positions(stamps: np.ndarray) -> np.ndarray:
    """(N, 7) joint angles swinging by 0.3 rad about the middle of each joint's range."""
    t = (stamps - stamps[0]) * 1e-9
    phase = np.arange(7)
    return 0.5 * (ARM.lower_rad + ARM.upper_rad) + 0.3 * np.sin(2 * np.pi * 0.7 * t[:, None] + phase)


def test_without_velocity_it_is_differenced_from_positions_after_one_warm_up_sample(states) -> None:
    stamps, _, _, effort = states
    q = smooth_positions(stamps)
    results = run(ResidualPipeline(ARM), stamps, q, None, effort)
    assert results[0] is SkipReason.VELOCITY_WARM_UP and not SkipReason.VELOCITY_WARM_UP.is_fault
    qd = np.diff(q, axis=0) / (np.diff(stamps) * 1e-9)[:, None]
    assert_close(stacked(results[1:], "qd"), qd, "q̇", rtol=1e-12)
    qdd = LowPassDifferentiator(10.0).run(qd, (stamps[1:] - stamps[1]) * 1e-9)
    assert_close(stacked(results[1:], "tau"), ARM.inverse_dynamics(q[1:], qd, qdd), "τ", atol=TOL)
    assert all(r.qd_from_positions for r in results[1:])


@pytest.mark.parametrize("field", ["q", "qd", "effort"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_skipped_without_touching_the_state(states, field: str, bad: float) -> None:
    stamps, q, qd, effort = states
    spoilt = {"q": q.copy(), "qd": qd.copy(), "effort": effort.copy()}
    spoilt[field][3, 4] = bad
    pipeline = ResidualPipeline(ARM)
    results = run(pipeline, stamps[:8], spoilt["q"], spoilt["qd"], spoilt["effort"])
    assert results[3] is SkipReason.NON_FINITE_INPUT
    keep = [0, 1, 2, 4, 5, 6, 7]
    qdd = LowPassDifferentiator(10.0).run(qd[keep], (stamps[keep] - stamps[0]) * 1e-9)
    assert_close(stacked([results[k] for k in keep], "qdd"), qdd, "q̈ of the good samples", atol=1e-9)


@pytest.mark.parametrize(("non_finite", "implausible"), [("effort", "q"), ("q", "effort"), ("qd", "q")])
def test_a_non_finite_value_is_the_cause_even_beside_an_implausible_one(states, non_finite: str, implausible: str) -> None:
    stamps, q, qd, effort = states
    spoilt = {"q": q[3].copy(), "qd": qd[3].copy(), "effort": effort[3].copy()}
    spoilt[non_finite][6] = math.nan
    spoilt[implausible][0] = 1e30
    sample = ArmSample(int(stamps[3]), spoilt["q"], spoilt["qd"], spoilt["effort"])
    assert ResidualPipeline(ARM).process(sample) is SkipReason.NON_FINITE_INPUT


def test_duplicate_stamp_is_skipped_and_backwards_stamp_resets(states) -> None:
    stamps, q, qd, effort = states
    pipeline = ResidualPipeline(ARM)
    run(pipeline, stamps[:5], q, qd, effort)
    assert pipeline.process(ArmSample(int(stamps[4]), q[5], qd[5], effort[5])) is SkipReason.DUPLICATE_STAMP
    assert pipeline.process(ArmSample(int(stamps[3]), q[5], qd[5], effort[5])) is SkipReason.STAMP_BACKWARDS
    # After the reset even an earlier stamp starts afresh, with q̈ = 0.
    restart = pipeline.process(ArmSample(int(stamps[0]), q[6], qd[6], effort[6]))
    assert isinstance(restart, ModelTorques) and np.all(restart.qdd == 0)


@pytest.mark.parametrize(
    ("field", "joint", "value"),
    [
        ("q", 3, ARM.upper_rad[3] + 0.11),  # beyond the limit by more than the 0.1 rad margin
        ("q", 0, ARM.lower_rad[0] - 1e3),
        ("qd", 1, 3.01 * ARM.velocity_limit_rad_s[1]),
        ("qd", 6, -1e100),
        ("effort", 4, 3.01 * ARM.effort_limit_nm[4]),
        ("effort", 2, 1e30),
    ],
)
def test_implausible_input_is_skipped_without_touching_the_state(states, field: str, joint: int, value: float) -> None:
    stamps, q, qd, effort = states
    spoilt = {"q": q.copy(), "qd": qd.copy(), "effort": effort.copy()}
    spoilt[field][3, joint] = value
    pipeline = ResidualPipeline(ARM)
    results = run(pipeline, stamps[:8], spoilt["q"], spoilt["qd"], spoilt["effort"])
    assert results[3] is SkipReason.IMPLAUSIBLE_INPUT and SkipReason.IMPLAUSIBLE_INPUT.is_fault
    keep = [0, 1, 2, 4, 5, 6, 7]
    reference = ResidualPipeline(ARM)
    expected = run(reference, stamps[keep], q[keep], qd[keep], effort[keep])
    for name in ("qdd", "tau", "residual", "external_torque"):
        np.testing.assert_array_equal(stacked([results[k] for k in keep], name), stacked(expected, name))


def test_plausible_extremes_are_taken() -> None:
    """At the bounds themselves: the limits plus the margin, three times the velocity and effort limits."""
    pipeline = ResidualPipeline(ARM)
    for k, (q, qd) in enumerate([(ARM.upper_rad + 0.099, 2.99 * ARM.velocity_limit_rad_s), (ARM.lower_rad - 0.099, -2.99 * ARM.velocity_limit_rad_s)]):
        result = pipeline.process(ArmSample(T0_NS + k * DT_NS, q, qd, 2.99 * ARM.effort_limit_nm * (-1) ** k))
        assert isinstance(result, ModelTorques)


def test_a_jump_of_the_positions_without_velocity_is_skipped_and_differencing_goes_on(states) -> None:
    stamps, _, _, effort = states
    q = smooth_positions(stamps[:10])
    jumped = q.copy()
    jumped[4, 2] += 0.5  # 0.5 rad in 10 ms: 50 rad/s
    results = run(ResidualPipeline(ARM), stamps[:10], jumped, None, effort)
    assert [r for r in results if isinstance(r, SkipReason)] == [SkipReason.VELOCITY_WARM_UP, *[SkipReason.IMPLAUSIBLE_INPUT] * 2]
    assert results[4] is results[5] is SkipReason.IMPLAUSIBLE_INPUT  # into the jump and out of it
    for k in (6, 7, 8, 9):  # differenced from sample 5 on, as if nothing had happened
        np.testing.assert_allclose(results[k].qd, (q[k] - q[k - 1]) / ((stamps[k] - stamps[k - 1]) * 1e-9), rtol=1e-12)


def test_non_finite_dynamics_skips_resets_and_is_counted(states) -> None:
    """Plausible input cannot overflow the rigid model; an absurd effects file can (damping 1e308 N·m·s/rad)."""
    from baxter_dynamics_ros.core.compensation import Compensation
    from baxter_dynamics_ros.core.effects import ViscousFriction

    stamps, q, qd, effort = states
    absurd = Compensation(ARM, (ViscousFriction(damping_nm_s_rad=[1e308] * 7),))
    pipeline = ResidualPipeline(ARM, compensation=absurd)
    monitor = HealthMonitor(ARM.joint_names, "/robot/joint_states")
    for k in range(3):  # 2 rad/s: a plausible speed; times 1e308 it overflows
        result = pipeline.process(ArmSample(int(stamps[k]), q[k], np.full(7, 2.0), effort[k]))
        assert result is SkipReason.NON_FINITE_MODEL
        monitor.record(result, 10)
    values = _values(monitor.report(1.0))
    assert values["resets_total.non_finite_state"] == "3" and values["skipped_total.non_finite_model"] == "3"
    # Reset each time: nothing of it stays. With the damping at rest (q̇ = 0) the sample goes through, from q̈ = 0.
    after = pipeline.process(ArmSample(int(stamps[3]), q[3], np.zeros(7), effort[3]))
    assert isinstance(after, ModelTorques) and np.all(after.qdd == 0) and np.all(np.isfinite(after.tau))


def test_dahl_friction_is_compensated_with_its_state_from_each_restart(states) -> None:
    """τ with dahl_friction compensated − τ without = F ⊙ z, z Dahl's state over the trapezoid of the
    samples' q̇ (an independent exact step), from z = 0 at the start and again after a stamp backwards."""
    from baxter_dynamics_ros.core.compensation import Compensation
    from baxter_dynamics_ros.core.effects import DahlFriction

    stamps, q, _, effort = states
    t = (stamps - stamps[0]) * 1e-9
    qd = np.outer(np.sin(2 * np.pi * 1.3 * t), [0.2, 0.3, -0.25, 0.1, 0.5, -0.4, 0.6])  # reversals every ~0.4 s
    friction = np.array([0.3, 1.0, 0.5, 0.4, 0.1, 0.08, 0.05])
    restart = 35
    stamps = stamps.copy()
    stamps[restart:] -= stamps[restart] - stamps[0] + 1  # the recording restarts: one sample skipped, then afresh
    with_dahl = run(ResidualPipeline(ARM, compensation=Compensation(ARM, (DahlFriction(friction, 0.05),))), stamps, q, qd, effort)
    rigid = run(ResidualPipeline(ARM), stamps, q, qd, effort)
    assert with_dahl[restart] == rigid[restart] == SkipReason.STAMP_BACKWARDS
    kept = [k for k in range(N) if k != restart]
    expected = np.zeros((N, 7))
    for part in (np.arange(restart), np.arange(restart + 1, N)):
        steps = np.zeros((len(part), 7))
        steps[1:] = 0.5 * (qd[part][1:] + qd[part][:-1]) * np.diff(stamps[part])[:, None] * 1e-9
        expected[part] = friction * dahl_state_of_steps(steps, 0.05)
    share = stacked([with_dahl[k] for k in kept], "tau") - stacked([rigid[k] for k in kept], "tau")
    np.testing.assert_allclose(share, expected[kept], atol=1e-12)
    assert np.all(np.abs(expected[kept]).max(axis=0) > 0.3 * friction), "the state moved at every joint"


def test_reset_and_configure_restart_the_estimator(states) -> None:
    stamps, q, qd, effort = states
    pipeline = ResidualPipeline(ARM)
    run(pipeline, stamps[:5], q, qd, effort)
    pipeline.reset()
    assert np.all(pipeline.process(ArmSample(int(stamps[5]), q[5], qd[5], effort[5])).qdd == 0)
    pipeline.configure("first_difference", 1.0)
    assert np.all(pipeline.process(ArmSample(int(stamps[6]), q[6], qd[6], effort[6])).qdd == 0)
    second = pipeline.process(ArmSample(int(stamps[7]), q[7], qd[7], effort[7]))
    assert_close(second.qdd[None], ((qd[7] - qd[6]) / ((stamps[7] - stamps[6]) * 1e-9))[None], "q̈", rtol=1e-12)


def test_make_estimator_refuses_unknown_names_and_bad_cutoffs() -> None:
    assert isinstance(make_estimator("lowpass", 3.0), LowPassDifferentiator)
    assert isinstance(make_estimator("first_difference", 3.0), FirstDifference)
    with pytest.raises(SettingsError, match="estimator: expected one of lowpass, first_difference"):
        make_estimator("kalman", 3.0)
    with pytest.raises(SettingsError, match="cutoff_hz"):
        make_estimator("lowpass", -1.0)


# ----------------------------------------------------------------------------- health
def _torques(residual: np.ndarray | None, qd_from_positions: bool = False) -> ModelTorques:
    z = np.zeros(7)
    return ModelTorques(0, z, z, z, z, z, residual, qd_from_positions)


def _values(report) -> dict[str, str]:
    return dict(report.values)


def test_health_ok_with_rate_latency_and_residual_rms() -> None:
    monitor = HealthMonitor(ARM.joint_names, "/robot/joint_states")
    residuals = np.random.default_rng(1).normal(0, 2, (50, 7))
    for k, r in enumerate(residuals):
        monitor.record(_torques(r), latency_ns=1000 * (k + 1))
    report = monitor.report(0.5)
    values = _values(report)
    assert report.level is Health.OK and "100.0 Hz" in report.message
    assert values["input_rate_hz"] == "100.0" and values["samples_published"] == "50"
    assert float(values["latency_mean_us"]) == pytest.approx(25.5) and float(values["latency_max_us"]) == 50.0
    rms = np.sqrt(np.mean(residuals**2, axis=0))
    got = [float(values[f"residual_rms_nm.{j}"]) for j in ARM.joint_names]
    np.testing.assert_allclose(got, rms, rtol=1e-3)


def test_health_levels() -> None:
    monitor = HealthMonitor(ARM.joint_names, "/robot/joint_states")
    report = monitor.report(1.0)
    assert report.level is Health.WARN and "no joint states on /robot/joint_states" in report.message
    assert _values(report)["residual_rms_nm.right_s0"] == "n/a"

    for _ in range(3):
        monitor.record(SkipReason.MISSING_JOINT, 10)
    report = monitor.report(1.0)
    assert report.level is Health.ERROR and "missing_joint: 3" in report.message

    monitor.record(SkipReason.VELOCITY_WARM_UP, 10)
    assert monitor.report(1.0).level is Health.WARN  # expected once: not an error

    monitor.record(SkipReason.DUPLICATE_STAMP, 10)
    monitor.record(_torques(np.ones(7)), 10)
    report = monitor.report(1.0)
    assert report.level is Health.WARN and "1 of 2 samples skipped (duplicate_stamp: 1)" in report.message

    monitor.record(_torques(None, qd_from_positions=True), 10)
    report = monitor.report(1.0)
    assert report.level is Health.WARN and "no effort" in report.message
    assert _values(report)["velocity_from_positions"] == "1"

    monitor.record_reset(ResetCause.CLOCK_JUMP)
    values = _values(monitor.report(1.0))
    assert values["skipped_total.missing_joint"] == "3" and values["skipped.missing_joint"] == "0"
    assert values["skipped_total.duplicate_stamp"] == "1" and values["resets_total.clock_jump"] == "1"


def test_health_is_never_ok_with_a_residual_rms_that_is_not_finite() -> None:
    monitor = HealthMonitor(ARM.joint_names, "/robot/joint_states")
    huge = np.full(7, 1.0)
    huge[2] = 1e200  # its square overflows
    monitor.record(_torques(huge), 10)
    monitor.record(_torques(np.ones(7)), 10)
    report = monitor.report(1.0)
    assert report.level is Health.WARN and "residual RMS not finite at right_e0" in report.message
    assert _values(report)["residual_rms_nm.right_e0"] == "inf"
    monitor.record(_torques(np.ones(7)), 10)
    assert monitor.report(1.0).level is Health.OK  # a new window


# ----------------------------------------------------------------------------- settings
def test_settings_defaults_are_the_packaged_parameters_file() -> None:
    raw = yaml.safe_load((REPO / "config" / "baxter_dynamics.yaml").read_text())
    params = raw["/**"]["ros__parameters"]
    defaults = {f.name: f.default for f in NodeSettings.fields()}
    assert params == defaults
    assert all(type(params[k]) is type(v) for k, v in defaults.items())  # 10.0 stays a float
    assert {f.name for f in NodeSettings.fields() if f.metadata["live"]} == {"estimator", "cutoff_hz"}


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"arm": "middle"}, "arm: expected 'right' or 'left'"),
        ({"joint_states_topic": ""}, "joint_states_topic"),
        ({"qos_depth": 0}, "qos_depth"),
        ({"estimator": "kalman"}, "estimator"),
        ({"cutoff_hz": 0.0}, "cutoff_hz"),
        ({"cutoff_hz": math.nan}, "cutoff_hz"),
        ({"diagnostics_period_s": -1.0}, "diagnostics_period_s"),
        ({"observer_gain_1_s": 0.0}, "observer_gain_1_s"),
        ({"calibration_window_s": math.inf}, "calibration_window_s"),
        ({"cutoff_hz": 1e300}, "cutoff_hz: must be from 0.1 to 1000, got 1e"),
        ({"qos_depth": 10**9}, "qos_depth: must be from 1 to 10000"),
        ({"observer_gain_1_s": 1e4}, "observer_gain_1_s"),
        ({"diagnostics_period_s": 1e9}, "diagnostics_period_s"),
        ({"calibration_window_s": 61.0}, "calibration_window_s: must be from 1 to 60"),
    ],
)
def test_settings_refuse_bad_values_naming_the_field(changes: dict, match: str) -> None:
    with pytest.raises(SettingsError, match=match):
        NodeSettings().replace(**changes)
