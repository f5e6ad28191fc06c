"""Lagrange-Euler dynamics of a 7-DoF revolute arm (paper eqs. 2, 5–12), batched over samples.

The paper's sums are evaluated in the arm base frame, where they collapse into recursions.
With ⁰T_i the pose of DH frame i and Q the revolute derivative matrix of eq. (11), eq. (9) reads

    U_ij = ⁰T_{j-1} Q ʲ⁻¹T_i = Q̂_j ⁰T_i,    Q̂_j = ⁰T_{j-1} Q ⁰T_{j-1}⁻¹,

Q̂_j being the twist matrix of joint axis j (unit axis z_{j-1}, through p_{j-1}). Writing the
pseudo-inertia of eq. (12) in the base frame, Ĵ_i = ⁰T_i J_i ⁰T_iᵀ, every trace of eqs. (5)–(8)
becomes a Frobenius product ⟨A, Q̂_i⟩ = Tr(A Q̂_iᵀ):

    M_ik = ⟨Q̂_k Ĵᶜ_k, Q̂_i⟩  for i ≤ k,  Ĵᶜ_k = Σ_{j≥k} Ĵ_j                       (eq. 6)
    G_i  = −g · (Q̂_i Ĵᶜ_i)[:3, 3]                                                 (eq. 8)
    τ_i  = ⟨Σ_{j≥i} T̈_j J_j ⁰T_jᵀ, Q̂_i⟩ + G_i                                     (eq. 5)

and the double sum of eq. (10) contracted with q̇ is the second time derivative of ⁰T_j:
T̈_j = (Ẇ_j + W_j²) ⁰T_j with the twist matrices W_j = Σ_{k≤j} Q̂_k q̇_k and
Ẇ_j = Ẇ_{j-1} + [W_{j-1}, Q̂_j] q̇_j + Q̂_j q̈_j (Hollerbach's recursive Lagrangian form). Gravity
enters as the base acceleration Ẇ_0 = [[0, −g], [0, 0]], so one forward and one backward sweep
give τ; G, C and M reuse the same sweep. Cost per sample is O(n) for τ and O(n²) for M,
against O(n⁴) for the literal triple sums.

Kernels are compiled with numba and loop over samples; the front functions take (..., 7)
arrays, check them and keep the leading batch shape. The batch kernels (``batch_*``,
:func:`cholesky_solve`) are public too, for per-sample loops (the live node, the simulator's
integrator) that cannot afford the fronts' checks: they take C-contiguous float64 (M, 7) arrays,
write into preallocated outputs, and check nothing.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .errors import InputShapeError

__all__ = [
    "batch_forward_dynamics",
    "batch_gravity",
    "batch_inertial_regressor",
    "batch_inverse_dynamics",
    "batch_kinematics",
    "batch_mass_matrix",
    "batch_momentum_terms",
    "cholesky_solve",
    "coriolis",
    "forward_dynamics",
    "forward_kinematics",
    "gravity",
    "inertial_basis",
    "inertial_regressor",
    "inverse_dynamics",
    "jacobian",
    "mass_matrix",
    "momentum_terms",
]

N = 7


# ----------------------------------------------------------------------------- kernels (one sample)
@njit(cache=True)
def _dh_constants(dh: np.ndarray) -> np.ndarray:
    """(7, 5) rows (d, a, cos α, sin α, θ offset) from the (7, 4) table: α's trigonometry once per batch."""
    out = np.empty((N, 5))
    for i in range(N):
        out[i, 0] = dh[i, 0]
        out[i, 1] = dh[i, 1]
        out[i, 2] = np.cos(dh[i, 2])
        out[i, 3] = np.sin(dh[i, 2])
        out[i, 4] = dh[i, 3]
    return out


