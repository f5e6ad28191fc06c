"""Independent references for the Lagrange-Euler core, used by the tests only.

- :func:`pinocchio_from_arm`: a Pinocchio model built from an :class:`ArmModel`'s own parameters
  (DH table, link inertials, gravity), so that crba/rnea/aba must match it to rounding.
- :func:`pinocchio_from_urdf`: Rethink's ``baxter.urdf`` (``../shared/reference``, read in place)
  through Pinocchio's URDF parser, with the arm base (DH frame 0) and the flange (``<side>_hand``).
- :class:`LiteralLagrangeEuler`: the paper's eqs. (2), (6)–(11) written out literally, with U_ij,
  U_ijk and the triple sums: O(n⁴), slow, and an oracle for the fast recursions.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

from baxter_dynamics_ros import ArmModel
from baxter_dynamics_ros.core import pinocchio_model
from repo_paths import SHARED

N = 7
URDF_PATH = SHARED / "reference" / "baxter.urdf"

# Q of eq. (11): ∂/∂θ of a rotation about z, as a 4×4 operator.
Q_REVOLUTE = np.zeros((4, 4))
Q_REVOLUTE[0, 1], Q_REVOLUTE[1, 0] = -1.0, 1.0


def link_placement(dh_row: np.ndarray, q: float = 0.0) -> pin.SE3:
    """ⁱ⁻¹T_i of eq. (2) as an SE3: Rz(q + offset) · Tz(d) · Tx(a) · Rx(α); dh_row = (d, a, α, offset).

    At q = 0 this is X_i, DH frame i in the frame of Pinocchio's joint i.
    """
    d, a, alpha, offset = dh_row
    return pin.SE3(pin.utils.rotate("z", q + offset), np.zeros(3)) * pin.SE3(
        pin.utils.rotate("x", alpha), np.array([a, 0.0, d])
    )


def link_frames(arm: ArmModel, q: np.ndarray) -> np.ndarray:
    """⁰T_i for i = 0..7, (8, 4, 4): DH frame i in the arm base frame; q (7,) rad."""
    frames = [np.eye(4)]
    for dh_row, qi in zip(arm.dh, q):
        frames.append(frames[-1] @ link_placement(dh_row, qi).homogeneous)
    return np.array(frames)


def potential_energy(arm: ArmModel, q: np.ndarray) -> float:
    """P(q) = −Σ m_i g · p_com,i in J, centres of mass placed by forward kinematics; q (7,) rad."""
    frames = link_frames(arm, q)
    return -sum(
        link.mass_kg * arm.gravity_m_s2 @ (frames[i + 1] @ np.append(link.com_m, 1.0))[:3]
        for i, link in enumerate(arm.links)
    )


# ----------------------------------------------------------------------------- Pinocchio references
@dataclass(frozen=True)
class PinocchioArm:
    """One arm inside a Pinocchio model, called per sample with (7,) arrays in the arm's joint order.

    ``idx`` are the arm's positions in the model's q (a URDF model holds other joints, left at 0);
    ``base`` is DH frame 0 in Pinocchio's world; ``flange`` the id of the flange frame.
    """

    model: pin.Model
    data: pin.Data
    idx: np.ndarray
    base: pin.SE3
    flange: int

    def _full(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.model.nv)
        out[self.idx] = x
        return out

    def rnea(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """τ (7,) N·m."""
        return pin.rnea(self.model, self.data, self._full(q), self._full(qd), self._full(qdd))[self.idx]

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """G (7,) N·m."""
        return pin.computeGeneralizedGravity(self.model, self.data, self._full(q))[self.idx]

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M (7, 7) kg·m², symmetrised (crba fills the upper triangle only)."""
        m = pin.crba(self.model, self.data, self._full(q))
        m = np.triu(m) + np.triu(m, 1).T
        return m[np.ix_(self.idx, self.idx)]

    def forward_dynamics(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """q̈ (7,) rad/s² by the articulated-body algorithm."""
        return pin.aba(self.model, self.data, self._full(q), self._full(qd), self._full(tau))[self.idx]

    def flange_pose(self, q: np.ndarray) -> np.ndarray:
        """(4, 4) flange pose in DH frame 0."""
        pin.framesForwardKinematics(self.model, self.data, self._full(q))
        return (self.base.actInv(self.data.oMf[self.flange])).homogeneous

    def flange_jacobian(self, q: np.ndarray) -> np.ndarray:
        """(6, 7) flange Jacobian, rows (v, ω), axes of DH frame 0 (LOCAL_WORLD_ALIGNED, rotated)."""
        jac = pin.computeFrameJacobian(
            self.model, self.data, self._full(q), self.flange, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )[:, self.idx]
        rot = self.base.rotation.T
        return np.vstack([rot @ jac[:3], rot @ jac[3:]])


def pinocchio_from_arm(arm: ArmModel) -> PinocchioArm:
    """The package's Pinocchio model of the arm (:func:`baxter_dynamics_ros.core.pinocchio_model.pinocchio_from_arm`:
    7 revolute-z joints from the DH table, link i attached at X_i), its flange frame = DH frame 7."""
    model = pinocchio_model.pinocchio_from_arm(arm)
    return PinocchioArm(model, model.createData(), np.arange(N), pin.SE3.Identity(), model.getFrameId("flange"))


def urdf_mount_offset(arm: ArmModel) -> np.ndarray:
    """``mount.base_offset_m`` (3,) of the arm's model file: DH frame 0 in the arm-mount frame."""
    raw = yaml.safe_load(Path(arm.source).read_text(encoding="utf-8"))
    return np.asarray(raw["mount"]["base_offset_m"], dtype=float)


def pinocchio_from_urdf(arm: ArmModel) -> PinocchioArm:
    """The URDF model (whole robot, fixed base), the arm's joints picked out, the others held at 0.

    Pinocchio's parser merges links on fixed joints into their parent body, so joint 7 carries the
    wrist, the hand and the hand's 0.1 g sensor links: the paper's merged link 7. (The URDF names a
    fixed joint and a link both ``<side>_hand``, which makes ``buildReducedModel`` refuse it; with
    the other joints at zero velocity and acceleration the arm's torques are the same.)
    DH frame 0 is the ``<side>_arm_mount`` frame translated by ``mount.base_offset_m``.
    """
    model = pin.buildModelFromUrdf(str(URDF_PATH))
    idx = np.array([model.joints[model.getJointId(name)].idx_q for name in arm.joint_names])
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    mount = data.oMf[model.getFrameId(f"{arm.side}_arm_mount", pin.FrameType.BODY)]
    base = mount * pin.SE3(np.eye(3), urdf_mount_offset(arm))
    flange = model.getFrameId(f"{arm.side}_hand", pin.FrameType.BODY)
    return PinocchioArm(model, data, idx, base, flange)


# ----------------------------------------------------------------------------- the paper, literally
class LiteralLagrangeEuler:
    """Eqs. (6)–(10) of the paper, term by term, for one sample: the oracle, O(n⁴).

    U_ij = ∂⁰T_i/∂q_j (eq. 9), U_ijk = ∂U_ij/∂q_k (eq. 10), J_i the pseudo-inertias of eq. (12).
    """

    def __init__(self, arm: ArmModel) -> None:
        self.arm = arm
        self.J = np.array(arm.pseudo_inertias)
        self.g_row = np.append(arm.gravity_m_s2, 0.0)  # g = (gx, gy, gz, 0) of eq. (8)

    def _setup(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A[i] = ⁱ⁻¹T_i (eq. 2); U[i, j] (eq. 9) and V[i, j, k] = U_ijk (eq. 10), 1-based i, j, k."""
        A = [np.eye(4)] + [link_placement(row, qi).homogeneous for row, qi in zip(self.arm.dh, q)]

        def T(a: int, b: int) -> np.ndarray:  # ᵃT_b = A_{a+1} ⋯ A_b
            out = np.eye(4)
            for m in range(a + 1, b + 1):
                out = out @ A[m]
            return out

        U = np.zeros((N + 1, N + 1, 4, 4))
        V = np.zeros((N + 1, N + 1, N + 1, 4, 4))
        Q = Q_REVOLUTE
        for i in range(1, N + 1):
            for j in range(1, i + 1):
                U[i, j] = T(0, j - 1) @ Q @ T(j - 1, i)
                for k in range(1, i + 1):
                    if k >= j:
                        V[i, j, k] = T(0, j - 1) @ Q @ T(j - 1, k - 1) @ Q @ T(k - 1, i)
                    else:
                        V[i, j, k] = T(0, k - 1) @ Q @ T(k - 1, j - 1) @ Q @ T(j - 1, i)
        return U, V, np.array(A)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M_ik = Σ_{j=max(i,k)}^n Tr(U_jk J_j U_jiᵀ) (eq. 6)."""
        U, _, _ = self._setup(q)
        M = np.zeros((N, N))
        for i in range(1, N + 1):
            for k in range(1, N + 1):
                M[i - 1, k - 1] = sum(
                    np.trace(U[j, k] @ self.J[j - 1] @ U[j, i].T) for j in range(max(i, k), N + 1)
                )
        return M

    def coriolis(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """C_i = Σ_k Σ_m h_ikm q̇_k q̇_m, h_ikm = Σ_{j=max(i,k,m)}^n Tr(U_jkm J_j U_jiᵀ) (eq. 7)."""
        U, V, _ = self._setup(q)
        C = np.zeros(N)
        for i in range(1, N + 1):
            for k in range(1, N + 1):
                for m in range(1, N + 1):
                    h = sum(
                        np.trace(V[j, k, m] @ self.J[j - 1] @ U[j, i].T) for j in range(max(i, k, m), N + 1)
                    )
                    C[i - 1] += h * qd[k - 1] * qd[m - 1]
        return C

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """G_i = Σ_{j=i}^n −m_j g U_ji r̄_j (eq. 8), r̄_j the homogeneous centre of mass in frame j."""
        U, _, _ = self._setup(q)
        G = np.zeros(N)
        for i in range(1, N + 1):
            for j in range(i, N + 1):
                link = self.arm.links[j - 1]
                G[i - 1] -= link.mass_kg * self.g_row @ U[j, i] @ np.append(link.com_m, 1.0)
        return G

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """τ = M q̈ + C + G (eq. 1)."""
        return self.mass_matrix(q) @ qdd + self.coriolis(q, qd) + self.gravity(q)


# ----------------------------------------------------------------------------- test helpers
def random_states(
    arm: ArmModel, n: int, seed: int, qdd_max_rad_s2: float, qd_max_rad_s: float = np.inf
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, qd, qdd (n, 7), uniform within the joint limits, |qd| <= qd_max_rad_s and |qdd| <= qdd_max_rad_s2."""
    rng = np.random.default_rng(seed)
    qd_max = np.minimum(arm.velocity_limit_rad_s, qd_max_rad_s)
    q = rng.uniform(arm.lower_rad, arm.upper_rad, (n, N))
    qd = rng.uniform(-qd_max, qd_max, (n, N))
    qdd = rng.uniform(-qdd_max_rad_s2, qdd_max_rad_s2, (n, N))
    return q, qd, qdd


def assert_close(
    actual: np.ndarray, expected: np.ndarray, what: str, *, rtol: float = 0.0, atol: float = 0.0
) -> float:
    """Per sample (leading axis): ‖a − b‖_∞ ≤ atol + rtol · max(‖b‖_∞, 1); returns the worst error.

    On failure the message shows the worst sample's index and both values.
    """
    a, b = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert a.shape == b.shape, f"{what}: shape {a.shape} != expected {b.shape}"
    a2, b2 = a.reshape(len(a), -1), b.reshape(len(b), -1)
    err = np.max(np.abs(a2 - b2), axis=1)
    tol = atol + rtol * np.maximum(np.max(np.abs(b2), axis=1), 1.0)
    worst = int(np.argmax(err - tol))
    assert np.all(err <= tol), (
        f"{what}: sample {worst} off by {err[worst]:.3g} (tolerance {tol[worst]:.3g})\n"
        f"got      {a[worst].tolist()}\nexpected {b[worst].tolist()}"
    )
    return float(err.max())
