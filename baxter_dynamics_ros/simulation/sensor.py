"""What the simulated robot records of its motion, and the result with its ground truth.

Recording, every 1 / rate_hz from t = 0 (what Baxter's ``/robot/joint_states`` holds): q quantised
to ``position_step_rad`` (2π/16384); q̇ plus the white noise of ``acceleration_noise``; effort =
τ_act (the transmitted torque: rigid body + every effect's share, the spring's negative) delayed by
``delay`` (linear interpolation between steps), times 1 + ``torque_gain``, plus ``torque_offset``, plus white noise of
``effort_noise_nm``, quantised to ``effort_step_nm`` (0.004 N·m). Noise comes from
``numpy.random.default_rng([seed, 1])``; the random trajectory from ``[seed, 0]``: same spec, same
numbers, bit for bit.

:func:`record` applies this to the plant's output (:mod:`.plant`); :class:`SimulationResult` holds
both, the recorded :meth:`~SimulationResult.recording` and the truth written beside it
(:func:`write_ground_truth`). Baxter's 21-joint message layout is in
:mod:`msg_adapters.robot_joint_states`.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.arm_model import ArmModel, load_arm_model
from ..core.effects import AccelerationNoise, S1Spring, TorqueGain, TorqueOffset
from ..core.joints import JOINTS as N
from ..core.recording import Recording
from .spec import SimulationSpec
from .trajectories import JointReference, seed_posture

__all__ = [
    "START_STAMP_NS",
    "SimulationResult",
    "record",
    "write_ground_truth",
]

#: Stamp of the first recorded sample, ns (a fixed epoch, 2023-11-14, so that files are reproducible).
START_STAMP_NS = 1_700_000_000_000_000_000


@dataclass(frozen=True)
class SimulationResult:
    """A simulated recording with its ground truth, all (N, 7) at stamps_ns (N,) unless said.

    q, qd, effort: as recorded (quantised, noisy, delayed, offset); q_true, qd_true: the state;
    qdd_true: the acceleration right after the sample (the step's first RK4 stage, rad/s²);
    tau_actuator: τ_act as applied (no delay, offset, noise or quantisation), N·m; q_ref: the
    reference; x_target (N, 3) the Cartesian target (torso frame, m) or None; other_q (7,) rad,
    other_effort (N, 7) N·m: the other arm, at rest; saturated_steps: steps with τ_act clipped;
    tau_external: the collisions' τ_ext on the arm right after each sample (zeros without).
    """

    spec: SimulationSpec
    joint_names: tuple[str, ...]
    stamps_ns: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray
    q_true: np.ndarray
    qd_true: np.ndarray
    qdd_true: np.ndarray
    tau_actuator: np.ndarray
    q_ref: np.ndarray
    x_target: np.ndarray | None
    other_q: np.ndarray
    other_effort: np.ndarray
    saturated_steps: int
    tau_external: np.ndarray

    def recording(self) -> Recording:
        """The simulated arm's joint states as a :class:`~baxter_dynamics_ros.core.recording.Recording`."""
        return Recording(self.spec.side, self.joint_names, self.stamps_ns, self.q, self.qd, self.effort)

    def ground_truth(self) -> dict[str, Any]:
        """The spec and summary figures, for the JSON written beside the recording."""
        error = self.q_ref - self.q_true
        return {
            "format": "baxter_dynamics_ros simulation ground truth, version 1",
            "spec": self.spec.to_dict(),
            "joint_names": list(self.joint_names),
            "samples": len(self.stamps_ns),
            "start_stamp_ns": int(self.stamps_ns[0]),
            "sign_convention": "recorded effort = rigid-body M q̈ + C + G of the nominal arm + Σ effect torques "
            "(each effect's share; the s1 spring's share is minus the torque it applies)",
            "tracking_rms_rad": np.sqrt(np.mean(error**2, axis=0)).tolist(),
            "saturated_steps": self.saturated_steps,
            **({"collisions": self.collision_truth()} if self.spec.collisions else {}),
        }

    def collision_truth(self) -> list[dict[str, Any]]:
        """Per collision: start_s, end_s, link, profile and the peak |τ_ext| per joint over the
        recorded samples in its window (N·m, 7; the torque on the arm, −residual)."""
        t = (self.stamps_ns - self.stamps_ns[0]) * 1e-9
        truth = []
        for c in self.spec.collisions:
            inside = (t >= c.start_s) & (t <= c.end_s)
            peak = np.abs(self.tau_external[inside]).max(axis=0) if inside.any() else np.zeros(N)
            truth.append({"start_s": c.start_s, "end_s": c.end_s, "link": c.link, "profile": c.profile,
                          "peak_joint_torque_nm": peak.tolist()})  # fmt: skip
        return truth


def write_ground_truth(path: str | os.PathLike[str], result: SimulationResult) -> None:
    """Write :meth:`SimulationResult.ground_truth` as indented JSON at ``path``."""
    with open(path, "w", encoding="utf-8") as stream:
        json.dump(result.ground_truth(), stream, indent=2, ensure_ascii=False)
        stream.write("\n")


def _quantise(x: np.ndarray, step: float) -> np.ndarray:
    return np.round(x / step) * step if step > 0 else x


def record(arm: ArmModel, spec: SimulationSpec, reference: JointReference, out: dict[str, np.ndarray], saturated: int) -> SimulationResult:
    """The recording of a run (module docstring): noise, offset, quantisation; the other arm at rest.

    out: the plant's (n, 7) arrays by name (q, qd, qdd, tau, tau_late, qref, ext); saturated: steps with τ_act clipped."""
    n = spec.samples
    rng = np.random.default_rng([spec.seed, 1])
    velocity_noise = rng.standard_normal((n, N))
    effort_noise = rng.standard_normal((n, N))
    other_noise = rng.standard_normal((n, N))
    noise = spec.effect(AccelerationNoise)
    qd = out["qd"] + (0.0 if noise is None else velocity_noise * noise.velocity_noise_rad_s)
    offset = spec.effect(TorqueOffset)
    gain = spec.effect(TorqueGain)
    effort = out["tau_late"] * (1.0 if gain is None else 1.0 + gain.gain) + (0.0 if offset is None else offset.offset_nm) + effort_noise * spec.sensor.effort_noise_nm
    other_arm = load_arm_model("left" if spec.side == "right" else "right")
    other_q = _quantise(seed_posture(other_arm.side), spec.sensor.position_step_rad)
    other_hold = other_arm.gravity(other_q)
    spring = spec.effect(S1Spring)
    if spring is not None:
        other_hold = other_hold + spring.torque(other_arm, other_q, np.zeros(N), np.zeros(N))
    other_effort = other_hold + other_noise * spec.sensor.effort_noise_nm
    step_nm = spec.sensor.effort_step_nm
    x_target = None
    if reference.x_m is not None:
        t_ref = np.arange(len(reference.x_m)) * reference.dt_s
        t = np.arange(n) / spec.rate_hz
        x_target = np.stack([np.interp(t, t_ref, reference.x_m[:, c]) for c in range(3)], axis=1)
    return SimulationResult(
        spec=spec,
        joint_names=arm.joint_names,
        stamps_ns=START_STAMP_NS + np.round(np.arange(n) * (1e9 / spec.rate_hz)).astype(np.int64),
        q=_quantise(out["q"], spec.sensor.position_step_rad),
        qd=qd,
        effort=_quantise(effort, step_nm),
        q_true=out["q"],
        qd_true=out["qd"],
        qdd_true=out["qdd"],
        tau_actuator=out["tau"],
        q_ref=out["qref"],
        x_target=x_target,
        other_q=other_q,
        other_effort=_quantise(other_effort, step_nm),
        saturated_steps=int(saturated),
        tau_external=out["ext"],
    )