@njit(cache=True)
def _chain(K: np.ndarray, q: np.ndarray, T: np.ndarray) -> None:
    """⁰T_i for i = 0..7 into T (8, 4, 4); K from _dh_constants.

    ⁰T_i = ⁰T_{i-1} ⁱ⁻¹T_i with ⁱ⁻¹T_i of eq. (2), θ = q + offset, multiplied out row by row:
    ⁱ⁻¹T_i = [[cθ, −cα sθ, sα sθ, a cθ], [sθ, cα cθ, −sα cθ, a sθ], [0, sα, cα, d], [0, 0, 0, 1]]
    (c = cos, s = sin).
    """
    for r in range(4):
        for c in range(4):
            T[0, r, c] = 1.0 if r == c else 0.0
    for i in range(N):
        d, a, ca, sa = K[i, 0], K[i, 1], K[i, 2], K[i, 3]
        th = q[i] + K[i, 4]
        ct, st = np.cos(th), np.sin(th)
        for r in range(3):
            t0, t1, t2, t3 = T[i, r, 0], T[i, r, 1], T[i, r, 2], T[i, r, 3]
            c0 = t0 * ct + t1 * st
            u = t1 * ct - t0 * st
            T[i + 1, r, 0] = c0
            T[i + 1, r, 1] = ca * u + sa * t2
            T[i + 1, r, 2] = ca * t2 - sa * u
            T[i + 1, r, 3] = a * c0 + d * t2 + t3
        T[i + 1, 3, 0] = 0.0
        T[i + 1, 3, 1] = 0.0
        T[i + 1, 3, 2] = 0.0
        T[i + 1, 3, 3] = 1.0


@njit(cache=True)
def _axes(T: np.ndarray, S: np.ndarray) -> None:
    """Joint twists S (7, 6) = (ω, v) of Q̂_i: ω = z_{i-1}, v = p_{i-1} × z_{i-1}."""
    for i in range(N):
        zx, zy, zz = T[i, 0, 2], T[i, 1, 2], T[i, 2, 2]
        px, py, pz = T[i, 0, 3], T[i, 1, 3], T[i, 2, 3]
        S[i, 0] = zx
        S[i, 1] = zy
        S[i, 2] = zz
        S[i, 3] = py * zz - pz * zy
        S[i, 4] = pz * zx - px * zz
        S[i, 5] = px * zy - py * zx


@njit(cache=True)
def _base_inertias(T: np.ndarray, J: np.ndarray, Jb: np.ndarray, B: np.ndarray) -> None:
    """Ĵ_i = ⁰T_i J_i ⁰T_iᵀ into Jb (7, 4, 4); B is (4, 4) scratch.

    With ⁰T_i = [[R, p], [0, 1]] and J_i = [[Σ, h], [hᵀ, m]] (h = m c):
    Ĵ_i = [[R Σ Rᵀ + k pᵀ + p (R h)ᵀ, k], [kᵀ, m]], k = R h + m p.
    """
    for i in range(N):
        Ti, Ji = T[i + 1], J[i]
        m = Ji[3, 3]
        for r in range(3):
            for c in range(3):  # B[:3, :3] = R Σ
                B[r, c] = Ti[r, 0] * Ji[0, c] + Ti[r, 1] * Ji[1, c] + Ti[r, 2] * Ji[2, c]
            B[r, 3] = Ti[r, 0] * Ji[0, 3] + Ti[r, 1] * Ji[1, 3] + Ti[r, 2] * Ji[2, 3]  # (R h)_r
        for r in range(3):
            k = B[r, 3] + m * Ti[r, 3]
            Jb[i, r, 3] = k
            Jb[i, 3, r] = k
        for r in range(3):
            for c in range(r, 3):
                s = B[r, 0] * Ti[c, 0] + B[r, 1] * Ti[c, 1] + B[r, 2] * Ti[c, 2]
                s += Jb[i, r, 3] * Ti[c, 3] + Ti[r, 3] * B[c, 3]
                Jb[i, r, c] = s
                Jb[i, c, r] = s
        Jb[i, 3, 3] = m


@njit(cache=True, inline="always")
def _twist_times(S: np.ndarray, i: int, X: np.ndarray, out: np.ndarray) -> None:
    """out (3, 4) = rows 0..2 of Q̂_i X for a (4, 4) X (Q̂_i's last row is zero)."""
    wx, wy, wz, vx, vy, vz = S[i, 0], S[i, 1], S[i, 2], S[i, 3], S[i, 4], S[i, 5]
    for c in range(4):
        x0, x1, x2, x3 = X[0, c], X[1, c], X[2, c], X[3, c]
        out[0, c] = -wz * x1 + wy * x2 + vx * x3
        out[1, c] = wz * x0 - wx * x2 + vy * x3
        out[2, c] = -wy * x0 + wx * x1 + vz * x3


