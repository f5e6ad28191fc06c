"""``baxter-dynamics process``: real files in, numbers checked against the core computed directly."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from repo_paths import REPO
from recorded_bags import (
    BAXTER_JOINTS,
    REAL_FILES,
    bag_path,
    bag_storage_file,
    joint_states,
    listing_of,
    read_output_bag,
    write_baxter_export,
    write_reference_bag,
)

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.cli.main import main
from baxter_dynamics_ros.core.acceleration import LowPassDifferentiator, first_difference, zero_phase_acceleration
from baxter_dynamics_ros.core.joints import arm_joint_names
from msg_adapters.bag_io import RESULT_TOPICS, read_bag_recording
from msg_adapters.csv_io import read_table_recording

N = 400
TOPICS = ("/robot/joint_states", *RESULT_TOPICS.values())


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """A ROS 1 bag of Baxter's 17 joints, 4 s at 100 Hz, and its states."""
    states = joint_states(N)
    path = write_reference_bag(tmp_path_factory.mktemp("in") / "baxter.bag", "ros1", states)
    return path, states


def expected(states: dict, acceleration: str = "zero_phase", cutoff_hz: float | None = None) -> dict[str, np.ndarray]:
    """The core's numbers computed directly on the right arm's columns of ``states``."""
    where = [BAXTER_JOINTS.index(j) for j in arm_joint_names("right")]
    q, qd, effort = (states[k][:, where] for k in ("position", "velocity", "effort"))
    stamps_s = (states["stamps_ns"] - states["stamps_ns"][0]) * 1e-9
    if acceleration == "zero_phase":
        qdd = zero_phase_acceleration(qd, 100.0, cutoff_hz or 5.0)
    elif acceleration == "lowpass":
        qdd = LowPassDifferentiator(cutoff_hz or 10.0).run(qd, stamps_s)
    else:
        qdd = first_difference(qd, stamps_s)
    arm = load_arm_model("right")
    tau = arm.inverse_dynamics(q, qd, qdd)
    return {
        "q": q,
        "qd": qd,
        "effort": effort,
        "qdd": qdd,
        "gravity": arm.gravity(q),
        "inverse_dynamics": tau,
        "residual": effort - tau,
    }


def run_cli(*argv: str | Path) -> int:
    return main([str(a) for a in argv])


def test_process_bag_to_mcap_has_the_node_topics_with_the_core_numbers(recorded, tmp_path: Path, capsys) -> None:
    path, states = recorded
    out = tmp_path / "result.mcap"
    assert run_cli("process", path, "--out", out) == 0
    assert "400 samples of the right arm" in capsys.readouterr().out
    topics = read_output_bag(out)
    assert sorted(topics) == sorted(TOPICS)
    want = expected(states)
    for topic, entry in topics.items():
        assert (entry["names"] == arm_joint_names("right")).all()
        np.testing.assert_array_equal(entry["stamps_ns"], states["stamps_ns"])
        np.testing.assert_array_equal(entry["position"], want["q"])
        np.testing.assert_array_equal(entry["velocity"], want["qd"])
    np.testing.assert_array_equal(topics["/robot/joint_states"]["effort"], want["effort"])
    for name, topic in RESULT_TOPICS.items():
        np.testing.assert_allclose(topics[topic]["effort"], want[name], rtol=0, atol=1e-12)
    # The output plays back like the input: it is itself a recording of the arm.
    again = read_bag_recording(out)
    np.testing.assert_array_equal(again.q, want["q"])


@pytest.mark.parametrize(("acceleration", "cutoff_hz"), [("lowpass", 7.0), ("first_difference", None), ("zero_phase", 3.0)])
def test_process_to_csv_with_each_estimator(recorded, tmp_path: Path, acceleration: str, cutoff_hz: float | None) -> None:
    path, states = recorded
    out = tmp_path / "result.csv"
    extra = ["--cutoff-hz", str(cutoff_hz)] if cutoff_hz else []
    assert run_cli("process", path, "--out", out, "--acceleration", acceleration, *extra) == 0
    header = out.read_text().splitlines()[0].split(",")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    col = {name: k for k, name in enumerate(header)}
    np.testing.assert_array_equal(np.loadtxt(out, delimiter=",", skiprows=1, usecols=0, dtype=np.int64), states["stamps_ns"])
    want = expected(states, acceleration, cutoff_hz)
    for prefix, key in [("acceleration", "qdd"), ("gravity", "gravity"), ("inverse_dynamics", "inverse_dynamics"), ("residual", "residual")]:
        got = table[:, [col[f"{prefix}_{j}"] for j in arm_joint_names("right")]]
        np.testing.assert_allclose(got, want[key], rtol=0, atol=1e-12)
    # A processed table is itself a readable recording (generic layout).
    np.testing.assert_array_equal(read_table_recording(out).q, want["q"])


