"""``python -m bench [name ...]`` (what ``./dev bench`` runs): each named benchmark runs with its own
defaults, never with this command's arguments (which are benchmark names, no options of theirs), and
an unknown name is one ERROR line before anything runs."""

from __future__ import annotations

import os
import subprocess
import sys

from repo_paths import REPO


def _bench(*names: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH", "")]))}
    return subprocess.run([sys.executable, "-m", "bench", *names], cwd=REPO, env=env, capture_output=True, text=True, timeout=600)


def test_a_named_benchmark_runs_with_its_defaults() -> None:
    """The diagnosis benchmark (the one hour of its default): runs to its goal line, exit 0."""
    done = _bench("diagnosis")
    assert done.returncode == 0, done.stderr
    assert "60 min of 100 Hz data" in done.stdout and "goal: one hour <= 15 s" in done.stdout, done.stdout


def test_an_unknown_name_is_one_error_line() -> None:
    done = _bench("diagnosis", "nosuch")
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.splitlines() == [done.stderr.strip()] and done.stderr.startswith("ERROR: no benchmark named nosuch; available: ")


def test_the_diagnosis_benchmark_refuses_a_length_it_cannot_use(capsys) -> None:
    """No length, an absurd one, or one too short for diagnose: one ERROR line, exit 1."""
    from bench.bench_diagnosis import main

    for minutes, said in (("0", "must be a positive number of minutes, got 0"), ("nan", "got nan"),
                          ("0.02", "--minutes 0.02: random-0: 30 samples, 0.30 s; a training recording needs")):
        assert main(["--minutes", minutes]) == 1
        captured = capsys.readouterr()
        err = captured.err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("ERROR: ") and said in err[0], err
        assert captured.out == ""
