"""Folders and patterns as the commands' inputs (issue 14 §1): real recordings in tmp_path.

An archive folder holds two bags written by the project's writer (single mcap files), a ROS 2 bag
folder (metadata.yaml and its mcap, written by rosbags), a CSV table, a file that is no recording
and a plain subfolder with a bag in it (not looked into). A second folder holds the test data.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_runs import listing, run_cli, the_error
from recorded_bags import write_reference_bag
from simulated_files import assert_json_close, simulated, write_states

from baxter_dynamics_ros.cli.inputs import expand_inputs


@pytest.fixture(scope="module")
def archive(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("archive")
    folder = root / "runs"
    folder.mkdir()
    paths = {"folder": folder, "a": write_states(folder / "a.mcap", simulated(12.0, 1)), "c": write_states(folder / "c.csv", simulated(12.0, 3))}
    states = simulated(12.0, 2)
    arrays = {"stamps_ns": states.stamps_ns, "position": states.position, "velocity": states.velocity, "effort": states.effort}
    paths["b"] = write_reference_bag(folder / "b", "mcap", arrays, names=states.names)
    (folder / "notes.md").write_text("not a recording\n")
    (folder / "sub").mkdir()
    write_states(folder / "sub" / "deeper.mcap", simulated(4.0, 5))
    held = root / "held"
    held.mkdir()
    paths["held"] = held
    paths["d"] = write_states(held / "d.mcap", simulated(6.0, 4))
    paths["empty"] = root / "empty"
    paths["empty"].mkdir()
    return paths


def test_folders_and_patterns_expand_to_their_recordings(archive) -> None:
    folder = archive["folder"]
    assert (folder / "b" / "metadata.yaml").is_file()
    assert expand_inputs([folder]) == [archive["a"], archive["b"], archive["c"]]  # sorted; no notes.md, no sub/
    assert expand_inputs([archive["b"]]) == [archive["b"]]  # a ROS 2 bag folder is one recording
    assert expand_inputs([Path(f"{folder}/*.mcap")]) == [archive["a"]]
    assert expand_inputs([Path(f"{folder}/[bc]*")]) == [archive["b"], archive["c"]]
    assert expand_inputs([Path(f"{folder.parent}/*")]) == [archive["d"], archive["a"], archive["b"], archive["c"]]  # held, runs; empty/ gives none
    assert expand_inputs([archive["d"], folder / "missing.mcap"]) == [archive["d"], folder / "missing.mcap"]  # left to check_paths


def test_diagnose_on_a_folder_and_a_pattern_is_the_diagnosis_of_the_files(archive, tmp_path: Path) -> None:
    from baxter_dynamics_ros import load_arm_model
    from baxter_dynamics_ros.diagnosis.procedure import diagnose
    from msg_adapters.recording_files import read_recording

    out = tmp_path / "out"
    result = run_cli("diagnose", "--train", archive["folder"], "--test", f"{archive['held']}/*.mcap", "--out", out, "--jobs", "1")
    assert result.returncode == 0, result.stderr
    doc = json.loads((out / "diagnosis.json").read_text())
    files = [archive[k] for k in "abc"]
    assert doc["train_files"] == [str(p) for p in files] and doc["test_files"] == [str(archive["d"])]
    read = [(str(p), read_recording(p, note=None)) for p in (*files, archive["d"])]
    expected = json.loads(json.dumps(diagnose(load_arm_model("right"), read[:3], read[3:]).to_dict()))
    assert_json_close(doc, expected)


def test_a_folder_or_pattern_without_recordings_is_refused(archive, tmp_path: Path) -> None:
    out = tmp_path / "out"
    line = the_error(run_cli("diagnose", "--train", archive["empty"], "--test", archive["d"], "--out", out))
    assert f"{archive['empty']}: a folder with no recording in it" in line
    line = the_error(run_cli("diagnose", "--train", archive["a"], "--test", f"{archive['held']}/*.csv", "--out", out))
    assert f"{archive['held']}/*.csv: no recording matches this pattern" in line
    line = the_error(run_cli("process", f"{archive['folder']}/*.db3", "--out", out))
    assert "no recording matches" in line
    line = the_error(run_cli("calibrate", archive["empty"], "--out", tmp_path / "t.yaml"))
    assert "a folder with no recording in it" in line
    assert listing(tmp_path) == []


def test_a_recording_given_twice_through_a_folder_is_refused(archive, tmp_path: Path) -> None:
    line = the_error(run_cli("diagnose", "--train", archive["folder"], "--test", archive["b"], "--out", tmp_path / "out"))
    assert f"{archive['b']} (in --test) is the same file as {archive['b']} (in --train)" in line
    assert listing(tmp_path) == []


def test_process_on_a_folder_writes_each_file_as_alone(archive, tmp_path: Path) -> None:
    import pyarrow.csv as pacsv

    out = tmp_path / "processed"
    result = run_cli("process", archive["folder"], "--out", out, "--format", "csv", "--jobs", "2")
    assert result.returncode == 0, result.stderr
    assert listing(out) == ["a.csv", "b.csv", "c.csv"]
    alone = tmp_path / "alone.csv"
    assert run_cli("process", archive["b"], "--out", alone).returncode == 0
    assert pacsv.read_csv(out / "b.csv").equals(pacsv.read_csv(alone))
    # A corrupt file among them: one error naming it, and no output at all.
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in ("a.mcap", "c.csv"):
        (broken / name).write_bytes(archive[name[0]].read_bytes())
    (broken / "bad.mcap").write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 8)
    again = tmp_path / "again"
    line = the_error(run_cli("process", broken, "--out", again, "--jobs", "2"))
    assert str(broken / "bad.mcap") in line
    assert not again.exists()


def test_calibrate_takes_a_pattern(archive, tmp_path: Path) -> None:
    import yaml

    out = tmp_path / "thresholds.yaml"
    result = run_cli("calibrate", f"{archive['folder']}/[ac]*", "--out", out)
    assert result.returncode == 0, result.stderr
    doc = yaml.safe_load(out.read_text())
    assert str(archive["a"]) in json.dumps(doc) and str(archive["c"]) in json.dumps(doc)
