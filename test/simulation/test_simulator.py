"""The simulated Baxter: recorded effort = rigid body + the effects' shares, sensor model, files, seeds."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.cli.main import main
from baxter_dynamics_ros.core.arm_model import ArmModel
from baxter_dynamics_ros.core.effect_specs import effects_from_dict
from baxter_dynamics_ros.core.effects import total_torque
from baxter_dynamics_ros.errors import SimulationError
from baxter_dynamics_ros.simulation.plant import simulate
from baxter_dynamics_ros.simulation.sensor import START_STAMP_NS
from baxter_dynamics_ros.simulation.spec import SensorModel, SimulationSpec, read_spec_json
from msg_adapters.recording_files import read_recording
from msg_adapters.robot_joint_states import BAXTER_JOINT_NAMES, robot_joint_states
from reference_models import dahl_state
from repo_paths import CONFIG

HALF_STEP_NM = 0.002 + 1e-9  # half the effort quantisation step
EXACT = SensorModel(position_step_rad=0.0, effort_step_nm=0.0)


@pytest.fixture(scope="module")
def arm() -> ArmModel:
    return load_arm_model("right")


def run(trajectory: str = "random", duration_s: float = 3.0, rate_hz: float = 100.0, effects: dict | None = None, **kw):
    return simulate(SimulationSpec(trajectory, duration_s, rate_hz, effects=effects_from_dict(effects or {}), **kw))


def rigid(arm: ArmModel, r) -> np.ndarray:
    return arm.inverse_dynamics(r.q_true, r.qd_true, r.qdd_true)


@pytest.mark.parametrize("trajectory", ["random", "paper_y"])
def test_without_effects_the_effort_is_the_rigid_body_torque(arm: ArmModel, trajectory: str) -> None:
    r = run(trajectory)
    assert r.effort.shape == (300, 7) and r.saturated_steps == 0
    np.testing.assert_allclose(r.tau_actuator, rigid(arm, r), atol=1e-9)
    np.testing.assert_allclose(r.effort, rigid(arm, r), atol=HALF_STEP_NM)
    np.testing.assert_array_equal(r.qd, r.qd_true)  # no q̇ noise without acceleration_noise
    assert np.abs(r.q_ref - r.q_true).max() < 2e-3, "the dual-loop controller tracks the reference"
    assert np.ptp(r.q_true, axis=0).min() > 0.01, "the arm moves"


@pytest.mark.parametrize(
    "effects",
    [
        {"s1_spring": {}},
        {"viscous_friction": {"damping_nm_s_rad": [0.5, 0.5, 0.3, 0.3, 0.05, 0.05, 0.02]}},
        {"coulomb_friction": {"friction_nm": [0.6, 0.6, 0.4, 0.4, 0.08, 0.08, 0.03]}},
        {"stribeck_friction": {"coulomb_nm": {"s0": 0.4, "e1": 0.4}, "static_nm": {"s0": 0.7, "e1": 0.7}, "smoothing_rad_s": 0.05}},
        {"payload": {"mass_kg": 2.0, "com_m": [0.0, 0.0, 0.1], "size_m": [0.1, 0.1, 0.1]}},
        {"inertial_error": {"mass_scale": {"s1": 1.2, "e1": 0.8}, "com_scale": {"e0": 1.3}}},
        {"armature": {"inertia_kgm2": 0.2}},
        {"s1_spring": {}, "viscous_friction": {"damping_nm_s_rad": 0.3}, "payload": {"mass_kg": 1.0}, "armature": {"inertia_kgm2": 0.05}},
    ],
    ids=lambda e: "+".join(e),
)
def test_recorded_effort_minus_rigid_body_is_the_effects_share(arm: ArmModel, effects: dict) -> None:
    r = run("paper_y", effects=effects)
    share = total_torque(r.spec.effects, arm, r.q_true, r.qd_true, r.qdd_true)
    assert np.abs(share).max() > 0.1, "the effect shows in the effort"
    np.testing.assert_allclose(r.effort - rigid(arm, r), share, atol=HALF_STEP_NM)
    assert r.saturated_steps == 0 and np.abs(r.q_ref - r.q_true).max() < 0.05


def test_dahl_friction_is_integrated_with_the_motion(arm: ArmModel) -> None:
    """The plant integrates Dahl's state ż = (q̇ − z|q̇|)/θ_p with the motion (RK4 at 4 kHz): the
    recorded share is F·z, z solved exactly over each 10 ms step of the true angle
    (``reference_models.dahl_state``); a presliding angle too small for the step is refused."""
    friction = np.array([0.3, 0.9, 0.3, 0.3, 0.08, 0.05, 0.03])
    r = run("random", duration_s=6.0, effects={"dahl_friction": {"friction_nm": friction.tolist(), "presliding_rad": 0.02}}, physics_rate_hz=4000.0)
    share = r.effort - rigid(arm, r)
    assert np.all(np.abs(share) <= friction + HALF_STEP_NM) and np.all(np.ptp(share, axis=0) > 1.5 * friction)
    np.testing.assert_allclose(share, friction * dahl_state(r.q_true, 0.02), atol=0.01 * friction.max())
    with pytest.raises(SimulationError, match="dahl_friction is too stiff"):
        run(effects={"dahl_friction": {"friction_nm": 0.5, "presliding_rad": 1e-5}})


def test_the_spring_is_missing_from_the_effort(arm: ArmModel) -> None:
    """The spring holds part of the weight: on s1 the actuators transmit less than G_s1."""
    r = run("paper_xyz", duration_s=6.0, effects={"s1_spring": {}})
    gravity_s1 = arm.gravity(r.q_true)[:, 1]
    assert np.all(gravity_s1 < -20.0)
    carried = r.effort[:, 1] - gravity_s1  # the spring's share, ≈ 10–25 N·m with the arm raised here
    assert np.all((carried > 5.0) & (carried < 35.0))
    assert np.all(np.abs(r.effort[:, 1]) < np.abs(gravity_s1))


def test_measurement_effects(arm: ArmModel) -> None:
    r = run(
        "paper_y",
        duration_s=4.0,
        effects={
            "delay": {"delay_s": 0.02},
            "torque_offset": {"offset_nm": {"s0": 0.5, "w1": -0.3}},
            "acceleration_noise": {"velocity_noise_rad_s": [0.01, 0.01, 0.02, 0.02, 0.03, 0.03, 0.03]},
        },
        sensor=SensorModel(effort_noise_nm=0.05),
    )
    offset = np.array([0.5, 0, 0, 0, 0, -0.3, 0])
    late = r.effort[2:] - offset - r.tau_actuator[:-2]  # 0.02 s = 2 samples at 100 Hz
    assert np.abs(late.mean(axis=0)).max() < 0.01
    np.testing.assert_allclose(late.std(axis=0), 0.05, rtol=0.15)  # effort noise (and quantisation)
    np.testing.assert_allclose((r.qd - r.qd_true).std(axis=0), [0.01, 0.01, 0.02, 0.02, 0.03, 0.03, 0.03], rtol=0.15)
    # Measurement effects leave the motion alone: the applied torque is still the rigid body's.
    np.testing.assert_allclose(r.tau_actuator, rigid(arm, r), atol=1e-9)


def test_quantisation_steps_are_exact() -> None:
    r = run(sensor=SensorModel(effort_noise_nm=0.01))
    q_steps = r.q / (2 * np.pi / 16384)
    effort_steps = r.effort / 0.004
    np.testing.assert_allclose(q_steps, np.round(q_steps), atol=1e-6)
    np.testing.assert_allclose(effort_steps, np.round(effort_steps), atol=1e-6)
    assert np.abs(r.q - r.q_true).max() <= np.pi / 16384 + 1e-12
    exact = run(sensor=EXACT)
    np.testing.assert_array_equal(exact.q, exact.q_true)


def test_sample_times_and_physics_rate() -> None:
    r = run(rate_hz=50.0, duration_s=2.0)
    assert r.spec.physics_rate_hz == 1000.0 and len(r.stamps_ns) == 100
    assert r.stamps_ns[0] == START_STAMP_NS and np.all(np.diff(r.stamps_ns) == 20_000_000)
    assert SimulationSpec("random", 1.0, 300.0).physics_rate_hz == 1200.0
    with pytest.raises(SimulationError, match="whole multiple"):
        SimulationSpec("random", 1.0, 100.0, physics_rate_hz=1050.0)


def test_the_whole_robot_is_recorded_the_other_arm_at_rest(arm: ArmModel) -> None:
    r = run(effects={"s1_spring": {}}, sensor=EXACT)
    states = robot_joint_states(r.recording(), r.other_q, r.other_effort)
    assert states.names == BAXTER_JOINT_NAMES == tuple(sorted(BAXTER_JOINT_NAMES)) and len(states.names) == 21
    index = {n: k for k, n in enumerate(states.names)}
    right = [index[n] for n in arm.joint_names]
    np.testing.assert_array_equal(states.position[:, right], r.q)
    left_arm = load_arm_model("left")
    left = [index[n] for n in left_arm.joint_names]
    assert np.all(np.ptp(states.position[:, left], axis=0) == 0) and np.all(states.velocity[:, left] == 0)
    hold = left_arm.gravity(states.position[0, left]) + effects_from_dict({"s1_spring": {}})[0].torque(left_arm, states.position[0, left], np.zeros(7), np.zeros(7))
    np.testing.assert_allclose(states.effort[:, left], np.tile(hold, (len(r.q), 1)), atol=1e-12)


def test_too_stiff_friction_is_refused() -> None:
    with pytest.raises(SimulationError, match="too stiff.*right_w2.*smoothing_rad_s"):
        run(effects={"coulomb_friction": {"friction_nm": 0.5, "smoothing_rad_s": 0.01}})


def _simulate_cli(out: Path, *extra: str) -> int:
    return main(["simulate", "--trajectory", "paper_xyz", "--effects", str(CONFIG / "effects_example.yaml"),
                 "--duration", "2", "--rate-hz", "100", "--out", str(out), *extra])  # fmt: skip


def test_same_seed_same_file_and_ground_truth(tmp_path: Path, arm: ArmModel) -> None:
    a, b, c = tmp_path / "a.mcap", tmp_path / "b.mcap", tmp_path / "c.mcap"
    assert _simulate_cli(a, "--seed", "7") == 0
    assert _simulate_cli(b, "--seed", "7") == 0
    assert _simulate_cli(c, "--seed", "8") == 0
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()
    truth = json.loads((tmp_path / "a.mcap.truth.json").read_text())
    assert truth["spec"]["seed"] == 7 and set(truth["spec"]["effects"]) >= {"s1_spring", "coulomb_friction"}
    assert truth["samples"] == 200 and len(truth["tracking_rms_rad"]) == 7
    # The spec round-trips, and simulating it again gives the file's numbers.
    spec = read_spec_json(tmp_path / "a.mcap.truth.json")
    assert spec.to_dict() == truth["spec"]
    again = simulate(spec)
    recording = read_recording(a)
    assert recording.side == "right" and len(recording) == 200
    np.testing.assert_array_equal(recording.effort, again.effort)
    np.testing.assert_array_equal(recording.q, again.q)
    np.testing.assert_array_equal(recording.stamps_ns, again.stamps_ns)


def test_csv_output_reads_back(tmp_path: Path) -> None:
    out = tmp_path / "sim.csv"
    assert main(["simulate", "--trajectory", "random", "--duration", "1", "--rate-hz", "50", "--arm", "left", "--out", str(out)]) == 0
    recording = read_recording(out)
    again = run(duration_s=1.0, rate_hz=50.0, side="left")
    assert recording.side == "left"
    np.testing.assert_array_equal(recording.effort, again.effort)
    np.testing.assert_array_equal(recording.qd, again.qd)
    header = out.read_text().splitlines()[0].split(",")
    assert header[:2] == ["stamp_ns", "time_s"] and len(header) == 2 + 3 * 21


def test_cli_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text("effects: {s1_spring: {}}\nnoise: {}\n")
    assert main(["simulate", "--effects", str(spec), "--duration", "1", "--out", str(tmp_path / "x.mcap")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("ERROR: ") and "unknown sections ['noise']" in err[-1]
    existing = tmp_path / "y.csv"
    existing.write_text("keep")
    assert main(["simulate", "--duration", "1", "--out", str(existing)]) == 1
    assert "exists already" in capsys.readouterr().err and existing.read_text() == "keep"


def test_spec_file_collisions_reach_the_ground_truth(tmp_path: Path) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        "collisions:\n"
        "  - {start_s: 0.5, duration_s: 0.3, profile: push, link: joints, torque_nm: [0, 0, 0, 5.0, 0, 0, 0]}\n"
    )
    out = tmp_path / "c.mcap"
    assert main(["simulate", "--trajectory", "random", "--duration", "1", "--effects", str(spec), "--out", str(out)]) == 0
    truth = json.loads(out.with_name(out.name + ".truth.json").read_text())
    (collision,) = truth["collisions"]
    assert collision["start_s"] == 0.5 and collision["end_s"] == pytest.approx(0.8)
    assert collision["peak_joint_torque_nm"][3] == pytest.approx(5.0)
    bad = tmp_path / "bad.yaml"
    bad.write_text("collisions: {start_s: 1}\n")
    assert main(["simulate", "--duration", "1", "--effects", str(bad), "--out", str(tmp_path / "x.mcap")]) == 1
