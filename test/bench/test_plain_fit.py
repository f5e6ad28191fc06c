"""The plain reference fit (bench/plain_fit.py) on synthetic recordings with known planted effects.

Efforts are Pinocchio's RNEA of Rethink's URDF (``../shared/reference``) at the exact q̈ of smooth
sinusoids, plus effects written out here — Coulomb friction f·sign(q̇) at e1, a per-recording offset
at w1 — and white noise. The fit must select exactly the planted effects, recover their values, and
reject every absent one; its regressor must reproduce RNEA (Y·π = τ).
"""

from __future__ import annotations

import numpy as np
import pytest
from urdf_motion import RATE_HZ, motion

from bench.plain_fit import COLUMNS, JOINT_EFFECTS, Fit, Model, UrdfArm, is_physical, physical_levels, plain_diagnosis, recording_stats

COULOMB_E1_NM = 1.5
OFFSETS_W1_NM = (0.30, 0.34, 0.27, 0.31)  # one per recording; the last is the test recording
NOISE_NM = 0.02


@pytest.fixture(scope="module")
def planted(arm: UrdfArm):
    """Statistics of 4 recordings (3 to train, 1 to test) with Coulomb friction at e1 and offsets at w1."""
    stats = []
    for k, offset in enumerate(OFFSETS_W1_NM):
        q, qd, qdd = motion(arm, seed=20 + k)
        effort = arm.torque(q, qd, qdd)
        effort[:, 3] += COULOMB_E1_NM * np.sign(qd[:, 3])
        effort[:, 5] += offset
        effort += np.random.default_rng(100 + k).normal(0.0, NOISE_NM, effort.shape)
        stats.append(recording_stats(arm, f"rec{k}", q, qd, effort, RATE_HZ))
    return stats, plain_diagnosis(stats[:3], stats[3:])


def test_regressor_reproduces_rnea(arm: UrdfArm) -> None:
    q, qd, qdd = motion(arm, seed=3, seconds=0.5)
    np.testing.assert_allclose(arm.regressor(q, qd, qdd) @ arm.pi, arm.torque(q, qd, qdd), atol=1e-9)


def test_holding_torque_matches_the_reference_figures(arm: UrdfArm) -> None:
    # ../shared/reference/README.md: the URDF's gravity torque at q = 0 (either arm: the mounts differ by a yaw).
    tau = arm.torque(np.zeros((1, 7)), np.zeros((1, 7)), np.zeros((1, 7)))[0]
    np.testing.assert_allclose(tau, [0, -52.876, 0.030, -15.609, 0.201, -1.819, 0.005], atol=0.02)


def test_selects_exactly_the_planted_effects(planted) -> None:
    _, result = planted
    assert sorted(result.selected) == ["coulomb_friction@e1", "torque_offset@w1"], result.selected


def test_recovers_the_planted_values(planted) -> None:
    stats, result = planted
    c = list(result.model.columns)
    theta = dict(zip(c, result.fit.theta))
    assert theta[int(COLUMNS["sign"][3])] == pytest.approx(COULOMB_E1_NM, abs=0.03)
    for rec, offset in zip(stats[:3], OFFSETS_W1_NM):
        assert result.fit.offsets[rec.name][5] == pytest.approx(offset, abs=0.01)
    # Held out: the Coulomb term carries over, the test recording's offset is the training mean.
    assert result.test_rms[3] < 2 * NOISE_NM
    assert result.test_rms[5] == pytest.approx(np.hypot(NOISE_NM, OFFSETS_W1_NM[3] - np.mean(OFFSETS_W1_NM[:3])), abs=0.005)
    assert result.rigid_test_rms[3] > 1.0  # what the planted Coulomb term leaves without the fit


def test_joint_values_are_the_planted_ones(planted) -> None:
    """Per selected "name@joint": the fitted values at that joint; an offset's, the one the test
    recording gets (the training recordings' mean); an effect not selected is refused."""
    _, result = planted
    assert result.joint_values("coulomb_friction@e1") == pytest.approx((COULOMB_E1_NM,), abs=0.03)
    assert result.joint_values("torque_offset@w1") == pytest.approx((np.mean(OFFSETS_W1_NM[:3]),), abs=0.01)
    # exactly the mean of the three recordings' own offsets (each checked above against its planted one)
    assert result.joint_values("torque_offset@w1") == pytest.approx((np.mean([result.fit.offsets[f"rec{k}"][5] for k in range(3)]),), rel=1e-12)
    for label in ("coulomb_friction@w1", "s1_spring", "armature@e1"):
        with pytest.raises(ValueError, match="no per-joint effect of this fit"):
            result.joint_values(label)


