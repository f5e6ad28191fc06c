"""The dynamics node's settings: one validated record whose fields are the node's ROS parameters.

:class:`NodeSettings` is the single source of the parameters' names, types, defaults and help
texts; the node declares one ROS parameter per field and validates every change (at start-up from
``--params-file`` / ``-p`` overrides, and later from ``ros2 param set``) by building a new record.
Every numeric setting has bounds (its field's ``bounds``), beyond which the node would misbehave
or run out of memory (a cut-off of 1e300 Hz overflows the filter; a calibration window is held
in buffers of window × 2000 Hz samples). ``config/baxter_dynamics.yaml`` repeats the defaults for
users to copy.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from ..core.acceleration import CAUSAL_ESTIMATORS, ESTIMATORS
from ..errors import SettingsError

__all__ = ["NodeSettings"]


def _setting(default: Any, help_text: str, *, live: bool = False, bounds: tuple[float, float] | None = None) -> Any:
    """A settings field; ``live`` ones may change while the node runs, the others need a restart.
    bounds: (lowest, highest) value of a numeric field, both allowed (the node's ParameterDescriptor
    range, so ``ros2 param describe`` shows it)."""
    return field(default=default, metadata={"help": help_text, "live": live, "bounds": bounds})


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
        100, "Keep-last depth of the input subscription and of the output publishers (samples).", bounds=(1, 10_000)
    )
    estimator: str = _setting(
        "lowpass",
        "q̈ estimator on q̇: lowpass (2nd-order low-pass differentiator, cutoff_hz) or "
        "first_difference (the paper's raw difference). Changing it resets the estimator.",
        live=True,
    )
    cutoff_hz: float = _setting(
        ESTIMATORS["lowpass"].default_cutoff_hz, "Cut-off of the lowpass estimator in Hz (-3 dB); ignored by first_difference.", live=True, bounds=(0.1, 1000.0)
    )
    diagnostics_period_s: float = _setting(1.0, "Period of the /diagnostics report and of its window (s).", bounds=(0.05, 3600.0))
    observer_gain_1_s: float = _setting(
        20.0, "Gain K_O of the momentum observer giving ~/external_torque, 1/s (time constant 1/K_O).", bounds=(0.1, 1000.0)
    )
    thresholds_file: str = _setting(
        "",
        "thresholds.yaml written by `baxter-dynamics calibrate`: collision detection on ~/external_torque "
        "(empty: no detection until ~/calibrate is called).",
    )
    calibration_window_s: float = _setting(
        10.0,
        "~/calibrate takes the thresholds from this many seconds of the latest samples (collision-free motion).",
        bounds=(1.0, 60.0),
    )

    def __post_init__(self) -> None:
        if self.arm not in ("right", "left"):
            raise SettingsError(f"arm: expected 'right' or 'left', got {self.arm!r}")
        if not self.joint_states_topic:
            raise SettingsError("joint_states_topic: must not be empty (default /robot/joint_states)")
        if self.estimator not in CAUSAL_ESTIMATORS:
            raise SettingsError(f"estimator: expected one of {', '.join(CAUSAL_ESTIMATORS)}, got {self.estimator!r}")
        for spec in self.fields():
            bounds = spec.metadata["bounds"]
            value = getattr(self, spec.name)
            if bounds is not None and not (math.isfinite(value) and bounds[0] <= value <= bounds[1]):
                raise SettingsError(f"{spec.name}: must be from {bounds[0]:g} to {bounds[1]:g}, got {value}")

    def replace(self, **changes: object) -> NodeSettings:
        """A copy with ``changes`` applied and validated (raises :class:`SettingsError`)."""
        return dataclasses.replace(self, **changes)

    @staticmethod
    def fields() -> tuple[dataclasses.Field, ...]:
        """The fields, in order: ``name``, ``default``, ``metadata['help']``, ``metadata['live']`` and
        ``metadata['bounds']``."""
        return dataclasses.fields(NodeSettings)
