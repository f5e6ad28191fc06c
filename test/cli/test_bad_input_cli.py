"""Bad input to every command, as a hostile user gives it (issues 11 §4 and 12).

Each case runs ``baxter-dynamics`` in a subprocess and checks the exit code, the one ``ERROR:``
line (no traceback) and that nothing new was written.
"""

from __future__ import annotations

import resource
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from cli_runs import REPO, listing, run_cli, the_error
from recorded_bags import BAXTER_JOINTS, joint_states, write_baxter_export

N = 600


@pytest.fixture(scope="module")
def export_100_hz(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A table in the real recordings' layout (no time column) of the right arm, 6 s at 100 Hz."""
    return write_baxter_export(tmp_path_factory.mktemp("in") / "export.csv", joint_states(N, names=BAXTER_JOINTS), side="right")


def rate_in(line: str) -> float:
    """The estimated rate an error line names ("... estimated ..., 99.98 Hz ...")."""
    import re

    (rate,) = re.findall(r"estimated from position and velocity, (\d+\.\d+) Hz", line)
    return float(rate)


@pytest.mark.parametrize("command", ["process", "diagnose", "calibrate"])
def test_a_rate_that_disagrees_with_the_estimate_is_refused(export_100_hz: Path, tmp_path: Path, command: str) -> None:
    out = {"process": tmp_path / "out.csv", "diagnose": tmp_path / "diag", "calibrate": tmp_path / "thresholds.yaml"}[command]
    inputs = {"diagnose": ["--train", export_100_hz]}.get(command, [export_100_hz])
    result = run_cli(command, *inputs, "--out", out, "--rate-hz", "80")
    line = the_error(result)
    assert str(export_100_hz) in line and "--rate-hz 80 disagrees" in line
    assert rate_in(line) == pytest.approx(100.0, rel=0.01)
    assert listing(tmp_path) == []


# ------------------------------------------------------------------------------------- inputs
@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Simulated right-arm recordings as the robot publishes them (21 joints, the left arm still):
    ``train`` (12 s) and ``test`` (4 s) bags, ``table`` (the test data as CSV), ``short`` (1 s)."""
    from baxter_dynamics_ros.simulation.plant import simulate
    from baxter_dynamics_ros.simulation.spec import SimulationSpec
    from msg_adapters.recording_files import write_joint_states
    from msg_adapters.robot_joint_states import robot_joint_states

    folder = tmp_path_factory.mktemp("sim")
    paths = {}
    for name, duration_s, seed, suffix in (("train", 12.0, 1, ".mcap"), ("test", 4.0, 2, ".mcap"), ("table", 4.0, 2, ".csv"), ("short", 1.0, 3, ".mcap")):
        result = simulate(SimulationSpec("random", duration_s, 100.0, seed=seed))
        states = robot_joint_states(result.recording(), result.other_q, result.other_effort)
        paths[name] = folder / f"{name}{suffix}"
        write_joint_states(paths[name], states.stamps_ns, states.names, states.position, states.velocity, states.effort)
    return paths


@pytest.fixture(scope="module")
def bad_yaml(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``binary``: bytes that are not UTF-8 (as a wrong file picked by mistake); ``empty``: only a comment."""
    folder = tmp_path_factory.mktemp("yaml")
    (folder / "binary.yaml").write_bytes(bytes(range(256)) * 4)
    (folder / "empty.yaml").write_text("# nothing here\n")
    return {"binary": folder / "binary.yaml", "empty": folder / "empty.yaml"}


def commands(sim: dict[str, Path], out: Path) -> dict[str, list]:
    """One run of each command that writes, with its output in the folder ``out``."""
    return {
        "process": ["process", sim["test"], "--out", out / "torques.csv"],
        "diagnose": ["diagnose", "--train", sim["train"], "--test", sim["test"], "--out", out / "diagnosis"],
        "calibrate": ["calibrate", sim["train"], "--out", out / "thresholds.yaml"],
        "simulate": ["simulate", "--duration", "1", "--out", out / "sim.mcap"],
    }


# ---------------------------------------------------------------------------- binary and empty YAML
@pytest.mark.parametrize(
    ("command", "option"),
    [("simulate", "--effects"), ("calibrate", "--effects"), ("process", "--model"), ("diagnose", "--model")],
)
@pytest.mark.parametrize("kind", ["binary", "empty"])
def test_a_binary_or_empty_yaml_file_is_one_error(sim, bad_yaml, tmp_path: Path, command: str, option: str, kind: str) -> None:
    result = run_cli(*commands(sim, tmp_path)[command], option, bad_yaml[kind])
    line = the_error(result)
    what = "effects file" if option == "--effects" else "model file"
    assert line.startswith(f"ERROR: {bad_yaml[kind]}: the {what} is ")
    assert ("not UTF-8 text" if kind == "binary" else "is empty") in line
    assert listing(tmp_path) == []


# ------------------------------------------------------------------------------------- outputs
def _can_write(folder: Path) -> bool:
    probe = folder / ".probe"
    try:
        probe.write_text("")
    except OSError:
        return False
    probe.unlink()
    return True


@pytest.fixture
def locked(tmp_path: Path) -> Iterator[Path]:
    """A folder the user may not write into: mode 555, or, for root (whom modes do not stop), the
    immutable attribute (chattr +i); skipped where neither holds."""
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o555)
    immutable = False
    try:
        if _can_write(folder):
            immutable = subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode == 0
            if not immutable or _can_write(folder):
                pytest.skip("cannot make a folder unwritable here (running as root, and chattr +i is not available)")
        yield folder
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
        folder.chmod(0o755)


