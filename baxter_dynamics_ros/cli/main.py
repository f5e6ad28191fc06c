"""The ``baxter-dynamics`` command line: a thin argparse shell over command modules.

Each command lives in its own module exposing ``add_arguments(parser)`` and ``run(args) -> int``;
its one-line help sits in :data:`COMMANDS`. Modules are imported only when their command runs, so ``--help`` stays
fast and ``process`` never imports rclpy. To add a command, add one entry to :data:`COMMANDS`.

Errors of this package (:class:`~baxter_dynamics_ros.errors.BaxterDynamicsError`) are caught here,
at the edge, and printed as one ``ERROR: ...`` line on stderr with exit status 1; any other
exception (a bug) too, as ``ERROR: unexpected ...``, unless ``BAXTER_DYNAMICS_DEBUG=1`` asks for its
traceback. Ctrl-C (SIGINT) at any time prints one ``ERROR: interrupted`` line and exits 130, and
SIGTERM (what ``timeout``, systemd and CI send) one ``ERROR: terminated (SIGTERM)`` line and exits
143, without a traceback: before the command runs (parsing, imports) the process ends at once,
nothing having been written; while it runs, KeyboardInterrupt (:class:`Terminated` for SIGTERM)
unwinds it so that its cleanups run (staged outputs and scratch folders removed, worker processes
stopped), further signals being ignored meanwhile. Worker processes the command spawns leave
SIGINT to this process (a Ctrl-C in a terminal reaches the whole process group) and die of SIGTERM.
While worker processes are being spawned (:func:`signals_deferred`) a signal is acted on once they
are, or at a second signal: stopped in the middle of a spawn, a new process finds the pipe of its
start-up data closed and prints a traceback of its own after the one ERROR line.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from types import FrameType

#: Whether a command is running (a signal unwinds it) rather than starting (a signal ends the process).
_running = False
#: The signal that stopped the command (SIGINT or SIGTERM), None while none came.
_received: int | None = None
#: Whether a signal is held until the end of a :func:`signals_deferred` block.
_deferring = False
#: set to 1 to see the traceback of an unexpected error instead of its one ERROR line
DEBUG_VARIABLE = "BAXTER_DYNAMICS_DEBUG"
#: signal -> (the one line printed, the exit status)
_ENDINGS = {signal.SIGINT: ("ERROR: interrupted", 130), signal.SIGTERM: ("ERROR: terminated (SIGTERM)", 128 + signal.SIGTERM)}


class Terminated(KeyboardInterrupt):
    """SIGTERM received while a command runs: raised where it is, so that its cleanups run as on Ctrl-C."""


def _ignored(signum: int, frame: FrameType | None) -> None:
    """A signal after the first: the cleanup goes on."""


def _on_signal(signum: int, frame: FrameType | None) -> None:
    """SIGINT, SIGTERM: one line and exit 130, 143 before a command runs; KeyboardInterrupt
    (:class:`Terminated`), once, while it runs; inside :func:`signals_deferred`, held until the
    block ends, unless a second signal comes first."""
    global _received
    if _running and _deferring and _received is None:
        _received = signum
        return
    _ignore_further()
    if not _running:
        line, status = _ENDINGS[signum]
        os.write(2, line.encode() + b"\n")
        os._exit(status)
    if _received is None:
        _received = signum
    _raise(_received)


def _ignore_further() -> None:
    """A second signal does not interrupt the cleanup (not SIG_IGN: a process spawned meanwhile
    would inherit it, and SIGTERM could not stop it)."""
    for later in _ENDINGS:
        signal.signal(later, _ignored)


def _raise(signum: int) -> None:
    raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt


@contextmanager
def signals_deferred() -> Iterator[None]:
    """A block a signal does not interrupt (worker processes being spawned): a SIGINT or SIGTERM
    received meanwhile is raised, as :func:`_on_signal` would have, when the block ends — or at
    once if a second one comes (a block that hangs can still be stopped)."""
    global _deferring
    if _deferring or _received is not None:  # nested, or the command is already unwinding
        yield
        return
    _deferring = True
    try:
        yield
    except Exception:
        if _received is None:
            raise  # an error of the block's own; with a signal held, the signal is what stops the command
    finally:
        _deferring = False
    if _received is not None:
        _ignore_further()
        _raise(_received)


def _thread_failed(args: threading.ExceptHookArgs) -> None:
    """A thread's uncaught exception: shown as Python does, unless the command was stopped by a signal."""
    if _received is None:
        threading.__excepthook__(args)


if __name__ == "__mp_main__" or "--multiprocessing-fork" in getattr(sys, "orig_argv", ()):
    # a worker process started by spawn (multiprocessing, dask's nanny): this process stops it
    signal.signal(signal.SIGINT, signal.SIG_IGN)
else:
    for _signum in _ENDINGS:
        signal.signal(_signum, _on_signal)
    # multiprocessing's resource tracker (a process of its own, started with this interpreter's -W
    # options) removes the semaphores of worker pools that an exit on a signal left, and would say so
    # on stderr after the one ERROR line
    sys.warnoptions.append("ignore::UserWarning:multiprocessing.resource_tracker")
    # and a library thread that fails as the command unwinds after a signal (concurrent.futures' pool
    # manager setting an exception on a future cancelled meanwhile, Python 3.11) prints no traceback
    threading.excepthook = _thread_failed

from ..errors import BaxterDynamicsError

__all__ = ["COMMANDS", "DEBUG_VARIABLE", "Terminated", "main", "signals_deferred"]

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
    try:
        args = _parser(argv).parse_args(argv)
        module = importlib.import_module(COMMANDS[args.command][0])
        for signum in _ENDINGS:  # a library imported meanwhile may have put its own handler in place
            signal.signal(signum, _on_signal)
        _running = True
        return int(module.run(args))
    except BaxterDynamicsError as err:
        if _received is not None:  # a worker stopped by the same signal (a process group's) failed first
            _end(_received)
        print(f"ERROR: {err}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # the command has unwound (its staged outputs removed): end here
        _end(signal.SIGTERM if _received == signal.SIGTERM else signal.SIGINT)
    except Exception as err:
        if _received is not None:  # a worker stopped by the same signal (a process group's) failed first
            _end(_received)
        if os.environ.get(DEBUG_VARIABLE) == "1":
            raise
        print(f"ERROR: unexpected {type(err).__name__}: {err} (a bug; {DEBUG_VARIABLE}=1 shows where)", file=sys.stderr)
        return 1
    finally:
        _running = False


def _end(signum: int) -> None:
    """Print the signal's one line and exit with its status."""
    line, status = _ENDINGS[signum]
    print(line, file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)  # not a return: a library that saw the interrupt could still turn the exit into -SIGINT