@njit(cache=True, inline="always")
def _frobenius_with_twist(S: np.ndarray, i: int, X: np.ndarray) -> float:
    """⟨X, Q̂_i⟩ = Tr(X Q̂_iᵀ) for X with at least 3 rows and 4 columns."""
    return (
        S[i, 0] * (X[2, 1] - X[1, 2])
        + S[i, 1] * (X[0, 2] - X[2, 0])
        + S[i, 2] * (X[1, 0] - X[0, 1])
        + S[i, 3] * X[0, 3]
        + S[i, 4] * X[1, 3]
        + S[i, 5] * X[2, 3]
    )


@njit(cache=True)
def _composite(Jb: np.ndarray, Jc: np.ndarray) -> None:
    """Ĵᶜ_i = Σ_{j≥i} Ĵ_j into Jc (7, 4, 4)."""
    for r in range(4):
        for c in range(4):
            Jc[N - 1, r, c] = Jb[N - 1, r, c]
    for i in range(N - 2, -1, -1):
        for r in range(4):
            for c in range(4):
                Jc[i, r, c] = Jc[i + 1, r, c] + Jb[i, r, c]


@njit(cache=True)
def _link_accelerations(S, qd, qdd, g, use_gravity, Phi):
    """Φ_j = Ẇ_j + W_j² (rows 0..2) into Phi (7, 3, 4), so that T̈_j = Φ_j ⁰T_j.

    W = (ω, v) and Ẇ = (α, a) are twists; with use_gravity, Ẇ_0 = (0, −g) adds G(q) downstream.
    """
    w0 = w1 = w2 = v0 = v1 = v2 = 0.0
    al0 = al1 = al2 = 0.0
    if use_gravity:
        a0, a1, a2 = -g[0], -g[1], -g[2]
    else:
        a0 = a1 = a2 = 0.0
    for j in range(N):
        sw0, sw1, sw2, sv0, sv1, sv2 = S[j, 0], S[j, 1], S[j, 2], S[j, 3], S[j, 4], S[j, 5]
        qdj, qddj = qd[j], qdd[j]
        # [W_{j-1}, Q̂_j] as a twist: (ω × s_ω, ω × s_v − s_ω × v)
        cw0 = w1 * sw2 - w2 * sw1
        cw1 = w2 * sw0 - w0 * sw2
        cw2 = w0 * sw1 - w1 * sw0
        cv0 = (w1 * sv2 - w2 * sv1) - (sw1 * v2 - sw2 * v1)
        cv1 = (w2 * sv0 - w0 * sv2) - (sw2 * v0 - sw0 * v2)
        cv2 = (w0 * sv1 - w1 * sv0) - (sw0 * v1 - sw1 * v0)
        al0 += cw0 * qdj + sw0 * qddj
        al1 += cw1 * qdj + sw1 * qddj
        al2 += cw2 * qdj + sw2 * qddj
        a0 += cv0 * qdj + sv0 * qddj
        a1 += cv1 * qdj + sv1 * qddj
        a2 += cv2 * qdj + sv2 * qddj
        w0 += sw0 * qdj
        w1 += sw1 * qdj
        w2 += sw2 * qdj
        v0 += sv0 * qdj
        v1 += sv1 * qdj
        v2 += sv2 * qdj
        # Φ = Ẇ + W² (rows 0..2): [α× + ω×ω×, a + ω × v]
        ww = w0 * w0 + w1 * w1 + w2 * w2
        P = Phi[j]
        P[0, 0] = w0 * w0 - ww
        P[0, 1] = -al2 + w0 * w1
        P[0, 2] = al1 + w0 * w2
        P[1, 0] = al2 + w1 * w0
        P[1, 1] = w1 * w1 - ww
        P[1, 2] = -al0 + w1 * w2
        P[2, 0] = -al1 + w2 * w0
        P[2, 1] = al0 + w2 * w1
        P[2, 2] = w2 * w2 - ww
        P[0, 3] = a0 + w1 * v2 - w2 * v1
        P[1, 3] = a1 + w2 * v0 - w0 * v2
        P[2, 3] = a2 + w0 * v1 - w1 * v0


@njit(cache=True, inline="always")
def _times_inertia(P: np.ndarray, X: np.ndarray, out: np.ndarray) -> None:
    """out (3, 4) = P (3, 4) · X (4, 4)."""
    for r in range(3):
        for c in range(4):
            out[r, c] = P[r, 0] * X[0, c] + P[r, 1] * X[1, c] + P[r, 2] * X[2, c] + P[r, 3] * X[3, c]


