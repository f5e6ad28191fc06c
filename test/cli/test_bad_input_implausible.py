"""Bad input, second round (issue 22 items 1, 4 and 9b), as a user gives it to the CLI.

One absurd sample in a recording (effort 1e30 or 1e308 N·m, NaN, a position far beyond the limits)
is left out by the readers with one warning line per file, and the commands give what they give
without it; a file mostly implausible is refused; malformed bag messages are counted; two
``diagnose`` runs racing for one new ``--out`` never both succeed.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from cli_runs import REPO, listing, run_cli, the_error
from recorded_bags import BAXTER_JOINTS, joint_states, message, write_bag

EXAMPLE_EFFECTS = REPO / "config" / "effects_example.yaml"
#: The row of the absurd sample (5 s into the 12 s training recording).
ROW = 500


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Simulated right-arm tables (generic layout, both arms' columns) with the example effects
    (the s1 spring among them): ``train`` 12 s, ``test`` 4 s."""
    folder = tmp_path_factory.mktemp("sim")
    paths = {"train": folder / "train.csv", "test": folder / "test.csv"}
    for (name, path), (duration, seed) in zip(paths.items(), (("12", "3"), ("4", "4"))):
        result = run_cli("simulate", "--trajectory", "random", "--duration", duration, "--seed", seed, "--effects", EXAMPLE_EFFECTS, "--out", path)
        assert result.returncode == 0, result.stderr
    return paths


def spoiled(source: Path, target: Path, column: str, value: str, rows=(ROW,)) -> Path:
    """``target``: the CSV ``source`` with ``column`` set to ``value`` in ``rows`` (0 = first data row)."""
    header, *lines = source.read_text().splitlines()
    k = header.split(",").index(column)
    for row in rows:
        cells = lines[row].split(",")
        cells[k] = value
        lines[row] = ",".join(cells)
    target.write_text("\n".join([header, *lines]) + "\n")
    return target


def warnings(result: subprocess.CompletedProcess) -> list[str]:
    return [line for line in result.stderr.splitlines() if line.startswith("WARNING:")]


def table(path: Path) -> tuple[list[str], np.ndarray]:
    header = path.read_text().split("\n", 1)[0].split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