@pytest.mark.parametrize("command", ["process", "diagnose", "calibrate", "simulate"])
def test_an_output_folder_the_user_may_not_write_is_one_error(sim, locked: Path, command: str) -> None:
    line = the_error(run_cli(*commands(sim, locked)[command]))
    assert "cannot write here" in line and str(locked) in line
    assert listing(locked) == []


def test_diagnose_out_naming_a_file_is_one_error(sim, tmp_path: Path) -> None:
    out = tmp_path / "notes.txt"
    out.write_text("keep")
    line = the_error(run_cli("diagnose", "--train", sim["train"], "--test", sim["test"], "--out", out))
    assert line == f"ERROR: {out}: is a file, not a folder; choose another --out"
    assert listing(tmp_path) == ["notes.txt"] and out.read_text() == "keep"


def test_an_output_that_is_a_folder_is_refused_before_any_work(sim, tmp_path: Path) -> None:
    out = tmp_path / "diagnosis"
    (out / "report.html").mkdir(parents=True)
    line = the_error(run_cli("diagnose", "--train", sim["train"], "--test", sim["test"], "--out", out, "--force"))
    assert f"{out / 'report.html'}: is a folder" in line
    assert listing(tmp_path) == ["diagnosis", "diagnosis/report.html"]


def _file_size_limit(limit_bytes: int):
    def limit() -> None:  # in the child: writing past the limit fails with EFBIG (Python ignores SIGXFSZ)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return limit


