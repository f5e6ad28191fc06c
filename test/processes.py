"""Stopping a child process the way a user stops a node, for the tests and benchmarks that start one."""

from __future__ import annotations

import signal
import subprocess


def interrupt(process: subprocess.Popen, timeout_s: float = 15.0) -> int:
    """Ctrl-C (SIGINT), as a user stops a node; kill it if it has not exited after timeout_s [s].

    Returns the exit code (negative: the signal that ended it). A process already gone is left as it is.
    """
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    return process.returncode
