"""Fits on sufficient statistics (diagnosis/fit.py) against references computed another way: numpy's
least squares on regressor columns built here (q̇, tanh(q̇/ε), q̇ low-passed by scipy) over the recordings' samples, and
payloads whose torques Pinocchio computes for the arm carrying them (the fit must recover a load in
its physical box and stop at the box for one outside it)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_recordings import COULOMB, VISCOUS, blocks_of, lowpassed_velocity, recording

from baxter_dynamics_ros.core.effects import Payload, TorqueGain
from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.core.log_cholesky import pseudo_from_log_cholesky
from baxter_dynamics_ros.diagnosis.fit import Fitter, Model, Term
from baxter_dynamics_ros.diagnosis.statistics import Pool, column_layout, prepare
from baxter_dynamics_ros.diagnosis.validation import validation_arm

N = 7
CUTOFF_HZ = (4.0,) * N


@pytest.fixture(scope="module")
def arm():
    return validation_arm()


def _index(layout, name: str, variant: str | None = None) -> int:
    return next(i for i, c in enumerate(layout.candidates) if c.name == name and c.variant == variant)


def test_linear_fit_and_cross_validation_are_least_squares(arm) -> None:
    """Viscous and Coulomb friction (ε 0.05 rad/s) at every joint: the fit's parameters are numpy's
    least squares of each joint's denoised residual on [q̇_j, tanh(q̇_j/ε)] (q̇ low-passed at the cut-off)
    over both recordings, their covariance λ (XᵀX)⁻¹ per joint (λ the samples per effective sample,
    unit weights), the effective number of parameters is their count, and the cross-validated
    error is the held-out squared error of the fit on the other recording, per joint."""
    layout = column_layout()
    named = [("A", recording(arm, 81, viscous=VISCOUS, coulomb=COULOMB)), ("B", recording(arm, 82, viscous=VISCOUS, coulomb=COULOMB))]
    pool = Pool.of(blocks_of(arm, named, CUTOFF_HZ))
    fitter = Fitter(arm, layout, pool, np.ones(N), 3.0)
    viscous, coulomb = _index(layout, "viscous_friction"), _index(layout, "coulomb_friction", "smoothing 0.05 rad/s")
    model = Model.of([Term(viscous, tuple(range(N))), Term(coulomb, tuple(range(N)))])
    fit = fitter.fit(model)
    prepared = [prepare(arm, rec, CUTOFF_HZ) for _, rec in named]
    velocity = {id(p): lowpassed_velocity(rec, CUTOFF_HZ) for p, (_, rec) in zip(prepared, named)}

    def columns(p, j):
        v = velocity[id(p)][:, j]
        return np.column_stack([v, np.tanh(v / 0.05)])

    cv = np.zeros(N)
    for j in range(N):
        X = np.vstack([columns(p, j) for p in prepared])
        r = np.concatenate([p.residual[:, j] for p in prepared])
        coef = np.linalg.lstsq(X, r, rcond=None)[0]
        assert np.all(coef > 0)  # bounds inactive: the reference needs none
        np.testing.assert_allclose(fit.x[[j, N + j]], coef, rtol=1e-6)
        np.testing.assert_allclose(fit.cov_x[np.ix_([j, N + j], [j, N + j])], 3.0 * np.linalg.inv(X.T @ X), rtol=1e-6)
        for out in range(2):
            p_fit, p_out = prepared[1 - out], prepared[out]
            c = np.linalg.lstsq(columns(p_fit, j), p_fit.residual[:, j], rcond=None)[0]
            cv[j] += float(np.sum((p_out.residual[:, j] - columns(p_out, j) @ c) ** 2))
    assert fit.df == pytest.approx(2 * N, abs=1e-4)
    np.testing.assert_allclose(fitter.cv_sse(model)[0], cv, rtol=1e-6)
    np.testing.assert_allclose(fit.x[:N], VISCOUS, rtol=0.1)


@pytest.mark.parametrize("name", ["viscous_friction", "armature"])
def test_dissipation_and_rotor_inertia_stop_at_zero(arm, name: str) -> None:
    """Viscous friction and armature are physical only ≥ 0: injected negative (−VISCOUS, or −0.1
    kg·m² at every joint), the fit holds every joint's parameter at 0 and marks it not free;
    injected positive, the same fit leaves it free and finds it (within 10 %)."""
    layout = column_layout()
    index = _index(layout, name)
    model = Model.of([Term(index, tuple(range(N)))])

    def fitted(sign: float):
        effect = {"viscous": sign * np.asarray(VISCOUS)} if name == "viscous_friction" else {"armature": sign * 0.1}
        named = [(f"{name}{s}", recording(arm, s, **effect)) for s in (71, 72)]
        return Fitter(arm, layout, Pool.of(blocks_of(arm, named, CUTOFF_HZ)), np.ones(N), 3.0).fit(model)

    truth = np.asarray(VISCOUS) if name == "viscous_friction" else np.full(N, 0.1)
    below, above = fitted(-1.0), fitted(1.0)
    np.testing.assert_array_equal(below.x, np.zeros(N))
    assert not below.free.any()
    assert above.free.all()
    np.testing.assert_allclose(above.x, truth, rtol=0.1)


def test_a_torque_gain_stops_inside_its_domain(arm) -> None:
    """A sensor gain g is > −1 (TorqueGain): where the effort is −0.5 τ (g = −1.5) the fit holds g just
    above −1, not free, and the effect can be made of it; where it is 0.8 τ, g = −0.2 is found."""
    truth = np.array([-1.5, -0.2, 0.0, 0.0, 0.0, 0.0, 0.0])
    named = []
    for s in (61, 62):
        rec = recording(arm, s)
        named.append((f"g{s}", Recording(rec.side, rec.joint_names, rec.stamps_ns, rec.q, rec.qd, rec.effort * (1.0 + truth))))
    layout = column_layout()
    fit = Fitter(arm, layout, Pool.of(blocks_of(arm, named, CUTOFF_HZ)), np.ones(N), 3.0).fit(Model.of([Term(_index(layout, "torque_gain"), (0, 1))]))
    assert -1.0 < fit.x[0] < -1.0 + 1e-12 and not fit.free[0]
    assert fit.free[1] and fit.x[1] == pytest.approx(-0.2, abs=0.01)
    TorqueGain(gain=[*fit.x, 0.0, 0.0, 0.0, 0.0, 0.0])


def _fitted_payload(arm, load: Payload) -> tuple[float, np.ndarray]:
    """(mass kg, centre of mass (3,) m in the flange frame) of the payload fitted to two recordings of
    the arm carrying ``load`` (torques from Pinocchio's model of the loaded arm)."""
    carried = load.apply_to(arm)
    named = [(f"p{s}", recording(arm, s, carried=carried)) for s in (91, 92)]
    layout = column_layout()
    pool = Pool.of(blocks_of(arm, named, CUTOFF_HZ))
    index = _index(layout, "payload")
    fit = Fitter(arm, layout, pool, np.ones(N), 3.0).fit(Model.of([Term(index, tuple(range(N)))]))
    J = pseudo_from_log_cholesky(fit.phi[index][0])
    mass = float(J[3, 3])
    return mass, J[:3, 3] / mass


def test_payload_inside_its_box_is_recovered(arm) -> None:
    """A 1.5 kg load 2 cm off-axis and 6 cm out along the flange: mass within 3 %, centre of mass within 1 cm."""
    mass, com = _fitted_payload(arm, Payload(mass_kg=1.5, com_m=(0.0, 0.02, 0.06)))
    assert mass == pytest.approx(1.5, rel=0.03)
    np.testing.assert_allclose(com, [0.0, 0.02, 0.06], atol=0.01)


def test_payload_outside_its_box_stops_at_the_box(arm) -> None:
    """An 8 kg load 0.5 m off-axis and 0.6 m out: the fit is held at the physical box (mass at most
    5 kg, centre of mass within ±0.1 m across and at most 0.3 m out), not carried to the load."""
    mass, com = _fitted_payload(arm, Payload(mass_kg=8.0, com_m=(0.5, 0.0, 0.6)))
    assert mass <= 5.0 * (1 + 1e-6)
    assert np.all(np.abs(com[:2]) <= 0.1 + 1e-6)
    assert -0.05 - 1e-6 <= com[2] <= 0.3 + 1e-6


def _offset(rec: Recording, offsets: dict[int, float]) -> Recording:
    """The recording with offsets {joint: N·m} added to its effort."""
    effort = rec.effort.copy()
    for j, value in offsets.items():
        effort[:, j] += value
    return Recording(rec.side, rec.joint_names, rec.stamps_ns, rec.q, rec.qd, effort)


def test_offsets_are_each_recordings_own_within_a_sensors_drift(arm) -> None:
    """Three recordings with viscous friction and offsets at e1 (0, 1.4, 0.7 N·m: 0.7 from their mean,
    more than a sensor drifts) and at w1 (0.10, 0.30, 0.20: 0.1 from it). Against numpy's least squares
    of each joint's denoised residual on [q̇_j low-passed by scipy, one indicator per recording]: at
    w1 the viscous coefficient and each recording's own offset, the offset used beyond the training
    data their mean, its variance λ/n plus the spread of the recordings' offsets over their count;
    at e1 the recordings' offsets depart from their mean by more than MAX_OFFSET_DRIFT_NM, so one
    offset is shared (least squares on [q̇_e1, 1]) and the departure is reported. The offsets count
    as parameters: 7 viscous and 2 offsets."""
    from baxter_dynamics_ros.diagnosis.fit import MAX_OFFSET_DRIFT_NM

    layout = column_layout()
    drift = {3: (0.0, 1.4, 0.7), 5: (0.10, 0.30, 0.20)}
    named = [(f"R{k}", _offset(recording(arm, 91 + k, viscous=VISCOUS), {j: v[k] for j, v in drift.items()})) for k in range(3)]
    pool = Pool.of(blocks_of(arm, named, CUTOFF_HZ))
    lam = 3.0
    fitter = Fitter(arm, layout, pool, np.ones(N), lam)
    viscous, offset = _index(layout, "viscous_friction"), _index(layout, "torque_offset")
    model = Model.of([Term(viscous, tuple(range(N))), Term(offset, (3, 5))])
    fit = fitter.fit(model)
    residual = [prepare(arm, rec, CUTOFF_HZ).residual for _, rec in named]
    velocity = [lowpassed_velocity(rec, CUTOFF_HZ) for _, rec in named]
    n = sum(len(r) for r in residual)

    def per_recording(j: int) -> np.ndarray:
        """[viscous, offset of each recording] by numpy."""
        X = np.zeros((n, 4))
        X[:, 0] = np.concatenate([v[:, j] for v in velocity])
        start = 0
        for k, r in enumerate(residual):
            X[start : start + len(r), 1 + k] = 1.0
            start += len(r)
        return np.linalg.lstsq(X, np.concatenate([r[:, j] for r in residual]), rcond=None)[0]

    free = per_recording(5)
    cols = list(fitter.columns(model))
    at = {c: k for k, c in enumerate(cols)}
    v5, o5 = at[layout.candidates[viscous].columns[5]], at[layout.candidates[offset].columns[5]]
    assert fit.x[v5] == pytest.approx(free[0], rel=1e-6)
    np.testing.assert_allclose([fit.offsets[f"R{k}"][list(fit.offset_joints).index(5)] for k in range(3)], free[1:], atol=1e-6)
    np.testing.assert_allclose(free[1:] - free[1:].mean(), np.array(drift[5]) - np.mean(drift[5]), atol=0.02)  # the planted spread
    assert fit.x[o5] == pytest.approx(free[1:].mean(), abs=1e-6)
    assert fit.cov_x[o5, o5] == pytest.approx(lam / n + free[1:].var(ddof=1) / 3, rel=1e-6)

    departure = np.max(np.abs(per_recording(3)[1:] - per_recording(3)[1:].mean()))
    assert departure > MAX_OFFSET_DRIFT_NM and set(fit.held_common) == {3}
    assert fit.held_common[3] == pytest.approx(departure, rel=1e-6)
    X = np.column_stack([np.concatenate([v[:, 3] for v in velocity]), np.ones(n)])
    shared = np.linalg.lstsq(X, np.concatenate([r[:, 3] for r in residual]), rcond=None)[0]
    o3, v3 = at[layout.candidates[offset].columns[3]], at[layout.candidates[viscous].columns[3]]
    np.testing.assert_allclose(fit.x[[v3, o3]], shared, rtol=1e-6, atol=1e-6)
    assert fit.df == pytest.approx(N + 2, abs=1e-4)


def test_a_payload_beside_a_link_change_keeps_its_own_parameters(arm) -> None:
    """A payload and inertial_error in one model share link 7's columns; with per-recording offsets
    (profiled out at w1) each term's x must still be its own φ's inertial parameters — the payload's
    π(φ), inertial_error's π(φ) − π(φ₀) per link — not one term's value written in both places."""
    from baxter_dynamics_ros.core.log_cholesky import parameters_from_log_cholesky

    carried = Payload(mass_kg=1.5, com_m=(0.0, 0.02, 0.06)).apply_to(arm)
    named = [(f"L{s}", _offset(recording(arm, s, carried=carried), {5: 0.1 * k})) for k, s in enumerate((93, 94))]
    layout = column_layout()
    fitter = Fitter(arm, layout, Pool.of(blocks_of(arm, named, CUTOFF_HZ)), np.ones(N), 3.0)
    payload, inertial, offset = _index(layout, "payload"), _index(layout, "inertial_error"), _index(layout, "torque_offset")
    model = Model.of([Term(offset, (5,)), Term(payload, tuple(range(N))), Term(inertial, tuple(range(N)))])
    fit = fitter.fit(model)
    assert fit.offset_joints == (5,)
    at = fitter.positions(model)
    pi_payload = parameters_from_log_cholesky(fit.phi[payload])[0][0]
    pi_links = parameters_from_log_cholesky(fit.phi[inertial])[0]
    np.testing.assert_allclose(fit.x[at[model.term(payload)]], pi_payload, rtol=1e-9, atol=1e-12)
    reference = fitter.link_setup(layout.candidates[inertial]).pi_reference
    np.testing.assert_allclose(fit.x[at[model.term(inertial)]], (pi_links - reference).ravel(), rtol=1e-9, atol=1e-12)
    assert pi_payload[0] > 0.5  # the load is carried by the payload, not only by link 7 (≤ 150 % of 0.54 kg)