CASES = {  # what is spoiled, the value, the cause the warning names
    "effort_1e30": ("effort_right_s1", "1e30", "1 effort beyond 3 × the effort limit"),
    "effort_1e308": ("effort_right_e0", "1e308", "1 effort beyond 3 × the effort limit"),
    "effort_nan": ("effort_right_w1", "nan", "1 NaN or inf"),
    "position_far": ("position_right_s0", "10.0", "1 position beyond the joint limits"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_process_leaves_one_absurd_sample_out_says_so_and_gives_the_clean_result(recordings: dict[str, Path], tmp_path: Path, case: str) -> None:
    column, value, cause = CASES[case]
    bad = spoiled(recordings["train"], tmp_path / "bad.csv", column, value)
    result = run_cli("process", bad, "--arm", "right", "--out", tmp_path / "bad_out.csv")
    assert result.returncode == 0, result.stderr
    assert warnings(result) == [
        f"WARNING: {bad}: 1 of 1200 samples skipped as implausible ({cause}); the recording is split into pieces at them"
    ]
    assert run_cli("process", recordings["train"], "--arm", "right", "--out", tmp_path / "clean_out.csv").returncode == 0
    header, got = table(tmp_path / "bad_out.csv")
    _, clean = table(tmp_path / "clean_out.csv")
    assert len(got) == len(clean) - 1 and np.array_equal(got[:, 0], np.delete(clean[:, 0], ROW))  # stamp_ns
    residual = [k for k, name in enumerate(header) if name.startswith("residual_")]
    expected = np.delete(clean[:, residual], ROW, axis=0)
    # q̈ is filtered on each side of the gap on its own: the edges of the two pieces differ a little
    # (as at a recording's start: q̇ here holds the example's noise), the rest is the clean result.
    far = np.abs(np.arange(len(got)) - ROW) > 100
    np.testing.assert_allclose(got[far][:, residual], expected[far], rtol=0, atol=1e-9)
    assert np.abs(got[:, residual] - expected).max() < 2.0
    rms = [np.sqrt(np.mean(r**2, axis=0)) for r in (got[:, residual], expected)]
    np.testing.assert_allclose(rms[0], rms[1], rtol=0.02, atol=0.01)


def test_calibrate_with_one_absurd_effort_gives_the_clean_thresholds(recordings: dict[str, Path], tmp_path: Path) -> None:
    bad = spoiled(recordings["train"], tmp_path / "bad.csv", "effort_right_s1", "1e30")
    result = run_cli("calibrate", bad, "--arm", "right", "--out", tmp_path / "bad.yaml")
    assert result.returncode == 0, result.stderr
    assert len(warnings(result)) == 1 and warnings(result)[0].startswith(f"WARNING: {bad}: 1 of 1200 samples skipped as implausible")
    assert run_cli("calibrate", recordings["train"], "--arm", "right", "--out", tmp_path / "clean.yaml").returncode == 0
    got, clean = (yaml.safe_load((tmp_path / name).read_text()) for name in ("bad.yaml", "clean.yaml"))
    for key in ("offset_nm", "slope_nm_s_rad"):
        for joint, value in clean[key].items():
            assert got[key][joint] == pytest.approx(value, rel=0.01, abs=0.01), (key, joint)


def test_diagnose_with_one_absurd_effort_keeps_the_spring_and_the_clean_held_out_error(recordings: dict[str, Path], tmp_path: Path) -> None:
    bad = spoiled(recordings["train"], tmp_path / "bad.csv", "effort_right_s1", "1e30")
    runs = {}
    for name, train in (("bad", bad), ("clean", recordings["train"])):
        result = run_cli("diagnose", "--train", train, "--test", recordings["test"], "--arm", "right", "--jobs", "1", "--out", tmp_path / name)
        assert result.returncode == 0, result.stderr
        runs[name] = json.loads((tmp_path / name / "diagnosis.json").read_text())
        if name == "bad":
            assert len(warnings(result)) == 1 and warnings(result)[0].startswith(f"WARNING: {bad}: 1 of 1200 samples skipped as implausible")
    s1 = [run["final"]["test_rms"][1] for run in (runs["bad"], runs["clean"])]
    assert s1[1] < 0.2 and abs(s1[0] - s1[1]) < 0.05, s1  # was 22.2 N·m: the spring dropped
    assert "s1_spring" in [e["name"] for e in runs["bad"]["effects"] if e["selected"]]


def test_a_mostly_implausible_file_is_refused(recordings: dict[str, Path], tmp_path: Path) -> None:
    bad = spoiled(recordings["train"], tmp_path / "bad.csv", "effort_right_s1", "1e30", rows=range(0, 1200, 5))
    line = the_error(run_cli("process", bad, "--arm", "right", "--out", tmp_path / "out.csv"))
    assert line.startswith(f"ERROR: {bad}: 240 of 1200 samples are implausible (240 effort beyond 3 × the effort limit): more than 10%")
    assert listing(tmp_path) == ["bad.csv"]


def test_malformed_bag_messages_are_counted_per_file(tmp_path: Path) -> None:
    states = joint_states(600, BAXTER_JOINTS, seed=5)
    msgs = [
        (int(t), message("mcap", t, BAXTER_JOINTS, p, v, e))
        for t, p, v, e in zip(states["stamps_ns"], states["position"], states["velocity"], states["effort"])
    ]
    t, p, v, e = (states[k][300] for k in ("stamps_ns", "position", "velocity", "effort"))
    msgs[300] = (int(t), message("mcap", t, BAXTER_JOINTS, p[:-1], v, e))  # one position short
    left = [k for k, name in enumerate(BAXTER_JOINTS) if not name.startswith("right_")]
    t, p, v, e = (states[k][301] for k in ("stamps_ns", "position", "velocity", "effort"))
    msgs[301] = (int(t), message("mcap", t, [BAXTER_JOINTS[k] for k in left], p[left], v[left], e[left]))  # no right arm
    bag = write_bag(tmp_path / "bag", "mcap", {"/robot/joint_states": msgs})
    result = run_cli("process", bag, "--arm", "right", "--out", tmp_path / "out.csv")
    assert result.returncode == 0, result.stderr
    assert warnings(result) == [f"WARNING: {bag}: 2 of 600 messages on /robot/joint_states skipped as malformed (1 missing_joint, 1 array_length)"]


def test_two_diagnose_runs_racing_for_one_new_out_never_both_succeed(recordings: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "diag"
    command = [
        sys.executable, "-m", "baxter_dynamics_ros.cli", "diagnose", "--train", str(recordings["train"]), "--test", str(recordings["test"]),
        "--arm", "right", "--jobs", "1", "--no-progress", "--out", str(out),
    ]  # fmt: skip
    first = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)
    second = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    results = []
    for child in (first, second):
        stdout, stderr = child.communicate(timeout=600)
        results.append(subprocess.CompletedProcess(command, child.returncode, stdout, stderr))
    codes = sorted(r.returncode for r in results)
    assert codes == [0, 1], [r.stderr for r in results]
    loser = next(r for r in results if r.returncode == 1)
    # the folder itself when the winner put it in place after the loser staged its own, else the
    # first of its files (the folder was there, empty or not, when the loser staged)
    claimed = re.fullmatch(rf"ERROR: {re.escape(str(out))}(/diagnosis\.json)?: appeared while this command ran \(another run writing there\?\); not replacing it, nothing was written: choose another --out or pass --force", the_error(loser))
    assert claimed, the_error(loser)
    winner = next(r for r in results if r.returncode == 0)
    assert f"{out}" in winner.stdout
    assert sorted(p.name for p in out.iterdir()) == sorted(["diagnosis.json", "report.html", "effects.yaml", "residual_over_time.png", "regimes.png", "before_after.png"])
    assert [p for p in listing(tmp_path) if "partial" in p] == []


def test_simulate_refuses_effects_no_real_baxter_has(tmp_path: Path) -> None:
    spec = tmp_path / "effects.yaml"
    spec.write_text("effects:\n  torque_offset: {offset_nm: {s1: 1.0e+30}}\n")
    line = the_error(run_cli("simulate", "--duration", "1", "--effects", spec, "--out", tmp_path / "sim.mcap"))
    assert line.startswith(f"ERROR: {spec}: with these effects the model's torque at right_s1 reaches 1e+30 N·m within the joint and velocity limits, above 300 N·m")
    assert listing(tmp_path) == ["effects.yaml"]
