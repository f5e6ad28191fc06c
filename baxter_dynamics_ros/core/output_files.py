"""Outputs written whole or not at all: every command's files go through here.

:func:`check_outputs` refuses, before any work, what would make writing fail: a missing folder, a
file where the folder should be, a folder where a file should be, an existing file (unless
replacing), a folder the user may not write. :func:`staged_outputs` then hands out fresh paths in
a temporary folder beside the targets (``.<name>.*.partial``, one per target folder, on the same
filesystem) and, when the block succeeds, moves them all into place; if the block, or one of the
moves, fails, the files already moved are taken back (replaced ones restored) and nothing new is
left. A folder of outputs that does not exist yet (``diagnose --out DIR``), with any of its parents
that do not exist either (as ``mkdir -p`` would make them), is staged whole and renamed into place
in one step.

Every OSError on the way (no permission, no space, a read-only filesystem) becomes one
:class:`~baxter_dynamics_ros.errors.OutputError` naming the path.
"""

from __future__ import annotations

import errno
import os
import secrets
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from ..errors import OutputError

__all__ = ["check_outputs", "staged_outputs"]


def _by_folder(targets: Sequence[Path]) -> dict[Path, list[Path]]:
    """The targets grouped by their folder, in order of first appearance."""
    groups: dict[Path, list[Path]] = {}
    for target in targets:
        groups.setdefault(target.parent, []).append(target)
    return groups


def _first_missing(folder: Path) -> Path | None:
    """The outermost of ``folder`` and its parents that does not exist (None if ``folder`` exists)."""
    if folder.exists():
        return None
    top = folder
    while not top.parent.exists() and top.parent != top:
        top = top.parent
    return top


def _staging_folder(folder: Path, made: list[Path]) -> Path:
    """A new temporary folder beside ``folder``'s contents (inside it, or beside the outermost
    missing folder of its path when that is to be made), listed in ``made`` before it is created, so
    that an interrupt (Ctrl-C) at any point leaves the caller a list to remove (:func:`_remove`)."""
    top = _first_missing(folder)
    where = folder if top is None else top.parent
    while True:
        path = where / f".{folder.name}.{secrets.token_hex(6)}.partial"
        made.append(path)
        try:
            path.mkdir(mode=0o700)
            return path
        except FileExistsError:
            made.remove(path)  # another's: never ours to remove
        except OSError as err:
            raise OutputError(f"{folder}: cannot write here ({err.strerror or err})") from err


def _remove(folders: list[Path]) -> None:
    """Remove the staging folders (those that exist), all of them even if Ctrl-C comes meanwhile;
    that interrupt is raised once they are gone."""
    interrupted: KeyboardInterrupt | None = None
    for folder in folders:
        while True:
            try:
                shutil.rmtree(folder, ignore_errors=True)
                break
            except KeyboardInterrupt as err:
                interrupted = err
    if interrupted is not None:
        raise interrupted


def check_outputs(targets: Sequence[str | os.PathLike[str]], *, replace: bool = False, option: str = "--out") -> None:
    """Refuse outputs that could not be written whole (module docstring); nothing is left behind.

    targets: the files to write; their folders and the folders' parents may be missing (they are
    then created, as ``mkdir -p`` would); replace: whether existing target files may be replaced (``--force``);
    option: the command-line option naming the output, for the messages.
    """
    paths = [Path(t) for t in targets]
    for folder, files in _by_folder(paths).items():
        if folder.exists() and not folder.is_dir():
            raise OutputError(f"{folder}: is a file, not a folder; choose another {option}")
        top = _first_missing(folder)
        if top is not None and not top.parent.is_dir():
            raise OutputError(f"{folder}: {top.parent} is a file, not a folder; choose another {option}")
        for path in files:
            if path.is_dir():
                raise OutputError(f"{path}: is a folder; not replacing it, choose another {option}")
        existing = [p.name for p in files if p.exists()]
        if existing and not replace:
            if len(paths) == 1:
                raise OutputError(f"{paths[0]}: exists already; choose another {option} or pass --force")
            raise OutputError(f"{folder}: holds earlier outputs ({', '.join(existing)}); choose another {option} or pass --force")
        made: list[Path] = []
        try:
            _staging_folder(folder, made)  # may we write there?
        finally:
            _remove(made)


