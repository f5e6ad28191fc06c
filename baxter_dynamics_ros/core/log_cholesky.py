"""Physically consistent rigid-body inertials: the log-Cholesky parametrisation of a pseudo-inertia.

A link's pseudo-inertia (paper eq. 12, in its DH frame) J = ∫ r̄ r̄ᵀ dm is physically consistent —
some mass distribution has it — exactly when J is positive definite (Wensing, Kim and Slotine 2017).
Rucker and Wensing (2022) write every such J, once, as J = U Uᵀ with

    U = e^α [[e^d1, s12, s13, t1],
             [0,    e^d2, s23, t2],
             [0,    0,    e^d3, t3],
             [0,    0,    0,    1 ]]

φ = (α, d1, d2, d3, s12, s23, s13, t1, t2, t3) ∈ ℝ¹⁰ is unconstrained, and every φ gives a
positive-definite J. Two of its coordinates are physical on their own: the mass m = e^{2α} and the
centre of mass c = (t1, t2, t3) (m). The rest, L = the upper-left 3×3 block of U / e^α, is the
centroidal second moment per unit mass, Σ_c / m = L Lᵀ (radii of gyration, m). So bounds on a link's
mass and centre of mass are box bounds on φ, and a fit over φ can never leave the physical set.

Functions work on stacks: φ (..., 10) ↔ J (..., 4, 4) ↔ π (..., 10), π the inertial parameters of
:func:`~baxter_dynamics_ros.core.arm_model.link_parameters` (m, m·c, inertia tensor about the frame origin).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "contraction_hessian",
    "log_cholesky_from_pseudo",
    "parameters_from_log_cholesky",
    "parameters_from_pseudo",
    "pseudo_from_log_cholesky",
]

#: Where the off-diagonal coordinates sit in U (row, column).
_OFF_DIAGONAL = ((0, 1), (1, 2), (0, 2))


def _unit_factor(phi: np.ndarray) -> np.ndarray:
    """V = U / e^α (..., 4, 4) from φ (..., 10)."""
    v = np.zeros(phi.shape[:-1] + (4, 4))
    for k in range(3):
        v[..., k, k] = np.exp(phi[..., 1 + k])
        v[..., k, 3] = phi[..., 7 + k]
    for k, (r, c) in enumerate(_OFF_DIAGONAL):
        v[..., r, c] = phi[..., 4 + k]
    v[..., 3, 3] = 1.0
    return v


def pseudo_from_log_cholesky(phi: np.ndarray) -> np.ndarray:
    """J (..., 4, 4) of φ (..., 10): positive definite for every finite φ."""
    phi = np.asarray(phi, dtype=float)
    v = _unit_factor(phi)
    return np.exp(2.0 * phi[..., 0])[..., None, None] * (v @ np.swapaxes(v, -1, -2))


def log_cholesky_from_pseudo(j: np.ndarray) -> np.ndarray:
    """φ (..., 10) of a positive-definite J (..., 4, 4); raises ValueError if J is not."""
    j = np.asarray(j, dtype=float)
    m = j[..., 3, 3]
    if np.any(~(m > 0)):
        raise ValueError("a pseudo-inertia needs a positive mass J[3, 3]")
    c = j[..., :3, 3] / m[..., None]
    centroidal = (j[..., :3, :3] - m[..., None, None] * c[..., :, None] * c[..., None, :]) / m[..., None, None]
    # L upper triangular with L Lᵀ = A: reverse the order, take the (lower) Cholesky factor, reverse back.
    flip = centroidal[..., ::-1, ::-1]
    try:
        lower = np.linalg.cholesky(flip)
    except np.linalg.LinAlgError as err:
        raise ValueError("the pseudo-inertia is not positive definite") from err
    upper = lower[..., ::-1, ::-1]
    phi = np.empty(j.shape[:-2] + (10,))
    phi[..., 0] = 0.5 * np.log(m)
    for k in range(3):
        phi[..., 1 + k] = np.log(upper[..., k, k])
        phi[..., 7 + k] = c[..., k]
    for k, (r, col) in enumerate(_OFF_DIAGONAL):
        phi[..., 4 + k] = upper[..., r, col]
    return phi


def parameters_from_pseudo(j: np.ndarray) -> np.ndarray:
    """π (..., 10) of J (..., 4, 4): m, m·c, and I = tr(Σ) 𝟙 − Σ about the origin (xx xy xz yy yz zz)."""
    j = np.asarray(j, dtype=float)
    sigma = j[..., :3, :3]
    inertia = np.trace(sigma, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - sigma
    rows, cols = (0, 0, 0, 1, 1, 2), (0, 1, 2, 1, 2, 2)
    return np.concatenate([j[..., 3:4, 3], j[..., :3, 3], inertia[..., rows, cols]], axis=-1)


def parameters_from_log_cholesky(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """π (..., 10) of φ (..., 10) and its Jacobian ∂π/∂φ (..., 10, 10) (exact, not differenced).

    J = e^{2α} V Vᵀ, so ∂J/∂α = 2 J and ∂J/∂V_rc = e^{2α} (E_rc Vᵀ + V E_cr) times ∂V_rc/∂φ
    (e^{d} on the diagonal, 1 elsewhere); π is linear in J.
    """
    phi = np.asarray(phi, dtype=float)
    flat = np.ascontiguousarray(phi.reshape(-1, 10))
    pi = np.empty_like(flat)
    jac = np.empty((len(flat), 10, 10))
    hess = np.empty((0, 10, 10))
    _link_kernel(flat, np.zeros((0, 10)), pi, jac, hess)
    return pi.reshape(phi.shape), jac.reshape(phi.shape + (10,))


def contraction_hessian(phi: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """∇²_φ (γ·π(φ)) (..., 10, 10) for φ, γ (..., 10): the curvature of π that Gauss-Newton leaves out.

    With J = s V Vᵀ (s = e^{2α}), G the symmetric matrix with γ·π(J) = ⟨G, J⟩, ψ_a the coordinate of
    V's entry (r_a, c_a) = f_a(ψ_a) (f = exp on the diagonal, identity elsewhere):
    ∂²/∂α² = 4⟨G, J⟩, ∂²/∂α∂ψ_a = 4 s f_a′ (G V)_{r_a c_a},
    ∂²/∂ψ_a∂ψ_b = 2 s [f_a′ f_b′ δ(c_a, c_b) G_{r_a r_b} + δ_ab f_a″ (G V)_{r_a c_a}].
    """
    phi = np.asarray(phi, dtype=float)
    flat = np.ascontiguousarray(phi.reshape(-1, 10))
    pi = np.empty_like(flat)
    jac = np.empty((len(flat), 10, 10))
    hess = np.empty((len(flat), 10, 10))
    _link_kernel(flat, np.ascontiguousarray(np.broadcast_to(gamma, phi.shape).reshape(-1, 10), dtype=np.float64), pi, jac, hess)
    return hess.reshape(phi.shape + (10,))


# V's entries that φ's coordinates 1..9 set: (row, column, through exp).
_ENTRY_ROW = np.array([0, 1, 2, 0, 1, 0, 0, 1, 2])
_ENTRY_COL = np.array([0, 1, 2, 1, 2, 2, 3, 3, 3])
_ENTRY_EXP = np.array([True, True, True, False, False, False, False, False, False])


@njit(cache=True)
def _parameters_of(j, out):
    """π (10,) of a symmetric 4×4 J into out."""
    tr = j[0, 0] + j[1, 1] + j[2, 2]
    out[0] = j[3, 3]
    out[1] = j[0, 3]
    out[2] = j[1, 3]
    out[3] = j[2, 3]
    out[4] = tr - j[0, 0]
    out[5] = -j[0, 1]
    out[6] = -j[0, 2]
    out[7] = tr - j[1, 1]
    out[8] = -j[1, 2]
    out[9] = tr - j[2, 2]


@njit(cache=True)
def _link_kernel(phi, gamma, pi, jac, hess):
    """Per link k: π(φ_k) into pi[k], ∂π/∂φ into jac[k]; if gamma has rows, ∇²(γ_k·π) into hess[k]."""
    v = np.zeros((4, 4))
    j = np.zeros((4, 4))
    dj = np.zeros((4, 4))
    g = np.zeros((4, 4))
    gv = np.zeros((4, 4))
    col = np.zeros(10)
    fp = np.zeros(9)
    for k in range(phi.shape[0]):
        v[:, :] = 0.0
        for a in range(9):
            value = np.exp(phi[k, 1 + a]) if _ENTRY_EXP[a] else phi[k, 1 + a]
            v[_ENTRY_ROW[a], _ENTRY_COL[a]] = value
            fp[a] = value if _ENTRY_EXP[a] else 1.0
        v[3, 3] = 1.0
        s = np.exp(2.0 * phi[k, 0])
        for r in range(4):
            for c in range(4):
                acc = 0.0
                for m in range(4):
                    acc += v[r, m] * v[c, m]
                j[r, c] = s * acc
        _parameters_of(j, pi[k])
        for r in range(10):
            jac[k, r, 0] = 2.0 * pi[k, r]
        for a in range(9):
            ra, ca = _ENTRY_ROW[a], _ENTRY_COL[a]
            # dJ = s f′ (e_ra V[:, ca]ᵀ + V[:, ca] e_raᵀ)
            dj[:, :] = 0.0
            for m in range(4):
                dj[ra, m] += s * fp[a] * v[m, ca]
                dj[m, ra] += s * fp[a] * v[m, ca]
            _parameters_of(dj, col)
            for r in range(10):
                jac[k, r, 1 + a] = col[r]
        if gamma.shape[0] == 0:
            continue
        # G with γ·π(J) = ⟨G, J⟩.
        g[:, :] = 0.0
        g[3, 3] = gamma[k, 0]
        for m in range(3):
            g[m, 3] = g[3, m] = 0.5 * gamma[k, 1 + m]
        dsum = gamma[k, 4] + gamma[k, 7] + gamma[k, 9]
        g[0, 0] = dsum - gamma[k, 4]
        g[1, 1] = dsum - gamma[k, 7]
        g[2, 2] = dsum - gamma[k, 9]
        g[0, 1] = g[1, 0] = -0.5 * gamma[k, 5]
        g[0, 2] = g[2, 0] = -0.5 * gamma[k, 6]
        g[1, 2] = g[2, 1] = -0.5 * gamma[k, 8]
        gj = 0.0
        for r in range(4):
            for c in range(4):
                gj += g[r, c] * j[r, c]
                acc = 0.0
                for m in range(4):
                    acc += g[r, m] * v[m, c]
                gv[r, c] = acc
        hess[k, 0, 0] = 4.0 * gj
        for a in range(9):
            ra, ca = _ENTRY_ROW[a], _ENTRY_COL[a]
            cross = 4.0 * s * fp[a] * gv[ra, ca]
            hess[k, 0, 1 + a] = cross
            hess[k, 1 + a, 0] = cross
            for b in range(9):
                value = 0.0
                if ca == _ENTRY_COL[b]:
                    value += fp[a] * fp[b] * g[ra, _ENTRY_ROW[b]]
                if a == b and _ENTRY_EXP[a]:
                    value += fp[a] * gv[ra, ca]
                hess[k, 1 + a, 1 + b] = 2.0 * s * value