def test_physical_values_only_refuses_a_negative_friction(arm: UrdfArm) -> None:
    """A planted negative viscous coefficient at e1 (−0.8 N·m·s/rad, what no friction does) beside a
    positive Coulomb term at w0: the plain fit takes a negative viscous friction at e1; with
    ``physical`` no move leaves a negative friction or armature value anywhere, the Coulomb term
    at w0 is still found, and e1's held-out error stays near its rigid level."""
    stats = []
    for k in range(4):
        q, qd, qdd = motion(arm, seed=40 + k)
        effort = arm.torque(q, qd, qdd)
        effort[:, 3] -= 0.8 * qd[:, 3]
        effort[:, 4] += 0.3 * np.sign(qd[:, 4])
        effort += np.random.default_rng(140 + k).normal(0.0, NOISE_NM, effort.shape)
        stats.append(recording_stats(arm, f"n{k}", q, qd, effort, RATE_HZ))
    free = plain_diagnosis(stats[:3], stats[3:])
    at_e1 = [e for e in free.selected if e.endswith("@e1")]
    assert any(min(physical_levels(e, free.joint_values(e)), default=0.0) < 0 for e in at_e1), free.selected
    bound = plain_diagnosis(stats[:3], stats[3:], physical=True)
    assert "coulomb_friction@w0" in bound.selected, bound.selected
    for e in bound.selected:
        if "@" in e:
            assert min(physical_levels(e, bound.joint_values(e)), default=0.0) >= 0, (e, bound.joint_values(e))
    assert bound.test_rms[3] > 5 * free.test_rms[3]


def test_physical_levels_name_what_must_not_be_negative() -> None:
    """Friction and armature values, Stribeck's as sliding F_c and breakaway F_c + bump; none for
    an offset, a delay or a gain (either sign is physical)."""
    assert physical_levels("armature@s1", (-0.4,)) == (-0.4,)
    assert physical_levels("stribeck_friction(v_s=0.02)@s1", (0.8, -0.9)) == pytest.approx((0.8, -0.1))
    assert physical_levels("viscous_friction@w0", (0.2,)) == (0.2,)
    for label in ("torque_offset@w1", "delay@e0", "torque_gain@s0"):
        assert physical_levels(label, (-1.0,)) == ()


def test_is_physical_checks_every_effect_not_only_the_last_added() -> None:
    """A model of viscous friction then armature at s1 (columns by hand): physical with both values
    positive; not physical when the first-added viscous coefficient has turned negative, nor when the
    armature has; the gain's negative value leaves it physical (a gain may take either sign)."""
    viscous, armature, gain = (int(COLUMNS[b][1]) for b in ("viscous", "armature", "gain"))
    model = Model(tuple(sorted((viscous, armature, gain))), (), ("viscous_friction@s1", "armature@s1", "torque_gain@s1"))
    theta = {viscous: 0.3, armature: 0.1, gain: -0.2}

    def physical(**values: float) -> bool:
        th = {**theta, **{{"viscous": viscous, "armature": armature}[k]: v for k, v in values.items()}}
        return is_physical(model, Fit(np.array([th[c] for c in model.columns]), {}))

    assert physical()
    assert not physical(viscous=-0.01)
    assert not physical(armature=-0.01)


def test_never_takes_an_excluded_move(planted) -> None:
    """Barred from Coulomb friction at e1, the fit takes a Stribeck variant there (it holds the same
    sign(q̇) column); barred from every friction move at e1, nothing stands in for it (held-out e1
    error far above the noise); the offset at w1 is found either way."""
    stats, result = planted
    barred = plain_diagnosis(stats[:3], stats[3:], exclude=frozenset({"coulomb_friction@e1"}))
    assert "coulomb_friction@e1" not in barred.selected and "torque_offset@w1" in barred.selected, barred.selected
    assert any(e.startswith("stribeck_friction") and e.endswith("@e1") for e in barred.selected), barred.selected
    friction = frozenset(f"{name}@e1" for name in JOINT_EFFECTS if "friction" in name)
    barred = plain_diagnosis(stats[:3], stats[3:], exclude=friction)
    assert not friction & set(barred.selected) and "torque_offset@w1" in barred.selected, barred.selected
    assert barred.test_rms[3] > 10 * result.test_rms[3]
    assert barred.test_rms[5] == pytest.approx(result.test_rms[5], abs=1e-3)


def test_rejects_an_absent_effect(arm: UrdfArm) -> None:
    # Nothing but noise on the rigid body: no effect may pass the 5 % rule.
    stats = []
    for k in range(3):
        q, qd, qdd = motion(arm, seed=40 + k, seconds=15.0)
        effort = arm.torque(q, qd, qdd) + np.random.default_rng(200 + k).normal(0.0, NOISE_NM, (len(q), 7))
        stats.append(recording_stats(arm, f"noise{k}", q, qd, effort, RATE_HZ))
    result = plain_diagnosis(stats[:2], stats[2:])
    assert result.selected == ()
