"""``baxter-dynamics diagnose --train FILES... [--test FILES...] --out DIR``: the gap diagnosis.

FILES: recordings, ROS 2 bag folders, folders of recordings or quoted patterns
(:mod:`~baxter_dynamics_ros.cli.inputs`). Each file is read when a pass of the diagnosis needs it
and reduced to statistics (:mod:`~baxter_dynamics_ros.diagnosis.passes`), in ``--jobs`` worker
processes or on a dask cluster (``--scheduler``; :mod:`~baxter_dynamics_ros.cli.workers`).
Parameters are fitted on ``--train`` only; every "after" figure is measured on ``--test``. Without
``--test``, the last training file is held out (or, with a single file, its last quarter: whole
contiguous blocks, never interleaved samples). Refused: a recording given twice (the same file, or
the same samples, in ``--train`` and ``--test`` or twice in ``--train``); a recording shorter than
:data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_S` or with fewer than
:data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_SAMPLES` samples (one not named but found in a
folder, by a pattern or in a file of arrays of several is passed over: :func:`~.inputs.too_short_found`); training data shorter than
:data:`~baxter_dynamics_ros.core.recording.MIN_FIT_S` in all; an arm that does not move or has no effort
(the readers). Writes ``DIR/diagnosis.json``, ``DIR/report.html``
with its PNG plots and ``DIR/effects.yaml`` (for the node's ``effects_file``). Never imports rclpy.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Hashable
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import DiagnosisError
from .inputs import expand_inputs, too_short_found
from .paths import check_paths
from .workers import add_worker_arguments, check_scheduler, file_mapper

if TYPE_CHECKING:
    from ..diagnosis.result import DiagnosisResult
    from ..diagnosis.sources import Mapper


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    from msg_adapters.bag_io import DEFAULT_TOPIC

    parser.add_argument("--train", type=Path, nargs="+", required=True, metavar="FILE", help="recordings to fit on (bags, tables, files of arrays (.mat, .npz, .h5) or FILE.mat:PART, folders of them, quoted patterns)")
    parser.add_argument("--test", type=Path, nargs="+", default=[], metavar="FILE", help="held-out recordings to measure on (as --train)")
    parser.add_argument("--out", "-o", type=Path, required=True, metavar="DIR", help="output folder (created)")
    parser.add_argument("--arm", choices=("right", "left"), help="arm to diagnose (default: from the joint names)")
    parser.add_argument("--model", type=Path, metavar="YAML", help="arm model file (default: the package's model of the arm)")
    parser.add_argument("--topic", default=DEFAULT_TOPIC, help=f"joint-state topic of bags (default {DEFAULT_TOPIC}, or a bag's only joint-state topic where it has none)")
    parser.add_argument("--rate-hz", type=float, metavar="HZ", help="sample rate of tables without a time column, Hz (default: estimated from position and velocity)")
    parser.add_argument("--force", action="store_true", help="replace the outputs of an earlier diagnosis in DIR")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr (default: when stderr is a terminal)")
    add_worker_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Diagnose and write the outputs; returns 0 (errors raise BaxterDynamicsError)."""
    from ..core.output_files import check_outputs
    from ..diagnosis.report import OUTPUT_FILES, write_diagnosis

    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    outputs = [args.out / name for name in OUTPUT_FILES]
    given = (("--train", expand_inputs(args.train)), ("--test", expand_inputs(args.test)))
    check_paths([p for _, paths in given for p in paths], outputs)
    check_outputs(outputs, replace=args.force)
    _refuse_repeats([(option, str(p), _file_id(p)) for option, paths in given for p in paths], "is the same file as")
    show = sys.stderr.isatty() if args.progress is None else args.progress

    with ExitStack() as stack:
        # Decoded once, loaded by the later passes; a remote cluster's workers cannot see this folder.
        scratch = None if args.scheduler not in (None, "local") else stack.enter_context(tempfile.TemporaryDirectory(prefix="baxter-dynamics-"))
        mapper = stack.enter_context(file_mapper(args.jobs, args.scheduler, scratch))
        result = _diagnose(args, given, show, mapper, scratch)
    paths = write_diagnosis(result, args.out, replace=args.force)
    print(_summary(result))
    print(f"report: {paths['report.html']}")
    return 0


