"""Inertial candidates (``payload``, ``inertial_error``) fitted inside the physical set.

Each link's pseudo-inertia is written in log-Cholesky coordinates φ
(:mod:`~baxter_dynamics_ros.core.log_cholesky`), so it stays positive definite whatever the data say;
its mass and centre of mass are box bounds on φ (``MASS_RANGE`` and ``COM_BOX_M`` about the paper's
values; the payload's in ``PAYLOAD_MASS_KG`` and ``PAYLOAD_COM_BOX_M`` at the flange); and a Gaussian
prior on φ about the paper's values (:class:`LinkSetup`) pulls the directions the data do not see
back to them. :func:`fit_inertial` solves the problem, with any linear terms of the same model, by a
bounded damped Newton iteration with Levenberg-Marquardt damping (:func:`box_newton`, exact
derivatives). The data term is the quadratic form of the weighted statistics in unit-norm columns,
yᵀ Hs y − 2 bsᵀ y (Hs = D⁻¹ H D⁻¹, y = x ⊙ diag(H)^½), so a cost evaluation costs as much as the
model has columns, whatever the length of the recordings. Why not an SDP (cvxpy, as FloBaRoID): the log-Cholesky form needs no extra
solver, handles the bounds and a prior in one smooth problem, and a warm-started fit of a
cross-validation fold takes a few milliseconds. :mod:`.fit` calls it and keeps the models' layout.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..core.arm_model import ArmModel, pseudo_inertia
from ..core.log_cholesky import contraction_hessian, log_cholesky_from_pseudo, parameters_from_log_cholesky
from ..errors import DiagnosisError
from .statistics import Candidate

__all__ = [
    "AT_BOUND",
    "COM_BOX_M",
    "MASS_RANGE",
    "PAYLOAD_COM_BOX_M",
    "PAYLOAD_MASS_KG",
    "RIDGE",
    "InertialSolution",
    "LinkSetup",
    "WarmStart",
    "box_newton",
    "fit_inertial",
    "link_setup",
]

#: A link's mass stays within this factor range of the paper's.
MASS_RANGE = (0.5, 1.5)
#: A link's centre of mass stays within this distance of the paper's along each axis of its DH frame, m.
COM_BOX_M = 0.05
#: Prior standard deviations of a link's log-Cholesky coordinates about the paper's values:
#: α (½ ln m: 0.1 is 20 % of mass), d (ln of a radius of gyration: 20 %), s (relative to the
#: link's mean radius of gyration), t (centre of mass, m).
LINK_PRIOR_STD = {"alpha": 0.1, "d": 0.2, "s": 0.2, "t": 0.02}
#: The payload: mass range (kg), centre-of-mass box in the flange frame (m, per axis lower/upper).
PAYLOAD_MASS_KG = (0.01, 5.0)
PAYLOAD_COM_BOX_M = ((-0.1, 0.1), (-0.1, 0.1), (-0.05, 0.3))
#: The payload's prior: 1 kg, centre of mass 5 cm out along the flange's z, radii of gyration 3 cm,
#: all broad (the data decide mass and centre of mass; the prior only what they cannot see).
PAYLOAD_PRIOR_MEAN = {"mass_kg": 1.0, "com_m": (0.0, 0.0, 0.05), "gyration_m": 0.03}
PAYLOAD_PRIOR_STD = {"alpha": 1.0, "d": 0.7, "s": 1.0, "t": 0.1}
#: Relative ridge on unit-norm columns: keeps directions the data never excite at zero.
RIDGE = 1e-9
#: Newton steps of a fit at most (a warm-started fit takes a few; a fold starts at the whole
#: pool's optimum; the iteration stops when it promises less than 1e-12 of the cost).
MAX_NEWTON_STEPS = 100
#: A parameter within this fraction of its range's width of a bound is at the bound.
AT_BOUND = 1e-9


class LinkSetup(NamedTuple):
    """An inertial candidate's log-Cholesky coordinates' prior and bounds, one row per link (L, 10)."""

    phi0: np.ndarray  # the prior's mean: the paper's values (the payload's: PAYLOAD_PRIOR_MEAN)
    prior_std: np.ndarray  # σ_φ
    lower: np.ndarray
    upper: np.ndarray
    pi_reference: np.ndarray  # the inertial parameters π(φ₀) the columns' x are changes of


@dataclass
class WarmStart:
    """Where the next exact fit starts: the last one's φ per inertial candidate and its linear
    parameters by column (shared by the fitters of one pool, whatever their weights)."""

    phi: dict[int, np.ndarray] = field(default_factory=dict)
    x: dict[int, float] = field(default_factory=dict)


class InertialSolution(NamedTuple):
    """:func:`fit_inertial`'s result, in the model's columns (c,)."""

    x: np.ndarray  # linear parameters, and π(φ) − π_reference for the inertial columns
    cov_x: np.ndarray  # (c, c), zero for a fold
    free: np.ndarray  # (c,) bool, not held at a bound
    df: float  # effective number of parameters
    phi: dict[int, np.ndarray]  # per inertial candidate index, its φ (links, 10)
    phi_cov: dict[int, np.ndarray]  # and its covariance (10·links, 10·links); empty for a fold
    z: np.ndarray  # the solver's variables: a fold's start


def link_setup(arm: ArmModel, cand: Candidate) -> LinkSetup:
    """The prior and the bounds of an inertial candidate's log-Cholesky coordinates (its links', or
    the payload's at the flange)."""
    if cand.is_payload:
        m0, c0, g0 = PAYLOAD_PRIOR_MEAN["mass_kg"], np.array(PAYLOAD_PRIOR_MEAN["com_m"]), PAYLOAD_PRIOR_MEAN["gyration_m"]
        phi0 = np.concatenate([[0.5 * np.log(m0)], np.full(3, np.log(g0)), np.zeros(3), c0])[None]
        std = _prior_std(PAYLOAD_PRIOR_STD, g0)[None]
        lo = np.full((1, 10), -np.inf)
        hi = np.full((1, 10), np.inf)
        lo[0, 0], hi[0, 0] = (0.5 * np.log(m) for m in PAYLOAD_MASS_KG)
        for k, (a, bnd) in enumerate(PAYLOAD_COM_BOX_M):
            lo[0, 7 + k], hi[0, 7 + k] = a, bnd
        return LinkSetup(phi0, std, lo, hi, np.zeros((1, 10)))
    links = [arm.links[i] for i in cand.links]
    J0 = np.stack([pseudo_inertia(link) for link in links])
    phi0 = log_cholesky_from_pseudo(J0)
    std = np.stack([_prior_std(LINK_PRIOR_STD, float(np.mean(np.exp(p[1:4])))) for p in phi0])
    lo = np.full_like(phi0, -np.inf)
    hi = np.full_like(phi0, np.inf)
    for i, link in enumerate(links):
        lo[i, 0], hi[i, 0] = (0.5 * np.log(f * link.mass_kg) for f in MASS_RANGE)
        lo[i, 7:10], hi[i, 7:10] = link.com_m - COM_BOX_M, link.com_m + COM_BOX_M
    pi0, _ = parameters_from_log_cholesky(phi0)
    return LinkSetup(phi0, std, lo, hi, pi0)


