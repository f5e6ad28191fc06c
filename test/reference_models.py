"""Independent references for the Lagrange-Euler core, used by the tests only.

- :func:`paper_reference`: a Pinocchio model of the arm built here from the paper's tables (written
  out below) and the DH lengths read from the URDF's text, with none of the package's code or files:
  what the 1e-9 tests compare the core with, so that a parsing or model-file error cannot pass them.
- :func:`pinocchio_from_arm`: a Pinocchio model built from an :class:`ArmModel`'s own parameters
  (DH table, link inertials, gravity), for arms the tests change (compensated inertials, payloads).
- :func:`pinocchio_from_urdf`: Rethink's ``baxter.urdf`` (``../shared/reference``, read in place)
  through Pinocchio's URDF parser, with the arm base (DH frame 0, the ``<side>_s0`` origin read from
  the URDF) and the flange (``<side>_hand``).
- :class:`LiteralLagrangeEuler`: the paper's eqs. (2), (6)–(11) written out literally, with U_ij,
  U_ijk and the triple sums: O(n⁴), slow, and an oracle for the fast recursions.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import pytest

from baxter_dynamics_ros import ArmModel
from baxter_dynamics_ros.core import pinocchio_model
from repo_paths import SHARED

N = 7
URDF_PATH = SHARED / "reference" / "baxter.urdf"


def require_urdf() -> None:
    """Skip the calling test when Rethink's URDF is not beside the checkout (../shared/reference)."""
    if not URDF_PATH.is_file():
        pytest.skip(f"Baxter's URDF is not at {URDF_PATH} (../shared/reference beside the checkout)")

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


#: The arm's joints, in order (Table II's links 1-7).
JOINT_SUFFIXES = ("s0", "s1", "e0", "e1", "w0", "w1", "w2")
#: Table II: α (rad) and mass (kg) of link i. θ offsets: θ2 = q_s1 + π/2, which the paper omits (the
#: URDF's zero pose; the flange test against the URDF checks it).
TABLE_II_ALPHA_RAD = (-np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, 0.0)
TABLE_II_MASS_KG = (5.70044, 3.22698, 4.31272, 2.07206, 2.24665, 1.60979, 0.54218)
THETA_OFFSET_RAD = (0.0, np.pi / 2, 0.0, 0.0, 0.0, 0.0, 0.0)
#: Table IV: centre of mass of link i (m, DH frame i).
TABLE_IV_COM_M = (
    (-0.05117, 0.07908, 0.00086),
    (0.00269, -0.00529, 0.06845),
    (-0.07176, 0.08149, 0.00132),
    (0.00159, -0.01117, 0.02618),
    (-0.01168, 0.13111, 0.0046),
    (0.00697, 0.006, 0.06048),
    (0.005137, 0.0009572, -0.06682),
)
#: Table III: inertia tensor of link i about its centre of mass (kg·m², DH frame i), as
#: (xx, yy, zz, xy, yz, xz), the off-diagonal entries the tensor's elements. Links 1-4 as printed;
#: links 5-6: the printed diagonal, the products (which the printed table lacks) from the URDF
#: rotated into the DH frames; link 7: the URDF's wrist and hand merged about their centre of mass
#: (the printed one is 4e-4 kg·m² below it). The URDF-derived figures are transcribed from that
#: derivation (the model files' comments describe it), not read from a model file.
TABLE_III_INERTIA_KGM2 = (
    (0.0470910226, 0.035959884, 0.0376697645, -0.0061487003, -0.0007808689, 0.0001278755),
    (0.027885975, 0.020787492, 0.0117520941, -0.0001882199, 0.0020767576, -0.00030096397),
    (0.0266173355, 0.012480083, 0.028443552, -0.0039218988, -0.001083893, 0.0002927063),
    (0.0131822787, 0.00926852, 0.0071158268, -0.0001966341, 0.000745949, 0.0003603617),
    (0.0166774282, 0.003746311, 0.0167545726, -0.00018657629, 0.00064732352, 0.00018403705),
    (0.0070053791, 0.005527552, 0.0038760715, 0.00015348067, -0.00021115038, -0.00044384784),
    (0.0012147746, 0.0012763573, 0.0005548668, 8.1434e-06, 4.7154e-06, -6.55078e-05),
)
GRAVITY_M_S2 = (0.0, 0.0, -9.81)  # in DH frame 0: the arm mount turns about the vertical only


def urdf_joint_origins(side: str) -> dict[str, np.ndarray]:
    """{joint suffix: origin xyz (3,) m} of the side's joints (and ``hand``), read from the URDF's text."""
    require_urdf()
    root = ET.parse(URDF_PATH).getroot()
    out = {}
    for joint in root.findall("joint"):
        name, origin = joint.get("name", ""), joint.find("origin")
        if name.startswith(f"{side}_") and origin is not None:
            out[name.removeprefix(f"{side}_")] = np.array(origin.get("xyz").split(), dtype=float)
    return out


