"""``baxter-dynamics process INPUT --out OUTPUT``: the model's torques for every sample of a file.

Reads joint states from a bag (ROS 1 ``.bag``, ROS 2 directory, ``.mcap``, ``.db3``) or a table
(``.csv``, ``.txt``, ``.tsv``, ``.dat``, each also compressed, ``.parquet``), estimates q̈, computes gravity, inverse dynamics and residual,
and writes them where ``--out`` says: a ``.mcap`` ROS 2 bag with the live node's topics, a ``.csv``
or ``.parquet`` table. INPUT may also be several files, a folder of recordings or a quoted pattern
(:mod:`~baxter_dynamics_ros.cli.inputs`); when it is more than one file, a folder or a pattern (even
one holding a single recording), ``--out`` is a folder that gets ``<name>.<--format>`` for each, the files processed in ``--jobs`` worker processes
and the outputs moved into place together once all are written (none if one fails). Never imports
rclpy.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from ..errors import OutputError, RecordingError, RecordingFileError
from .inputs import expand_inputs
from .paths import check_paths
from .workers import add_worker_arguments, file_mapper


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    from msg_adapters.bag_io import DEFAULT_TOPIC

    from ..core.acceleration import ESTIMATORS

    parser.add_argument(
        "input", type=Path, nargs="+", metavar="INPUT",
        help="bag (.bag, ROS 2 folder, .mcap, .db3), table (.csv, .txt, .tsv, .dat, each also .gz/.bz2/.xz; .parquet) or file of arrays (.mat, .npz, .h5, .hdf5; FILE.mat:PART for one of its recordings); or several, a folder of them, a quoted pattern",
    )
    parser.add_argument(
        "--out", "-o", type=Path, required=True, metavar="OUTPUT",
        help="output: .mcap (ROS 2 bag with the live node's topics), .csv or .parquet; for several inputs a folder (made if missing)",
    )
    parser.add_argument("--format", choices=("mcap", "csv", "parquet"), default="mcap", help="output format of each file when --out is a folder (default mcap)")
    parser.add_argument("--arm", choices=("right", "left"), help="arm to process (default: from the joint names)")
    parser.add_argument("--model", type=Path, metavar="YAML", help="arm model file (default: the package's model of the arm)")
    parser.add_argument("--topic", default=DEFAULT_TOPIC, help=f"joint-state topic of a bag (default {DEFAULT_TOPIC}, or a bag's only joint-state topic where it has none)")
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
    add_worker_arguments(parser, cluster=False)


def run(args: argparse.Namespace) -> int:
    """Process args.input into args.out; returns 0 (errors raise BaxterDynamicsError)."""
    from msg_adapters.recording_files import OUTPUT_FORMATS, check_output

    from ..core.output_files import staged_outputs

    inputs = expand_inputs(args.input)
    options = _Options(args.model, args.topic, args.arm, args.rate_hz, args.acceleration, args.cutoff_hz, args.force)
    if list(args.input) == inputs and len(inputs) == 1:  # one file given: --out is the output file
        check_paths(inputs, [args.out])
        check_output(args.out, replace=args.force)  # before reading: fail fast
        show = sys.stderr.isatty() if args.progress is None else args.progress
        print(f"{args.out}: {_process_one(options, (inputs[0], args.out), show)}")
        return 0
    if args.out.suffix in OUTPUT_FORMATS and not args.out.is_dir():
        raise OutputError(
            f"{args.out}: names a file, but the input stands for {len(inputs)} recordings ({', '.join(map(str, inputs[:3]))}"
            f"{', ...' if len(inputs) > 3 else ''}); give a folder for their outputs (--format sets their type), or one recording"
        )
    outputs = [args.out / f"{_output_stem(p)}.{args.format}" for p in inputs]
    clash = next((o for k, o in enumerate(outputs) if o in outputs[:k]), None)
    if clash is not None:
        raise OutputError(f"{clash}: two inputs would be written here; give inputs with different names")
    check_paths(inputs, [args.out, *outputs])
    for out in outputs:
        check_output(out, replace=args.force)
    with staged_outputs(outputs, replace=args.force) as staged, file_mapper(args.jobs, None) as mapper:
        done = mapper(partial(_process_one, options), list(zip(inputs, staged)))
    for out, what in zip(outputs, done):
        print(f"{out}: {what}")
    return 0


def _output_stem(path: Path) -> str:
    """The name of an input's output in a folder, without extension: the file's name without its
    kind and compression suffixes (``run`` for ``run.csv.gz``; a bag folder's name),
    ``<stem>_<part>`` for a part of a file of arrays."""
    from msg_adapters.array_files import split_part
    from msg_adapters.text_files import stem

    file, part = split_part(path)
    return stem(file) if part is None else f"{stem(file)}_{part}"


@dataclass(frozen=True)
class _Options:
    model: Path | None
    topic: str
    arm: str | None
    rate_hz: float | None
    acceleration: str
    cutoff_hz: float | None
    force: bool


def _process_one(options: _Options, job: tuple[Path, Path], show: bool = False) -> str:
    """Read, process and write one file (job: input, output); what was done, in words."""
    from msg_adapters.recording_files import read_recording, write_processed

    from ..core.arm_model import load_arm_model
    from ..core.processing import process_recording
    from .progress import ProgressBar

    source, out = job
    reading = ProgressBar("reading", show)  # writing goes in bulk, a few seconds at most: no bar
    try:
        recording = read_recording(source, topic=options.topic, arm=options.arm, rate_hz=options.rate_hz, progress=reading)
    finally:
        reading.close()
    arm = load_arm_model(options.model if options.model is not None else recording.side)
    try:
        processed = process_recording(arm, recording, acceleration=options.acceleration, cutoff_hz=options.cutoff_hz)
    except RecordingError as err:
        raise RecordingFileError(f"{source}: {err}") from err
    write_processed(out, processed, input_topic=options.topic, replace=options.force)
    return (
        f"{len(recording)} samples of the {recording.side} arm "
        f"({recording.duration_s:.1f} s at {recording.rate_hz:.1f} Hz), q̈ by {options.acceleration}"
    )
