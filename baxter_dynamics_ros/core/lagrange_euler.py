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

Kernels are compiled with numba and work on blocks of LANES samples: each quantity of a block is
held lane-major in one scratch array, so that every innermost loop runs over the samples of the
block and compiles to SIMD instructions (sin and cos too: a polynomial kernel instead of libm's
scalar calls). The front functions take (..., 7) arrays, check them and keep the leading batch shape; those of
τ, C, G and M split batches of PARALLEL_MIN_SAMPLES samples or more over numba's thread pool (all
cores by default; ``numba.set_num_threads`` or ``NUMBA_NUM_THREADS`` to change), smaller batches
and single samples stay on the calling thread. The batch kernels (``batch_*``,
:func:`cholesky_solve`) are public too, for per-sample loops (the live node, the simulator's
integrator) that cannot afford the fronts' checks: they take C-contiguous float64 (M, 7) arrays,
write into preallocated outputs, check nothing, and run on the calling thread. A loop over single
samples keeps a workspace (:func:`sample_workspace`) for :func:`sample_torques` instead.
"""

from __future__ import annotations

import os

import numpy as np
from numba import njit, prange

from ..errors import InputShapeError
from .joints import JOINTS as N

__all__ = [
    "as_batches",
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
    "sample_torques",
    "sample_workspace",
]

LANES = 16
"""Samples per block. A block's intermediates live in one flat scratch array, LANES values per
quantity (lane-major), so that every innermost loop runs over samples at fixed offsets of one
array and LLVM compiles it to SIMD instructions without run-time aliasing checks."""
PARALLEL_MIN_SAMPLES = 4096
"""Batches of at least this many samples are split over all cores (numba's thread pool); smaller
ones, and single samples, run on the calling thread, so they never wait for the pool to start.
4096 samples are four chunks of _CHUNK_SAMPLES (two per core here) and take 0.2–0.5 ms on one
core, against a few µs to wake the pool (``./dev bench dynamics`` prints both)."""
# numba's OpenMP pool spins while it waits; on a machine shared with other busy processes a
# spinning worker can hold the split batch up for a scheduler time slice (8 ms measured here on
# 4096 samples, against 0.5 ms on one thread). Unless the user chose otherwise, workers sleep.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
_CHUNK_SAMPLES = 64 * LANES  # rows per task of the thread pool, each with its own scratch
_PAIRS = N * (N + 1) // 2  # M's upper triangle, packed: (i, k), i ≤ k, at k (k + 1) / 2 + i
_CONTRACT = {"contract"}  # fused multiply-adds only: no reordering, no assumption about NaN or inf

# A block's scratch B holds one record per joint (8: frame 7 has one too), then M's triangle.
# Quantity `field` of joint j in lane l is B[_at(j, field) + l]; a loop at joint j touches
# records j and j ± 1 only, at fixed distances, which LLVM can prove free of overlap.
_Q, _QD, _QDD, _CS, _SN = 0, 1, 2, 3, 4  # q_j, q̇_j, q̈_j (rad, rad/s, rad/s²), cos θ_j, sin θ_j
_T = 5  # ⁰T_j, rows 0..2 row by row (12)
_S = _T + 12  # twist of joint j: (ω, v) of Q̂_j (6)
_V = _S + 6  # twists W and Ẇ of link j − 1 (12)
_PHI = _V + 12  # Φ_j of link j (12, rows 0..2 row by row)
_JB = _PHI + 12  # Ĵ_j of link j, or the composite Ĵᶜ_j: Σ̂ (xx, xy, xz, yy, yz, zz), k (9)
_F = _JB + 9  # the force of link j (6)
_FSUM = _F + 6  # Σ_{i≥j} forces (6)
_H = _FSUM + 6  # Σ_{i≥j} m_i ⁰T_i r̄_i, first three entries (3)
_OUT = _H + 3  # τ_j or G_j
_REC = _OUT + 1
_MB = (N + 1) * _REC  # M's packed upper triangle (28)
_SLOTS = _MB + _PAIRS

# sin/cos on a block: Cody-Waite reduction by π/2 and fdlibm's kernels __kernel_sin/__kernel_cos
# (|error| < 1 ulp on [-π/4, π/4]); arguments beyond _SINCOS_MAX_RAD, inf and NaN go to libm.
_TWO_OVER_PI = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00  # π/2 in three parts: the first two have 33 significant bits,
_PIO2_2 = 6.07710050630396597660e-11  # so that k · part is exact for |k| < 2^20
_PIO2_3 = 2.02226624871116645580e-21
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_SINCOS_MAX_RAD = 1.0e5


# ----------------------------------------------------------------------------- constants of a model
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
def _inertia_constants(J: np.ndarray) -> np.ndarray:
    """(n, 10) rows (Σxx, Σxy, Σxz, Σyy, Σyz, Σzz, hx, hy, hz, m) of n pseudo-inertias J (n, 4, 4) = [[Σ, h], [hᵀ, m]]."""
    out = np.empty((J.shape[0], 10))
    for i in range(J.shape[0]):
        out[i, 0] = J[i, 0, 0]
        out[i, 1] = J[i, 0, 1]
        out[i, 2] = J[i, 0, 2]
        out[i, 3] = J[i, 1, 1]
        out[i, 4] = J[i, 1, 2]
        out[i, 5] = J[i, 2, 2]
        out[i, 6] = J[i, 0, 3]
        out[i, 7] = J[i, 1, 3]
        out[i, 8] = J[i, 2, 3]
        out[i, 9] = J[i, 3, 3]
    return out


# ----------------------------------------------------------------------------- kernels (one block)
# A block is nl ≤ LANES samples; B its scratch (see the records above).
@njit(cache=True, inline="always")
def _at(j: int, field: int) -> int:
    """Offset in B of lane 0 of quantity `field` of joint j."""
    return (j * _REC + field) * LANES


@njit(cache=True, inline="always")
def _block_scratch() -> np.ndarray:
    """A block's scratch B (_SLOTS · LANES,): ⁰T_0 = identity; the sums past the last link zero."""
    B = np.empty(_SLOTS * LANES)
    for e in range(12):
        for l in range(LANES):
            B[_at(0, _T + e) + l] = 1.0 if e in (0, 5, 10) else 0.0
    for e in range(9):
        for l in range(LANES):
            B[_at(N, _JB + e) + l] = 0.0
    for e in range(6):
        for l in range(LANES):
            B[_at(N, _FSUM + e) + l] = 0.0
    for e in range(3):
        for l in range(LANES):
            B[_at(N, _H + e) + l] = 0.0
    return B


@njit(cache=True, inline="always")
def _to_lanes(x, n0, nl, B, field) -> None:
    """B's `field` of joints 0..6, lane l = x[n0 + l, :]: nl rows of an (M, 7) array."""
    for l in range(nl):
        for i in range(N):
            B[_at(i, field) + l] = x[n0 + l, i]


@njit(cache=True, inline="always")
def _from_lanes(B, field, n0, nl, out) -> None:
    """out[n0 + l, :] = B's `field` of joints 0..6, lane l: the inverse of :func:`_to_lanes`."""
    for l in range(nl):
        for i in range(N):
            out[n0 + l, i] = B[_at(i, field) + l]


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _sincos(B, j, offset, nl) -> None:
    """cos, sin of θ_j = q_j + offset (rad) into joint j's _CS, _SN; libm's to within 1 ulp or so.

    θ = k π/2 + r, |r| ≤ π/4, then fdlibm's polynomials for sin r and cos r and the quadrant k mod 4,
    branch-free so that the lane loop is vectorised; lanes beyond ±_SINCOS_MAX_RAD (inf, NaN) are
    redone with libm.
    """
    x, c, s = _at(j, _Q), _at(j, _CS), _at(j, _SN)
    far = False
    for l in range(nl):
        t = B[x + l] + offset
        k = np.floor(t * _TWO_OVER_PI + 0.5)
        r = ((t - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
        z = r * r
        sr = r + z * r * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
        hz = 0.5 * z
        w = 1.0 - hz
        cr = w + (((1.0 - w) - hz) + z * z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6))))))
        quadrant = k - 4.0 * np.floor(0.25 * k)
        odd = (quadrant == 1.0) | (quadrant == 3.0)
        s1 = cr if odd else sr
        c1 = sr if odd else cr
        B[s + l] = -s1 if quadrant >= 2.0 else s1
        B[c + l] = -c1 if (quadrant == 1.0) | (quadrant == 2.0) else c1
        far |= not (abs(t) <= _SINCOS_MAX_RAD)
    if far:
        for l in range(nl):
            t = B[x + l] + offset
            if not (abs(t) <= _SINCOS_MAX_RAD):
                B[c + l] = np.cos(t)
                B[s + l] = np.sin(t)


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _frames(K, B, nl) -> None:
    """⁰T_1 … ⁰T_7 (_T) and the joint twists (_S) from the joint angles (_Q); K from _dh_constants.

    ⁰T_i = ⁰T_{i-1} ⁱ⁻¹T_i with ⁱ⁻¹T_i of eq. (2), θ = q + offset, multiplied out row by row:
    ⁱ⁻¹T_i = [[cθ, −cα sθ, sα sθ, a cθ], [sθ, cα cθ, −sα cθ, a sθ], [0, sα, cα, d], [0, 0, 0, 1]].
    Twist i = (ω, v) of Q̂_i: ω = z_{i-1}, v = p_{i-1} × z_{i-1} (joint i − 1's record holds ⁰T_{i-1}).
    """
    L = LANES
    for i in range(N):
        t, s, cs, sn = _at(i, _T), _at(i, _S), _at(i, _CS), _at(i, _SN)
        for l in range(nl):
            zx, zy, zz = B[t + 2 * L + l], B[t + 6 * L + l], B[t + 10 * L + l]
            px, py, pz = B[t + 3 * L + l], B[t + 7 * L + l], B[t + 11 * L + l]
            B[s + l] = zx
            B[s + L + l] = zy
            B[s + 2 * L + l] = zz
            B[s + 3 * L + l] = py * zz - pz * zy
            B[s + 4 * L + l] = pz * zx - px * zz
            B[s + 5 * L + l] = px * zy - py * zx
        _sincos(B, i, K[i, 4], nl)
        d, a, ca, sa = K[i, 0], K[i, 1], K[i, 2], K[i, 3]
        for r in range(3):
            src = t + 4 * r * L
            dst = src + _REC * L
            for l in range(nl):
                t0, t1, t2, t3 = B[src + l], B[src + L + l], B[src + 2 * L + l], B[src + 3 * L + l]
                ct, st = B[cs + l], B[sn + l]
                c0 = t0 * ct + t1 * st
                u = t1 * ct - t0 * st
                B[dst + l] = c0
                B[dst + L + l] = ca * u + sa * t2
                B[dst + 2 * L + l] = ca * t2 - sa * u
                B[dst + 3 * L + l] = a * c0 + d * t2 + t3


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _base_inertia(B, j, p, nl) -> None:
    """Ĵ_j = ⁰T_j J_j ⁰T_jᵀ into link j's _JB; p (10,) its row of _inertia_constants.

    With ⁰T_j = [[R, p], [0, 1]] (held by record j + 1) and J_j = [[Σ, h], [hᵀ, m]]:
    Ĵ_j = [[R Σ Rᵀ + k pᵀ + p (R h)ᵀ, k], [kᵀ, m]], k = R h + m p (m is unchanged).
    """
    s00, s01, s02, s11, s12, s22 = p[0], p[1], p[2], p[3], p[4], p[5]
    h0, h1, h2, m = p[6], p[7], p[8], p[9]
    L, t, o = LANES, _at(j + 1, _T), _at(j, _JB)
    for l in range(nl):
        r00, r01, r02, p0 = B[t + l], B[t + L + l], B[t + 2 * L + l], B[t + 3 * L + l]
        r10, r11, r12, p1 = B[t + 4 * L + l], B[t + 5 * L + l], B[t + 6 * L + l], B[t + 7 * L + l]
        r20, r21, r22, p2 = B[t + 8 * L + l], B[t + 9 * L + l], B[t + 10 * L + l], B[t + 11 * L + l]
        g0 = r00 * h0 + r01 * h1 + r02 * h2  # R h
        g1 = r10 * h0 + r11 * h1 + r12 * h2
        g2 = r20 * h0 + r21 * h1 + r22 * h2
        k0, k1, k2 = g0 + m * p0, g1 + m * p1, g2 + m * p2
        b00 = r00 * s00 + r01 * s01 + r02 * s02  # R Σ
        b01 = r00 * s01 + r01 * s11 + r02 * s12
        b02 = r00 * s02 + r01 * s12 + r02 * s22
        b10 = r10 * s00 + r11 * s01 + r12 * s02
        b11 = r10 * s01 + r11 * s11 + r12 * s12
        b12 = r10 * s02 + r11 * s12 + r12 * s22
        b20 = r20 * s00 + r21 * s01 + r22 * s02
        b21 = r20 * s01 + r21 * s11 + r22 * s12
        b22 = r20 * s02 + r21 * s12 + r22 * s22
        B[o + l] = b00 * r00 + b01 * r01 + b02 * r02 + k0 * p0 + p0 * g0
        B[o + L + l] = b00 * r10 + b01 * r11 + b02 * r12 + k0 * p1 + p0 * g1
        B[o + 2 * L + l] = b00 * r20 + b01 * r21 + b02 * r22 + k0 * p2 + p0 * g2
        B[o + 3 * L + l] = b10 * r10 + b11 * r11 + b12 * r12 + k1 * p1 + p1 * g1
        B[o + 4 * L + l] = b10 * r20 + b11 * r21 + b12 * r22 + k1 * p2 + p1 * g2
        B[o + 5 * L + l] = b20 * r20 + b21 * r21 + b22 * r22 + k2 * p2 + p2 * g2
        B[o + 6 * L + l] = k0
        B[o + 7 * L + l] = k1
        B[o + 8 * L + l] = k2


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _twist_dot(B, twist, force, l) -> float:
    """twist · force of lane l, both given by their offsets in B: ⟨D, Q̂⟩ for a force read off D."""
    L = LANES
    return (
        B[twist + l] * B[force + l]
        + B[twist + L + l] * B[force + L + l]
        + B[twist + 2 * L + l] * B[force + 2 * L + l]
        + B[twist + 3 * L + l] * B[force + 3 * L + l]
        + B[twist + 4 * L + l] * B[force + 4 * L + l]
        + B[twist + 5 * L + l] * B[force + 5 * L + l]
    )


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _mass_block(P, B, nl) -> None:
    """M_ik = ⟨Q̂_k Ĵᶜ_k, Q̂_i⟩ of eq. (6) into _MB (packed upper triangle, i ≤ k).

    Ĵᶜ_k = Ĵ_k + Ĵᶜ_{k+1} replaces Ĵ_k in link k's _JB. With Ĵᶜ_k = [[Σ, h], [hᵀ, m]] and the
    rotational inertia I = tr(Σ) 𝟙 − Σ, the product is twist i applied to the force
    f_k = (I ω + h × v, m v − h × ω) of twist k = (ω, v): M_ik = ω_i · f_k[:3] + v_i · f_k[3:].
    """
    L = LANES
    mass = 0.0
    for k in range(N - 1, -1, -1):
        _base_inertia(B, k, P[k], nl)
        mass += P[k, 9]
        jc, up, s, f = _at(k, _JB), _at(k + 1, _JB), _at(k, _S), _at(k, _F)
        for l in range(nl):
            s00 = B[jc + l] + B[up + l]
            s01 = B[jc + L + l] + B[up + L + l]
            s02 = B[jc + 2 * L + l] + B[up + 2 * L + l]
            s11 = B[jc + 3 * L + l] + B[up + 3 * L + l]
            s12 = B[jc + 4 * L + l] + B[up + 4 * L + l]
            s22 = B[jc + 5 * L + l] + B[up + 5 * L + l]
            h0 = B[jc + 6 * L + l] + B[up + 6 * L + l]
            h1 = B[jc + 7 * L + l] + B[up + 7 * L + l]
            h2 = B[jc + 8 * L + l] + B[up + 8 * L + l]
            B[jc + l], B[jc + L + l], B[jc + 2 * L + l] = s00, s01, s02
            B[jc + 3 * L + l], B[jc + 4 * L + l], B[jc + 5 * L + l] = s11, s12, s22
            B[jc + 6 * L + l], B[jc + 7 * L + l], B[jc + 8 * L + l] = h0, h1, h2
            w0, w1, w2 = B[s + l], B[s + L + l], B[s + 2 * L + l]
            v0, v1, v2 = B[s + 3 * L + l], B[s + 4 * L + l], B[s + 5 * L + l]
            trace = s00 + s11 + s22
            B[f + l] = trace * w0 - (s00 * w0 + s01 * w1 + s02 * w2) + (h1 * v2 - h2 * v1)
            B[f + L + l] = trace * w1 - (s01 * w0 + s11 * w1 + s12 * w2) + (h2 * v0 - h0 * v2)
            B[f + 2 * L + l] = trace * w2 - (s02 * w0 + s12 * w1 + s22 * w2) + (h0 * v1 - h1 * v0)
            B[f + 3 * L + l] = mass * v0 - (h1 * w2 - h2 * w1)
            B[f + 4 * L + l] = mass * v1 - (h2 * w0 - h0 * w2)
            B[f + 5 * L + l] = mass * v2 - (h0 * w1 - h1 * w0)
        for i in range(k + 1):
            out, twist = (_MB + k * (k + 1) // 2 + i) * L, _at(i, _S)
            for l in range(nl):
                B[out + l] = _twist_dot(B, twist, f, l)


@njit(cache=True, inline="always")
def _unpack_mass(B, l, out) -> None:
    """out (7, 7) = M of lane l from the packed upper triangle _MB, mirrored."""
    for k in range(N):
        for i in range(k + 1):
            m = B[(_MB + k * (k + 1) // 2 + i) * LANES + l]
            out[i, k] = m
            out[k, i] = m


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _link_accelerations(B, g, use_gravity, nl) -> None:
    """Φ_j = Ẇ_j + W_j² (rows 0..2) into _PHI, so that T̈_j = Φ_j ⁰T_j; q̇, q̈ from _QD, _QDD.

    W = (ω, v) and Ẇ = (α, a) are twists; record j's _V holds those of link j − 1. With
    use_gravity, Ẇ_0 = (0, −g) adds G(q) downstream.
    """
    L, base = LANES, _at(0, _V)
    gx, gy, gz = (-g[0], -g[1], -g[2]) if use_gravity else (0.0, 0.0, 0.0)
    for l in range(nl):
        for e in range(9):
            B[base + e * L + l] = 0.0
        B[base + 9 * L + l] = gx
        B[base + 10 * L + l] = gy
        B[base + 11 * L + l] = gz
    for j in range(N):
        V, Vn, s, P = _at(j, _V), _at(j + 1, _V), _at(j, _S), _at(j, _PHI)
        qd, qdd = _at(j, _QD), _at(j, _QDD)
        for l in range(nl):
            w0, w1, w2 = B[V + l], B[V + L + l], B[V + 2 * L + l]
            v0, v1, v2 = B[V + 3 * L + l], B[V + 4 * L + l], B[V + 5 * L + l]
            sw0, sw1, sw2 = B[s + l], B[s + L + l], B[s + 2 * L + l]
            sv0, sv1, sv2 = B[s + 3 * L + l], B[s + 4 * L + l], B[s + 5 * L + l]
            qdj, qddj = B[qd + l], B[qdd + l]
            # [W_{j-1}, Q̂_j] as a twist: (ω × s_ω, ω × s_v − s_ω × v)
            cw0 = w1 * sw2 - w2 * sw1
            cw1 = w2 * sw0 - w0 * sw2
            cw2 = w0 * sw1 - w1 * sw0
            cv0 = (w1 * sv2 - w2 * sv1) - (sw1 * v2 - sw2 * v1)
            cv1 = (w2 * sv0 - w0 * sv2) - (sw2 * v0 - sw0 * v2)
            cv2 = (w0 * sv1 - w1 * sv0) - (sw0 * v1 - sw1 * v0)
            al0 = B[V + 6 * L + l] + cw0 * qdj + sw0 * qddj
            al1 = B[V + 7 * L + l] + cw1 * qdj + sw1 * qddj
            al2 = B[V + 8 * L + l] + cw2 * qdj + sw2 * qddj
            a0 = B[V + 9 * L + l] + cv0 * qdj + sv0 * qddj
            a1 = B[V + 10 * L + l] + cv1 * qdj + sv1 * qddj
            a2 = B[V + 11 * L + l] + cv2 * qdj + sv2 * qddj
            w0 += sw0 * qdj
            w1 += sw1 * qdj
            w2 += sw2 * qdj
            v0 += sv0 * qdj
            v1 += sv1 * qdj
            v2 += sv2 * qdj
            B[Vn + l], B[Vn + L + l], B[Vn + 2 * L + l] = w0, w1, w2
            B[Vn + 3 * L + l], B[Vn + 4 * L + l], B[Vn + 5 * L + l] = v0, v1, v2
            B[Vn + 6 * L + l], B[Vn + 7 * L + l], B[Vn + 8 * L + l] = al0, al1, al2
            B[Vn + 9 * L + l], B[Vn + 10 * L + l], B[Vn + 11 * L + l] = a0, a1, a2
            # Φ = Ẇ + W² (rows 0..2): [α× + ω×ω×, a + ω × v]
            ww = w0 * w0 + w1 * w1 + w2 * w2
            B[P + l] = w0 * w0 - ww
            B[P + L + l] = -al2 + w0 * w1
            B[P + 2 * L + l] = al1 + w0 * w2
            B[P + 3 * L + l] = a0 + w1 * v2 - w2 * v1
            B[P + 4 * L + l] = al2 + w1 * w0
            B[P + 5 * L + l] = w1 * w1 - ww
            B[P + 6 * L + l] = -al0 + w1 * w2
            B[P + 7 * L + l] = a1 + w2 * v0 - w0 * v2
            B[P + 8 * L + l] = -al1 + w2 * w0
            B[P + 9 * L + l] = al0 + w2 * w1
            B[P + 10 * L + l] = w2 * w2 - ww
            B[P + 11 * L + l] = a2 + w0 * v1 - w1 * v0


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _link_force(B, j, m, nl) -> None:
    """Link j's _F = what ⟨D, Q̂⟩ reads of D = Φ_j Ĵ_j: (D₂₁ − D₁₂, D₀₂ − D₂₀, D₁₀ − D₀₁, D₀₃, D₁₃, D₂₃).

    Then ⟨D, Q̂_i⟩ = twist_i · force; Ĵ_j from link j's _JB, m its mass (kg). With Φ = [A | a]
    and Ĵ = [[Σ, k], [kᵀ, m]]: D_rc = A_r · Σ_c + a_r k_c (c < 3), D_r3 = A_r · k + m a_r.
    """
    L, jb, P, f = LANES, _at(j, _JB), _at(j, _PHI), _at(j, _F)
    for l in range(nl):
        s00, s01, s02 = B[jb + l], B[jb + L + l], B[jb + 2 * L + l]
        s11, s12, s22 = B[jb + 3 * L + l], B[jb + 4 * L + l], B[jb + 5 * L + l]
        k0, k1, k2 = B[jb + 6 * L + l], B[jb + 7 * L + l], B[jb + 8 * L + l]
        A00, A01, A02, a0 = B[P + l], B[P + L + l], B[P + 2 * L + l], B[P + 3 * L + l]
        A10, A11, A12, a1 = B[P + 4 * L + l], B[P + 5 * L + l], B[P + 6 * L + l], B[P + 7 * L + l]
        A20, A21, A22, a2 = B[P + 8 * L + l], B[P + 9 * L + l], B[P + 10 * L + l], B[P + 11 * L + l]
        d01 = A00 * s01 + A01 * s11 + A02 * s12 + a0 * k1
        d02 = A00 * s02 + A01 * s12 + A02 * s22 + a0 * k2
        d10 = A10 * s00 + A11 * s01 + A12 * s02 + a1 * k0
        d12 = A10 * s02 + A11 * s12 + A12 * s22 + a1 * k2
        d20 = A20 * s00 + A21 * s01 + A22 * s02 + a2 * k0
        d21 = A20 * s01 + A21 * s11 + A22 * s12 + a2 * k1
        B[f + l] = d21 - d12
        B[f + L + l] = d02 - d20
        B[f + 2 * L + l] = d10 - d01
        B[f + 3 * L + l] = A00 * k0 + A01 * k1 + A02 * k2 + m * a0
        B[f + 4 * L + l] = A10 * k0 + A11 * k1 + A12 * k2 + m * a1
        B[f + 5 * L + l] = A20 * k0 + A21 * k1 + A22 * k2 + m * a2


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _rne_block(P, g, use_gravity, B, nl) -> None:
    """τ of eq. (5) into _OUT from the recursive form τ_i = ⟨Σ_{j≥i} Φ_j Ĵ_j, Q̂_i⟩."""
    L = LANES
    _link_accelerations(B, g, use_gravity, nl)
    for j in range(N - 1, -1, -1):
        _base_inertia(B, j, P[j], nl)
        _link_force(B, j, P[j, 9], nl)
        f, fsum, up, s, out = _at(j, _F), _at(j, _FSUM), _at(j + 1, _FSUM), _at(j, _S), _at(j, _OUT)
        for l in range(nl):
            B[fsum + l] = B[f + l] + B[up + l]
            B[fsum + L + l] = B[f + L + l] + B[up + L + l]
            B[fsum + 2 * L + l] = B[f + 2 * L + l] + B[up + 2 * L + l]
            B[fsum + 3 * L + l] = B[f + 3 * L + l] + B[up + 3 * L + l]
            B[fsum + 4 * L + l] = B[f + 4 * L + l] + B[up + 4 * L + l]
            B[fsum + 5 * L + l] = B[f + 5 * L + l] + B[up + 5 * L + l]
            B[out + l] = _twist_dot(B, s, fsum, l)


@njit(cache=True, fastmath=_CONTRACT, inline="always")
def _gravity_block(P, g, B, nl) -> None:
    """G_i = −g · (Q̂_i Σ_{j≥i} m_j ⁰T_j r̄_j)[:3] of eq. (8) into _OUT.

    Only the last column of Ĵᶜ_i is needed: Σ_{j≥i} m_j ⁰T_j r̄_j = (Σ R_j h_j + m_j p_j, Σ m_j),
    kept in _H, and Q̂_i (x, m) = ω_i × x + m v_i.
    """
    L = LANES
    gx, gy, gz = g[0], g[1], g[2]
    mass = 0.0
    for j in range(N - 1, -1, -1):
        h0, h1, h2, m = P[j, 6], P[j, 7], P[j, 8], P[j, 9]
        mass += m
        t, H, up, s, out = _at(j + 1, _T), _at(j, _H), _at(j + 1, _H), _at(j, _S), _at(j, _OUT)
        for l in range(nl):
            hx = B[up + l] + B[t + l] * h0 + B[t + L + l] * h1 + B[t + 2 * L + l] * h2 + m * B[t + 3 * L + l]
            hy = B[up + L + l] + B[t + 4 * L + l] * h0 + B[t + 5 * L + l] * h1 + B[t + 6 * L + l] * h2 + m * B[t + 7 * L + l]
            hz = B[up + 2 * L + l] + B[t + 8 * L + l] * h0 + B[t + 9 * L + l] * h1 + B[t + 10 * L + l] * h2 + m * B[t + 11 * L + l]
            B[H + l], B[H + L + l], B[H + 2 * L + l] = hx, hy, hz
            wx, wy, wz = B[s + l], B[s + L + l], B[s + 2 * L + l]
            vx, vy, vz = B[s + 3 * L + l], B[s + 4 * L + l], B[s + 5 * L + l]
            B[out + l] = -(
                gx * (wy * hz - wz * hy + mass * vx)
                + gy * (wz * hx - wx * hz + mass * vy)
                + gz * (wx * hy - wy * hx + mass * vz)
            )


# ----------------------------------------------------------------------------- kernels (rows of a batch)
@njit(cache=True, fastmath=_CONTRACT)
def _inverse_dynamics_rows(K, P, g, q, qd, qdd, use_gravity, out, start, stop) -> None:
    """out[start:stop] = τ of those rows; K, P from _dh_constants and _inertia_constants."""
    B = _block_scratch()
    for n0 in range(start, stop, LANES):
        nl = min(LANES, stop - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _to_lanes(qd, n0, nl, B, _QD)
        _to_lanes(qdd, n0, nl, B, _QDD)
        _frames(K, B, nl)
        _rne_block(P, g, use_gravity, B, nl)
        _from_lanes(B, _OUT, n0, nl, out)


@njit(cache=True, fastmath=_CONTRACT)
def _gravity_rows(K, P, g, q, out, start, stop) -> None:
    """out[start:stop] = G of those rows."""
    B = _block_scratch()
    for n0 in range(start, stop, LANES):
        nl = min(LANES, stop - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _frames(K, B, nl)
        _gravity_block(P, g, B, nl)
        _from_lanes(B, _OUT, n0, nl, out)


@njit(cache=True, fastmath=_CONTRACT)
def _mass_matrix_rows(K, P, q, out, start, stop) -> None:
    """out[start:stop] = M of those rows, (·, 7, 7)."""
    B = _block_scratch()
    for n0 in range(start, stop, LANES):
        nl = min(LANES, stop - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _frames(K, B, nl)
        _mass_block(P, B, nl)
        for l in range(nl):
            _unpack_mass(B, l, out[n0 + l])


@njit(cache=True)
def _chunks(n: int) -> int:
    """How many chunks of _CHUNK_SAMPLES rows (the last one shorter) cover n rows."""
    return (n + _CHUNK_SAMPLES - 1) // _CHUNK_SAMPLES


@njit(cache=True, parallel=True)
def _inverse_dynamics_parallel(dh, J, g, q, qd, qdd, use_gravity, out) -> None:
    """:func:`batch_inverse_dynamics` with the rows split over numba's thread pool."""
    K, P = _dh_constants(dh), _inertia_constants(J)
    for c in prange(_chunks(q.shape[0])):
        start, stop = c * _CHUNK_SAMPLES, min(q.shape[0], (c + 1) * _CHUNK_SAMPLES)
        _inverse_dynamics_rows(K, P, g, q, qd, qdd, use_gravity, out, start, stop)


@njit(cache=True, parallel=True)
def _gravity_parallel(dh, J, g, q, out) -> None:
    """:func:`batch_gravity` with the rows split over numba's thread pool."""
    K, P = _dh_constants(dh), _inertia_constants(J)
    for c in prange(_chunks(q.shape[0])):
        start, stop = c * _CHUNK_SAMPLES, min(q.shape[0], (c + 1) * _CHUNK_SAMPLES)
        _gravity_rows(K, P, g, q, out, start, stop)


@njit(cache=True, parallel=True)
def _mass_matrix_parallel(dh, J, q, out) -> None:
    """:func:`batch_mass_matrix` with the rows split over numba's thread pool."""
    K, P = _dh_constants(dh), _inertia_constants(J)
    for c in prange(_chunks(q.shape[0])):
        start, stop = c * _CHUNK_SAMPLES, min(q.shape[0], (c + 1) * _CHUNK_SAMPLES)
        _mass_matrix_rows(K, P, q, out, start, stop)


# ----------------------------------------------------------------------------- kernels (batches)
# Single-threaded: njit code calls them (the simulator's integrator), and a cached njit function
# that calls a parallel one crashes when it is loaded from numba's cache in a new process. The
# fronts below pick the parallel versions for large batches.
@njit(cache=True)
def batch_inverse_dynamics(dh, J, g, q, qd, qdd, use_gravity, out):
    """out (M, 7) = τ(q, q̇, q̈) of every row (without G when use_gravity is False); J (7, 4, 4) pseudo-inertias."""
    _inverse_dynamics_rows(_dh_constants(dh), _inertia_constants(J), g, q, qd, qdd, use_gravity, out, 0, q.shape[0])


@njit(cache=True)
def batch_gravity(dh, J, g, q, out):
    """out (M, 7) = G(q) of every row."""
    _gravity_rows(_dh_constants(dh), _inertia_constants(J), g, q, out, 0, q.shape[0])


@njit(cache=True)
def batch_mass_matrix(dh, J, q, out):
    """out (M, 7, 7) = M(q) of every row."""
    _mass_matrix_rows(_dh_constants(dh), _inertia_constants(J), q, out, 0, q.shape[0])


# ----------------------------------------------------------------------------- one sample, with a workspace
# A per-sample loop (the live node) keeps the model's constants and a block scratch between calls,
# as Pinocchio keeps a Data beside its Model: no allocation, no trigonometry of the DH table, and a
# scratch that stays in the cache, where a batch kernel would allocate and fill a fresh one per call.
def sample_workspace(dh: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K, P, B) for :func:`sample_torques`: the constants of the model (dh (7, 4), J (7, 4, 4)) and a
    block scratch. The kernels never write the scratch's constant entries, so it serves every call."""
    dh, J = np.ascontiguousarray(dh, dtype=np.float64), np.ascontiguousarray(J, dtype=np.float64)
    return _dh_constants(dh), _inertia_constants(J), _new_scratch()


@njit(cache=True)
def _new_scratch() -> np.ndarray:
    return _block_scratch()


@njit(cache=True, fastmath=_CONTRACT)
def sample_torques(K, P, B, g, q, qd, qdd, out) -> None:
    """out[0] = τ(q, q̇, q̈) and out[1] = G(q) = τ(q, 0, 0) of one sample, q, qd, qdd (7,), out (≥2, 7):
    lanes 0 and 1 of the workspace (K, P, B) of :func:`sample_workspace`; the numbers of
    :func:`batch_inverse_dynamics` on the rows (q, q̇, q̈) and (q, 0, 0)."""
    for i in range(N):
        B[_at(i, _Q)] = q[i]
        B[_at(i, _Q) + 1] = q[i]
        B[_at(i, _QD)] = qd[i]
        B[_at(i, _QD) + 1] = 0.0
        B[_at(i, _QDD)] = qdd[i]
        B[_at(i, _QDD) + 1] = 0.0
    _frames(K, B, 2)
    _rne_block(P, g, True, B, 2)
    for i in range(N):
        out[0, i] = B[_at(i, _OUT)]
        out[1, i] = B[_at(i, _OUT) + 1]


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


@njit(cache=True, fastmath=_CONTRACT)
def batch_inertial_regressor(dh, E, g, q, qd, qdd, out):
    """out (M, 7, 70): τ = Y π, π the 10 inertial parameters of each link in turn (eq. 5 is linear in J_j)."""
    K, Pe = _dh_constants(dh), _inertia_constants(E)
    n_par = E.shape[0]
    B = _block_scratch()
    for n0 in range(0, q.shape[0], LANES):
        nl = min(LANES, q.shape[0] - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _to_lanes(qd, n0, nl, B, _QD)
        _to_lanes(qdd, n0, nl, B, _QDD)
        _frames(K, B, nl)
        _link_accelerations(B, g, True, nl)
        for j in range(N):
            for k in range(n_par):
                _base_inertia(B, j, Pe[k], nl)
                _link_force(B, j, Pe[k, 9], nl)
                col = n_par * j + k
                for l in range(nl):
                    for i in range(N):
                        out[n0 + l, i, col] = _twist_dot(B, _at(i, _S), _at(j, _F), l) if i <= j else 0.0


@njit(cache=True, fastmath=_CONTRACT)
def batch_momentum_terms(dh, J, g, q, qd, eps, p_out, w_out):
    """p = M(q) q̇ and w = Ṁ q̇ − (C(q, q̇) q̇ + G(q)) per sample, Ṁ = (M(q + ε q̇) − M(q − ε q̇)) / 2ε."""
    K, P = _dh_constants(dh), _inertia_constants(J)
    B = _block_scratch()
    Mm, qd_l = np.empty((N, N)), np.empty(N)
    for e in range(N):
        for l in range(LANES):
            B[_at(e, _QDD) + l] = 0.0
    for n0 in range(0, q.shape[0], LANES):
        nl = min(LANES, q.shape[0] - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _to_lanes(qd, n0, nl, B, _QD)
        _frames(K, B, nl)
        _mass_block(P, B, nl)
        _rne_block(P, g, True, B, nl)
        for l in range(nl):
            _unpack_mass(B, l, Mm)
            for i in range(N):
                qd_l[i] = qd[n0 + l, i]
            for i in range(N):
                s = 0.0
                for k in range(N):
                    s += Mm[i, k] * qd_l[k]
                p_out[n0 + l, i] = s
                w_out[n0 + l, i] = -B[_at(i, _OUT) + l]
        for sign in (1.0, -1.0):
            for l in range(nl):
                for i in range(N):
                    B[_at(i, _Q) + l] = q[n0 + l, i] + sign * eps * qd[n0 + l, i]
            _frames(K, B, nl)
            _mass_block(P, B, nl)
            for l in range(nl):
                _unpack_mass(B, l, Mm)
                for i in range(N):
                    s = 0.0
                    for k in range(N):
                        s += Mm[i, k] * qd[n0 + l, k]
                    w_out[n0 + l, i] += sign * s / (2.0 * eps)


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


@njit(cache=True, fastmath=_CONTRACT)
def batch_forward_dynamics(dh, J, g, q, qd, tau, out):
    """out (M, 7) = q̈ = M⁻¹ (τ − C − G) of every row."""
    K, P = _dh_constants(dh), _inertia_constants(J)
    B = _block_scratch()
    Mm, L, rhs = np.empty((N, N)), np.empty((N, N)), np.empty(N)
    for e in range(N):
        for l in range(LANES):
            B[_at(e, _QDD) + l] = 0.0
    for n0 in range(0, q.shape[0], LANES):
        nl = min(LANES, q.shape[0] - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _to_lanes(qd, n0, nl, B, _QD)
        _frames(K, B, nl)
        _mass_block(P, B, nl)
        _rne_block(P, g, True, B, nl)
        for l in range(nl):
            _unpack_mass(B, l, Mm)
            for i in range(N):
                rhs[i] = tau[n0 + l, i] - B[_at(i, _OUT) + l]
            cholesky_solve(Mm, rhs, L, out[n0 + l])


@njit(cache=True, fastmath=_CONTRACT)
def batch_kinematics(dh, q, pose, jac):
    """pose (M, 4, 4) of the last frame and its geometric Jacobian jac (M, 6, 7) (linear rows first) of every row."""
    K = _dh_constants(dh)
    B = _block_scratch()
    L = LANES
    for n0 in range(0, q.shape[0], L):
        nl = min(L, q.shape[0] - n0)
        _to_lanes(q, n0, nl, B, _Q)
        _frames(K, B, nl)
        last = _at(N, _T)
        for l in range(nl):
            n = n0 + l
            for e in range(12):
                pose[n, e // 4, e % 4] = B[last + e * L + l]
            pose[n, 3, 0] = pose[n, 3, 1] = pose[n, 3, 2] = 0.0
            pose[n, 3, 3] = 1.0
            px, py, pz = B[last + 3 * L + l], B[last + 7 * L + l], B[last + 11 * L + l]
            for i in range(N):
                t = _at(i, _T)
                zx, zy, zz = B[t + 2 * L + l], B[t + 6 * L + l], B[t + 10 * L + l]
                dx, dy, dz = px - B[t + 3 * L + l], py - B[t + 7 * L + l], pz - B[t + 11 * L + l]
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


def as_batches(**arrays: np.ndarray) -> tuple[list[np.ndarray], tuple[int, ...]]:
    """Several (..., 7) arrays that must share one leading shape, as (M, 7) C-contiguous float64
    arrays and that leading shape (the fronts' one shape check; raises InputShapeError)."""
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
    (q2, qd2, qdd2), lead = as_batches(q=q, qd=qd, qdd=qdd)
    out = np.empty_like(q2)
    split = len(q2) >= PARALLEL_MIN_SAMPLES
    (_inverse_dynamics_parallel if split else batch_inverse_dynamics)(
        dh, pseudo_inertias, gravity_m_s2, q2, qd2, qdd2, True, out
    )
    return out.reshape(lead + (N,))


def coriolis(dh, pseudo_inertias, q, qd) -> np.ndarray:
    """The Coriolis/centrifugal vector C(q, q̇) of eq. (7), N·m, shape of q."""
    (q2, qd2), lead = as_batches(q=q, qd=qd)
    out = np.empty_like(q2)
    split = len(q2) >= PARALLEL_MIN_SAMPLES
    (_inverse_dynamics_parallel if split else batch_inverse_dynamics)(
        dh, pseudo_inertias, np.zeros(3), q2, qd2, np.zeros_like(q2), False, out
    )
    return out.reshape(lead + (N,))


def gravity(dh, pseudo_inertias, gravity_m_s2, q) -> np.ndarray:
    """G(q) of eq. (8), N·m, shape of q; q (..., 7) rad."""
    q2, lead = _as_batch("q", q)
    out = np.empty_like(q2)
    (_gravity_parallel if len(q2) >= PARALLEL_MIN_SAMPLES else batch_gravity)(dh, pseudo_inertias, gravity_m_s2, q2, out)
    return out.reshape(lead + (N,))


def mass_matrix(dh, pseudo_inertias, q) -> np.ndarray:
    """M(q) of eq. (6), kg·m², (..., 7, 7); q (..., 7) rad."""
    q2, lead = _as_batch("q", q)
    out = np.empty((q2.shape[0], N, N))
    (_mass_matrix_parallel if len(q2) >= PARALLEL_MIN_SAMPLES else batch_mass_matrix)(dh, pseudo_inertias, q2, out)
    return out.reshape(lead + (N, N))


def forward_dynamics(dh, pseudo_inertias, gravity_m_s2, q, qd, tau) -> np.ndarray:
    """q̈ = M⁻¹(τ − C − G), rad/s², shape of q; q, qd, tau (..., 7) in rad, rad/s, N·m."""
    (q2, qd2, tau2), lead = as_batches(q=q, qd=qd, tau=tau)
    out = np.empty_like(q2)
    batch_forward_dynamics(dh, pseudo_inertias, gravity_m_s2, q2, qd2, tau2, out)
    return out.reshape(lead + (N,))


def inertial_regressor(dh, gravity_m_s2, q, qd, qdd) -> np.ndarray:
    """Y (..., 7, 70) with τ = Y π (N·m): the regressor of the links' inertial parameters.

    π stacks, link by link, the 10 parameters of :func:`inertial_basis` (kg, kg·m, kg·m²) in each
    link's DH frame; gravity included. q, qd, qdd (..., 7) in rad, rad/s, rad/s².
    """
    (q2, qd2, qdd2), lead = as_batches(q=q, qd=qd, qdd=qdd)
    out = np.empty((q2.shape[0], N, 10 * N))
    batch_inertial_regressor(dh, inertial_basis(), gravity_m_s2, q2, qd2, qdd2, out)
    return out.reshape(lead + (N, 10 * N))


def momentum_terms(dh, pseudo_inertias, gravity_m_s2, q, qd, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """p = M(q) q̇ (kg·m²/s) and Ṁ q̇ − C(q, q̇) q̇ − G(q) (N·m), each of q's shape, in one compiled pass.

    Ṁ is the central difference (M(q + ε q̇) − M(q − ε q̇)) / 2ε, exact to O(ε²); since
    Cᵀ q̇ = Ṁ q̇ − C q̇, the second output is Cᵀ q̇ − G, what a momentum observer integrates.
    """
    (q2, qd2), lead = as_batches(q=q, qd=qd)
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
