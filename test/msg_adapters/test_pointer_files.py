"""Git LFS and git-annex pointers in place of a dataset's files (msg_adapters.pointer_files): told
for what they are, with the command that fetches the file, by every reader and by the commands."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from cli_runs import listing, run_cli, the_error
from recorded_bags import joint_states, write_baxter_export

from baxter_dynamics_ros.errors import RecordingFileError
from msg_adapters.pointer_files import pointer_file
from msg_adapters.recording_files import read_recording, recordings_in

# As git-lfs writes one (its pointer specification): the version line, the oid, the size; LF line ends.
LFS_POINTER = "version https://git-lfs.github.com/spec/v1\noid sha256:4d7a214614ab2935c943f9e0ff69d22eadbb8f32b1258daaa5e2ca24d17e2393\nsize 1523942\n"
ANNEX_TARGET = "../.git/annex/objects/pX/8Q/SHA256E-s1523942--4d7a2146.csv/SHA256E-s1523942--4d7a2146.csv"


@pytest.mark.parametrize("name", ["run.csv", "run.bag", "run.mat", "run.csv.gz", "run.parquet"])
def test_a_git_lfs_pointer_is_told_for_what_it_is_by_every_reader(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_text(LFS_POINTER)
    assert recordings_in(path) == [path]
    with pytest.raises(RecordingFileError, match=r"run\.[a-z.]+: a Git LFS pointer to a file of 1,523,942 bytes, not the file itself: fetch it with `git lfs pull`"):
        read_recording(path)


def test_pointers_and_what_is_none(tmp_path: Path) -> None:
    hawser = tmp_path / "old.csv"
    hawser.write_text(LFS_POINTER.replace("git-lfs.github.com", "hawser.github.com"))
    assert "Git LFS pointer" in pointer_file(hawser)
    unlocked = tmp_path / "unlocked.csv"
    unlocked.write_text(ANNEX_TARGET.removeprefix("../.git") + "\n")
    assert pointer_file(unlocked) == "a git-annex pointer, not the file itself: fetch it with `git annex get`"
    link = tmp_path / "locked.csv"
    os.symlink(ANNEX_TARGET, link)
    assert pointer_file(link) == f"a git-annex link whose content is not in this clone ({ANNEX_TARGET}): fetch it with `git annex get`"
    broken = tmp_path / "broken.csv"
    os.symlink("nowhere.csv", broken)
    recording = write_baxter_export(tmp_path / "real.csv", joint_states(20))
    long_text = tmp_path / "notes.csv"
    long_text.write_text(LFS_POINTER + "#" * 1024)  # no pointer is this long: a file that begins so
    assert [pointer_file(p) for p in (broken, recording, long_text, tmp_path, tmp_path / "absent.csv")] == [None] * 5


def test_the_commands_refuse_a_pointer_in_one_line_writing_nothing(tmp_path: Path) -> None:
    pointer = tmp_path / "data" / "left_circle.csv"
    pointer.parent.mkdir()
    pointer.write_text(LFS_POINTER)
    before = listing(tmp_path)
    error = the_error(run_cli("process", pointer, "--arm", "left", "--out", tmp_path / "out.csv"))
    assert error == f"ERROR: {pointer}: a Git LFS pointer to a file of 1,523,942 bytes, not the file itself: fetch it with `git lfs pull` (or download the file)"
    os.symlink(ANNEX_TARGET, pointer.parent / "square.csv")
    error = the_error(run_cli("diagnose", "--train", pointer.parent / "square.csv", "--test", pointer, "--arm", "left", "--out", tmp_path / "d"))
    assert error.startswith(f"ERROR: {pointer.parent / 'square.csv'}: a git-annex link whose content is not in this clone")
    pointer.unlink()  # the folder holds the annex link alone: listed, and refused for what it is
    error = the_error(run_cli("calibrate", pointer.parent, "--arm", "left", "--out", tmp_path / "t.yaml"))
    assert "git-annex link" in error and "git annex get" in error
    assert before == ["data", "data/left_circle.csv"] and listing(tmp_path) == ["data", "data/square.csv"]  # no output
