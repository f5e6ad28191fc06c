"""SIGINT and SIGTERM in the ``baxter-dynamics`` process: one ERROR line, an exit status, no traceback.

Before a command runs (parsing, imports) a signal ends the process at once, nothing having been
written; while it runs (:func:`command_running`), KeyboardInterrupt (:class:`Terminated` for SIGTERM)
unwinds it so that its cleanups run, further signals being ignored meanwhile. While worker processes
are being spawned (:func:`signals_deferred`) a signal is acted on once they are, or at a second
signal: stopped in the middle of a spawn, a new process finds the pipe of its start-up data closed
and prints a traceback of its own after the one ERROR line.

A signal whose exception Python cannot raise where the handler ran (a garbage collector's callback)
is sent again, so that it is never lost (:func:`_unraisable`).

Nothing happens on import: :func:`install` (called by :mod:`.main`, the command line's entry point)
puts the handlers in place, so that a module that only spawns workers (:mod:`.workers`) can use
:func:`signals_deferred` without taking over the signals of the process that imports it.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["Terminated", "command_running", "end", "install", "received", "signals_deferred"]

#: signal -> (the one line printed, the exit status)
_ENDINGS = {signal.SIGINT: ("ERROR: interrupted", 130), signal.SIGTERM: ("ERROR: terminated (SIGTERM)", 128 + signal.SIGTERM)}
#: Whether a command is running (a signal unwinds it) rather than starting (a signal ends the process).
_running = False
#: The signal that stopped the command (SIGINT or SIGTERM), None while none came.
_received: int | None = None
#: Whether a signal is held until the end of a :func:`signals_deferred` block.
_deferring = False
#: How long after a signal was lost (:func:`_unraisable`) it is sent again, s.
RESEND_DELAY_S = 0.01
#: The exception last raised for a signal (so that only its loss sends the signal again).
_raised: BaseException | None = None


class Terminated(KeyboardInterrupt):
    """SIGTERM received while a command runs: raised where it is, so that its cleanups run as on Ctrl-C."""


def received() -> int | None:
    """The signal that stopped the command (SIGINT or SIGTERM), None while none came."""
    return _received


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
    global _raised
    _raised = Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
    raise _raised


def _unraisable(args: sys.UnraisableHookArgs) -> None:
    """An exception Python cannot raise where it happened (in a ``__del__``, a weakref's or the
    garbage collector's callback — a cluster's scheduler keeps one): when it is the signal's, raised
    by :func:`_on_signal` in such a place, the signal is sent again so that it stops the command at
    the next chance instead of being lost (the command then ran to its end and wrote its outputs);
    anything else is shown as Python does."""
    if _running and _received is not None and args.exc_value is _raised and threading.current_thread() is threading.main_thread():
        signal.signal(_received, _on_signal)  # raises it again (ends the process, if the command has ended)
        # a moment later, from another thread: sent from here, its handler would run here, inside the
        # hook, and be lost again (should it land in such a place again, it comes back here)
        again = threading.Timer(RESEND_DELAY_S, os.kill, (os.getpid(), _received))
        again.daemon = True
        again.start()
        return
    sys.__unraisablehook__(args)


@contextmanager
def signals_deferred() -> Iterator[None]:
    """A block a signal does not interrupt (worker processes being spawned): a SIGINT or SIGTERM
    received meanwhile is raised, as :func:`_on_signal` would have, when the block ends — or at
    once if a second one comes (a block that hangs can still be stopped). Without :func:`install`
    (a library use of the workers) the block holds nothing."""
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


@contextmanager
def command_running() -> Iterator[None]:
    """The block in which the command runs: a signal unwinds it instead of ending the process. The
    handlers are put in place again first (a library imported meanwhile may have put its own)."""
    global _running
    for signum in _ENDINGS:
        signal.signal(signum, _on_signal)
    _running = True
    try:
        yield
    finally:
        _running = False


def end(signum: int) -> None:
    """Print the signal's one line and exit with its status."""
    line, status = _ENDINGS[signum]
    print(line, file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)  # not a return: a library that saw the interrupt could still turn the exit into -SIGINT


def _thread_failed(args: threading.ExceptHookArgs) -> None:
    """A thread's uncaught exception: shown as Python does, unless the command was stopped by a signal."""
    if _received is None:
        threading.__excepthook__(args)


def install(module_name: str) -> None:
    """Put the handlers in place in the command line's process; module_name: the ``__name__`` of the
    module calling (in a worker process started by spawn, multiprocessing's or dask's nanny, the
    process that started it stops it: SIGINT is ignored there, SIGTERM left to kill it)."""
    if module_name == "__mp_main__" or "--multiprocessing-fork" in getattr(sys, "orig_argv", ()):
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        return
    for signum in _ENDINGS:
        signal.signal(signum, _on_signal)
    # multiprocessing's resource tracker (a process of its own, started with this interpreter's -W
    # options) removes the semaphores of worker pools that an exit on a signal left, and would say so
    # on stderr after the one ERROR line
    sys.warnoptions.append("ignore::UserWarning:multiprocessing.resource_tracker")
    # and a library thread that fails as the command unwinds after a signal (concurrent.futures' pool
    # manager setting an exception on a future cancelled meanwhile, Python 3.11) prints no traceback
    threading.excepthook = _thread_failed
    sys.unraisablehook = _unraisable
