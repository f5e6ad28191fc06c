"""Recording files as the diagnosis' sources: a path and its reader's options, read where it runs.

:class:`RecordingFile` is small and picklable, so a worker process or a dask worker reads the file
itself (from the path it sees: a cluster needs the files on a filesystem shared with its workers).
:func:`inspect` is the command line's first look at a file: its arm, size and a digest of its
samples (for the refusal of a recording given twice), and the reader's notes to show the user.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.joints import arm_joint_names
from ..core.recording import Recording

__all__ = ["Inspection", "RecordingFile", "inspect", "load", "store"]


@dataclass(frozen=True)
class RecordingFile:
    """One recording file (bag, bag folder or table) with the reader's options.

    label: its name in results and errors; rows: (start, stop) to keep only those samples (a part
    of the file held out as test data), None for all; scratch: a folder of this run where the first
    read leaves the decoded arm's arrays (:func:`store`) and later reads take them from (a pass
    after the first costs a load instead of a decode), None to decode at every read.
    """

    label: str
    path: str
    topic: str
    arm: str | None = None
    rate_hz: float | None = None
    rows: tuple[int, int] | None = None
    scratch: str | None = None

    def read(self, note=None) -> Recording:
        """The recording (RecordingFileError naming the path if the file cannot be read); note: the
        reader's messages for the user (None: dropped; a read from the scratch folder has none)."""
        from msg_adapters.recording_files import read_recording

        kept = None if self.scratch is None else self._scratch_file()
        rec = load(kept) if kept is not None and kept.exists() else None
        if rec is None:
            rec = read_recording(self.path, topic=self.topic, arm=self.arm, rate_hz=self.rate_hz, note=note)
            if kept is not None:
                store(rec, kept)
        if self.rows is None:
            return rec
        a, b = self.rows
        return Recording(rec.side, rec.joint_names, rec.stamps_ns[a:b], rec.q[a:b], rec.qd[a:b], rec.effort[a:b])

    def _scratch_file(self) -> Path:
        """Where this file's decoded arrays go in the scratch folder: named by the path, the
        reader's options and the file's size and modification time (a changed file is decoded anew)."""
        from msg_adapters.recording_files import source_file

        path = source_file(self.path)
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        stats = [(str(p), p.stat().st_size, p.stat().st_mtime_ns) for p in files]
        key = json.dumps([str(path.resolve()), self.path, self.topic, self.arm, self.rate_hz, stats])  # self.path: a part of a MATLAB file
        return Path(self.scratch) / f"{hashlib.sha1(key.encode()).hexdigest()[:16]}.npz"


def store(rec: Recording, path: Path) -> None:
    """Write rec's arrays to path (.npz, written aside and renamed: never half there); a scratch
    folder that cannot be written only costs speed, so an OSError leaves no file and is dropped."""
    partial = path.with_name(path.name + ".partial")
    try:
        with open(partial, "wb") as f:
            np.savez(f, side=rec.side, stamps_ns=rec.stamps_ns, q=rec.q, qd=rec.qd, effort=rec.effort)
        os.replace(partial, path)
    except OSError:
        with contextlib.suppress(OSError):  # also when the folder is not there at all
            partial.unlink(missing_ok=True)


def load(path: Path) -> Recording | None:
    """The recording :func:`store` wrote to path; None if it cannot be read."""
    try:
        with np.load(path) as z:
            side = str(z["side"])
            return Recording(side, arm_joint_names(side), z["stamps_ns"], z["q"], z["qd"], z["effort"])
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None


@dataclass(frozen=True)
class Inspection:
    """A file's arm side, samples, span (s), a digest of q, q̇ and effort, and the reader's notes."""

    side: str
    samples: int
    span_s: float
    digest: str
    notes: tuple[str, ...]


def inspect(source: RecordingFile) -> Inspection:
    """Read ``source`` once and describe it (module docstring)."""
    notes: list[str] = []
    rec = source.read(note=notes.append)
    digest = hashlib.sha256()
    for array in (rec.q, rec.qd, rec.effort):
        digest.update(array.tobytes())
    return Inspection(rec.side, len(rec), rec.span_s, digest.hexdigest(), tuple(notes))
