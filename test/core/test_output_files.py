"""Outputs all or nothing (baxter_dynamics_ros.core.output_files), on real files in tmp_path."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_runs import listing

from baxter_dynamics_ros.core.output_files import check_outputs, staged_outputs
from baxter_dynamics_ros.errors import OutputError


def test_outputs_appear_together_and_replace_old_ones_only_at_the_end(tmp_path: Path) -> None:
    targets = [tmp_path / "a.txt", tmp_path / "b.txt"]
    targets[0].write_text("old a")
    with staged_outputs(targets) as staged:
        assert [p.name for p in staged] == ["a.txt", "b.txt"] and all(p.parent != tmp_path for p in staged)
        for path, text in zip(staged, ("new a", "new b")):
            path.write_text(text)
        assert targets[0].read_text() == "old a" and not targets[1].exists()
    assert [p.read_text() for p in targets] == ["new a", "new b"]
    assert listing(tmp_path) == ["a.txt", "b.txt"]


def test_a_failure_while_writing_leaves_nothing_new(tmp_path: Path) -> None:
    targets = [tmp_path / "a.txt", tmp_path / "b.txt"]
    targets[0].write_text("old a")
    with pytest.raises(RuntimeError, match="half way"), staged_outputs(targets) as staged:
        staged[0].write_text("new a")
        raise RuntimeError("half way")
    assert listing(tmp_path) == ["a.txt"] and targets[0].read_text() == "old a"


def test_a_failed_move_takes_back_the_files_already_moved(tmp_path: Path) -> None:
    """The third move fails (its file was never written): the first two are undone, the replaced one restored."""
    targets = [tmp_path / name for name in ("a.txt", "b.txt", "c.txt")]
    targets[0].write_text("old a")
    with pytest.raises(OutputError, match=f"{tmp_path / 'c.txt'}: cannot write the outputs .*nothing was written"):
        with staged_outputs(targets) as staged:
            staged[0].write_text("new a")
            staged[1].write_text("new b")
    assert listing(tmp_path) == ["a.txt"] and targets[0].read_text() == "old a"


def test_a_new_folder_of_outputs_appears_whole_or_not_at_all(tmp_path: Path) -> None:
    folder = tmp_path / "out"
    targets = [folder / "x.json", folder / "y.png"]
    with pytest.raises(RuntimeError), staged_outputs(targets) as staged:
        staged[0].write_text("{}")
        raise RuntimeError
    assert listing(tmp_path) == []
    with staged_outputs(targets) as staged:
        for path in staged:
            path.write_text("done")
    assert listing(tmp_path) == ["out", "out/x.json", "out/y.png"]


def test_check_outputs_refuses_what_could_not_be_written_whole(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("x")
    (tmp_path / "dir.csv").mkdir()
    (tmp_path / "old.csv").write_text("x")
    cases = [
        ([tmp_path / "file" / "a.json"], f"{tmp_path / 'file'}: is a file, not a folder; choose another --out"),
        ([tmp_path / "file" / "x" / "a.json"], f"{tmp_path / 'file' / 'x'}: {tmp_path / 'file'} is a file, not a folder; choose another --out"),
        ([tmp_path / "dir.csv"], f"{tmp_path / 'dir.csv'}: is a folder; not replacing it, choose another --out"),
        ([tmp_path / "old.csv"], f"{tmp_path / 'old.csv'}: exists already; choose another --out or pass --force"),
        ([tmp_path / "old.csv", tmp_path / "new.csv"], f"{tmp_path}: holds earlier outputs (old.csv); choose another --out or pass --force"),
    ]
    for targets, message in cases:
        with pytest.raises(OutputError) as refused:
            check_outputs(targets)
        assert str(refused.value) == message
    check_outputs([tmp_path / "old.csv"], replace=True)
    check_outputs([tmp_path / "new" / "a.json"])
    check_outputs([tmp_path / "no" / "such" / "a.json"])  # parents made as mkdir -p would
    assert listing(tmp_path) == ["dir.csv", "file", "old.csv"]


def test_outputs_in_several_folders_are_taken_back_together(tmp_path: Path) -> None:
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "page.md").write_text("old page")
    targets = [tmp_path / "figures" / "fig.png", tmp_path / "docs" / "page.md", tmp_path / "docs" / "table.md"]
    with pytest.raises(OutputError, match="table.md: cannot write the outputs"), staged_outputs(targets) as staged:
        staged[0].write_text("png")
        staged[1].write_text("new page")  # table.md is never written: its move fails, after the others
    assert listing(tmp_path) == ["docs", "docs/page.md"] and (tmp_path / "docs" / "page.md").read_text() == "old page"


@pytest.mark.parametrize("when", ["check", "stage"])
def test_ctrl_c_just_after_a_staging_folder_is_made_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, when: str) -> None:
    """Ctrl-C arriving the instant a staging folder exists, before anything has noted it (in the
    check of a new output folder, or in staging one): the folder is still removed, nothing is left.
    The interrupt is planted in the folder's creation: the real mkdir runs, then KeyboardInterrupt."""
    real_mkdir = Path.mkdir

    def mkdir_then_interrupt(self: Path, *args, **kwargs) -> None:
        real_mkdir(self, *args, **kwargs)
        if self.name.endswith(".partial"):
            raise KeyboardInterrupt

    target = tmp_path / "new" / "out.csv"
    if when == "stage":
        check_outputs([target])
    monkeypatch.setattr(Path, "mkdir", mkdir_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        if when == "check":
            check_outputs([target])
        else:
            with staged_outputs([target]) as (staged,):
                staged.write_text("x")
    monkeypatch.undo()
    assert listing(tmp_path) == []


def test_without_replacing_a_file_that_appears_meanwhile_stops_all_and_is_left_alone(tmp_path: Path) -> None:
    """replace=False (no --force) into an existing folder: another run writes b.txt while this one
    stages; at the end this one refuses, a.txt (already linked into place) is taken back, and the
    other run's b.txt is left as it wrote it."""
    targets = [tmp_path / "a.txt", tmp_path / "b.txt"]
    with pytest.raises(OutputError, match=f"{tmp_path / 'b.txt'}: appeared while this command ran"):
        with staged_outputs(targets, replace=False) as staged:
            for path, text in zip(staged, ("mine a", "mine b")):
                path.write_text(text)
            targets[1].write_text("theirs")
    assert listing(tmp_path) == ["b.txt"] and targets[1].read_text() == "theirs"
