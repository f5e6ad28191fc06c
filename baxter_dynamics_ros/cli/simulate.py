"""``baxter-dynamics simulate``: a simulated Baxter recording whose unmodelled effects are known.

Writes ``/robot/joint_states`` as the robot publishes it (Baxter's 21 joints with the grippers' fingers, the simulated arm
moving, the rest still) to ``--out``: a ``.mcap`` ROS 2 bag or a ``.csv`` / ``.parquet`` table
(the generic layout of :mod:`msg_adapters.csv_io`), and the ground truth beside it as
``<out>.truth.json`` (spec, effects with parameters, seed, tracking): both or neither
(:mod:`baxter_dynamics_ros.core.output_files`).

The effects spec (``--effects``) is a YAML file with up to four sections; see
``config/effects_example.yaml``::

    effects:      # name: {parameter: value}; names and parameters in baxter_dynamics_ros.core.effects
      s1_spring: {}                              # Baxter-like defaults
      viscous_friction: {damping_nm_s_rad: {s1: 1.0, e1: 0.5}}
      acceleration_noise: {velocity_noise_rad_s: 0.01}
    sensor:       # optional: quantisation steps and effort noise (SensorModel)
      effort_noise_nm: 0.02
    controller:   # optional: dual-loop gains (ControllerGains)
      inner_bandwidth_rad_s: 150.0
    collisions:   # optional: external forces/torques on the arm (simulation.spec.Collision), with ground truth
      - {start_s: 5.0, duration_s: 0.5, profile: push, link: flange, force_n: [0.0, 0.0, -30.0]}
      - {start_s: 9.0, duration_s: 0.05, profile: impact, link: joints, torque_nm: [0, 0, 0, 4.0, 0, 0, 0]}
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import EffectSpecError

SPEC_SECTIONS = ("effects", "sensor", "controller", "collisions")
DEFAULT_TOPIC = "/robot/joint_states"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    from ..simulation.trajectories import TRAJECTORIES

    parser.add_argument("--trajectory", choices=TRAJECTORIES, default="paper_xyz", help="reference trajectory (default paper_xyz)")
    parser.add_argument("--effects", type=Path, metavar="SPEC.yaml", help="effects spec (default: none, the rigid-body arm)")
    parser.add_argument("--duration", type=float, default=60.0, metavar="S", help="recorded time, s (default 60)")
    parser.add_argument("--rate-hz", type=float, default=100.0, metavar="HZ", help="recording rate, Hz (default 100)")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="seed of the noise and the random trajectory (default 0)")
    parser.add_argument("--arm", choices=("right", "left"), default="right", help="simulated arm (default right)")
    parser.add_argument("--topic", default=DEFAULT_TOPIC, help=f"joint-state topic of an mcap output (default {DEFAULT_TOPIC})")
    parser.add_argument("--out", "-o", type=Path, required=True, metavar="FILE", help="output: .mcap (ROS 2 bag), .csv or .parquet")
    parser.add_argument("--force", action="store_true", help="replace an existing output")


def ground_truth_path(out: Path) -> Path:
    """Where the ground truth of the recording ``out`` is written: ``<out>.truth.json``."""
    return out.with_name(out.name + ".truth.json")


def load_spec(path: Path | None) -> dict:
    """The simulation settings of an effects spec file (None: the rigid-body arm, no collisions), as
    :class:`~baxter_dynamics_ros.simulation.spec.SimulationSpec` arguments: effects, sensor, controller, collisions."""
    from ..core.effect_specs import effects_from_dict, read_spec_file
    from ..simulation.spec import ControllerGains, SensorModel

    raw = {} if path is None else read_spec_file(path)
    unknown = set(raw) - set(SPEC_SECTIONS)
    if unknown:
        raise EffectSpecError(f"{path}: unknown sections {sorted(unknown)}; a spec has {', '.join(SPEC_SECTIONS)}")
    where = str(path or "effects spec")
    return {
        "effects": effects_from_dict(raw.get("effects") or {}, f"{where}: effects"),
        "sensor": SensorModel.from_dict(raw.get("sensor") or {}, f"{where}: sensor"),
        "controller": ControllerGains.from_dict(raw.get("controller") or {}, f"{where}: controller"),
        "collisions": _collisions(raw.get("collisions") or [], where),
    }


def _collisions(raw, where: str):
    """The spec's ``collisions:`` list as simulator Collisions."""
    from ..simulation.spec import Collision

    if not isinstance(raw, list):
        raise EffectSpecError(f"{where}: collisions must be a list of mappings, got {raw!r}")
    return tuple(Collision.from_dict(c, f"{where}: collisions[{i}]") for i, c in enumerate(raw))


def run(args: argparse.Namespace) -> int:
    """Simulate args into args.out and its ground truth; returns 0 (errors raise BaxterDynamicsError)."""
    from msg_adapters.recording_files import check_output, write_joint_states
    from msg_adapters.robot_joint_states import robot_joint_states

    from ..core.arm_model import load_arm_model
    from ..core.compensation import Compensation, require_plausible
    from ..core.output_files import check_outputs, staged_outputs
    from ..simulation.plant import simulate
    from ..simulation.sensor import write_ground_truth
    from ..simulation.spec import SimulationSpec

    truth = ground_truth_path(args.out)
    check_output(args.out, replace=args.force)  # before simulating: fail fast
    check_outputs([truth], replace=args.force)
    spec = SimulationSpec(
        trajectory=args.trajectory, duration_s=args.duration, rate_hz=args.rate_hz, seed=args.seed, side=args.arm,
        **load_spec(args.effects),
    )  # fmt: skip
    if args.effects is not None:  # effects no real Baxter has would make a recording no real Baxter gives
        require_plausible(Compensation(load_arm_model(spec.side), spec.effects), str(args.effects))
    print(
        f"simulating {spec.duration_s:g} s of {spec.trajectory} on the {spec.side} arm, "
        f"RK4 at {spec.physics_rate_hz:g} Hz, recorded at {spec.rate_hz:g} Hz",
        file=sys.stderr,
    )
    result = simulate(spec)
    states = robot_joint_states(result.recording(), result.other_q, result.other_effort)
    with staged_outputs([args.out, truth], replace=args.force) as (staged_out, staged_truth):  # both or neither
        write_joint_states(
            staged_out, states.stamps_ns, states.names, states.position, states.velocity, states.effort, topic=args.topic
        )
        write_ground_truth(staged_truth, result)
    effects = ", ".join(e.name for e in spec.effects) or "none"
    print(f"{args.out}: {spec.samples} samples; effects: {effects}; ground truth: {truth}")
    return 0