@njit(cache=True)
def _rne_sweep(S, Jb, qd, qdd, g, use_gravity, tau, Dsum, Phi, D):
    """τ of eq. (5) from the recursive form: τ_i = ⟨Σ_{j≥i} Φ_j Ĵ_j, Q̂_i⟩ (Φ_j = Ẇ_j + W_j²).

    Phi (7, 3, 4), D (3, 4) and Dsum (3, 4) are scratch.
    """
    _link_accelerations(S, qd, qdd, g, use_gravity, Phi)
    for r in range(3):
        for c in range(4):
            Dsum[r, c] = 0.0
    for i in range(N - 1, -1, -1):
        _times_inertia(Phi[i], Jb[i], D)
        for r in range(3):
            for c in range(4):
                Dsum[r, c] += D[r, c]
        tau[i] = _frobenius_with_twist(S, i, Dsum)


@njit(cache=True)
def _gravity(T, S, J, g, out):
    """G_i = −g · (Q̂_i Σ_{j≥i} m_j ⁰T_j r̄_j)[:3] of eq. (8).

    Only the last column of Ĵᶜ_i is needed: Σ_{j≥i} m_j ⁰T_j r̄_j = (Σ R_j h_j + m_j p_j, Σ m_j),
    and Q̂_i (x, m) = ω_i × x + m v_i.
    """
    hx = hy = hz = mass = 0.0
    for j in range(N - 1, -1, -1):
        Tj, Jj = T[j + 1], J[j]
        m = Jj[3, 3]
        hx += Tj[0, 0] * Jj[0, 3] + Tj[0, 1] * Jj[1, 3] + Tj[0, 2] * Jj[2, 3] + m * Tj[0, 3]
        hy += Tj[1, 0] * Jj[0, 3] + Tj[1, 1] * Jj[1, 3] + Tj[1, 2] * Jj[2, 3] + m * Tj[1, 3]
        hz += Tj[2, 0] * Jj[0, 3] + Tj[2, 1] * Jj[1, 3] + Tj[2, 2] * Jj[2, 3] + m * Tj[2, 3]
        mass += m
        wx, wy, wz, vx, vy, vz = S[j, 0], S[j, 1], S[j, 2], S[j, 3], S[j, 4], S[j, 5]
        out[j] = -(
            g[0] * (wy * hz - wz * hy + mass * vx)
            + g[1] * (wz * hx - wx * hz + mass * vy)
            + g[2] * (wx * hy - wy * hx + mass * vz)
        )


@njit(cache=True)
def _mass_from_composite(S, Jc, out, B):
    """M_ik = ⟨Q̂_k Ĵᶜ_k, Q̂_i⟩ of eq. (6), i ≤ k, mirrored."""
    for k in range(N):
        _twist_times(S, k, Jc[k], B)
        for i in range(k + 1):
            m = _frobenius_with_twist(S, i, B)
            out[i, k] = m
            out[k, i] = m


@njit(cache=True)
def _mass_at(K, q, J, T, S, Jb, Jc, B, out):
    """M(q) (7, 7) into out, leaving T, S and Jb those of q; Jc (7, 4, 4) and B (4, 4) are scratch."""
    _chain(K, q, T)
    _axes(T, S)
    _base_inertias(T, J, Jb, B)
    _composite(Jb, Jc)
    _mass_from_composite(S, Jc, out, B)


# ----------------------------------------------------------------------------- kernels (batches)
@njit(cache=True)
def batch_inverse_dynamics(dh, J, g, q, qd, qdd, use_gravity, out):
    """out (M, 7) = τ(q, q̇, q̈) of every row (without G when use_gravity is False); J (7, 4, 4) pseudo-inertias."""
    K = _dh_constants(dh)
    T = np.empty((N + 1, 4, 4))
    B = np.empty((4, 4))
    S = np.empty((N, 6))
    Jb = np.empty((N, 4, 4))
    Dsum = np.empty((3, 4))
    Phi = np.empty((N, 3, 4))
    D = np.empty((3, 4))
    for n in range(q.shape[0]):
        _chain(K, q[n], T)
        _axes(T, S)
        _base_inertias(T, J, Jb, B)
        _rne_sweep(S, Jb, qd[n], qdd[n], g, use_gravity, out[n], Dsum, Phi, D)


