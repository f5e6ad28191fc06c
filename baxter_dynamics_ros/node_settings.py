"""The dynamics node's settings: one validated record whose fields are the node's ROS parameters.

:class:`NodeSettings` is the single source of the parameters' names, types, defaults and help
texts; the node declares one ROS parameter per field and validates every change (at start-up from
``--params-file`` / ``-p`` overrides, and later from ``ros2 param set``) by building a new record.
``config/baxter_dynamics.yaml`` repeats the defaults for users to copy.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from .errors import SettingsError

__all__ = ["ESTIMATORS", "NodeSettings"]

#: Causal q̈ estimators the live node offers (see :mod:`baxter_dynamics_ros.acceleration`).
ESTIMATORS = ("lowpass", "first_difference")


def _setting(default: Any, help_text: str, *, live: bool = False) -> Any:
    """A settings field; ``live`` ones may change while the node runs, the others need a restart."""
    return field(default=default, metadata={"help": help_text, "live": live})


@dataclass(frozen=True)
class NodeSettings:
    """Validated settings of the ``baxter_dynamics`` node (field = ROS parameter of that name)."""

    arm: str = _setting("right", "Arm to model: right or left (its joints are read from the input by name).")
    model_file: str = _setting("", "Arm model YAML to use instead of the built-in model of `arm` (empty: built-in).")
    effects_file: str = _setting(
        "",
        "effects.yaml written by `baxter-dynamics diagnose`: its effects are compensated in the model "
        "(empty: the rigid-body model alone).",
    )
    joint_states_topic: str = _setting("/robot/joint_states", "Input sensor_msgs/JointState topic.")
    qos_depth: int = _setting(
        100, "Keep-last depth of the input subscription and of the output publishers (samples)."
    )
    estimator: str = _setting(
        "lowpass",
        "q̈ estimator on q̇: lowpass (2nd-order low-pass differentiator, cutoff_hz) or "
        "first_difference (the paper's raw difference). Changing it resets the estimator.",
        live=True,
    )
    cutoff_hz: float = _setting(
        10.0, "Cut-off of the lowpass estimator in Hz (-3 dB); ignored by first_difference.", live=True
    )
    diagnostics_period_s: float = _setting(1.0, "Period of the /diagnostics report and of its window (s).")
    observer_gain_1_s: float = _setting(
        20.0, "Gain K_O of the momentum observer giving ~/external_torque, 1/s (time constant 1/K_O)."
    )
    thresholds_file: str = _setting(
        "",
        "thresholds.yaml written by `baxter-dynamics calibrate`: collision detection on ~/external_torque "
        "(empty: no detection until ~/calibrate is called).",
    )
    calibration_window_s: float = _setting(
        10.0, "~/calibrate takes the thresholds from this many seconds of the latest samples (collision-free motion)."
    )

    def __post_init__(self) -> None:
        if self.arm not in ("right", "left"):
            raise SettingsError(f"arm: expected 'right' or 'left', got {self.arm!r}")
        if not self.joint_states_topic:
            raise SettingsError("joint_states_topic: must not be empty (default /robot/joint_states)")
        if self.qos_depth < 1:
            raise SettingsError(f"qos_depth: must be at least 1, got {self.qos_depth}")
        if self.estimator not in ESTIMATORS:
            raise SettingsError(f"estimator: expected one of {', '.join(ESTIMATORS)}, got {self.estimator!r}")
        for name in ("cutoff_hz", "diagnostics_period_s", "observer_gain_1_s", "calibration_window_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise SettingsError(f"{name}: must be a positive number, got {value}")

    def replace(self, **changes: object) -> NodeSettings:
        """A copy with ``changes`` applied and validated (raises :class:`SettingsError`)."""
        return dataclasses.replace(self, **changes)

    @staticmethod
    def fields() -> tuple[dataclasses.Field, ...]:
        """The fields, in order: ``name``, ``default``, ``metadata['help']`` and ``metadata['live']``."""
        return dataclasses.fields(NodeSettings)
