"""The library of unmodelled effects: signs, magnitudes, regressors, spec round trips and errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.acceleration import zero_phase_acceleration
from baxter_dynamics_ros.core.arm_model import ArmModel
from baxter_dynamics_ros.core.effect_specs import effects_from_dict, effects_to_dict, load_effects
from baxter_dynamics_ros.core.effects import (
    EFFECTS,
    AccelerationNoise,
    Armature,
    CoulombFriction,
    DahlFriction,
    Delay,
    InertialError,
    Payload,
    S1Spring,
    StribeckFriction,
    TorqueOffset,
    ViscousFriction,
    total_torque,
)
from baxter_dynamics_ros.errors import EffectSpecError
from repo_paths import CONFIG

ALL = {
    "torque_offset": {"offset_nm": {"s0": -0.4, "e1": 0.5}},
    "viscous_friction": {"damping_nm_s_rad": 0.5},
    "coulomb_friction": {"friction_nm": [0.6, 0.6, 0.4, 0.4, 0.08, 0.08, 0.03], "smoothing_rad_s": 0.05},
    "stribeck_friction": {"coulomb_nm": 0.4, "static_nm": 0.7},
    "dahl_friction": {"friction_nm": [0.3, 0.9, 0.3, 0.3, 0.08, 0.05, 0.03], "presliding_rad": 0.02},
    "s1_spring": {},
    "payload": {"mass_kg": 1.0, "com_m": [0.01, 0.0, 0.08], "size_m": [0.08, 0.05, 0.1]},
    "inertial_error": {"mass_scale": {"s1": 1.2, "e1": 0.9}, "com_scale": {"e0": 1.3}},
    "armature": {"inertia_kgm2": {"s0": 0.1, "w2": 0.01}},
    "delay": {"delay_s": 0.02},
    "torque_gain": {"gain": {"s0": -0.05, "e1": 0.03}},
    "acceleration_noise": {"velocity_noise_rad_s": 0.01},
}


@pytest.fixture(scope="module")
def arm() -> ArmModel:
    return load_arm_model("right")


def smooth_series(arm: ArmModel, n: int = 400, rate_hz: float = 100.0, noise_rad_s: float = 0.0, seed: int = 0):
    """A smooth joint motion (q, q̇, q̈ exact) with stamps; optionally noisy q̇ and q̈ of its differences."""
    t = np.arange(n) / rate_hz
    phase = np.linspace(0.0, 1.0, 7)
    amplitude = np.array([0.4, 0.3, 0.4, 0.3, 0.5, 0.4, 0.5])
    centre = np.array([0.0, -0.55, 0.0, 0.75, 0.0, 1.26, 0.0])
    w = 2.0 * np.pi * 0.4
    q = centre + amplitude * np.sin(w * t[:, None] + phase)
    qd = amplitude * w * np.cos(w * t[:, None] + phase)
    qdd = -amplitude * w**2 * np.sin(w * t[:, None] + phase)
    if noise_rad_s:
        qd = qd + np.random.default_rng(seed).normal(0.0, noise_rad_s, qd.shape)
        qdd = np.gradient(qd, t, axis=0)
    return t, q, qd, qdd


def test_the_library_has_exactly_the_diagnosis_names() -> None:
    assert list(EFFECTS) == [
        "torque_offset", "viscous_friction", "coulomb_friction", "stribeck_friction", "dahl_friction", "s1_spring",
        "payload", "inertial_error", "armature", "delay", "torque_gain", "acceleration_noise",
    ]  # fmt: skip
    assert [e.name for e in effects_from_dict(ALL)] == list(EFFECTS)


@pytest.mark.parametrize("name", list(EFFECTS))
def test_regressor_times_parameters_gives_the_torque(arm: ArmModel, name: str) -> None:
    (effect,) = effects_from_dict({name: ALL[name]})
    t, q, qd, qdd = smooth_series(arm, noise_rad_s=0.01 if name == "acceleration_noise" else 0.0)
    tau = effect.torque(arm, q, qd, qdd, stamps_s=t)
    y = effect.regressor(arm, q, qd, qdd, stamps_s=t)
    theta = effect.parameter_vector(arm)
    assert tau.shape == q.shape
    assert y.shape == q.shape + theta.shape == (len(t), 7, len(effect.parameter_names()))
    assert np.abs(tau).max() > 1e-3, "the test motion must excite the effect"
    if name == "delay":  # first order in the delay: exact up to O(d²·d²τ/dt²)
        inner = slice(5, -5)
        np.testing.assert_allclose((y @ theta)[inner], tau[inner], atol=0.05 * np.abs(tau).max())
    else:
        np.testing.assert_allclose(y @ theta, tau, atol=1e-10)


def test_friction_and_armature_have_the_sign_of_the_motion(arm: ArmModel) -> None:
    _, q, qd, qdd = smooth_series(arm)
    moving = np.abs(qd) > 0.05
    for effect in (ViscousFriction(0.5), CoulombFriction(0.5), StribeckFriction(0.4, 0.7)):
        tau = effect.torque(arm, q, qd, qdd)
        assert np.all(np.sign(tau[moving]) == np.sign(qd[moving])), effect.name
    accelerating = np.abs(qdd) > 0.05
    tau = Armature(0.1).torque(arm, q, qd, qdd)
    assert np.all(np.sign(tau[accelerating]) == np.sign(qdd[accelerating]))
    np.testing.assert_array_equal(TorqueOffset([1, 2, 3, 4, 5, 6, 7]).torque(arm, q, qd, qdd), np.tile(np.arange(1.0, 8.0), (len(q), 1)))


def test_stribeck_breakaway_and_coulomb_limit(arm: ArmModel) -> None:
    effect = StribeckFriction(coulomb_nm=0.4, static_nm=0.7, stribeck_rad_s=0.1, smoothing_rad_s=0.001)
    z = np.zeros(7)
    slow, fast = np.full(7, 0.01), np.full(7, 2.0)
    np.testing.assert_allclose(effect.torque(arm, z, slow, z), 0.4 + 0.3 * np.exp(-0.01), rtol=1e-6)  # near F_s
    np.testing.assert_allclose(effect.torque(arm, z, fast, z), 0.4, rtol=1e-6)  # F_c when sliding fast
    same = StribeckFriction(coulomb_nm=0.4, static_nm=0.4, smoothing_rad_s=0.05)
    _, q, qd, qdd = smooth_series(arm)
    np.testing.assert_allclose(same.torque(arm, q, qd, qdd), CoulombFriction(0.4, 0.05).torque(arm, q, qd, qdd), atol=1e-15)


def test_dahl_friction_builds_up_over_its_presliding_angle_after_each_reversal(arm: ArmModel) -> None:
    """Closed forms of Dahl's dz/dθ = (1 − z sgn θ̇)/θ_p from z = 0: turning by θ gives
    z = 1 − exp(−θ/θ_p); after a reversal at z_0, turning back by θ gives −1 + (1 + z_0) exp(−θ/θ_p)."""
    angle, rate = 0.02, 1000.0
    effect = DahlFriction(friction_nm=np.arange(1.0, 8.0), presliding_rad=angle)
    t = np.arange(201) / rate
    speed = 0.4  # rad/s: 0.2 mrad per sample, 0.04 rad in 0.1 s, then back
    qd = np.where(t < 0.1, speed, -speed)[:, None] * np.ones(7)
    qd[100] = 0.0  # the reversal: the trapezoid turns half a step either side of it
    turned = np.concatenate([[0.0], np.cumsum(0.5 * (qd[1:, 0] + qd[:-1, 0]) / rate)])
    up = 1.0 - np.exp(-turned[:101] / angle)
    back = -1.0 + (1.0 + up[-1]) * np.exp(-(turned[100] - turned[100:]) / angle)
    z = effect.torque(arm, np.zeros_like(qd), qd, np.zeros_like(qd), stamps_s=t)
    np.testing.assert_allclose(z[:101] / np.arange(1.0, 8.0), np.tile(up[:, None], 7), atol=1e-12)
    np.testing.assert_allclose(z[100:] / np.arange(1.0, 8.0), np.tile(back[:, None], 7), atol=1e-12)
    assert z[100, 0] == pytest.approx(1.0 - np.exp(-2.0), abs=2e-3), "after about two presliding angles: 86 % of F"
    # Its limit θ_p → 0 is Coulomb friction with a sharp sign.
    _, q, qd_smooth, qdd = smooth_series(arm)
    stamps = np.arange(len(q)) / 100.0
    sharp = DahlFriction(friction_nm=0.4, presliding_rad=1e-6).torque(arm, q, qd_smooth, qdd, stamps_s=stamps)
    steady = np.vstack([np.zeros((1, 7), bool), np.sign(qd_smooth[1:]) == np.sign(qd_smooth[:-1])])  # no reversal within the step
    coulomb = CoulombFriction(0.4, 1e-9).torque(arm, q, qd_smooth, qdd)
    assert steady.mean() > 0.9
    np.testing.assert_allclose(sharp[steady], coulomb[steady], atol=1e-9)
    with pytest.raises(EffectSpecError, match="needs a time series"):
        effect.torque(arm, q, qd_smooth, qdd)


def test_s1_spring_holds_30_nm_at_zero_and_less_as_the_arm_rises(arm: ArmModel) -> None:
    spring = S1Spring()
    q = np.zeros((30, 7))
    q[:, 1] = np.linspace(0.0, -1.5, 30)  # q_s1 < 0 raises the arm
    z = np.zeros_like(q)
    share = spring.torque(arm, q, z, z)
    assert share[0, 1] == pytest.approx(30.0)
    assert np.all(np.diff(share[:, 1]) < 0), "the share falls as the arm rises"
    assert np.all(share[:, [0, 2, 3, 4, 5, 6]] == 0.0), "the spring acts on s1 only"
    assert (arm.base_in_torso @ arm.forward_kinematics(q[-1]))[2, 3] > (arm.base_in_torso @ arm.forward_kinematics(q[0]))[2, 3]
    # The spring's own torque helps hold the arm: the sign of gravity's G_s1 (−52.9 N·m at q = 0).
    holding = spring.holding_torque(arm, q, z, z)[:, 1]
    assert np.all(np.sign(holding) == np.sign(arm.gravity(q)[:, 1]))
    assert np.all(np.abs(holding) < np.abs(arm.gravity(q)[:, 1])), "it carries part of the weight"


def test_payload_at_rest_is_the_weight_of_a_point_at_its_centre(arm: ArmModel) -> None:
    """Independent check: τ = −J_p(q)ᵀ m g with J_p the linear Jacobian of the load's centre."""
    payload = Payload(mass_kg=1.5, com_m=[0.02, -0.01, 0.1], size_m=[0.1, 0.1, 0.1])
    rng = np.random.default_rng(3)
    q = rng.uniform(arm.lower_rad, arm.upper_rad, (20, 7))
    z = np.zeros_like(q)
    pose, jac = arm.forward_kinematics(q), arm.jacobian(q)
    r = pose[:, :3, :3] @ payload.com_m  # flange origin → load centre, base frame
    jv = jac[:, :3] - np.cross(r[:, :, None], jac[:, 3:], axis=1)  # v_p = v + ω × r
    expected = -np.einsum("nij,i->nj", jv, payload.mass_kg * arm.gravity_m_s2)
    np.testing.assert_allclose(payload.torque(arm, q, z, z), expected, atol=1e-10)


