"""Per-joint collision thresholds a + b·|q̇| on the observer's r, and their file (``thresholds.yaml``).

A :class:`Thresholds` records, besides a and b, how it was calibrated and what the detector and the
observer must use with it: the observer's gain and effort–state alignment (:mod:`.observer`), the
samples in a row the detector needs and the time constant of the slow bias it removes
(:mod:`.detector`). :func:`write_thresholds` writes it whole or not at all; :func:`read_thresholds`
validates a file and names what is wrong.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from ..core.joints import JOINT_SUFFIXES
from ..core.joints import JOINTS as N
from ..core.output_files import staged_outputs
from ..core.plausibility import PLAUSIBLE_FACTOR, first_beyond_plausible_effort
from ..core.yaml_files import read_yaml
from ..errors import CollisionError
from .observer import DEFAULT_GAIN_1_S, check_effort_delay

if TYPE_CHECKING:
    from ..core.arm_model import ArmModel

__all__ = [
    "DEFAULT_CONSECUTIVE",
    "Thresholds",
    "check_consecutive",
    "check_time_constant",
    "read_thresholds",
    "require_plausible",
    "write_thresholds",
]

#: Samples in a row above a threshold before the detector turns on.
DEFAULT_CONSECUTIVE = 2


def check_consecutive(value: Any) -> int:
    """``consecutive`` checked: a whole number ≥ 1."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise CollisionError(f"consecutive: expected a whole number >= 1, got {value!r}")
    return int(value)


def check_time_constant(value: Any) -> float:
    """``bias_time_constant_s`` checked: finite seconds ≥ 0 (0: no bias removed)."""
    try:
        t = float(value)
    except (TypeError, ValueError) as err:
        raise CollisionError(f"bias_time_constant_s: expected seconds >= 0, got {value!r}") from err
    if not (t >= 0 and np.isfinite(t)):
        raise CollisionError(f"bias_time_constant_s: expected seconds >= 0, got {value!r}")
    return t


def _joint_vector(value: Any, where: str, *, positive: bool) -> np.ndarray:
    if isinstance(value, dict):
        unknown = set(value) - set(JOINT_SUFFIXES)
        missing = set(JOINT_SUFFIXES) - set(value)
        if unknown or missing:
            raise CollisionError(f"{where}: expected the joints {', '.join(JOINT_SUFFIXES)}, got {sorted(value)}")
        value = [value[j] for j in JOINT_SUFFIXES]
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise CollisionError(f"{where}: expected 7 numbers, got {value!r}") from err
    if arr.shape != (N,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0 if positive else arr < 0):
        raise CollisionError(f"{where}: expected 7 finite numbers {'> 0' if positive else '>= 0'}, got {value!r}")
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class Thresholds:
    """Per-joint thresholds a + b |q̇|: offset_nm (7,) N·m > 0, slope_nm_s_rad (7,) N·m·s/rad ≥ 0.

    gain_1_s (7,): the observer gain they were calibrated with (r depends on it); consecutive: the
    samples in a row above that the detector needs (they were calibrated for it); effort_delay_s:
    the effort–state alignment the observer ran with, s; bias_time_constant_s: T_b of the slow bias
    the detector removes, s (0: none); as in :mod:`.observer` and :mod:`.detector`; margin and files: how they
    were calibrated (for the record).
    """

    offset_nm: np.ndarray
    slope_nm_s_rad: np.ndarray = field(default_factory=lambda: np.zeros(N))
    gain_1_s: np.ndarray = field(default_factory=lambda: np.full(N, DEFAULT_GAIN_1_S))
    margin: float = 1.0
    files: tuple[str, ...] = ()
    consecutive: int = DEFAULT_CONSECUTIVE
    effort_delay_s: float = 0.0
    bias_time_constant_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset_nm", _joint_vector(self.offset_nm, "offset_nm", positive=True))
        object.__setattr__(self, "slope_nm_s_rad", _joint_vector(self.slope_nm_s_rad, "slope_nm_s_rad", positive=False))
        object.__setattr__(self, "gain_1_s", _joint_vector(self.gain_1_s, "gain_1_s", positive=True))
        if isinstance(self.files, (str, bytes)) or not isinstance(self.files, (list, tuple)):
            raise CollisionError(f"files: expected a list of file names, got {self.files!r}")
        object.__setattr__(self, "files", tuple(str(f) for f in self.files))
        object.__setattr__(self, "consecutive", check_consecutive(self.consecutive))
        object.__setattr__(self, "effort_delay_s", check_effort_delay(self.effort_delay_s))
        object.__setattr__(self, "bias_time_constant_s", check_time_constant(self.bias_time_constant_s))
        try:
            margin = float(self.margin)
        except (TypeError, ValueError) as err:
            raise CollisionError(f"margin: expected a number >= 1, got {self.margin!r}") from err
        if not margin >= 1.0 or not np.isfinite(margin):
            raise CollisionError(f"margin: expected a number >= 1, got {self.margin!r}")
        object.__setattr__(self, "margin", margin)

    def at(self, qd: np.ndarray) -> np.ndarray:
        """Thresholds at the speed qd, (..., 7) N·m; qd (..., 7) rad/s."""
        return self.offset_nm + self.slope_nm_s_rad * np.abs(qd)

    def to_dict(self) -> dict[str, Any]:
        def joints(v: np.ndarray) -> dict[str, float]:
            return {j: float(x) for j, x in zip(JOINT_SUFFIXES, v)}

        return {
            "offset_nm": joints(self.offset_nm),
            "slope_nm_s_rad": joints(self.slope_nm_s_rad),
            "gain_1_s": joints(self.gain_1_s),
            "consecutive": self.consecutive,
            "effort_delay_s": self.effort_delay_s,
            "bias_time_constant_s": self.bias_time_constant_s,
            "margin": float(self.margin),
            "files": list(self.files),
        }

    @classmethod
    def from_dict(cls, raw: Any, where: str = "thresholds") -> Thresholds:
        if not isinstance(raw, dict) or "offset_nm" not in raw:
            raise CollisionError(f"{where}: expected a mapping with offset_nm (and slope_nm_s_rad, gain_1_s), got {raw!r}")
        unknown = set(raw) - {"offset_nm", "slope_nm_s_rad", "gain_1_s", "consecutive", "effort_delay_s", "bias_time_constant_s", "margin", "files"}
        if unknown:
            raise CollisionError(f"{where}: unknown keys {sorted(unknown)}")
        try:
            return cls(**raw)
        except CollisionError as err:
            raise CollisionError(f"{where}: {err}") from err


