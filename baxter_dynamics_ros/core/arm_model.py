"""The arm model: validated, immutable Lagrange-Euler parameters of one Baxter arm.

An :class:`ArmModel` holds the constants (DH table, pseudo-inertias, gravity); the algorithms of
:mod:`baxter_dynamics_ros.core.lagrange_euler` do the work. Models are read from the YAML files in
``config/`` (``baxter_right_arm.yaml``, ``baxter_left_arm.yaml``) or any file of that layout.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelFileError
from . import lagrange_euler
from .joints import JOINTS as N_JOINTS
from .yaml_files import read_yaml

__all__ = [
    "ArmModel",
    "LinkInertial",
    "config_dir",
    "link_from_parameters",
    "link_parameters",
    "load_arm_model",
    "pseudo_inertia",
]

PACKAGE = "baxter_dynamics_ros"


@dataclass(frozen=True)
class LinkInertial:
    """Inertial parameters of one link, in its DH frame.

    mass_kg: kg; com_m: (3,) centre of mass in m; inertia_kgm2: (3, 3) tensor about the centre of
    mass in kg·m² (off-diagonals are tensor elements, minus the products ∫xy dm).
    """

    name: str
    mass_kg: float
    com_m: np.ndarray
    inertia_kgm2: np.ndarray


def pseudo_inertia(link: LinkInertial) -> np.ndarray:
    """Pseudo-inertia J_i = ∫ r̄ r̄ᵀ dm of paper eq. (12), (4, 4), in the link's DH frame.

    Upper-left block: the second moments about the frame origin,
    Σ = ½ tr(I_c) 𝟙 − I_c + m c cᵀ; last column and row: m c and m.
    """
    m, c, inertia = link.mass_kg, link.com_m, link.inertia_kgm2
    j = np.empty((4, 4))
    j[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia + m * np.outer(c, c)
    j[:3, 3] = j[3, :3] = m * c
    j[3, 3] = m
    return j


def link_parameters(link: LinkInertial) -> np.ndarray:
    """(10,) inertial parameters of one link: m, m·c, and the tensor about the frame origin (xx xy xz yy yz zz)."""
    m, c = link.mass_kg, link.com_m
    origin = link.inertia_kgm2 + m * (np.dot(c, c) * np.eye(3) - np.outer(c, c))
    return np.array([m, *(m * c), origin[0, 0], origin[0, 1], origin[0, 2], origin[1, 1], origin[1, 2], origin[2, 2]])


def link_from_parameters(name: str, pi: np.ndarray) -> LinkInertial:
    """Inverse of :func:`link_parameters`: a LinkInertial (not validated) from 10 parameters."""
    m = float(pi[0])
    c = np.asarray(pi[1:4]) / m
    xx, xy, xz, yy, yz, zz = pi[4:10]
    origin = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return LinkInertial(name, m, c, origin - m * (np.dot(c, c) * np.eye(3) - np.outer(c, c)))


def _rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """Rotation matrix of URDF roll-pitch-yaw angles (rad): Rz(yaw) · Ry(pitch) · Rx(roll)."""
    cr, cp, cy = np.cos(rpy)
    sr, sp, sy = np.sin(rpy)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@dataclass(frozen=True)
class ArmModel:
    """Lagrange-Euler model of one 7-DoF Baxter arm (paper Tables II–IV).

    Arrays are read-only. ``dh`` is (7, 4): d [m], a [m], α [rad], θ offset [rad] per joint;
    ``pseudo_inertias`` is (7, 4, 4), J_i of eq. (12) in DH frame i; ``gravity_m_s2`` (3,) is
    gravity in the arm base frame (DH frame 0); ``base_in_torso`` (4, 4) places that frame on the
    robot. Joint limits are (7,) arrays in rad, rad/s and N·m.
    """

    side: str
    joint_names: tuple[str, ...]
    dh: np.ndarray
    links: tuple[LinkInertial, ...]
    gravity_m_s2: np.ndarray
    base_in_torso: np.ndarray
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity_limit_rad_s: np.ndarray
    effort_limit_nm: np.ndarray
    source: str = ""
    pseudo_inertias: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "pseudo_inertias", np.stack([pseudo_inertia(l) for l in self.links]))
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False

    @property
    def inertial_parameters(self) -> np.ndarray:
        """(70,) the links' inertial parameters π in the order of :func:`lagrange_euler.inertial_basis`.

        Per link: m [kg], m·c [kg·m], then I_xx, I_xy, I_xz, I_yy, I_yz, I_zz [kg·m²] of the tensor
        about the DH frame's origin, so that τ = inertial_regressor(q, q̇, q̈) · π.
        """
        return np.concatenate([link_parameters(link) for link in self.links])

    @property
    def masses_kg(self) -> np.ndarray:
        """(7,) link masses in kg."""
        return np.array([link.mass_kg for link in self.links])

    # The algorithms live in lagrange_euler; these methods bind them to this model's constants.
    def gravity(self, q: np.ndarray) -> np.ndarray:
        """G(q) of eq. (8), N·m; q (..., 7) rad."""
        return lagrange_euler.gravity(self.dh, self.pseudo_inertias, self.gravity_m_s2, q)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """M(q) of eq. (6), (..., 7, 7) kg·m²; q (..., 7) rad."""
        return lagrange_euler.mass_matrix(self.dh, self.pseudo_inertias, q)

    def coriolis(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The vector C(q, q̇) of eqs. (1) and (7), N·m; q, qd (..., 7) rad, rad/s."""
        return lagrange_euler.coriolis(self.dh, self.pseudo_inertias, q, qd)

    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """τ = M(q) q̈ + C(q, q̇) + G(q) of eq. (1), N·m; inputs (..., 7) rad, rad/s, rad/s²."""
        return lagrange_euler.inverse_dynamics(self.dh, self.pseudo_inertias, self.gravity_m_s2, q, qd, qdd)

    def forward_dynamics(self, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """q̈ = M⁻¹(τ − C − G), rad/s²; inputs (..., 7) rad, rad/s, N·m."""
        return lagrange_euler.forward_dynamics(self.dh, self.pseudo_inertias, self.gravity_m_s2, q, qd, tau)

    def forward_kinematics(self, q: np.ndarray) -> np.ndarray:
        """(..., 4, 4) pose of the hand flange (DH frame 7) in the arm base frame; q (..., 7) rad."""
        return lagrange_euler.forward_kinematics(self.dh, q)

    def inertial_regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """(..., 7, 70) Y with inverse_dynamics = Y · inertial_parameters; inputs (..., 7)."""
        return lagrange_euler.inertial_regressor(self.dh, self.gravity_m_s2, q, qd, qdd)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        """(..., 6, 7) geometric Jacobian of the flange in the base frame, rows (v [m/s], ω [rad/s])."""
        return lagrange_euler.jacobian(self.dh, q)


def config_dir() -> Path:
    """The folder holding the package's YAML files.

    Looked up in the source tree (checkout or editable install), then under the install prefix
    (``pip install .``: ``<prefix>/share/baxter_dynamics_ros/config``), then in every
    ``AMENT_PREFIX_PATH`` entry (colcon workspace).
    """
    candidates = [Path(__file__).resolve().parents[2] / "config"]
    prefixes = [sys.prefix, *os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)]
    candidates += [Path(p) / "share" / PACKAGE / "config" for p in prefixes if p]
    for candidate in candidates:
        if (candidate / "baxter_right_arm.yaml").is_file():
            return candidate
    raise ModelFileError(
        "cannot find the package's config/ folder (looked in: "
        + ", ".join(str(c) for c in candidates)
        + "); reinstall the package or pass a model file path"
    )


