"""Bad input, second round (issue 22 items 1, 6, 7, 9, 10), as a user gives it to the CLI.

Each case runs ``baxter-dynamics`` in a subprocess and checks the exit code, the one ``ERROR:``
line (no traceback) and what was (or was not) written.
"""

from __future__ import annotations

import resource
import subprocess
import sys
from pathlib import Path

import pytest
from cli_runs import REPO, listing, run_cli, the_error

#: Nine levels of nine aliases: 9⁹ strings (~390 million) once expanded, from 600 bytes.
ALIAS_BOMB = "a: &a [" + ",".join(['"lol"'] * 9) + "]\n" + "".join(
    f"{b}: &{b} [" + ",".join([f"*{a}"] * 9) + "]\n" for a, b in zip("abcdefgh", "bcdefghi")
) + "effects: *i\n"


def _memory_limit(limit_bytes: int):
    def limit() -> None:  # in the child: the address space bounded, so a bomb fails instead of swapping
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))

    return limit


def test_a_yaml_alias_bomb_is_refused_before_it_expands(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(ALIAS_BOMB)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "baxter_dynamics_ros.cli", "simulate", "--duration", "1", "--effects", str(bomb), "--out", str(out / "sim.mcap")]
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=120, preexec_fn=_memory_limit(3 * 2**30))
    line = the_error(result)
    assert line.startswith(f"ERROR: {bomb}: the effects file uses a YAML alias (*name) at line 2")
    assert listing(tmp_path) == ["bomb.yaml"]
