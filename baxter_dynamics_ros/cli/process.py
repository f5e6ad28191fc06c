"""``baxter-dynamics process INPUT --out OUTPUT``: the model's torques for every sample of a file.

Reads joint states from a bag (ROS 1 ``.bag``, ROS 2 directory, ``.mcap``, ``.db3``) or a table
(``.csv``, ``.txt``, ``.parquet``), estimates q̈, computes gravity, inverse dynamics and residual,
and writes them where ``--out`` says: a ``.mcap`` ROS 2 bag with the live node's topics, a ``.csv``
or ``.parquet`` table. Never imports rclpy.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .paths import check_paths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    from msg_adapters.bag_io import DEFAULT_TOPIC

    from ..core.acceleration import ESTIMATORS

    parser.add_argument("input", type=Path, metavar="INPUT", help="bag (.bag, ROS 2 folder, .mcap, .db3) or table (.csv, .txt, .parquet)")
    parser.add_argument(
        "--out", "-o", type=Path, required=True, metavar="OUTPUT",
        help="output: .mcap (ROS 2 bag with the live node's topics), .csv or .parquet",
    )
    parser.add_argument("--arm", choices=("right", "left"), help="arm to process (default: from the joint names)")
    parser.add_argument("--model", type=Path, metavar="YAML", help="arm model file (default: the package's model of the arm)")
    parser.add_argument("--topic", default=DEFAULT_TOPIC, help=f"joint-state topic of a bag (default {DEFAULT_TOPIC})")
    parser.add_argument(
        "--rate-hz", type=float, metavar="HZ",
        help="sample rate of a table without a time column, Hz (default: estimated from position and velocity)",
    )
    parser.add_argument(
        "--acceleration", choices=tuple(ESTIMATORS), default="zero_phase",
        help="q̈ estimator: zero_phase (offline, default), lowpass (the live node's causal filter), first_difference (the paper's)",
    )
    parser.add_argument(
        "--cutoff-hz", type=float,
        help="filter cutoff, Hz (default: "
        + ", ".join(f"{m} {e.default_cutoff_hz:g}" for m, e in ESTIMATORS.items() if e.default_cutoff_hz is not None) + ")",
    )
    parser.add_argument("--force", action="store_true", help="replace an existing output (never the input)")
    parser.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )


def run(args: argparse.Namespace) -> int:
    """Process args.input into args.out; returns 0 (errors raise BaxterDynamicsError)."""
    from msg_adapters.recording_files import check_output, read_recording, write_processed

    from ..core.arm_model import load_arm_model
    from ..core.processing import process_recording
    from .progress import ProgressBar

    check_paths([args.input], [args.out])
    check_output(args.out, replace=args.force)  # before reading: fail fast
    show = sys.stderr.isatty() if args.progress is None else args.progress
    reading = ProgressBar("reading", show)  # writing goes in bulk, a few seconds at most: no bar
    try:
        recording = read_recording(args.input, topic=args.topic, arm=args.arm, rate_hz=args.rate_hz, progress=reading)
    finally:
        reading.close()
    arm = load_arm_model(args.model if args.model is not None else recording.side)
    processed = process_recording(arm, recording, acceleration=args.acceleration, cutoff_hz=args.cutoff_hz)
    write_processed(args.out, processed, input_topic=args.topic, replace=args.force)
    print(
        f"{args.out}: {len(recording)} samples of the {recording.side} arm "
        f"({recording.duration_s:.1f} s at {recording.rate_hz:.1f} Hz), q̈ by {args.acceleration}"
    )
    return 0
