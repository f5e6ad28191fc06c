"""``baxter-dynamics calibrate FILES... --out thresholds.yaml``: collision thresholds from collision-free data.

Estimates the effort–state alignment of the files (or takes ``--effort-delay``), runs the momentum
observer (:mod:`baxter_dynamics_ros.monitoring.observer`, gain ``--gain``) with it over every
file, with the effects of ``--effects`` compensated, removes the slow bias
(``--bias-time-constant``) and writes per-joint thresholds a + b|q̇| by the calibration rule of
:mod:`baxter_dynamics_ros.monitoring.calibration` (``--margin``; ``--consecutive`` samples in a row
above before a detection; ``--constant`` for b = 0). The
recordings must be free of contacts: every residual they hold is taken as normal; each must hold
:data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_S` and
:data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_SAMPLES` samples, all of them
:data:`~baxter_dynamics_ros.core.recording.MIN_FIT_S` together, and the arm must move and have effort
(the readers); one too short that was not named (:func:`~.inputs.too_short_found`) is passed over.
Never imports rclpy.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import CollisionError, RecordingError
from .inputs import expand_inputs, too_short_found
from .paths import check_paths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    from msg_adapters.bag_io import DEFAULT_TOPIC

    from ..monitoring.calibration import DEFAULT_MARGIN
    from ..monitoring.detector import DEFAULT_BIAS_TIME_CONSTANT_S
    from ..monitoring.observer import DEFAULT_GAIN_1_S
    from ..monitoring.thresholds import DEFAULT_CONSECUTIVE

    parser.add_argument("files", type=Path, nargs="+", metavar="FILE", help="collision-free recordings (bags, tables, files of arrays (.mat, .npz, .h5) or FILE.mat:PART, folders of them, quoted patterns)")
    parser.add_argument("--out", "-o", type=Path, required=True, metavar="YAML", help="thresholds file to write")
    parser.add_argument("--effects", type=Path, metavar="YAML", help="effects file from `diagnose` to compensate")
    parser.add_argument("--gain", type=float, default=DEFAULT_GAIN_1_S, metavar="1/S", help=f"observer gain K_O (default {DEFAULT_GAIN_1_S:g})")
    parser.add_argument("--margin", type=float, default=DEFAULT_MARGIN, help=f"thresholds = margin x the largest residual (default {DEFAULT_MARGIN:g})")
    parser.add_argument(
        "--effort-delay", type=float, metavar="SECONDS",
        help="effort-state alignment: recorded effort(t) = true effort(t - SECONDS), negative when the effort is early (default: estimated from the files)",
    )  # fmt: skip
    parser.add_argument(
        "--bias-time-constant", type=float, default=DEFAULT_BIAS_TIME_CONSTANT_S, metavar="SECONDS",
        help=f"time constant of the slow bias the detector removes, 0 for none (default {DEFAULT_BIAS_TIME_CONSTANT_S:g})",
    )  # fmt: skip
    parser.add_argument(
        "--consecutive", type=int, default=DEFAULT_CONSECUTIVE, metavar="N",
        help=f"samples in a row above a threshold before a detection; the thresholds are calibrated for it (default {DEFAULT_CONSECUTIVE})",
    )  # fmt: skip
    parser.add_argument("--constant", action="store_true", help="no speed-dependent part")
    parser.add_argument("--arm", choices=("right", "left"), help="arm (default: from the joint names)")
    parser.add_argument("--model", type=Path, metavar="YAML", help="arm model file (default: the package's model of the arm)")
    parser.add_argument("--topic", default=DEFAULT_TOPIC, help=f"joint-state topic of bags (default {DEFAULT_TOPIC}, or a bag's only joint-state topic where it has none)")
    parser.add_argument("--rate-hz", type=float, metavar="HZ", help="sample rate of tables without a time column, Hz (default: estimated from position and velocity)")
    parser.add_argument("--force", action="store_true", help="replace an existing thresholds file")


def run(args: argparse.Namespace) -> int:
    """Calibrate and write args.out; returns 0 (errors raise BaxterDynamicsError)."""
    from msg_adapters.recording_files import read_recording

    from ..core.arm_model import load_arm_model
    from ..core.compensation import load_compensation
    from ..core.output_files import check_outputs
    from ..core.recording import MIN_FIT_S, require_length
    from ..monitoring.calibration import calibrate
    from ..monitoring.thresholds import require_plausible, write_thresholds

    given, args.files = args.files, expand_inputs(args.files)
    check_paths(args.files, [args.out])
    if args.out.suffix not in (".yaml", ".yml"):
        raise CollisionError(f"{args.out}: the thresholds file must end in .yaml")
    check_outputs([args.out], replace=args.force)
    recordings = [read_recording(p, topic=args.topic, arm=args.arm, rate_hz=args.rate_hz) for p in args.files]
    passed = too_short_found(args.files, [(len(rec), rec.span_s) for rec in recordings], given)
    if len(passed) == len(recordings):
        raise CollisionError("every recording given is too short for a calibration (passed over above)")
    args.files, recordings = ([x for k, x in enumerate(items) if k not in passed] for items in (args.files, recordings))
    try:
        require_length(list(zip(map(str, args.files), recordings)), "calibration", MIN_FIT_S)
    except RecordingError as err:
        raise CollisionError(str(err)) from err
    sides = {rec.side for rec in recordings}
    if len(sides) > 1:
        raise CollisionError("the recordings are of different arms; pass --arm right|left")
    arm = load_arm_model(args.model if args.model is not None else sides.pop())
    compensation = None if args.effects is None else load_compensation(arm, args.effects)
    thresholds = calibrate(
        arm, recordings, compensation=compensation, gain_1_s=args.gain, effort_delay_s=args.effort_delay, margin=args.margin,
        consecutive=args.consecutive, bias_time_constant_s=args.bias_time_constant, speed_dependent=not args.constant,
        files=[str(p) for p in args.files],
    )  # fmt: skip
    require_plausible(thresholds, arm, str(args.out))
    write_thresholds(args.out, thresholds, replace=args.force)
    joints = "  ".join(f"{j.split('_', 1)[-1]} {a:.2f}+{b:.2f}|q̇|" for j, a, b in zip(arm.joint_names, thresholds.offset_nm, thresholds.slope_nm_s_rad))
    print(f"{args.out}: thresholds [N·m] {joints}; effort delay {thresholds.effort_delay_s * 1e3:+.1f} ms")
    return 0
