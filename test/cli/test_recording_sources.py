"""The diagnosis' recording files and their scratch folder (issue 14 §2): a file is decoded once per
run, the later passes load the decoded arm; a changed file is decoded anew, a scratch folder that
cannot be written costs only speed, and the command leaves no scratch behind.

References: the reader's own decode of the file (``read_recording``), compared bit for bit.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest
from cli_runs import listing, run_cli, the_error
from simulated_files import simulated, write_states

from baxter_dynamics_ros.cli.recording_sources import RecordingFile, load, store
from baxter_dynamics_ros.core.recording import Recording
from msg_adapters.recording_files import read_recording

TOPIC = "/robot/joint_states"


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_states(tmp_path_factory.mktemp("sources") / "run.mcap", simulated(6.0, 5))


def _same(a: Recording, b: Recording) -> None:
    assert (a.side, a.joint_names) == (b.side, b.joint_names)
    for name in ("stamps_ns", "q", "qd", "effort"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_the_later_reads_load_what_the_first_decoded(bag: Path, tmp_path: Path) -> None:
    source = RecordingFile("run", str(bag), TOPIC, scratch=str(tmp_path))
    decoded = read_recording(str(bag), topic=TOPIC)
    _same(source.read(), decoded)
    [kept] = tmp_path.iterdir()
    _same(load(kept), decoded)
    # What the scratch file holds is what a later read returns: plant a changed effort there.
    store(dataclasses.replace(decoded, effort=decoded.effort + 1.0), kept)
    np.testing.assert_array_equal(source.read().effort, decoded.effort + 1.0)
    # Rows of a held-out part come from the same scratch file.
    part = dataclasses.replace(source, rows=(10, 200)).read()
    np.testing.assert_array_equal(part.effort, decoded.effort[10:200] + 1.0)
    np.testing.assert_array_equal(part.stamps_ns, decoded.stamps_ns[10:200])


def test_a_changed_file_is_decoded_again(bag: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy.mcap"
    copy.write_bytes(bag.read_bytes())
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    source = RecordingFile("copy", str(copy), TOPIC, scratch=str(scratch))
    first = source.read()
    [kept] = scratch.iterdir()
    store(dataclasses.replace(first, effort=first.effort + 1.0), kept)  # a stale entry, were the key kept
    copy.unlink()
    write_states(copy, simulated(6.0, 6))
    os.utime(copy, ns=(os.stat(kept).st_mtime_ns + 10**9,) * 2)
    _same(source.read(), read_recording(str(copy), topic=TOPIC))


def test_a_scratch_folder_that_cannot_be_written_costs_only_speed(bag: Path, tmp_path: Path) -> None:
    missing = tmp_path / "no" / "such" / "folder"
    _same(RecordingFile("run", str(bag), TOPIC, scratch=str(missing)).read(), read_recording(str(bag), topic=TOPIC))
    assert listing(tmp_path) == []
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("x")
    _same(RecordingFile("run", str(bag), TOPIC, scratch=str(not_a_folder)).read(), read_recording(str(bag), topic=TOPIC))
    assert listing(tmp_path) == ["file"]


def test_a_corrupt_scratch_file_is_decoded_again(bag: Path, tmp_path: Path) -> None:
    source = RecordingFile("run", str(bag), TOPIC, scratch=str(tmp_path))
    source.read()
    [kept] = tmp_path.iterdir()
    kept.write_bytes(b"PK\x03\x04 not a zip")
    _same(source.read(), read_recording(str(bag), topic=TOPIC))


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_the_command_leaves_no_scratch_behind(bag: Path, tmp_path: Path, jobs: str) -> None:
    temp = tmp_path / "tmp"
    temp.mkdir()
    other = bag.parent / f"other{jobs}.mcap"
    if not other.exists():
        write_states(other, simulated(12.0, 7))  # training data need 10 s
    env = {"TMPDIR": str(temp)}
    result = run_cli("diagnose", "--train", other, "--test", bag, "--out", tmp_path / "out", "--jobs", jobs, env=env)
    assert result.returncode == 0, result.stderr
    assert listing(temp) == []
    # Also when the run is refused after the files were read: the same samples in two files.
    twin = tmp_path / "twin.mcap"
    twin.write_bytes(bag.read_bytes())
    line = the_error(run_cli("diagnose", "--train", bag, other, "--test", twin, "--out", tmp_path / "out2", "--jobs", jobs, env=env))
    assert "holds the same samples as" in line
    assert listing(temp) == []