def _diagnose(
    args: argparse.Namespace, given: tuple[tuple[str, list[Path]], ...], show: bool, mapper: Mapper, scratch: str | None
) -> DiagnosisResult:
    """The diagnosis of the given (option, paths) pairs with the command's options; the files'
    decoded arms kept in the folder scratch for the later passes (None: decoded at every pass)."""
    from ..core.arm_model import load_arm_model
    from ..diagnosis.procedure import diagnose
    from .progress import ProgressBar
    from .recording_sources import RecordingFile, inspect

    def source(path: Path) -> RecordingFile:
        return RecordingFile(str(path), str(path), args.topic, args.arm, args.rate_hz, scratch=scratch)

    sources = [(option, source(p)) for option, paths in given for p in paths]
    seen = mapper(inspect, [s for _, s in sources])
    for info in seen:
        for note in info.notes:
            print(note, file=sys.stderr)
    passed = too_short_found([p for _, paths in given for p in paths], [(i.samples, i.span_s) for i in seen], [*args.train, *args.test])
    for option, paths in given:
        if paths and all(k in passed for k, (o, _) in enumerate(sources) if o == option):
            raise DiagnosisError(f"{option}: every recording in it is too short for the diagnosis (passed over above)")
    kept = [(option, s, info) for k, ((option, s), info) in enumerate(zip(sources, seen)) if k not in passed]
    sides = {info.side for _, _, info in kept}
    if len(sides) > 1:
        raise DiagnosisError("the recordings are of different arms; pass --arm right|left")
    _refuse_repeats([(option, s.label, info.digest) for option, s, info in kept], "holds the same samples as")
    train, test = ([s for o, s, _ in kept if o == option] for option, _ in given)
    if not test:
        if len(train) > 1:
            test = [train.pop()]
        else:
            lone = kept[0][2]
            train, test = _split_last_quarter(train[0], lone.samples, lone.span_s)
    arm = load_arm_model(args.model if args.model is not None else sides.pop())
    bar = ProgressBar("diagnosis", show)
    try:
        result = diagnose(arm, train, test, progress=bar, mapper=mapper)
        return replace(result, passed_over={sources[k][1].label: why for k, why in passed.items()})
    finally:
        bar.close()


def _refuse_repeats(items: list[tuple[str, str, Hashable]], same: str) -> None:
    """Refuse a recording given twice, within --train or in --train and --test: a held-out figure on
    fitted data, or a cross-validation fold inside its own training set, would lie.

    items: (option, label, key) of every recording; equal keys are the same recording."""
    seen: dict[Hashable, tuple[str, str]] = {}
    for option, label, key in items:
        if key in seen:
            first_option, first = seen[key]
            fitted = "held-out data must not have been fitted on; " if option != first_option else ""
            raise DiagnosisError(f"{label} (in {option}) {same} {first} (in {first_option}): {fitted}give each recording once")
        seen[key] = (option, label)


def _file_id(path: Path) -> tuple[int, int, str | None]:
    """(device, inode, part) of a file or bag folder (part: of a file of arrays, else None): equal for
    two names of one recording."""
    from msg_adapters.array_files import split_part

    file, part = split_part(path)
    st = file.stat()
    return st.st_dev, st.st_ino, part


def _split_last_quarter(source, samples: int, span_s: float):
    """A lone recording as ([its first three quarters], [its last quarter]), whole contiguous parts."""
    from ..core.recording import MIN_RECORDING_S, MIN_RECORDING_SAMPLES

    cut = (3 * samples) // 4
    if samples - cut < MIN_RECORDING_SAMPLES or span_s / 4 < MIN_RECORDING_S:
        raise DiagnosisError(
            f"{source.label}: {samples} samples, {span_s:.2f} s, are too few to hold out its last quarter "
            f"({MIN_RECORDING_SAMPLES} samples and {MIN_RECORDING_S:g} s); give --test data"
        )
    label = source.label
    return [replace(source, label=f"{label}[0:{cut}]", rows=(0, cut))], [replace(source, label=f"{label}[{cut}:{samples}]", rows=(cut, samples))]


def _summary(result) -> str:
    """A few lines for the terminal: where the gap is, what explains it, how far it shrinks."""
    joints = [n.split("_", 1)[-1] for n in result.joint_names]
    lines = [
        "held-out RMS per joint [N·m]: " + "  ".join(joints),
        "  rigid model (raw q̈)      " + "  ".join(f"{v:6.3f}" for v in result.baseline_test_rms),
        "  rigid model (denoised q̈) " + "  ".join(f"{v:6.3f}" for v in result.denoised_test_rms),
        "  with effects             " + "  ".join(f"{v:6.3f}" for v in result.final_test_rms),
        "selected effects: "
        + (", ".join(e.name + (" (uncertain)" if e.uncertain else "") + (f" at {', '.join(j.split('_', 1)[-1] for j in e.joints)}" if e.name != "acceleration_noise" else "") for e in result.selected()) or "none"),
        *(f"WARNING: {w}" for w in result.warnings()),
    ]
    return "\n".join(lines)