def test_inertial_effects_are_the_changed_models_dynamics(arm: ArmModel) -> None:
    _, q, qd, qdd = smooth_series(arm, n=50)
    for effect in (InertialError(mass_scale={"s1": 1.2, "w0": 0.8}, com_scale={"e0": 1.3}), Payload(1.0, [0, 0, 0.1])):
        changed = effect.apply_to(arm)
        assert np.any(changed.pseudo_inertias != arm.pseudo_inertias)
        np.testing.assert_allclose(
            effect.torque(arm, q, qd, qdd), changed.inverse_dynamics(q, qd, qdd) - arm.inverse_dynamics(q, qd, qdd), atol=1e-10
        )
    np.testing.assert_allclose(InertialError().torque(arm, q, qd, qdd), 0.0, atol=1e-12)
    hand = Payload(1.0, [0, 0, 0.1]).apply_to(arm).links[-1]
    assert hand.mass_kg == pytest.approx(arm.links[-1].mass_kg + 1.0)


def test_delay_shifts_the_rigid_torque(arm: ArmModel) -> None:
    t, q, qd, qdd = smooth_series(arm)
    tau = arm.inverse_dynamics(q, qd, qdd)
    share = Delay(0.03).torque(arm, q, qd, qdd, stamps_s=t)
    np.testing.assert_allclose(share[3:], tau[:-3] - tau[3:], atol=1e-10)  # 3 samples at 100 Hz
    np.testing.assert_allclose(share[:3], tau[0] - tau[:3], atol=1e-10)  # first sample held before the start
    with pytest.raises(EffectSpecError, match="stamps_s"):
        Delay(0.03).torque(arm, q, qd, qdd)


