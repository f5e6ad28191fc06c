"""``baxter-dynamics`` run as a user runs it: a subprocess, its exit code, stdout and stderr.

Helpers for the tests of bad input: :func:`run_cli`, :func:`the_error` (exit 1 and exactly one
``ERROR:`` line on stderr, no traceback) and :func:`listing` (every path under a folder, to check
that nothing new was written).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from repo_paths import REPO


def run_cli(*args: str | Path, timeout_s: float = 600.0, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """``python -m baxter_dynamics_ros.cli ARGS...`` in the checkout, with ``env`` added to this
    process' environment; output captured as text."""
    command = [sys.executable, "-m", "baxter_dynamics_ros.cli", *map(str, args)]
    return subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=timeout_s, env={**os.environ, **(env or {})})


def the_error(result: subprocess.CompletedProcess) -> str:
    """The one ``ERROR:`` line of a refused run (exit 1, no traceback); fails the test otherwise.

    Other stderr lines (a rate estimated for an earlier file, a progress note) may come before it.
    """
    shown = f"exit {result.returncode}\nstdout:\n{result.stdout}\nstderr:\n{result.stderr}"
    assert result.returncode == 1, shown
    assert "Traceback" not in result.stderr, shown
    errors = [line for line in result.stderr.splitlines() if line.startswith("ERROR:")]
    assert len(errors) == 1 and result.stderr.rstrip("\n").splitlines()[-1] == errors[0], shown
    return errors[0]


def listing(folder: Path) -> list[str]:
    """Every file and folder under ``folder``, relative, sorted."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))
