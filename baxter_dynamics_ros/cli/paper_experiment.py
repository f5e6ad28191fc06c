"""``baxter-dynamics paper-experiment --out DIR [--page PAGE.md]``: the paper's experiment on simulated recordings.

What it runs and writes: :mod:`baxter_dynamics_ros.diagnosis.paper_experiment`. Never imports rclpy.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..diagnosis.paper_experiment import DURATION_S

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    parser.add_argument("--out", "-o", type=Path, required=True, metavar="DIR", help="folder for the tables, figures and page (created)")
    parser.add_argument("--page", type=Path, metavar="PAGE.md", help="where to write the page (default DIR/paper_experiment.md)")
    parser.add_argument("--duration", type=float, default=DURATION_S, metavar="S", help=f"seconds per set (default {DURATION_S:g})")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="seed of set 1's noise (set k: N + k − 1; default 0)")


def run(args: argparse.Namespace) -> int:
    """Run the experiment and write its outputs; returns 0."""
    from ..core.output_files import check_outputs
    from ..diagnosis.paper_experiment import run_experiment, write_outputs

    page = args.page if args.page is not None else args.out / "paper_experiment.md"
    command = f"baxter-dynamics paper-experiment --out {args.out.as_posix()}"
    if args.page is not None:
        command += f" --page {args.page.as_posix()}"
    if args.duration != DURATION_S:
        command += f" --duration {args.duration:g}"
    if args.seed != 0:
        command += f" --seed {args.seed}"
    check_outputs([args.out / "results.json", page], replace=True)  # before the experiment: fail fast
    sets = run_experiment(args.duration, args.seed)
    write_outputs(sets, args.out, page, command)
    print(f"{args.out}: Table V, figures and results; page: {page}")
    return 0