@contextmanager
def staged_outputs(targets: Sequence[str | os.PathLike[str]], *, replace: bool = True, option: str = "--out") -> Iterator[list[Path]]:
    """Fresh paths, one per target (same names), to write in the block; moved onto the targets together.

    targets: files in one or more folders (see :func:`check_outputs`, which should have been called
    first). replace: existing targets are replaced, only once every new file is in place; False
    (a command without ``--force``) takes each destination atomically instead — a new folder by
    one rename, which fails once another one is there, a file by a hard link, which fails once
    another file is — so that an output another run wrote meanwhile (after :func:`check_outputs`)
    is refused (OutputError naming it and ``option``), never replaced, and nothing of this run is left.
    """
    paths = [Path(t) for t in targets]
    stagings: dict[Path, Path] = {}  # folder -> its staging folder
    made: list[Path] = []  # every staging folder, listed before it is created
    tops: dict[Path, Path | None] = {}  # folder -> the outermost of it and its parents missing when staged
    try:
        where: dict[Path, Path] = {}  # target -> staged path
        for folder, files in _by_folder(paths).items():
            stagings[folder] = staging = _staging_folder(folder, made)
            tops[folder] = top = _first_missing(folder)
            inner = staging if top is None else staging / folder.relative_to(top.parent)
            inner.mkdir(parents=True, exist_ok=True)
            where.update({target: inner / target.name for target in files})
        try:
            yield [where[p] for p in paths]
            _commit(stagings, where, None if replace else tops, option)
        except OSError as err:
            staged_as = {str(new): target for target, new in where.items()}
            shown = staged_as.get(str(err.filename), paths[0].parent if len(paths) > 1 else paths[0])
            raise OutputError(f"{shown}: cannot write the outputs ({err.strerror or err}); nothing was written") from err
    finally:
        _remove(made)


def _commit(stagings: dict[Path, Path], where: dict[Path, Path], exclusive: dict[Path, Path | None] | None, option: str) -> None:
    """Move every staged file onto its target, a new folder renamed into place whole; all or none
    (moved files taken back, replaced ones restored, new folders moved back). exclusive: None to
    replace existing targets; else each folder's outermost missing folder when it was staged, and
    no target, nor such a folder, that exists now is replaced (:func:`staged_outputs`)."""
    for target in where:
        if target.is_dir():
            raise IsADirectoryError(21, "a folder is in the way", str(target))
    undo: list[tuple[Path, Path | None]] = []  # (what was put in place, where its predecessor went)
    try:
        for folder, staging in stagings.items():
            top = _first_missing(folder) if exclusive is None else exclusive[folder]
            if top is not None:  # made whole: the outermost missing folder renamed into place
                made = staging / top.name  # staging was made in top's parent, mirroring it
                try:
                    os.rename(made, top)  # onto a folder another run made meanwhile: fails unless it is empty
                except OSError as err:
                    if exclusive is not None and err.errno in (errno.EEXIST, errno.ENOTEMPTY, errno.ENOTDIR, errno.EISDIR):
                        raise _taken(top, option) from err
                    raise
                undo.append((top, made))  # undone by renaming the folder back
                continue
            for k, (target, new) in enumerate((t, n) for t, n in where.items() if t.parent == folder):
                if exclusive is not None:
                    try:
                        os.link(new, target)  # fails if a file is there: never replaces one
                    except FileExistsError as err:
                        raise _taken(target, option) from err
                    undo.append((target, None))
                    continue
                old = None
                if target.exists():
                    old = staging / f".replaced-{k}"
                    os.replace(target, old)
                undo.append((target, old))
                os.replace(new, target)
    except BaseException:
        for placed, previous in reversed(undo):
            if placed.is_dir():
                os.rename(placed, previous)  # a new folder back into its staging folder
            elif previous is not None:
                os.replace(previous, placed)
            elif placed.exists():
                placed.unlink()
        raise


def _taken(target: Path, option: str) -> OutputError:
    return OutputError(
        f"{target}: appeared while this command ran (another run writing there?); not replacing it, "
        f"nothing was written: choose another {option} or pass --force"
    )