def test_diagnose_leaves_nothing_when_one_output_cannot_be_written(sim, tmp_path: Path) -> None:
    """The outputs are written one after the other (report.html last, the largest): with a file size
    limit between report.html's size and the others', the last write fails after the others succeeded."""
    whole = tmp_path / "whole"
    args = ["--train", sim["train"], "--test", sim["test"]]
    assert run_cli("diagnose", *args, "--out", whole).returncode == 0
    sizes = {p.name: p.stat().st_size for p in whole.iterdir()}
    others = max(size for name, size in sizes.items() if name != "report.html")
    assert sizes["report.html"] > others
    out = tmp_path / "out"
    out.mkdir()
    (out / "diagnosis.json").write_text("{}")  # an earlier diagnosis' file, to be replaced only on success
    command = [sys.executable, "-m", "baxter_dynamics_ros.cli", "diagnose", *map(str, args), "--out", str(out), "--force"]
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=600,
                            preexec_fn=_file_size_limit((others + sizes["report.html"]) // 2))  # fmt: skip
    line = the_error(result)
    assert "File too large" in line and "nothing was written" in line
    assert listing(out) == ["diagnosis.json"] and (out / "diagnosis.json").read_text() == "{}"
    fresh = tmp_path / "fresh"  # a folder to be made: not made at all
    result = subprocess.run([*command[:-3], "--out", str(fresh)], cwd=REPO, capture_output=True, text=True, timeout=600,
                            preexec_fn=_file_size_limit((others + sizes["report.html"]) // 2))  # fmt: skip
    the_error(result)
    assert listing(tmp_path) == sorted(["whole", "out", "out/diagnosis.json", *(f"whole/{n}" for n in sizes)])


# --------------------------------------------------------------------------- results that would lie
def test_the_same_recording_in_train_and_test_is_refused(sim, tmp_path: Path) -> None:
    line = the_error(run_cli("diagnose", "--train", sim["train"], "--test", sim["train"], "--out", tmp_path / "d"))
    assert f"{sim['train']} (in --test) is the same file as {sim['train']} (in --train)" in line
    copy = tmp_path / "copy.mcap"
    copy.write_bytes(sim["train"].read_bytes())
    line = the_error(run_cli("diagnose", "--train", sim["train"], "--test", copy, "--out", tmp_path / "d"))
    assert f"{copy} (in --test) holds the same samples as {sim['train']} (in --train)" in line
    line = the_error(run_cli("diagnose", "--train", sim["train"], copy, "--test", sim["test"], "--out", tmp_path / "d"))
    assert "(in --train) holds the same samples as" in line
    assert listing(tmp_path) == ["copy.mcap"]


@pytest.mark.parametrize("command", ["process", "diagnose", "calibrate"])
def test_an_arm_that_does_not_move_is_refused_naming_the_one_that_does(sim, tmp_path: Path, command: str) -> None:
    line = the_error(run_cli(*commands(sim, tmp_path)[command], "--arm", "left"))
    assert "the left arm does not move here" in line and "the right arm moves and has effort: pass --arm right" in line
    assert listing(tmp_path) == []


def test_a_table_lacking_one_column_of_the_moving_arm_is_refused_naming_it(sim, tmp_path: Path) -> None:
    header, *rows = sim["table"].read_text().splitlines()
    names = header.split(",")
    k = names.index("effort_right_w2")
    table = tmp_path / "lacking.csv"
    table.write_text("\n".join(",".join(v for i, v in enumerate(line.split(",")) if i != k) for line in [header, *rows]) + "\n")
    line = the_error(run_cli("process", table, "--out", tmp_path / "out.csv"))
    assert "the left arm does not move here" in line and "the right arm moves, but effort_right_w2 is missing" in line
    assert listing(tmp_path) == ["lacking.csv"]


def test_a_recording_without_effort_is_refused(sim, tmp_path: Path) -> None:
    header, *rows = sim["table"].read_text().splitlines()
    names = header.split(",")
    efforts = {i for i, n in enumerate(names) if n.startswith("effort_")}
    table = tmp_path / "no_effort.csv"
    table.write_text("\n".join([header, *(",".join("0" if i in efforts else v for i, v in enumerate(r.split(","))) for r in rows)]) + "\n")
    line = the_error(run_cli("diagnose", "--train", sim["train"], "--test", table, "--out", tmp_path / "d"))
    assert f"{table}: the right arm has no effort here (every value is 0)" in line
    assert listing(tmp_path) == ["no_effort.csv"]


def test_recordings_shorter_than_the_methods_need_are_refused(sim, tmp_path: Path) -> None:
    line = the_error(run_cli("diagnose", "--train", sim["train"], "--test", sim["short"], "--out", tmp_path / "d"))
    assert line == f"ERROR: {sim['short']}: 100 samples, 1.00 s; a test recording needs at least 200 samples and 2 s"
    line = the_error(run_cli("diagnose", "--train", sim["test"], "--test", sim["train"], "--out", tmp_path / "d"))
    assert line == "ERROR: the training recordings hold 4.00 s together; at least 10 s are needed"
    line = the_error(run_cli("calibrate", sim["short"], sim["train"], "--out", tmp_path / "t.yaml"))
    assert line == f"ERROR: {sim['short']}: 100 samples, 1.00 s; a calibration recording needs at least 200 samples and 2 s"
    line = the_error(run_cli("calibrate", sim["test"], "--out", tmp_path / "t.yaml"))
    assert line == "ERROR: the calibration recordings hold 4.00 s together; at least 10 s are needed"
    assert listing(tmp_path) == []


@pytest.mark.parametrize("velocity", ["[]", "[0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0]"])
def test_a_dump_of_one_message_is_refused_as_one_sample(tmp_path: Path, velocity: str) -> None:
    """`ros2 topic echo` saved after one message, with velocities or without (nothing to difference):
    one sample is no time series, said as such (not as samples that are NaN)."""
    names = "".join(f"- left_{j}\n" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
    values = "".join(f"- {0.1 * k}\n" for k in range(7))
    dump = tmp_path / "one_message.txt"
    dump.write_text(
        "header:\n  stamp:\n    sec: 100\n    nanosec: 0\n  frame_id: ''\n"
        f"name:\n{names}position:\n{values}velocity: {velocity}\neffort:\n{values}---\n"
    )
    line = the_error(run_cli("process", dump, "--out", tmp_path / "out.csv"))
    assert line == f"ERROR: {dump}: holds 1 sample(s) of the arm: a recording is a time series of at least 2"
    assert listing(tmp_path) == ["one_message.txt"]


def test_play_on_a_table_says_that_it_takes_bags(sim) -> None:
    line = the_error(run_cli("play", sim["table"]))
    assert line.startswith(f"ERROR: {sim['table']}: play takes bags (.bag, a ROS 2 bag folder, .mcap, .db3), not tables")