def urdf_dh_lengths(side: str) -> tuple[np.ndarray, np.ndarray]:
    """d, a (7,) m of the DH table, from the URDF's joint origins.

    The URDF puts each joint's frame on its axis; along the DH normals its offsets add up as
    d1 = z(s1), a1 = x(s1), d3 = x(e0) + z(e1), a3 = x(e1), d5 = x(w0) + z(w1), a5 = x(w1),
    d7 = x(w2) + z(hand) (the flange), the other lengths 0.
    """
    o = urdf_joint_origins(side)
    d = [o["s1"][2], 0.0, o["e0"][0] + o["e1"][2], 0.0, o["w0"][0] + o["w1"][2], 0.0, o["w2"][0] + o["hand"][2]]
    a = [o["s1"][0], 0.0, o["e1"][0], 0.0, o["w1"][0], 0.0, 0.0]
    return np.array(d), np.array(a)


def paper_reference(side: str) -> PinocchioArm:
    """Pinocchio's model of one arm from the tables above and the URDF's DH lengths (module docstring).

    Joint i+1 sits on joint i at X_i = Rz(θ offset_i)·Tz(d_i)·Tx(a_i)·Rx(α_i) (eq. 2 at q = 0), link
    i's inertials (DH frame i) are attached at X_i, the flange frame is DH frame 7; world = DH frame 0.
    """
    d, a = urdf_dh_lengths(side)
    model = pin.Model()
    joint, placement = 0, pin.SE3.Identity()
    for i, suffix in enumerate(JOINT_SUFFIXES):
        joint = model.addJoint(joint, pin.JointModelRZ(), placement, f"{side}_{suffix}")
        placement = link_placement((d[i], a[i], TABLE_II_ALPHA_RAD[i], THETA_OFFSET_RAD[i]))
        xx, yy, zz, xy, yz, xz = TABLE_III_INERTIA_KGM2[i]
        tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        model.appendBodyToJoint(joint, pin.Inertia(TABLE_II_MASS_KG[i], np.array(TABLE_IV_COM_M[i]), tensor), placement)
    flange = model.addFrame(pin.Frame("flange", joint, placement, pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array(GRAVITY_M_S2)
    return PinocchioArm(model, model.createData(), np.arange(N), pin.SE3.Identity(), flange)


def pinocchio_from_arm(arm: ArmModel) -> PinocchioArm:
    """The package's Pinocchio model of the arm (:func:`baxter_dynamics_ros.core.pinocchio_model.pinocchio_from_arm`:
    7 revolute-z joints from the DH table, link i attached at X_i), its flange frame = DH frame 7."""
    model = pinocchio_model.pinocchio_from_arm(arm)
    return PinocchioArm(model, model.createData(), np.arange(N), pin.SE3.Identity(), model.getFrameId("flange"))


def pinocchio_from_urdf(arm: ArmModel) -> PinocchioArm:
    """The URDF model (whole robot, fixed base), the arm's joints picked out, the others held at 0.

    Pinocchio's parser merges links on fixed joints into their parent body, so joint 7 carries the
    wrist, the hand and the hand's 0.1 g sensor links: the paper's merged link 7. (The URDF names a
    fixed joint and a link both ``<side>_hand``, which makes ``buildReducedModel`` refuse it; with
    the other joints at zero velocity and acceleration the arm's torques are the same.)
    DH frame 0 is the ``<side>_arm_mount`` frame translated by the ``<side>_s0`` joint's origin.
    """
    require_urdf()
    model = pin.buildModelFromUrdf(str(URDF_PATH))
    idx = np.array([model.joints[model.getJointId(name)].idx_q for name in arm.joint_names])
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    mount = data.oMf[model.getFrameId(f"{arm.side}_arm_mount", pin.FrameType.BODY)]
    base = mount * pin.SE3(np.eye(3), urdf_joint_origins(arm.side)["s0"])
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
def dahl_state(q: np.ndarray, presliding_rad: float) -> np.ndarray:
    """(n, 7) Dahl's friction state along q (n, 7) rad from 0, over each step of the angle itself
    (not of q̇, as the package does): :func:`dahl_state_of_steps` of Δq."""
    return dahl_state_of_steps(np.diff(q, axis=0, prepend=q[:1]), presliding_rad)


def dahl_state_of_steps(steps: np.ndarray, presliding_rad: float) -> np.ndarray:
    """(n, 7) Dahl's friction state from 0 after turning steps[k] (n, 7) rad into each sample k
    (row 0 unused): dz/dθ = (1 − z sgn dθ)/θ_p solved exactly, z → sgn(step) by exp(−|step|/θ_p)."""
    z = np.zeros_like(steps)
    for k in range(1, len(steps)):
        target = np.sign(steps[k])
        z[k] = target + (z[k - 1] - target) * np.exp(-np.abs(steps[k]) / presliding_rad)
    return z


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