def test_acceleration_noise_is_what_filtering_removes(arm: ArmModel) -> None:
    t, q, qd, qdd = smooth_series(arm, noise_rad_s=0.02)
    effect = AccelerationNoise(0.02, cutoff_hz=5.0)
    share = effect.torque(arm, q, qd, qdd, stamps_s=t)
    smooth = zero_phase_acceleration(qd, 100.0, 5.0)
    expected = np.einsum("nij,nj->ni", arm.mass_matrix(q), smooth - qdd)
    np.testing.assert_allclose(share, expected, atol=1e-9)
    # It cancels most of the noise the raw differences put into the model's torque.
    _, _, qd_true, qdd_true = smooth_series(arm)
    truth = arm.inverse_dynamics(q, qd, qdd_true)
    before = truth - arm.inverse_dynamics(q, qd, qdd)
    after = before - share
    assert np.sqrt(np.mean(after[20:-20] ** 2)) < 0.3 * np.sqrt(np.mean(before[20:-20] ** 2))


def test_dict_round_trip_and_joint_forms() -> None:
    effects = effects_from_dict(ALL)
    assert effects_from_dict(effects_to_dict(effects)) == effects
    (viscous,) = effects_from_dict({"viscous_friction": {"damping_nm_s_rad": {"s1": 2.0}}})
    np.testing.assert_array_equal(viscous.damping_nm_s_rad, [0, 2, 0, 0, 0, 0, 0])
    (scales,) = effects_from_dict({"inertial_error": {"mass_scale": {"e1": 1.5}}})
    np.testing.assert_array_equal(scales.mass_scale, [1, 1, 1, 1.5, 1, 1, 1])
    np.testing.assert_array_equal(scales.com_scale, np.ones(7))
    assert S1Spring() == effects_from_dict({"s1_spring": None})[0]
    assert ViscousFriction(1.0) != ViscousFriction(2.0)