def test_process_to_parquet(recorded, tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    path, states = recorded
    out = tmp_path / "result.parquet"
    assert run_cli("process", path, "--out", out) == 0
    table = pq.read_table(out)
    np.testing.assert_array_equal(table.column("stamp_ns").to_numpy(), states["stamps_ns"])
    got = np.stack([table.column(f"residual_{j}").to_numpy() for j in arm_joint_names("right")], axis=1)
    np.testing.assert_allclose(got, expected(states)["residual"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(read_table_recording(out).effort, expected(states)["effort"])


@pytest.mark.skipif(not REAL_FILES, reason="real Baxter recordings absent (../shared/data/baxter_real)")
def test_process_a_real_recording(tmp_path: Path) -> None:
    out = tmp_path / "real.mcap"
    assert run_cli("process", REAL_FILES[0], "--out", out) == 0
    topics = read_output_bag(out)
    rec = read_table_recording(REAL_FILES[0])
    arm = load_arm_model("left")
    np.testing.assert_allclose(topics["/baxter_dynamics/gravity"]["effort"], arm.gravity(rec.q), rtol=0, atol=1e-12)
    # The real robot's springs carry much of s1's gravity: a large s1 residual, as documented.
    assert np.mean(np.abs(topics["/baxter_dynamics/residual"]["effort"][:, 1])) > 5.0


def test_refuses_to_overwrite_its_input_even_with_force(tmp_path: Path, capsys) -> None:
    states = joint_states(50)
    for kind in ("mcap", "ros1"):
        path = write_reference_bag(bag_path(tmp_path, kind, f"in_{kind}"), kind, states)
        before = listing_of(tmp_path)
        assert run_cli("process", path, "--out", path, "--force") == 1
        err = capsys.readouterr().err
        assert err.startswith("ERROR: ") and "refusing to overwrite the input" in err and err.count("\n") == 1
        assert listing_of(tmp_path) == before
    csv = write_baxter_export(tmp_path / "in.csv", joint_states(50))
    assert run_cli("process", csv, "--out", tmp_path / "in.csv") == 1
    assert "refusing to overwrite the input" in capsys.readouterr().err


def test_refuses_an_existing_output_unless_forced(recorded, tmp_path: Path, capsys) -> None:
    path, _ = recorded
    out = tmp_path / "result.csv"
    out.write_text("keep me\n")
    assert run_cli("process", path, "--out", out) == 1
    assert "exists already; choose another --out or pass --force" in capsys.readouterr().err
    assert out.read_text() == "keep me\n"
    assert run_cli("process", path, "--out", out, "--force") == 0
    assert out.read_text().startswith("stamp_ns,time_s,position_right_s0")
    assert listing_of(tmp_path) == ["result.csv"]


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_corrupt_bag_fails_with_one_line_and_writes_nothing(tmp_path: Path, capsys, kind: str) -> None:
    (tmp_path / "in").mkdir()
    path = write_reference_bag(bag_path(tmp_path / "in", kind), kind, joint_states(N))
    storage = bag_storage_file(path)
    storage.write_bytes(storage.read_bytes()[: storage.stat().st_size // 2])
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    for out in ("r.mcap", "r.csv"):
        assert run_cli("process", path, "--out", out_dir / out) == 1
        err = capsys.readouterr().err
        assert err.startswith("ERROR: ") and err.count("\n") == 1 and "corrupt or truncated" in err
    assert listing_of(out_dir) == []


def test_missing_joints_fail_with_one_line_and_write_nothing(tmp_path: Path, capsys) -> None:
    names = ["head_pan", "torso_t0"]
    path = write_reference_bag(tmp_path / "head.bag", "ros1", joint_states(20, names=names), names=names)
    out = tmp_path / "result.mcap"
    assert run_cli("process", path, "--out", out, "--arm", "left") == 1
    err = capsys.readouterr().err
    assert err == (
        f"ERROR: {path}: no message on /robot/joint_states has position, velocity and effort of all 7 left arm "
        "joints (left_s0, left_s1, left_e0, left_e1, left_w0, left_w1, left_w2); joint names found: head_pan, torso_t0\n"
    )
    assert listing_of(tmp_path) == ["head.bag"]
    assert run_cli("process", path, "--out", out) == 1
    assert capsys.readouterr().err == f"ERROR: {path}: no arm has all 7 joints (right_s0..right_w2 or left_s0..left_w2); joint names found: head_pan, torso_t0\n"


def test_a_failed_write_leaves_nothing_behind_and_the_old_output_intact(recorded, tmp_path: Path, capsys, monkeypatch) -> None:
    """Failure injected after the whole file is written (disk full at the last byte, say)."""
    import msg_adapters.bag_io as bag_io

    real_write = bag_io.write_mcap

    def write_then_fail(path, *args):
        real_write(path, *args)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(bag_io, "write_mcap", write_then_fail)
    path, _ = recorded
    out = tmp_path / "result.mcap"
    out.write_bytes(b"previous result")
    assert run_cli("process", path, "--out", out, "--force") == 1
    err = capsys.readouterr().err
    assert err.startswith("ERROR: ") and err.count("\n") == 1 and "No space left on device" in err
    assert listing_of(tmp_path) == ["result.mcap"] and out.read_bytes() == b"previous result"


def test_a_folder_in_the_way_is_never_replaced(recorded, tmp_path: Path, capsys) -> None:
    path, _ = recorded
    out = tmp_path / "result.mcap"
    out.mkdir()
    (out / "precious").write_text("x")
    assert run_cli("process", path, "--out", out, "--force") == 1
    assert "is a folder" in capsys.readouterr().err
    assert listing_of(tmp_path) == ["result.mcap"] and listing_of(out) == ["precious"]


def test_unknown_output_type_and_bad_options(recorded, tmp_path: Path, capsys) -> None:
    path, _ = recorded
    assert run_cli("process", path, "--out", tmp_path / "result.xlsx") == 1
    assert "unknown output type '.xlsx'; use .mcap (ROS 2 bag), .csv or .parquet" in capsys.readouterr().err
    assert run_cli("process", path, "--out", tmp_path / "r.csv", "--acceleration", "first_difference", "--cutoff-hz", "4") == 1
    assert "first_difference has no filter" in capsys.readouterr().err
    assert run_cli("process", path, "--out", tmp_path / "r.csv", "--cutoff-hz", "80") == 1
    assert "cutoff_hz must lie in (0, 50.0) Hz" in capsys.readouterr().err
    assert run_cli("process", tmp_path / "absent.bag", "--out", tmp_path / "r.csv") == 1
    assert "absent.bag: no such file or directory" in capsys.readouterr().err
    assert listing_of(tmp_path) == []


def test_progress_bar_only_when_asked(recorded, tmp_path: Path, capsys) -> None:
    path, _ = recorded
    assert run_cli("process", path, "--out", tmp_path / "a.csv", "--progress") == 0
    assert "reading   [##############################] 100%  400/400" in capsys.readouterr().err
    assert run_cli("process", path, "--out", tmp_path / "b.csv") == 0  # stderr is not a terminal here
    assert capsys.readouterr().err == ""


def test_console_script_process_never_imports_rclpy(recorded, tmp_path: Path) -> None:
    path, _ = recorded
    code = (
        "import sys; from baxter_dynamics_ros.cli.main import main; "
        f"status = main(['process', {str(path)!r}, '--out', {str(tmp_path / 'r.csv')!r}]); "
        "assert 'rclpy' not in sys.modules, 'rclpy imported'; sys.exit(status)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert result.returncode == 0, result.stderr
    help_text = subprocess.run(
        [sys.executable, "-m", "baxter_dynamics_ros.cli", "--help"], capture_output=True, text=True, timeout=60, cwd=REPO
    ).stdout
    assert "process" in help_text and "play" in help_text
