"""What determines a simulated recording: :class:`SimulationSpec` and its sections.

The trajectory, duration, rate and seed; the unmodelled effects (:mod:`baxter_dynamics_ros.core.effects`);
the sensor model (:class:`SensorModel`: quantisation and effort noise), the controller's gains
(:class:`ControllerGains`) and the collisions (:class:`Collision`). Every value is validated when
the spec is made; ``from_dict`` / ``to_dict`` are the ``simulate`` command's YAML and the ground
truth's JSON (:func:`read_spec_json` reads it back). The plant and controller that run a spec are
in :mod:`.plant`, what is recorded of them in :mod:`.sensor`.
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..core.effect_specs import effects_from_dict, effects_to_dict
from ..core.effects import Delay, Effect
from ..core.joints import JOINTS as N
from ..errors import EffectSpecError, SimulationError
from .trajectories import TRAJECTORIES

__all__ = [
    "COLLISION_LINKS",
    "COLLISION_PROFILES",
    "MAX_DURATION_S",
    "MAX_RATE_HZ",
    "MAX_SAMPLES",
    "MIN_PHYSICS_RATE_HZ",
    "Collision",
    "ControllerGains",
    "SensorModel",
    "SimulationSpec",
    "read_spec_json",
]

MIN_PHYSICS_RATE_HZ = 1000.0
#: Bounds of a simulated recording (issue 22 item 2: 1e12 s or 1e9 Hz ran out of memory in numpy):
#: at most an hour (3.6 million RK4 steps at 1 kHz, a few minutes), sampled at most at 10 kHz, and at
#: most a million samples (about 2 GB of memory while simulating, measured: 1.9 kB per sample).
MAX_DURATION_S = 3600.0
MAX_RATE_HZ = 10_000.0
MAX_SAMPLES = 1_000_000
COLLISION_PROFILES = ("impact", "push")
COLLISION_LINKS = ("flange", "joints")


def _positive(value: Any, where: str, *, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError) as err:
        raise EffectSpecError(f"{where}: expected a number, got {value!r}") from err
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise EffectSpecError(f"{where}: must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return x


def _fields_from(cls: type, raw: Any, where: str) -> dict[str, Any]:
    """raw as keyword arguments of a small dataclass, unknown keys refused."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise EffectSpecError(f"{where}: expected a mapping, got {raw!r}")
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = set(raw) - known
    if unknown:
        raise EffectSpecError(f"{where}: unknown keys {sorted(unknown)}; allowed: {', '.join(sorted(known))}")
    return dict(raw)


class _Section:
    """A spec section of numbers, each validated by :func:`_positive`; ``section`` names it in errors
    and ``may_be_zero`` lists the fields allowed to be 0."""

    section: ClassVar[str] = ""
    may_be_zero: ClassVar[tuple[str, ...]] = ()

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = _positive(getattr(self, f.name), f"{self.section}.{f.name}", allow_zero=f.name in self.may_be_zero)
            object.__setattr__(self, f.name, value)

    @classmethod
    def from_dict(cls, raw: Any, where: str = ""):
        return cls(**_fields_from(cls, raw, where or cls.section))

    def to_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class SensorModel(_Section):
    """How the robot reports its state: quantisation steps (rad, N·m; 0 disables) and the standard
    deviation of the white noise on the effort (N·m). q̇ noise is the ``acceleration_noise`` effect."""

    section: ClassVar[str] = "sensor"
    may_be_zero: ClassVar[tuple[str, ...]] = ("position_step_rad", "effort_step_nm", "effort_noise_nm")
    position_step_rad: float = 2.0 * np.pi / 16384
    effort_step_nm: float = 0.004
    effort_noise_nm: float = 0.0


@dataclass(frozen=True)
class ControllerGains(_Section):
    """Gains of the dual-loop controller (:mod:`.plant`): outer K_p (1/s) and K_d (-) of eq. 14,
    inner bandwidth ω_v (rad/s) setting K_v = ω_v M(q) and K_i = ω_v² M(q) / 10 of eq. 15."""

    section: ClassVar[str] = "controller"
    may_be_zero: ClassVar[tuple[str, ...]] = ("outer_kd",)
    outer_kp_1_s: float = 20.0
    outer_kd: float = 0.0
    inner_bandwidth_rad_s: float = 150.0


