"""The inertial effects' report (diagnosis/inertial_report.py): a link's φ read as mass, centre of
mass and inertia about it, and what the data, the prior or a bound decided of each.

The expected quantities are written out here from the log-Cholesky coordinates' definition
(Rucker and Wensing 2022): m = e^{2α}, c = t, Σ_c = m·L·Lᵀ with L the upper triangle of e^d and s,
and the inertia about the centre of mass tr(Σ_c)·𝟙 − Σ_c.
"""

from __future__ import annotations

import numpy as np

from baxter_dynamics_ros.diagnosis.inertial_report import inertial_quantities, link_report

#: φ = (α, d1, d2, d3, s12, s23, s13, t1, t2, t3) of a link of about 2.2 kg.
PHI = np.array([0.4, -2.3, -2.0, -2.6, 0.03, -0.02, 0.01, 0.02, -0.05, 0.12])
QUANTITIES = ("mass", "com x", "com y", "com z", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


def by_hand(phi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(m kg, c (3,) m, inertia about c (3, 3) kg·m²) from φ's definition."""
    alpha, d1, d2, d3, s12, s23, s13 = phi[:7]
    L = np.array([[np.exp(d1), s12, s13], [0.0, np.exp(d2), s23], [0.0, 0.0, np.exp(d3)]])
    m = np.exp(2 * alpha)
    sigma = m * L @ L.T
    return m, phi[7:].copy(), np.trace(sigma) * np.eye(3) - sigma


def test_quantities_are_those_of_the_coordinates() -> None:
    m, c, inertia = inertial_quantities(PHI)
    m0, c0, inertia0 = by_hand(PHI)
    np.testing.assert_allclose(m, m0, rtol=1e-12)
    np.testing.assert_allclose(c, c0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(inertia, inertia0, rtol=1e-12, atol=1e-15)
    # A physical body's inertia about its centre of mass: positive, with the triangle inequalities.
    moments = np.linalg.eigvalsh(inertia)
    assert moments[0] > 0 and moments[2] <= moments[0] + moments[1]


def setup(prior_std: float, lower: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.full(10, prior_std), (np.full(10, -np.inf) if lower is None else lower), np.full(10, np.inf)


def test_what_the_data_decided_is_told_from_what_the_prior_set() -> None:
    """A posterior far narrower than the prior: every quantity decided by the data, its SD the
    linearised posterior's; as wide as the prior: every quantity set by it; the mass alone
    measured (φ's α known to 1 %, the rest as the prior): only the mass decided."""
    narrow = link_report("link", PHI, np.eye(10) * 1e-8, setup(1.0), None)
    assert narrow["set_by_prior"] == [] and narrow["at_bound"] == []
    m = by_hand(PHI)[0]
    # m = e^{2α}: SD(m) = 2m·SD(α)
    np.testing.assert_allclose(narrow["std"]["mass"], 2 * m * 1e-4, rtol=1e-4)
    np.testing.assert_allclose([narrow["std"][q] for q in ("com x", "com y", "com z")], 1e-4, rtol=1e-4)
    np.testing.assert_allclose([narrow["mass_kg"], *narrow["com_m"]], [m, *PHI[7:]], rtol=1e-12, atol=1e-15)

    wide = link_report("link", PHI, np.eye(10) * 0.04, setup(0.2), None)
    assert wide["set_by_prior"] == list(QUANTITIES)

    cov = np.eye(10) * 0.04
    cov[0, 0] = 1e-4
    mass_only = link_report("link", PHI, cov, setup(0.2), None)
    assert "mass" not in mass_only["set_by_prior"] and {"com x", "com y", "com z"} <= set(mass_only["set_by_prior"])


def test_a_quantity_held_at_its_bound_is_said_so_with_no_sd() -> None:
    """φ's mass coordinate at its lower bound and com z at its upper: both listed under at_bound
    with a null SD, and not as set by the prior; a com x 1 cm inside its bound is not."""
    lower = np.full(10, -np.inf)
    lower[0] = PHI[0]
    upper = np.full(10, np.inf)
    upper[9] = PHI[9]
    upper[7] = PHI[7] + 0.01
    rep = link_report("link", PHI, np.eye(10) * 0.04, (np.full(10, 0.2), lower, upper), None)
    assert rep["at_bound"] == ["mass", "com z"]
    assert rep["std"]["mass"] is None and rep["std"]["com z"] is None and rep["std"]["com x"] is not None
    # as wide as the prior, the others are set by it; the bound, not the prior, set those two
    assert rep["set_by_prior"] == [q for q in QUANTITIES if q not in ("mass", "com z")]


def test_the_values_before_the_change_are_reported_beside() -> None:
    """``before`` (mass, com, inertia about it) is written out in the report's own order."""
    m, c, inertia = by_hand(PHI)
    rep = link_report("link 7", PHI, np.eye(10) * 1e-8, setup(1.0), (m + 1.0, c + 0.01, inertia * 2))
    assert rep["link"] == "link 7" and rep["before"]["mass_kg"] == m + 1.0
    np.testing.assert_allclose(rep["before"]["com_m"], c + 0.01)
    xx, xy, xz, yy, yz, zz = rep["before"]["inertia_about_com_kgm2"]
    np.testing.assert_allclose([xx, xy, xz, yy, yz, zz], 2 * inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]])
    np.testing.assert_allclose(rep["inertia_about_com_kgm2"], inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]], rtol=1e-12, atol=1e-15)
