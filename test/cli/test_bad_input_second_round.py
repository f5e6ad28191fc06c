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


@pytest.fixture(scope="module")
def table(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated right-arm recording as a generic-layout CSV (both arms' columns), 12 s at 100 Hz."""
    out = tmp_path_factory.mktemp("sim") / "table.csv"
    assert run_cli("simulate", "--trajectory", "random", "--duration", "12", "--out", out).returncode == 0
    return out


def _rewritten(source: Path, target: Path, edit) -> Path:
    """``target``: the CSV ``source`` with ``edit(header, rows)`` (lists of cell lists) applied."""
    header, *rows = (line.split(",") for line in source.read_text().splitlines())
    header, rows = edit(header, rows)
    target.write_text("\n".join(",".join(r) for r in [header, *rows]) + "\n")
    return target


def test_a_column_named_twice_is_refused_naming_it(table: Path, tmp_path: Path) -> None:
    def twice(header, rows):
        return header + ["position_right_s0"], [r + ["5.0"] for r in rows]

    bad = _rewritten(table, tmp_path / "twice.csv", twice)
    for command in (["process", bad, "--out", tmp_path / "o.csv"], ["calibrate", bad, "--out", tmp_path / "t.yaml"]):
        line = the_error(run_cli(*command, "--arm", "right"))
        assert line == f"ERROR: {bad}: column position_right_s0 appears more than once in the header; keep one"
    assert listing(tmp_path) == ["twice.csv"]


def test_a_folder_holding_one_recording_writes_into_the_out_folder(table: Path, tmp_path: Path) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "only.csv").write_bytes(table.read_bytes())
    result = run_cli("process", folder, "--arm", "right", "--out", tmp_path / "out", "--format", "csv")
    assert result.returncode == 0, result.stderr
    assert listing(tmp_path / "out") == ["only.csv"]


def test_a_three_sample_table_is_refused_naming_the_file_and_the_fix(table: Path, tmp_path: Path) -> None:
    short = _rewritten(table, tmp_path / "short.csv", lambda header, rows: (header, rows[::150][:3]))
    line = the_error(run_cli("process", short, "--arm", "right", "--out", tmp_path / "o.csv"))
    assert line.startswith(f"ERROR: {short}: cannot estimate q̈ by zero_phase on this recording (3 samples at ")
    assert line.endswith("give a longer recording at a higher rate, or a lower --cutoff-hz")
    assert listing(tmp_path) == ["short.csv"]


@pytest.mark.parametrize("command", ["process", "calibrate", "diagnose", "simulate"])
def test_out_with_missing_parents_is_made_as_mkdir_p_would(table: Path, tmp_path: Path, command: str) -> None:
    out = {"process": "a/b/out.csv", "calibrate": "a/b/thresholds.yaml", "diagnose": "a/b/diagnosis", "simulate": "a/b/sim.mcap"}[command]
    inputs = {"diagnose": ["--train", table, "--test", table.with_name("held.csv")], "simulate": ["--duration", "1"]}.get(command, [table])
    if command == "diagnose" and not table.with_name("held.csv").exists():
        assert run_cli("simulate", "--trajectory", "random", "--duration", "4", "--seed", "2", "--out", table.with_name("held.csv")).returncode == 0
    extra = [] if command == "simulate" else ["--arm", "right"]
    result = run_cli(command, *inputs, *extra, "--out", tmp_path / out)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / out).exists() and listing(tmp_path)[:2] == ["a", "a/b"]
    assert not [p for p in listing(tmp_path) if "partial" in p]


def test_out_with_missing_parents_leaves_nothing_when_the_command_fails(table: Path, tmp_path: Path) -> None:
    short = _rewritten(table, tmp_path / "short.csv", lambda header, rows: (header, rows[::150][:3]))
    the_error(run_cli("process", short, "--arm", "right", "--out", tmp_path / "a" / "b" / "o.csv"))
    assert listing(tmp_path) == ["short.csv"]


@pytest.mark.parametrize("delay_s", [0.1, 0.15, 0.2, 0.3, 0.6, 1.5])
def test_ctrl_c_at_any_time_is_one_line_and_exit_130(table: Path, tmp_path: Path, delay_s: float) -> None:
    """From 0.1 s on: before that the interpreter is still importing the environment's .pth files (site),
    before any of the package's code can install its handler."""
    import signal
    import time

    command = [sys.executable, "-m", "baxter_dynamics_ros.cli", "process", str(table), "--arm", "right", "--out", str(tmp_path / "a" / "o.mcap")]
    child = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(delay_s)
    child.send_signal(signal.SIGINT)
    _, stderr = child.communicate(timeout=120)
    if child.returncode == 0:  # finished before the signal: nothing to check but a clean run
        return
    if child.returncode == -signal.SIGINT and not stderr:
        # the command had finished and the interpreter was exiting, its handlers already reset by
        # Python's finalisation (a shell reports this as 130 too): the result is whole, nothing staged
        assert listing(tmp_path) == ["a", "a/o.mcap"], listing(tmp_path)
        return
    assert "Traceback" not in stderr, stderr
    assert child.returncode == 130 and stderr.strip().splitlines()[-1] == "ERROR: interrupted", stderr
    assert listing(tmp_path) == []