def test_lower_bounds_are_each_parameters_own() -> None:
    """One bound per entry of parameter_vector, read from the field it belongs to: ≥ 0 for friction
    and armature, just above −1 for a gain (strict), none for an offset, a delay, the spring and the
    inertial parameters of a payload or a link change (no field of their own); every effect of ALL
    lies within its bounds."""
    arm = load_arm_model("right")
    for effect in effects_from_dict(ALL):
        if effect.name == "acceleration_noise":
            continue
        low = effect.parameter_lower_bounds()
        assert low.shape == effect.parameter_vector(arm).shape, effect.name
        if effect.name not in ("payload", "inertial_error"):
            assert np.all(effect.parameter_vector(arm) >= low), effect.name
    stribeck = StribeckFriction(coulomb_nm=0.1, static_nm=0.2).parameter_lower_bounds()
    np.testing.assert_array_equal(stribeck, np.zeros(14))
    np.testing.assert_array_equal(Armature(inertia_kgm2=0.0).parameter_lower_bounds(), np.zeros(7))
    (gain,) = effects_from_dict({"torque_gain": {"gain": 0.0}})
    assert np.all(gain.parameter_lower_bounds() == np.nextafter(-1.0, 0.0))
    for free in (TorqueOffset(offset_nm=0.0), Delay(delay_s=0.0), S1Spring(), Payload(mass_kg=1.0), InertialError()):
        assert np.all(free.parameter_lower_bounds() == -np.inf), free.name


@pytest.mark.parametrize(
    ("raw", "match"),
    [
        ({"spring": {}}, "unknown effects.*s1_spring"),
        ({"viscous_friction": {"damping": 1.0}}, "unknown parameters.*damping_nm_s_rad"),
        ({"viscous_friction": {}}, "missing parameters damping_nm_s_rad"),
        ({"coulomb_friction": {"friction_nm": -1.0}}, "friction_nm: must be >= 0"),
        ({"armature": {"inertia_kgm2": [1, 2, 3]}}, "inertia_kgm2: expected a number, a list of 7"),
        ({"delay": {"delay_s": float("nan")}}, "non-finite"),
        ({"payload": {"mass_kg": 0.0}}, "mass_kg: must be > 0"),
        ({"torque_offset": {"offset_nm": {"s9": 1.0}}}, "unknown joints"),
        ({"s1_spring": [1, 2]}, "expected a mapping of parameters"),
    ],
)
def test_bad_specs_are_refused_with_the_field(raw: dict, match: str) -> None:
    with pytest.raises(EffectSpecError, match=match):
        effects_from_dict(raw)


def test_example_config_loads(arm: ArmModel) -> None:
    effects = load_effects(CONFIG / "effects_example.yaml")
    assert {e.name for e in effects} >= {"s1_spring", "viscous_friction", "coulomb_friction", "acceleration_noise"}
    _, q, qd, qdd = smooth_series(arm, n=20)
    physical = tuple(e for e in effects if e.name != "acceleration_noise")
    assert total_torque(physical, arm, q, qd, qdd).shape == q.shape


def test_spec_file_errors(tmp_path: Path) -> None:
    with pytest.raises(EffectSpecError, match="cannot read"):
        load_effects(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("sensor: {}\n")
    with pytest.raises(EffectSpecError, match="no 'effects' section"):
        load_effects(bad)