@njit(cache=True)
def batch_gravity(dh, J, g, q, out):
    """out (M, 7) = G(q) of every row."""
    K = _dh_constants(dh)
    T = np.empty((N + 1, 4, 4))
    S = np.empty((N, 6))
    for n in range(q.shape[0]):
        _chain(K, q[n], T)
        _axes(T, S)
        _gravity(T, S, J, g, out[n])


@njit(cache=True)
def batch_mass_matrix(dh, J, q, out):
    """out (M, 7, 7) = M(q) of every row."""
    K = _dh_constants(dh)
    T = np.empty((N + 1, 4, 4))
    B = np.empty((4, 4))
    S = np.empty((N, 6))
    Jb = np.empty((N, 4, 4))
    Jc = np.empty((N, 4, 4))
    for n in range(q.shape[0]):
        _mass_at(K, q[n], J, T, S, Jb, Jc, B, out[n])


def inertial_basis() -> np.ndarray:
    """(10, 4, 4): pseudo-inertias of the unit inertial parameters, J = Σ_k π_k E_k.

    π = (m, m c_x, m c_y, m c_z, I_xx, I_xy, I_xz, I_yy, I_yz, I_zz) with I the inertia tensor about
    the link frame's origin (tensor elements) and J = [[½ tr(I) 𝟙 − I, m c], [m cᵀ, m]] (eq. 12).
    """
    E = np.zeros((10, 4, 4))
    E[0, 3, 3] = 1.0
    for k in range(3):
        E[1 + k, k, 3] = E[1 + k, 3, k] = 1.0
    for k, (r, c) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
        unit = np.zeros((3, 3))
        unit[r, c] = unit[c, r] = 1.0
        E[4 + k, :3, :3] = 0.5 * np.trace(unit) * np.eye(3) - unit
    return E


@njit(cache=True)
def batch_inertial_regressor(dh, E, g, q, qd, qdd, out):
    """out (M, 7, 70): τ = Y π, π the 10 inertial parameters of each link in turn (eq. 5 is linear in J_j)."""
    K = _dh_constants(dh)
    n_par = E.shape[0]
    T = np.empty((N + 1, 4, 4))
    B = np.empty((4, 4))
    S = np.empty((N, 6))
    Jb = np.empty((N, 4, 4))
    Phi = np.empty((N, 3, 4))
    D = np.empty((3, 4))
    Ek = np.empty((N, 4, 4))
    for n in range(q.shape[0]):
        _chain(K, q[n], T)
        _axes(T, S)
        _link_accelerations(S, qd[n], qdd[n], g, True, Phi)
        for k in range(n_par):
            for j in range(N):
                Ek[j] = E[k]
            _base_inertias(T, Ek, Jb, B)
            for j in range(N):
                _times_inertia(Phi[j], Jb[j], D)
                col = n_par * j + k
                for i in range(N):
                    out[n, i, col] = _frobenius_with_twist(S, i, D) if i <= j else 0.0


@njit(cache=True)
def batch_momentum_terms(dh, J, g, q, qd, eps, p_out, w_out):
    """p = M(q) q̇ and w = Ṁ q̇ − (C(q, q̇) q̇ + G(q)) per sample, Ṁ = (M(q + ε q̇) − M(q − ε q̇)) / 2ε."""
    K = _dh_constants(dh)
    T = np.empty((N + 1, 4, 4))
    B = np.empty((4, 4))
    S = np.empty((N, 6))
    Jb = np.empty((N, 4, 4))
    Jc = np.empty((N, 4, 4))
    Dsum = np.empty((3, 4))
    Phi = np.empty((N, 3, 4))
    D = np.empty((3, 4))
    Mm = np.empty((N, N))
    Mp = np.empty((N, N))
    zero = np.zeros(N)
    qs = np.empty(N)
    n_vec = np.empty(N)
    for n in range(q.shape[0]):
        _mass_at(K, q[n], J, T, S, Jb, Jc, B, Mm)
        _rne_sweep(S, Jb, qd[n], zero, g, True, n_vec, Dsum, Phi, D)
        for i in range(N):
            s = 0.0
            for k in range(N):
                s += Mm[i, k] * qd[n, k]
            p_out[n, i] = s
            w_out[n, i] = -n_vec[i]
        for sign in (1.0, -1.0):
            for i in range(N):
                qs[i] = q[n, i] + sign * eps * qd[n, i]
            _mass_at(K, qs, J, T, S, Jb, Jc, B, Mp)
            for i in range(N):
                s = 0.0
                for k in range(N):
                    s += Mp[i, k] * qd[n, k]
                w_out[n, i] += sign * s / (2.0 * eps)


