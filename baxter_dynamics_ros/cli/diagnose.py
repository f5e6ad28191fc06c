"""``baxter-dynamics diagnose --train FILES... [--test FILES...] --out DIR``: the gap diagnosis.

Parameters are fitted on ``--train`` only; every "after" figure is measured on ``--test``. Without
``--test``, the last training file is held out (or, with a single file, its last quarter: whole
contiguous blocks, never interleaved samples). Refused: a recording given twice (the same file, or
the same samples, in ``--train`` and ``--test`` or twice in ``--train``); a recording shorter than
:data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_S` or with fewer than
:data:`~baxter_dynamics_ros.core.recording.MIN_RECORDING_SAMPLES` samples; training data shorter than
:data:`~baxter_dynamics_ros.core.recording.MIN_FIT_S` in all; an arm that does not move or has no effort
(the readers). Writes ``DIR/diagnosis.json``, ``DIR/report.html``
with its PNG plots and ``DIR/effects.yaml`` (for the node's ``effects_file``). Never imports rclpy.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from collections.abc import Hashable
from pathlib import Path

from ..errors import DiagnosisError
from .paths import check_paths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    from msg_adapters.bag_io import DEFAULT_TOPIC

    parser.add_argument("--train", type=Path, nargs="+", required=True, metavar="FILE", help="recordings to fit on (bags or tables)")
    parser.add_argument("--test", type=Path, nargs="+", default=[], metavar="FILE", help="held-out recordings to measure on")
    parser.add_argument("--out", "-o", type=Path, required=True, metavar="DIR", help="output folder (created)")
    parser.add_argument("--arm", choices=("right", "left"), help="arm to diagnose (default: from the joint names)")
    parser.add_argument("--model", type=Path, metavar="YAML", help="arm model file (default: the package's model of the arm)")
    parser.add_argument("--topic", default=DEFAULT_TOPIC, help=f"joint-state topic of bags (default {DEFAULT_TOPIC})")
    parser.add_argument("--rate-hz", type=float, metavar="HZ", help="sample rate of tables without a time column, Hz (default: estimated from position and velocity)")
    parser.add_argument("--force", action="store_true", help="replace the outputs of an earlier diagnosis in DIR")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None, help="progress bar on stderr (default: when stderr is a terminal)")


def run(args: argparse.Namespace) -> int:
    """Diagnose and write the outputs; returns 0 (errors raise BaxterDynamicsError)."""
    from msg_adapters.recording_files import read_recording

    from ..core.arm_model import load_arm_model
    from ..core.output_files import check_outputs
    from ..diagnosis.procedure import diagnose
    from ..diagnosis.report import OUTPUT_FILES, write_diagnosis
    from .progress import ProgressBar

    outputs = [args.out / name for name in OUTPUT_FILES]
    check_paths([*args.train, *args.test], outputs)
    check_outputs(outputs, replace=args.force)
    given = (("--train", args.train), ("--test", args.test))
    _refuse_repeats([(option, str(p), _file_id(p)) for option, paths in given for p in paths], "is the same file as")
    show = sys.stderr.isatty() if args.progress is None else args.progress

    def read(path: Path):
        return str(path), read_recording(path, topic=args.topic, arm=args.arm, rate_hz=args.rate_hz)

    train = [read(p) for p in args.train]
    test = [read(p) for p in args.test]
    sides = {rec.side for _, rec in (*train, *test)}
    if len(sides) > 1:
        raise DiagnosisError("the recordings are of different arms; pass --arm right|left")
    read_in = (("--train", train), ("--test", test))
    _refuse_repeats([(o, label, _fingerprint(rec)) for o, recs in read_in for label, rec in recs], "holds the same samples as")
    if not test:
        if len(train) > 1:
            test = [train.pop()]
        else:
            label, rec = train[0]
            train, test = _split_last_quarter(label, rec)
    arm = load_arm_model(args.model if args.model is not None else sides.pop())
    bar = ProgressBar("diagnosis", show)
    try:
        result = diagnose(arm, train, test, progress=bar)
    finally:
        bar.close()
    paths = write_diagnosis(result, args.out)
    print(_summary(result))
    print(f"report: {paths['report.html']}")
    return 0


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


def _file_id(path: Path) -> tuple[int, int]:
    """(device, inode) of a file or bag folder: equal for two names of one file."""
    st = path.stat()
    return st.st_dev, st.st_ino


def _fingerprint(rec) -> str:
    """A digest of a recording's samples (q, q̇, effort): equal for copies of one recording."""
    digest = hashlib.sha256()
    for array in (rec.q, rec.qd, rec.effort):
        digest.update(array.tobytes())
    return digest.hexdigest()


def _split_last_quarter(label, rec):
    from ..core.recording import MIN_RECORDING_S, MIN_RECORDING_SAMPLES, Recording

    n = len(rec)
    cut = (3 * n) // 4
    if n - cut < MIN_RECORDING_SAMPLES or rec.span_s / 4 < MIN_RECORDING_S:
        raise DiagnosisError(
            f"{label}: {n} samples, {rec.span_s:.2f} s, are too few to hold out its last quarter "
            f"({MIN_RECORDING_SAMPLES} samples and {MIN_RECORDING_S:g} s); give --test data"
        )

    def part(a: int, b: int) -> Recording:
        return Recording(rec.side, rec.joint_names, rec.stamps_ns[a:b], rec.q[a:b], rec.qd[a:b], rec.effort[a:b])

    return [(f"{label}[0:{cut}]", part(0, cut))], [(f"{label}[{cut}:{n}]", part(cut, n))]


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