@dataclass(frozen=True)
class Collision:
    """An external force or torque on the arm from start_s for duration_s (s, recording time).

    profile: "impact" (half-sine pulse) or "push" (ramps of ramp_s, then held); link: "flange"
    with force_n (3,) N in the arm's base frame, or "joints" with torque_nm (7,) N·m directly.
    """

    start_s: float
    duration_s: float
    profile: str = "push"
    link: str = "flange"
    force_n: tuple[float, ...] = (0.0, 0.0, 0.0)
    torque_nm: tuple[float, ...] = (0.0,) * N
    ramp_s: float = 0.02

    def __post_init__(self) -> None:
        where = "collision"
        _positive(self.start_s, f"{where}.start_s", allow_zero=True)
        object.__setattr__(self, "start_s", float(self.start_s))
        object.__setattr__(self, "duration_s", _positive(self.duration_s, f"{where}.duration_s"))
        object.__setattr__(self, "ramp_s", _positive(self.ramp_s, f"{where}.ramp_s"))
        if self.profile not in COLLISION_PROFILES:
            raise EffectSpecError(f"{where}.profile must be one of {', '.join(COLLISION_PROFILES)}, got {self.profile!r}")
        if self.link not in COLLISION_LINKS:
            raise EffectSpecError(f"{where}.link must be one of {', '.join(COLLISION_LINKS)} (forces act at the flange only), got {self.link!r}")
        for name, size in (("force_n", 3), ("torque_nm", N)):
            arr = np.array(getattr(self, name), dtype=np.float64)
            if arr.shape != (size,) or not np.all(np.isfinite(arr)):
                raise EffectSpecError(f"{where}.{name}: expected {size} finite numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(float(x) for x in arr))
        if self.profile == "push" and 2 * self.ramp_s > self.duration_s:
            raise EffectSpecError(f"{where}: a push needs duration_s >= 2 ramp_s, got {self.duration_s} and {self.ramp_s}")

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s

    def to_dict(self) -> dict[str, Any]:
        out = {"start_s": self.start_s, "duration_s": self.duration_s, "profile": self.profile, "link": self.link}
        if self.link == "flange":
            out["force_n"] = list(self.force_n)
        else:
            out["torque_nm"] = list(self.torque_nm)
        if self.profile == "push":
            out["ramp_s"] = self.ramp_s
        return out

    @classmethod
    def from_dict(cls, raw: Any, where: str = "collision") -> Collision:
        return cls(**_fields_from(cls, raw, where))


@dataclass(frozen=True)
class SimulationSpec:
    """Everything that determines a simulated recording (written beside it as JSON).

    side: "right" | "left"; trajectory: one of :data:`~baxter_dynamics_ros.simulation.trajectories.TRAJECTORIES`;
    duration_s, rate_hz: the recording; seed: noise and random trajectory; effects: the unmodelled
    effects; physics_rate_hz: RK4 rate (None: the smallest multiple of rate_hz ≥ 1 kHz);
    settle_s: unrecorded time at the start posture before t = 0; collisions: external forces or
    torques on the arm (:class:`Collision`).
    """

    trajectory: str
    duration_s: float
    rate_hz: float
    seed: int = 0
    side: str = "right"
    effects: tuple[Effect, ...] = ()
    sensor: SensorModel = field(default_factory=SensorModel)
    controller: ControllerGains = field(default_factory=ControllerGains)
    physics_rate_hz: float | None = None
    settle_s: float = 1.0
    collisions: tuple[Collision, ...] = ()

    def __post_init__(self) -> None:
        if self.trajectory not in TRAJECTORIES:
            raise SimulationError(f"trajectory must be one of {', '.join(TRAJECTORIES)}, got {self.trajectory!r}")
        if self.side not in ("right", "left"):
            raise SimulationError(f"arm must be 'right' or 'left', got {self.side!r}")
        for name in ("duration_s", "rate_hz", "settle_s"):
            object.__setattr__(self, name, _positive(getattr(self, name), name))
        if self.duration_s > MAX_DURATION_S:
            raise SimulationError(f"duration_s (--duration) {self.duration_s:g} s: a simulated recording lasts at most {MAX_DURATION_S:g} s")
        if self.rate_hz > MAX_RATE_HZ:
            raise SimulationError(f"rate_hz (--rate-hz) {self.rate_hz:g} Hz: a simulated recording is sampled at most at {MAX_RATE_HZ:g} Hz")
        if self.duration_s * self.rate_hz > MAX_SAMPLES:
            raise SimulationError(
                f"{self.duration_s:g} s at {self.rate_hz:g} Hz is {self.duration_s * self.rate_hz:.0f} samples: a simulated recording "
                f"has at most {MAX_SAMPLES} (about 2 GB of memory); shorten --duration or lower --rate-hz"
            )
        if self.settle_s > MAX_DURATION_S:
            raise SimulationError(f"settle_s {self.settle_s:g} s: at most {MAX_DURATION_S:g} s")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise SimulationError(f"seed must be a non-negative integer, got {self.seed!r}")
        object.__setattr__(self, "seed", int(self.seed))
        object.__setattr__(self, "effects", tuple(self.effects))
        object.__setattr__(self, "collisions", tuple(self.collisions))
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            raise SimulationError(f"each effect may appear once, got {names}")
        rate = self.rate_hz
        physics = self.physics_rate_hz
        if physics is None:
            physics = rate * np.ceil(MIN_PHYSICS_RATE_HZ / rate)
        physics = _positive(physics, "physics_rate_hz")
        ratio = physics / rate
        if physics < MIN_PHYSICS_RATE_HZ or abs(ratio - round(ratio)) > 1e-9:
            raise SimulationError(
                f"physics_rate_hz must be >= {MIN_PHYSICS_RATE_HZ:g} and a whole multiple of rate_hz ({rate:g}), got {physics:g}"
            )
        object.__setattr__(self, "physics_rate_hz", float(physics))
        delay = self.effect(Delay)
        if delay is not None and (np.any(delay.delay_s < 0) or np.any(delay.delay_s > self.settle_s)):
            raise SimulationError(
                f"delay.delay_s ({delay.delay_s.tolist()} s) must lie in [0, settle_s = {self.settle_s} s] at every joint: "
                "the simulator delays the effort causally"
            )

    def effect(self, cls: type[Effect]) -> Any:
        """The spec's effect of class ``cls``, or None."""
        return next((e for e in self.effects if isinstance(e, cls)), None)

    @property
    def samples(self) -> int:
        """Number of recorded samples."""
        return int(round(self.duration_s * self.rate_hz))

    def to_dict(self) -> dict[str, Any]:
        out = {
            "trajectory": self.trajectory,
            "duration_s": self.duration_s,
            "rate_hz": self.rate_hz,
            "seed": self.seed,
            "side": self.side,
            "effects": effects_to_dict(self.effects),
            "sensor": self.sensor.to_dict(),
            "controller": self.controller.to_dict(),
            "physics_rate_hz": self.physics_rate_hz,
            "settle_s": self.settle_s,
        }
        if self.collisions:  # absent without collisions: earlier ground truths stay as they were
            out["collisions"] = [c.to_dict() for c in self.collisions]
        return out

    @classmethod
    def from_dict(cls, raw: Any) -> SimulationSpec:
        kwargs = _fields_from(cls, raw, "simulation spec")
        kwargs["effects"] = effects_from_dict(kwargs.get("effects"))
        kwargs["sensor"] = SensorModel.from_dict(kwargs.get("sensor"))
        kwargs["controller"] = ControllerGains.from_dict(kwargs.get("controller"))
        collisions = kwargs.get("collisions") or []
        if not isinstance(collisions, list):
            raise EffectSpecError(f"simulation spec: collisions must be a list, got {collisions!r}")
        kwargs["collisions"] = tuple(Collision.from_dict(c, f"collisions[{i}]") for i, c in enumerate(collisions))
        missing = [k for k in ("trajectory", "duration_s", "rate_hz") if k not in kwargs]
        if missing:
            raise EffectSpecError(f"simulation spec: missing {', '.join(missing)}")
        return cls(**kwargs)


def read_spec_json(path: str | os.PathLike[str]) -> SimulationSpec:
    """The :class:`SimulationSpec` of a ground-truth JSON file written by :func:`write_ground_truth`."""
    try:
        with open(path, encoding="utf-8") as stream:
            raw = json.load(stream)
    except (OSError, json.JSONDecodeError) as err:
        raise EffectSpecError(f"{path}: cannot read the ground-truth JSON ({err})") from err
    if not isinstance(raw, dict) or "spec" not in raw:
        raise EffectSpecError(f"{path}: no 'spec' in this file; is it a simulation's ground truth?")
    return SimulationSpec.from_dict(raw["spec"])