@njit(cache=True)
def cholesky_solve(Mm, b, L, x):
    """x = M⁻¹ b for a symmetric positive-definite (7, 7) M; L is (7, 7) scratch."""
    for i in range(N):
        for j in range(i + 1):
            s = Mm[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = np.sqrt(s) if s > 0.0 else np.nan
            else:
                L[i, j] = s / L[j, j]
    for i in range(N):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(N - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, N):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(cache=True)
def batch_forward_dynamics(dh, J, g, q, qd, tau, out):
    """out (M, 7) = q̈ = M⁻¹ (τ − C − G) of every row."""
    K = _dh_constants(dh)
    T = np.empty((N + 1, 4, 4))
    B = np.empty((4, 4))
    S = np.empty((N, 6))
    Jb = np.empty((N, 4, 4))
    Jc = np.empty((N, 4, 4))
    Dsum = np.empty((3, 4))
    Phi = np.empty((N, 3, 4))
    D = np.empty((3, 4))
    Mm = np.empty((N, N))
    L = np.empty((N, N))
    h = np.empty(N)
    zero = np.zeros(N)
    for n in range(q.shape[0]):
        _mass_at(K, q[n], J, T, S, Jb, Jc, B, Mm)
        _rne_sweep(S, Jb, qd[n], zero, g, True, h, Dsum, Phi, D)
        for i in range(N):
            h[i] = tau[n, i] - h[i]
        cholesky_solve(Mm, h, L, out[n])


@njit(cache=True)
def batch_kinematics(dh, q, pose, jac):
    """pose (M, 4, 4) of the last frame and its geometric Jacobian jac (M, 6, 7) (linear rows first) of every row."""
    K = _dh_constants(dh)
    T = np.empty((N + 1, 4, 4))
    for n in range(q.shape[0]):
        _chain(K, q[n], T)
        for r in range(4):
            for c in range(4):
                pose[n, r, c] = T[N, r, c]
        px, py, pz = T[N, 0, 3], T[N, 1, 3], T[N, 2, 3]
        for i in range(N):
            zx, zy, zz = T[i, 0, 2], T[i, 1, 2], T[i, 2, 2]
            dx, dy, dz = px - T[i, 0, 3], py - T[i, 1, 3], pz - T[i, 2, 3]
            jac[n, 0, i] = zy * dz - zz * dy
            jac[n, 1, i] = zz * dx - zx * dz
            jac[n, 2, i] = zx * dy - zy * dx
            jac[n, 3, i] = zx
            jac[n, 4, i] = zy
            jac[n, 5, i] = zz


# ----------------------------------------------------------------------------- public front
def _as_batch(name: str, x: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    """(..., 7) array → contiguous float64 (M, 7) and the leading shape to restore."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != N:
        raise InputShapeError(f"{name}: expected shape (7,) or (N, 7), got {arr.shape}")
    lead = arr.shape[:-1]
    return np.ascontiguousarray(arr.reshape(-1, N)), lead


def _as_batches(**arrays: np.ndarray) -> tuple[list[np.ndarray], tuple[int, ...]]:
    """Several (..., 7) arrays that must share one leading shape."""
    out, leads = [], {}
    for name, x in arrays.items():
        flat, lead = _as_batch(name, x)
        out.append(flat)
        leads[name] = lead
    if len(set(leads.values())) > 1:
        shown = ", ".join(f"{k} {v + (N,)}" for k, v in leads.items())
        raise InputShapeError(f"inputs must have the same shape, got {shown}")
    return out, next(iter(leads.values()))


def inverse_dynamics(dh, pseudo_inertias, gravity_m_s2, q, qd, qdd) -> np.ndarray:
    """τ = M q̈ + C + G (eq. 5), N·m, shape of q; q, qd, qdd (..., 7) in rad, rad/s, rad/s²."""
    (q2, qd2, qdd2), lead = _as_batches(q=q, qd=qd, qdd=qdd)
    out = np.empty_like(q2)
    batch_inverse_dynamics(dh, pseudo_inertias, gravity_m_s2, q2, qd2, qdd2, True, out)
    return out.reshape(lead + (N,))


def coriolis(dh, pseudo_inertias, q, qd) -> np.ndarray:
    """The Coriolis/centrifugal vector C(q, q̇) of eq. (7), N·m, shape of q."""
    (q2, qd2), lead = _as_batches(q=q, qd=qd)
    out = np.empty_like(q2)
    batch_inverse_dynamics(dh, pseudo_inertias, np.zeros(3), q2, qd2, np.zeros_like(q2), False, out)
    return out.reshape(lead + (N,))


def gravity(dh, pseudo_inertias, gravity_m_s2, q) -> np.ndarray:
    """G(q) of eq. (8), N·m, shape of q; q (..., 7) rad."""
    q2, lead = _as_batch("q", q)
    out = np.empty_like(q2)
    batch_gravity(dh, pseudo_inertias, gravity_m_s2, q2, out)
    return out.reshape(lead + (N,))


def mass_matrix(dh, pseudo_inertias, q) -> np.ndarray:
    """M(q) of eq. (6), kg·m², (..., 7, 7); q (..., 7) rad."""
    q2, lead = _as_batch("q", q)
    out = np.empty((q2.shape[0], N, N))
    batch_mass_matrix(dh, pseudo_inertias, q2, out)
    return out.reshape(lead + (N, N))


def forward_dynamics(dh, pseudo_inertias, gravity_m_s2, q, qd, tau) -> np.ndarray:
    """q̈ = M⁻¹(τ − C − G), rad/s², shape of q; q, qd, tau (..., 7) in rad, rad/s, N·m."""
    (q2, qd2, tau2), lead = _as_batches(q=q, qd=qd, tau=tau)
    out = np.empty_like(q2)
    batch_forward_dynamics(dh, pseudo_inertias, gravity_m_s2, q2, qd2, tau2, out)
    return out.reshape(lead + (N,))


def inertial_regressor(dh, gravity_m_s2, q, qd, qdd) -> np.ndarray:
    """Y (..., 7, 70) with τ = Y π (N·m): the regressor of the links' inertial parameters.

    π stacks, link by link, the 10 parameters of :func:`inertial_basis` (kg, kg·m, kg·m²) in each
    link's DH frame; gravity included. q, qd, qdd (..., 7) in rad, rad/s, rad/s².
    """
    (q2, qd2, qdd2), lead = _as_batches(q=q, qd=qd, qdd=qdd)
    out = np.empty((q2.shape[0], N, 10 * N))
    batch_inertial_regressor(dh, inertial_basis(), gravity_m_s2, q2, qd2, qdd2, out)
    return out.reshape(lead + (N, 10 * N))


def momentum_terms(dh, pseudo_inertias, gravity_m_s2, q, qd, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """p = M(q) q̇ (kg·m²/s) and Ṁ q̇ − C(q, q̇) q̇ − G(q) (N·m), each of q's shape, in one compiled pass.

    Ṁ is the central difference (M(q + ε q̇) − M(q − ε q̇)) / 2ε, exact to O(ε²); since
    Cᵀ q̇ = Ṁ q̇ − C q̇, the second output is Cᵀ q̇ − G, what a momentum observer integrates.
    """
    (q2, qd2), lead = _as_batches(q=q, qd=qd)
    p = np.empty_like(q2)
    w = np.empty_like(q2)
    batch_momentum_terms(dh, pseudo_inertias, gravity_m_s2, q2, qd2, float(eps), p, w)
    return p.reshape(lead + (N,)), w.reshape(lead + (N,))


def _kinematics(dh, q) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    q2, lead = _as_batch("q", q)
    pose = np.empty((q2.shape[0], 4, 4))
    jac = np.empty((q2.shape[0], 6, N))
    batch_kinematics(dh, q2, pose, jac)
    return pose, jac, lead


def forward_kinematics(dh, q) -> np.ndarray:
    """Pose of DH frame 7 (the hand flange) in DH frame 0, (..., 4, 4); q (..., 7) rad."""
    pose, _, lead = _kinematics(dh, q)
    return pose.reshape(lead + (4, 4))


def jacobian(dh, q) -> np.ndarray:
    """Geometric Jacobian of the flange in DH frame 0, (..., 6, 7): rows v (m/s) then ω (rad/s)."""
    _, jac, lead = _kinematics(dh, q)
    return jac.reshape(lead + (6, N))
