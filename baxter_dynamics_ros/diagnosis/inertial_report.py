"""The inertial effects' report: a fitted payload or link change as the physical quantities a user
reads (mass, centre of mass, inertia about it), each with its SD and whether the data, the prior or
a bound decided it.
"""

from __future__ import annotations

import numpy as np

from ..core.arm_model import ArmModel, pseudo_inertia
from ..core.log_cholesky import pseudo_from_log_cholesky
from .fit import Fit, Fitter, Term
from .statistics import Candidate

__all__ = ["inertial_params", "inertial_quantities", "link_report"]


def inertial_quantities(phi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass (kg), centre of mass (3,) m and inertia tensor about it (3, 3) kg·m² of one link's φ."""
    j = pseudo_from_log_cholesky(phi)
    m = float(j[3, 3])
    c = j[:3, 3] / m
    sigma = j[:3, :3] - m * np.outer(c, c)
    return m, c, np.trace(sigma) * np.eye(3) - sigma


#: The physical quantities of a link reported, with the flat index they take in
#: [m, c (3), inertia about the centre of mass (xx xy xz yy yz zz)].
_QUANTITY_NAMES = ("mass", "com x", "com y", "com z", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


def _quantity_vector(phi: np.ndarray) -> np.ndarray:
    m, c, inertia = inertial_quantities(phi)
    return np.concatenate([[m], c, inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]])


#: φ's coordinates with a bound, and the quantity each is: α the mass, t the centre of mass.
_BOUNDED = {0: "mass", 7: "com x", 8: "com y", 9: "com z"}


def link_report(name: str, phi: np.ndarray, cov: np.ndarray, setup: tuple[np.ndarray, ...], before: tuple | None) -> dict:
    """One link's (or the payload's) inertials after the fit, their SD, and what the data decided.

    setup: the link's (prior std (10,), lower (10,), upper (10,)) of φ. A quantity is *decided by
    the data* when its posterior variance is less than half its prior variance (linearised at the
    fit); the others are set by the prior (the paper's values). A mass or centre-of-mass coordinate
    held at its bound is listed under ``at_bound`` (its SD is then null): the bound decided it, not
    the data — the sign of a link made to absorb what another effect would explain.
    """
    prior_std, lo, hi = setup
    value = _quantity_vector(phi)
    jac = np.empty((10, 10))
    for k in range(10):
        step = np.zeros(10)
        step[k] = 1e-6
        jac[:, k] = (_quantity_vector(phi + step) - _quantity_vector(phi - step)) / 2e-6
    post = np.diag(jac @ cov @ jac.T)
    prior = np.diag(jac @ np.diag(prior_std**2) @ jac.T)
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    pinned = [q for k, q in _BOUNDED.items() if min(phi[k] - lo[k], hi[k] - phi[k]) <= 1e-6 * width[k]]
    undecided = [q for q, a, b in zip(_QUANTITY_NAMES, post, prior) if q not in pinned and b > 0 and a > 0.5 * b]
    std = {q: (None if q in pinned else float(np.sqrt(max(v, 0.0)))) for q, v in zip(_QUANTITY_NAMES, post)}
    out = {
        "link": name,
        "mass_kg": float(value[0]),
        "com_m": value[1:4].tolist(),
        "inertia_about_com_kgm2": value[4:].tolist(),
        "std": std,
        "set_by_prior": undecided,
        "at_bound": pinned,
    }
    if before is not None:
        m, c, inertia = before
        out["before"] = {"mass_kg": m, "com_m": list(c), "inertia_about_com_kgm2": inertia[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]].tolist()}
    return out


def inertial_params(arm: ArmModel, fitter: Fitter, cand: Candidate, term: Term, fit: Fit) -> tuple[dict, dict, list[dict]]:
    """Payload / inertial change: physical parameters, their SD and the per-link report."""
    phi = fit.phi[term.candidate]
    cov = fit.phi_cov[term.candidate]
    _, prior_std, lower, upper, _ = fitter.link_setup(cand)
    links = []
    if cand.is_payload:
        rep = link_report("payload", phi[0], cov, (prior_std[0], lower[0], upper[0]), None)
        params = {"mass_kg": rep["mass_kg"], **{f"com_m[{a}]": v for a, v in zip("xyz", rep["com_m"])}}
        params.update({f"inertia_kgm2[{q}]": v for q, v in zip(("xx", "xy", "xz", "yy", "yz", "zz"), rep["inertia_about_com_kgm2"])})
        std = {k: _nan_if_none(v) for k, v in zip(params, rep["std"].values())}
        return params, std, [rep]
    params, std = {}, {}
    for i, link_index in enumerate(cand.links):
        link = arm.links[link_index]
        j0 = pseudo_inertia(link)
        m0 = float(j0[3, 3])
        before = (m0, link.com_m, link.inertia_kgm2)
        rep = link_report(
            f"link {link_index + 1} ({link.name})", phi[i], cov[10 * i : 10 * i + 10, 10 * i : 10 * i + 10], (prior_std[i], lower[i], upper[i]), before
        )
        sd = np.array([rep["std"][q] if rep["std"][q] is not None else 0.0 for q in ("mass", "com x", "com y", "com z")])
        change = np.abs(np.concatenate([[rep["mass_kg"] - m0], np.array(rep["com_m"]) - link.com_m]))
        rep["changed"] = bool(rep["at_bound"]) or bool(np.any(change > 2 * sd))
        links.append(rep)
        params[f"link{link_index + 1}.mass_kg"] = rep["mass_kg"]
        std[f"link{link_index + 1}.mass_kg"] = _nan_if_none(rep["std"]["mass"])
        for a, v, q in zip("xyz", rep["com_m"], ("com x", "com y", "com z")):
            params[f"link{link_index + 1}.com_m[{a}]"] = v
            std[f"link{link_index + 1}.com_m[{a}]"] = _nan_if_none(rep["std"][q])
    return params, std, links


def _nan_if_none(value: float | None) -> float:
    return float("nan") if value is None else float(value)