def write_thresholds(path: str | os.PathLike[str], thresholds: Thresholds, *, replace: bool = True) -> None:
    """Write ``thresholds`` as YAML (thresholds.yaml), whole or not at all (:mod:`~baxter_dynamics_ros.core.output_files`;
    replace: False refuses a file that is there, also one written meanwhile)."""
    with staged_outputs([Path(path)], replace=replace) as (staged,), open(staged, "w", encoding="utf-8") as stream:
        stream.write("# Collision thresholds a + b|q̇| per joint, from `baxter-dynamics calibrate`.\n")
        yaml.safe_dump(thresholds.to_dict(), stream, sort_keys=False, allow_unicode=True)


def read_thresholds(path: str | os.PathLike[str], arm: ArmModel | None = None) -> Thresholds:
    """The :class:`Thresholds` of a YAML file written by :func:`write_thresholds`; with ``arm``, held
    to its plausible effort (:func:`require_plausible`)."""
    thresholds = Thresholds.from_dict(read_yaml(path, CollisionError, "thresholds file"), str(path))
    if arm is not None:
        require_plausible(thresholds, arm, str(path))
    return thresholds


def require_plausible(thresholds: Thresholds, arm: ArmModel, where: str) -> None:
    """Refuse (CollisionError) thresholds that no real collision could cross: at a joint's velocity
    limit, a + b·q̇ above :data:`~baxter_dynamics_ros.core.plausibility.PLAUSIBLE_FACTOR` times its
    effort limit (150–300 N·m at s0–e1, 45 N·m at the wrist), the largest effort a real Baxter gives
    (:mod:`baxter_dynamics_ros.core.plausibility`). Calibrated thresholds lie far below (the
    simulated recordings': 57 N·m at s1, under 20 N·m elsewhere); above it, detection at that joint
    would be silently off."""
    at_limit = thresholds.at(arm.velocity_limit_rad_s)
    beyond = first_beyond_plausible_effort(arm, at_limit)
    if beyond is not None:
        j, bound = beyond
        raise CollisionError(
            f"{where}: the {JOINT_SUFFIXES[j]} threshold at its velocity limit is {at_limit[j]:.3g} N·m, above "
            f"{bound:g} N·m ({PLAUSIBLE_FACTOR:g} × the joint's effort limit, more than a real Baxter gives): "
            "no collision could ever be detected there; calibrate again (baxter-dynamics calibrate, or ~/calibrate)"
        )