def fit_inertial(
    terms: Sequence[tuple[Candidate, int, np.ndarray]],
    setups: Callable[[Candidate], LinkSetup],
    lower: np.ndarray,
    cols: np.ndarray,
    Hw: np.ndarray,
    bw: np.ndarray,
    constant: float,
    *,
    lam: float,
    warm: WarmStart,
    exact: bool,
    start: np.ndarray | None,
) -> InertialSolution:
    """Fit a model holding inertial terms: its columns ``cols`` (c,), the weighted statistics Hw
    (c, c), bw (c,) and Σ_j w_j r_j·r_j (``constant``), with λ = ``lam``.

    terms: each term's (candidate, index, its positions in cols); setups: the inertial candidates'
    :class:`LinkSetup`; lower: (c,) the linear columns' lower bounds. exact: the whole pool's fit
    (its covariance and effective parameters computed, and ``warm`` updated for the next fits); else a
    cross-validation fold's (parameters only). start: z to start from (a fold starts at the pool's).
    """
    c = len(cols)
    # Variables z = [linear parameters the data see, φ of each inertial term's links];
    # x = [linear, π(φ) − π_ref]. The data term in unit-norm columns y = x ⊙ scale is
    # yᵀ Hs y − 2 bsᵀ y (+ Σ_j w_j r_j·r_j), Hs = D⁻¹ H D⁻¹.
    blocks, lin_idx = [], []
    for cand, index, where in terms:
        if cand.kind == "inertial":
            blocks.append((index, int(where[0]), *setups(cand)))
        else:
            lin_idx.extend(where.tolist())
    diag = np.diag(Hw).copy()
    seen = diag > 1e-14 * max(float(diag.max()), 1e-300)
    row = np.full(c, -1)
    row[seen] = np.arange(int(seen.sum()))
    scale = np.sqrt(diag[seen])
    Hs = Hw[np.ix_(seen, seen)] / np.outer(scale, scale) + RIDGE * np.eye(int(seen.sum()))
    bs = bw[seen] / scale
    lin_pos = np.array([k for k in lin_idx if seen[k]], dtype=int)
    lin_rows = row[lin_pos]
    lin_low = lower[lin_pos]
    n_lin = len(lin_pos)
    # Per link of every inertial term: its φ's place in z, its x positions seen by the data.
    links = []  # (z slice start, rows in y, which of the link's 10 parameters they are, π_ref)
    k = n_lin
    for _, first_col, phi0_b, _, _, _, pi_ref in blocks:
        for i in range(len(phi0_b)):
            pos = first_col + 10 * i + np.arange(10)
            sel = seen[pos]
            links.append((k, row[pos[sel]], np.flatnonzero(sel), pi_ref[i]))
            k += 10
    n_z = k
    phi0 = np.concatenate([blk[2].ravel() for blk in blocks])
    prior_w = lam / np.concatenate([blk[3].ravel() for blk in blocks]) ** 2
    lo = np.concatenate([lin_low, np.concatenate([blk[4].ravel() for blk in blocks])])
    hi = np.concatenate([np.full(n_lin, np.inf), np.concatenate([blk[5].ravel() for blk in blocks])])

    link_z = np.array([kz for kz, *_ in links], dtype=int)

    def derivatives(z: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """Cost, half its gradient, its Gauss-Newton and second-order curvature (halves)."""
        phis = z[link_z[:, None] + np.arange(10)]
        pis, jacs = parameters_from_log_cholesky(phis)
        y = np.zeros(len(bs))
        y[lin_rows] = z[:n_lin] * scale[lin_rows]
        dys = []  # ∂y/∂φ of each link on its rows, (rows, 10)
        for (kz, rows, sel, pi_ref), pi, jac in zip(links, pis, jacs):
            y[rows] = (pi - pi_ref)[sel] * scale[rows]
            dys.append(jac[sel] * scale[rows, None])
        resid = Hs @ y - bs
        dphi = z[n_lin:] - phi0
        cost = constant + float(y @ (resid - bs)) + float(np.sum(prior_w * dphi**2))
        # H_s ∂y/∂z, column block by column block (∂y/∂z is the identity on the linear part).
        hdy = np.empty((len(bs), n_z))
        hdy[:, :n_lin] = Hs[:, lin_rows] * scale[lin_rows]
        for (kz, rows, _, _), dy in zip(links, dys):
            hdy[:, kz : kz + 10] = Hs[:, rows] @ dy
        grad = np.empty(n_z)
        gauss = np.empty((n_z, n_z))
        grad[:n_lin] = resid[lin_rows] * scale[lin_rows]
        gauss[:n_lin] = hdy[lin_rows] * scale[lin_rows, None]
        gamma_y = resid * scale  # ∂(data cost / 2)/∂x on the seen positions
        gammas = np.zeros((len(links), 10))
        for i, ((kz, rows, sel, _), dy) in enumerate(zip(links, dys)):
            grad[kz : kz + 10] = dy.T @ resid[rows]
            gauss[kz : kz + 10] = dy.T @ hdy[rows]
            gammas[i, sel] = gamma_y[rows]
        second = np.zeros((n_z, n_z))
        for (kz, *_), h in zip(links, contraction_hessian(phis, gammas)):
            second[kz : kz + 10, kz : kz + 10] = h
        grad[n_lin:] += prior_w * dphi
        gauss[n_lin:, n_lin:] += np.diag(prior_w)
        return cost, grad, gauss, second

    if start is not None and len(start) == n_z:
        z0 = start  # a fold starts from the whole pool's fit (unless it holds other offsets common)
    else:
        # The last fit of each term (a neighbouring model's), else zero and the paper's values.
        start_lin = np.array([warm.x.get(int(col), 0.0) for col in cols[lin_pos]])
        z0 = np.concatenate([np.maximum(lin_low, start_lin)] + [warm.phi.get(blk[0], blk[2]).ravel() for blk in blocks])
    with np.errstate(over="ignore", invalid="ignore"):  # a rejected trial step may overflow exp(φ)
        z, gauss, second = box_newton(derivatives, z0, lo, hi, MAX_NEWTON_STEPS)
    if not np.all(np.isfinite(z)):
        raise DiagnosisError(f"the inertial fit of {', '.join(cand.name for cand, _, _ in terms)} did not converge")
    x = np.zeros(c)
    x[lin_pos] = z[:n_lin]
    dx = np.zeros((c, n_z))
    dx[lin_pos, np.arange(n_lin)] = 1.0
    phis, spans = {}, {}  # per inertial candidate: its φ (links, 10), and its slice of z
    kz = n_lin
    for cand_index, first_col, phi0_b, *_, pi_ref in blocks:
        links_b = len(phi0_b)
        spans[cand_index] = slice(kz, kz + 10 * links_b)
        phis[cand_index] = z[spans[cand_index]].reshape(links_b, 10)
        pis, jacs = parameters_from_log_cholesky(phis[cand_index])
        for i in range(links_b):
            rows = slice(first_col + 10 * i, first_col + 10 * i + 10)
            x[rows] = pis[i] - pi_ref[i]
            dx[rows, kz + 10 * i : kz + 10 * i + 10] = jacs[i]
        kz += 10 * links_b
    if not exact:
        return InertialSolution(x, np.zeros((c, c)), np.ones(c, dtype=bool), 0.0, phis, {}, z)
    warm.phi.update(phis)
    warm.x.update(zip(cols[lin_pos].tolist(), z[:n_lin].tolist()))
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    active = (np.isfinite(lo) & (z - lo <= AT_BOUND * width)) | (np.isfinite(hi) & (hi - z <= AT_BOUND * width))
    freev = ~active
    prior_curv = np.zeros(n_z)
    prior_curv[n_lin:] = prior_w
    K = (gauss + second)[np.ix_(freev, freev)]
    if np.linalg.eigvalsh(K)[0] <= 0:  # not a strict minimum in every direction: the Gauss-Newton curvature
        K = gauss[np.ix_(freev, freev)]
        second = np.zeros_like(second)
    Kd = K - np.diag(prior_curv[freev])
    inv = np.linalg.inv(K)
    df = float(np.einsum("ij,ji->", inv, Kd))  # tr((K_d + P)⁻¹ K_d): what the data decide
    cov_z = np.zeros((n_z, n_z))
    cov_z[np.ix_(freev, freev)] = lam * inv
    free = np.zeros(c, dtype=bool)
    free[lin_pos] = freev[:n_lin]
    phi_cov = {}
    for cand_index, first_col, phi0_b, *_ in blocks:
        phi_cov[cand_index] = cov_z[spans[cand_index], spans[cand_index]]
        free[first_col : first_col + 10 * len(phi0_b)] = True
    return InertialSolution(x, dx @ cov_z @ dx.T, free, df, phis, phi_cov, z)


def _prior_std(spec: dict[str, float], gyration_m: float) -> np.ndarray:
    """(10,) prior standard deviations of φ from a spec of α, d, s (relative to gyration_m), t."""
    return np.concatenate([[spec["alpha"]], np.full(3, spec["d"]), np.full(3, spec["s"] * gyration_m), np.full(3, spec["t"])])


def box_newton(fun, z0: np.ndarray, lo: np.ndarray, hi: np.ndarray, max_iter: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """min C(z) over lo ≤ z ≤ hi; fun(z) → (C, g, G, S) with g = ½∇C, G + S = ½∇²C (G the Gauss-Newton
    part, positive semi-definite). Returns z and G, S there.

    Damped Newton steps (G + S plus Levenberg-Marquardt damping μ diag(G), raised where G + S is not
    positive definite or a step does not pay) on the variables not held at a bound: held are those at a bound whose
    gradient points out of the box, and those a step would carry past one (the step is then solved
    again without them, a Newton step on the face). A step is taken only if it lowers the cost; the
    iteration stops when the model promises less than 1e-12 of the cost. Gauss-Newton alone converges
    only linearly here (the residual at the optimum is large and π(φ) is curved); scipy's
    trust-region solver took 40 times longer for the same optimum.
    """
    z = np.clip(z0, lo, hi)
    cost, g, gauss, second = fun(z)
    mu = 0.0
    for _ in range(max_iter):
        K = gauss + second
        scale = np.maximum(np.diag(gauss), 1e-300)
        held = ((z <= lo) & (g > 0)) | ((z >= hi) & (g < 0))
        step = np.zeros_like(z)
        while True:
            f = ~held
            try:
                factor = np.linalg.cholesky(K[np.ix_(f, f)] + mu * np.diag(scale[f]))
            except np.linalg.LinAlgError:
                mu = max(10.0 * mu, 1e-8)  # not convex here: damp until it is
                continue
            step[:] = 0.0
            step[f] = -np.linalg.solve(factor.T, np.linalg.solve(factor, g[f]))
            past = f & ((z + step < lo) | (z + step > hi))
            if not past.any():
                break
            held = held | past
            z = np.where(past, np.clip(z + step, lo, hi), z)  # those variables go to their bound
        predicted = -(2.0 * g @ step + step @ K @ step)
        new = fun(z + step)
        if np.isfinite(new[0]) and new[0] < cost:
            z = z + step
            cost, g, gauss, second = new
            mu = mu / 10.0 if mu > 1e-10 else 0.0
            if predicted <= 1e-12 * abs(cost):
                break
        else:
            cost, g, gauss, second = fun(z)  # z may have moved variables to their bounds
            if predicted <= 1e-12 * abs(cost):
                break
            mu = max(10.0 * mu, 1e-8)
            if mu > 1e12:
                break
    return z, gauss, second