def load_arm_model(arm: str | os.PathLike[str] = "right") -> ArmModel:
    """Load and validate an arm model: ``"right"``, ``"left"`` or the path of a model YAML file."""
    if str(arm) in ("right", "left"):
        path = config_dir() / f"baxter_{arm}_arm.yaml"
    else:
        path = Path(arm)
    return _parse(read_yaml(path, ModelFileError, "model file"), str(path))


#: Bounds of a model file's numbers: far beyond any robot arm, near enough that every product the
#: dynamics form stays finite (a centre of mass of 1e154 m overflowed the pseudo-inertia).
MAX_LENGTH_M = 100.0
MAX_ANGLE_RAD = 100.0
MAX_MASS_KG = 1e4
MAX_INERTIA_KGM2 = 1e4
MAX_SPEED_RAD_S = 1e3
MAX_EFFORT_NM = 1e5
MAX_GRAVITY_M_S2 = 100.0
DH_FIELDS = (("d_m", MAX_LENGTH_M), ("a_m", MAX_LENGTH_M), ("alpha_rad", MAX_ANGLE_RAD), ("theta_offset_rad", MAX_ANGLE_RAD))


class _Fields:
    """Reads fields of a parsed YAML mapping, failing with the field's dotted path."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, where: str, what: str) -> ModelFileError:
        return ModelFileError(f"{self.source}: {where}: {what}")

    def get(self, mapping: Any, key: str, where: str) -> Any:
        if not isinstance(mapping, dict):
            raise self.fail(where, "expected a mapping")
        if key not in mapping:
            raise self.fail(f"{where}.{key}" if where else key, "missing")
        return mapping[key]

    def array(self, mapping: Any, key: str, where: str, shape: tuple[int, ...], limit: float) -> np.ndarray:
        """The field as a float array of ``shape``, finite and within ±``limit`` (its unit)."""
        path = f"{where}.{key}" if where else key
        value = self.get(mapping, key, where)
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as err:
            raise self.fail(path, f"expected numbers, got {value!r}") from err
        if arr.shape != shape:
            raise self.fail(path, f"expected shape {shape}, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise self.fail(path, f"non-finite value in {arr.tolist()}")
        if np.any(np.abs(arr) > limit):
            raise self.fail(path, f"{arr.tolist()} is beyond ±{limit:g}, not a robot arm's")
        return arr


def _parse(raw: Any, source: str) -> ArmModel:
    f = _Fields(source)
    if not isinstance(raw, dict):
        raise f.fail("top level", "expected a mapping of model fields")
    side = f.get(raw, "arm", "")
    if side not in ("right", "left"):
        raise f.fail("arm", f"expected 'right' or 'left', got {side!r}")
    names = f.get(raw, "joint_names", "")
    if (
        not isinstance(names, list)
        or len(names) != N_JOINTS
        or not all(isinstance(n, str) and n for n in names)
        or len(set(names)) != N_JOINTS
    ):
        raise f.fail("joint_names", f"expected {N_JOINTS} distinct names, got {names!r}")
    dh_raw = f.get(raw, "dh", "")
    dh = np.stack(
        [f.array(dh_raw, k, "dh", (N_JOINTS,), limit) for k, limit in DH_FIELDS],
        axis=1,
    )
    links_raw = f.get(raw, "links", "")
    if not isinstance(links_raw, list) or len(links_raw) != N_JOINTS:
        raise f.fail("links", f"expected a list of {N_JOINTS} links")
    links = tuple(_parse_link(f, entry, f"links[{i}]") for i, entry in enumerate(links_raw))
    lim = f.get(raw, "joint_limits", "")
    lower = f.array(lim, "lower_rad", "joint_limits", (N_JOINTS,), MAX_ANGLE_RAD)
    upper = f.array(lim, "upper_rad", "joint_limits", (N_JOINTS,), MAX_ANGLE_RAD)
    if np.any(lower >= upper):
        raise f.fail("joint_limits", "every lower_rad must be below its upper_rad")
    velocity = f.array(lim, "velocity_rad_s", "joint_limits", (N_JOINTS,), MAX_SPEED_RAD_S)
    effort = f.array(lim, "effort_nm", "joint_limits", (N_JOINTS,), MAX_EFFORT_NM)
    for key, arr in (("velocity_rad_s", velocity), ("effort_nm", effort)):
        if np.any(arr <= 0):
            raise f.fail(f"joint_limits.{key}", "limits must be positive")
    mount = f.get(raw, "mount", "")
    rotation = _rpy_matrix(f.array(mount, "rpy_rad", "mount", (3,), MAX_ANGLE_RAD))
    base = np.eye(4)
    base[:3, :3] = rotation
    base[:3, 3] = f.array(mount, "xyz_m", "mount", (3,), MAX_LENGTH_M) + rotation @ f.array(
        mount, "base_offset_m", "mount", (3,), MAX_LENGTH_M
    )
    gravity_torso = f.array(raw, "gravity_m_s2", "", (3,), MAX_GRAVITY_M_S2)
    return ArmModel(
        side=side,
        joint_names=tuple(names),
        dh=dh,
        links=links,
        gravity_m_s2=rotation.T @ gravity_torso,
        base_in_torso=base,
        lower_rad=lower,
        upper_rad=upper,
        velocity_limit_rad_s=velocity,
        effort_limit_nm=effort,
        source=source,
    )


def _parse_link(f: _Fields, raw: Any, where: str) -> LinkInertial:
    name = f.get(raw, "name", where)
    mass = float(f.array(raw, "mass_kg", where, (), MAX_MASS_KG))
    if mass <= 0:
        raise f.fail(f"{where}.mass_kg", f"must be positive, got {mass}")
    com = f.array(raw, "com_m", where, (3,), MAX_LENGTH_M)
    tensor = f.get(raw, "inertia_kgm2", where)
    keys = ("xx", "yy", "zz", "xy", "yz", "xz")
    xx, yy, zz, xy, yz, xz = (float(f.array(tensor, k, f"{where}.inertia_kgm2", (), MAX_INERTIA_KGM2)) for k in keys)
    inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] <= 0:
        raise f.fail(f"{where}.inertia_kgm2", f"not positive definite (eigenvalues {eig.tolist()})")
    # Principal moments of a real body satisfy the triangle inequality: each ≤ the sum of the others.
    if eig[2] > eig[0] + eig[1] + 1e-12 * eig[2]:
        raise f.fail(
            f"{where}.inertia_kgm2",
            f"principal moments {eig.tolist()} break the triangle inequality (largest > sum of the others)",
        )
    return LinkInertial(name=str(name), mass_kg=mass, com_m=com, inertia_kgm2=inertia)


