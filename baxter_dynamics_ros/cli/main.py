"""The ``baxter-dynamics`` command line: a thin argparse shell over command modules.

Each command lives in its own module exposing ``add_arguments(parser)`` and ``run(args) -> int``;
its one-line help sits in :data:`COMMANDS`. Modules are imported only when their command runs, so ``--help`` stays
fast and ``process`` never imports rclpy. To add a command, add one entry to :data:`COMMANDS`.

Errors of this package (:class:`~baxter_dynamics_ros.errors.BaxterDynamicsError`) are caught here,
at the edge, and printed as one ``ERROR: ...`` line on stderr with exit status 1. Ctrl-C (SIGINT)
at any time prints one ``ERROR: interrupted`` line and exits 130, without a traceback: before the
command runs (parsing, imports) the process ends at once, nothing having been written; while it
runs, KeyboardInterrupt unwinds it so that its staged outputs are removed, further Ctrl-C being
ignored meanwhile.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from collections.abc import Sequence
from types import FrameType

#: Whether a command is running (Ctrl-C unwinds it) rather than starting (Ctrl-C ends the process).
_running = False
_INTERRUPTED = 130


def _on_interrupt(signum: int, frame: FrameType | None) -> None:
    """SIGINT: one line and exit 130 before a command runs; KeyboardInterrupt, once, while it runs."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not interrupt the cleanup
    if not _running:
        os.write(2, b"ERROR: interrupted\n")
        os._exit(_INTERRUPTED)
    raise KeyboardInterrupt


if __name__ != "__mp_main__":  # not in a worker process started by spawn
    signal.signal(signal.SIGINT, _on_interrupt)

from ..errors import BaxterDynamicsError

__all__ = ["COMMANDS", "main"]

#: command name -> (module implementing it, one-line help). The module is imported lazily.
COMMANDS: dict[str, tuple[str, str]] = {
    "process": (
        "baxter_dynamics_ros.cli.process",
        "gravity, inverse dynamics and residual for every sample of a bag or CSV file",
    ),
    "play": (
        "baxter_dynamics_ros.cli.play",
        "publish a bag's JointState topics and /clock for a node running on use_sim_time",
    ),
    "simulate": (
        "baxter_dynamics_ros.cli.simulate",
        "simulate a Baxter recording with known unmodelled effects (mcap or CSV, ground truth as JSON)",
    ),
    "diagnose": (
        "baxter_dynamics_ros.cli.diagnose",
        "where the sim-to-real gap lies, which unmodelled effect causes it, how far it shrinks (held-out)",
    ),
    "calibrate": (
        "baxter_dynamics_ros.cli.calibrate",
        "collision thresholds per joint from collision-free recordings (momentum observer), as thresholds.yaml",
    ),
    "paper-experiment": (
        "baxter_dynamics_ros.cli.paper_experiment",
        "the paper's experiment (Table V, Figs. 5-7) on simulated recordings: L-E and Pinocchio RNEA against the recorded torques",
    ),
}


def _parser(argv: Sequence[str]) -> argparse.ArgumentParser:
    """The top-level parser; only the chosen command's module is imported to add its options."""
    parser = argparse.ArgumentParser(
        prog="baxter-dynamics",
        description="Baxter arm dynamics: offline processing, playback into the live node.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    chosen = next((a for a in argv if not a.startswith("-")), None)
    for name, (module_name, help_text) in COMMANDS.items():
        command_parser = sub.add_parser(name, help=help_text, description=help_text)
        if name == chosen:
            importlib.import_module(module_name).add_arguments(command_parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``baxter-dynamics`` with argv (default: sys.argv[1:]); returns the exit status."""
    global _running
    argv = list(sys.argv[1:] if argv is None else argv)
    args = _parser(argv).parse_args(argv)
    module = importlib.import_module(COMMANDS[args.command][0])
    try:
        _running = True
        return int(module.run(args))
    except BaxterDynamicsError as err:
        print(f"ERROR: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # the command has unwound (its staged outputs removed): end here, exit 130
        print("ERROR: interrupted", file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_INTERRUPTED)  # not a return: a library that saw the interrupt could still turn the exit into -SIGINT
    finally:
        _running = False

