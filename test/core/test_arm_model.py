"""Loading and validating arm model files; the pseudo-inertia of eq. (12)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from baxter_dynamics_ros import LinkInertial, ModelFileError, load_arm_model
from baxter_dynamics_ros.core.arm_model import config_dir, pseudo_inertia


def real_model() -> dict[str, Any]:
    return yaml.safe_load((config_dir() / "baxter_right_arm.yaml").read_text(encoding="utf-8"))


def write_variant(tmp_path: Path, edit: Callable[[dict[str, Any]], None]) -> Path:
    """The real right-arm file with one edit applied, written to tmp_path."""
    raw = real_model()
    edit(raw)
    path = tmp_path / "arm.yaml"
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    return path


@pytest.mark.parametrize("side", ["right", "left"])
def test_loads_both_arms(side: str) -> None:
    arm = load_arm_model(side)
    assert arm.side == side
    assert arm.joint_names == tuple(f"{side}_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
    assert arm.dh.shape == (7, 4) and arm.pseudo_inertias.shape == (7, 4, 4)
    np.testing.assert_allclose(arm.gravity_m_s2, [0.0, 0.0, -9.81], atol=1e-12)
    # Table II; link 7 is the URDF's wrist + hand.
    table_ii = [5.70044, 3.22698, 4.31272, 2.07206, 2.24665, 1.60979, 0.35093 + 0.19125]
    np.testing.assert_allclose(arm.masses_kg, table_ii)
    assert not arm.dh.flags.writeable and not arm.pseudo_inertias.flags.writeable


def test_loads_a_path_like_the_name(tmp_path: Path) -> None:
    path = write_variant(tmp_path, lambda raw: None)
    from_path, by_name = load_arm_model(path), load_arm_model("right")
    np.testing.assert_array_equal(from_path.pseudo_inertias, by_name.pseudo_inertias)
    assert from_path.source == str(path)


def test_pseudo_inertia_equals_second_moments_of_point_masses() -> None:
    """J = Σ m r̄ r̄ᵀ (eq. 12) for a body of point masses, built from its mass, CoM and centroidal tensor."""
    rng = np.random.default_rng(11)
    masses, points = rng.uniform(0.1, 1.0, 6), rng.uniform(-0.2, 0.3, (6, 3))
    mass = masses.sum()
    com = masses @ points / mass
    rel = points - com
    inertia = sum(m * (r @ r * np.eye(3) - np.outer(r, r)) for m, r in zip(masses, rel))
    homogeneous = np.hstack([points, np.ones((6, 1))])
    expected = np.einsum("n,ni,nj->ij", masses, homogeneous, homogeneous)
    link = LinkInertial(name="points", mass_kg=mass, com_m=com, inertia_kgm2=inertia)
    np.testing.assert_allclose(pseudo_inertia(link), expected, rtol=1e-12, atol=1e-15)


DELETE = object()


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    """An edit setting the dotted path (list indices as numbers) to value, or deleting it if value is DELETE."""

    def edit(raw: dict[str, Any]) -> None:
        *parents, last = [int(k) if k.isdigit() else k for k in path.split(".")]
        node = raw
        for key in parents:
            node = node[key]
        if value is DELETE:
            del node[last]
        else:
            node[last] = value

    return edit


MALFORMED = [
    ("missing-link-mass", _set("links.2.mass_kg", DELETE), r"links\[2\]\.mass_kg: missing"),
    ("missing-section", _set("dh", DELETE), r"dh: missing"),
    ("missing-inertia-term", _set("links.4.inertia_kgm2.xz", DELETE), r"links\[4\]\.inertia_kgm2\.xz: missing"),
    ("negative-mass", _set("links.1.mass_kg", -3.2), r"links\[1\]\.mass_kg: must be positive"),
    (
        "not-positive-definite",
        _set("links.3.inertia_kgm2.xx", -0.01),
        r"links\[3\]\.inertia_kgm2: not positive definite",
    ),
    (
        "triangle-inequality",
        _set("links.0.inertia_kgm2", {"xx": 0.001, "yy": 0.001, "zz": 0.01, "xy": 0.0, "yz": 0.0, "xz": 0.0}),
        r"links\[0\]\.inertia_kgm2: principal moments .* triangle inequality",
    ),
    ("short-dh-list", _set("dh.d_m", [0.27, 0.0, 0.36, 0.0, 0.37, 0.0]), r"dh\.d_m: expected shape \(7,\), got \(6,\)"),
    ("long-limit-list", _set("joint_limits.lower_rad", [-1.0] * 8), r"joint_limits\.lower_rad: expected shape \(7,\)"),
    ("six-links", lambda raw: raw["links"].pop(), r"links: expected a list of 7 links"),
    ("nan-com", _set("links.0.com_m", [math.nan, 0.0, 0.0]), r"links\[0\]\.com_m: non-finite value"),
    ("inf-gravity", _set("gravity_m_s2", [0.0, 0.0, -math.inf]), r"gravity_m_s2: non-finite value"),
    # Found by the fuzz test: a finite centre of mass whose square overflows in the pseudo-inertia.
    ("far-com", _set("links.3.com_m", [1.34e154, 0.0, 0.0]), r"links\[3\]\.com_m: .* is beyond ±100, not a robot arm's"),
    ("huge-mass", _set("links.6.mass_kg", 1e300), r"links\[6\]\.mass_kg: .* is beyond ±10000"),
    ("huge-inertia", _set("links.2.inertia_kgm2.xx", 1e200), r"links\[2\]\.inertia_kgm2\.xx: .* is beyond"),
    ("far-dh", _set("dh.a_m", [0.069, 0.0, 0.069, 0.0, 1e30, 0.0, 0.0]), r"dh\.a_m: .* is beyond ±100"),
    ("huge-gravity", _set("gravity_m_s2", [0.0, 0.0, -1e6]), r"gravity_m_s2: .* is beyond ±100"),
    ("text-number", _set("links.5.mass_kg", "heavy"), r"links\[5\]\.mass_kg: expected numbers, got 'heavy'"),
    ("bad-side", _set("arm", "middle"), r"arm: expected 'right' or 'left', got 'middle'"),
    ("duplicate-joint-names", _set("joint_names", ["j"] * 7), r"joint_names: expected 7 distinct names"),
    ("lower-above-upper", _set("joint_limits.upper_rad", [-2.0] * 7), r"joint_limits: every lower_rad must be below"),
    (
        "zero-velocity-limit",
        _set("joint_limits.velocity_rad_s", [0.0] * 7),
        r"joint_limits\.velocity_rad_s: limits must be positive",
    ),
    ("mount-not-mapping", _set("mount", [1, 2, 3]), r"mount: expected a mapping"),
]


@pytest.mark.parametrize(("edit", "match"), [m[1:] for m in MALFORMED], ids=[m[0] for m in MALFORMED])
def test_malformed_model_file_names_the_field(tmp_path: Path, edit, match: str) -> None:
    path = write_variant(tmp_path, edit)
    with pytest.raises(ModelFileError, match=match) as err:
        load_arm_model(path)
    assert str(path) in str(err.value)


def test_bad_yaml(tmp_path: Path) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text("dh: [0.27035, 0.0\nlinks: {", encoding="utf-8")
    with pytest.raises(ModelFileError, match=r"arm\.yaml: the model file is not valid YAML"):
        load_arm_model(path)


def test_not_a_mapping(tmp_path: Path) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text("- 1\n- 2\n", encoding="utf-8")
    with pytest.raises(ModelFileError, match=r"top level: expected a mapping"):
        load_arm_model(path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ModelFileError, match=r"nowhere\.yaml: cannot read the model file \(No such file"):
        load_arm_model(tmp_path / "nowhere.yaml")
