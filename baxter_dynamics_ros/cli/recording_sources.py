"""Recording files as the diagnosis' sources: a path and its reader's options, read where it runs.

:class:`RecordingFile` is small and picklable, so a worker process or a dask worker reads the file
itself (from the path it sees: a cluster needs the files on a filesystem shared with its workers).
:func:`inspect` is the command line's first look at a file: its arm, size and a digest of its
samples (for the refusal of a recording given twice), and the reader's notes to show the user.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

from ..core.recording import Recording

__all__ = ["Inspection", "RecordingFile", "inspect"]


@dataclass(frozen=True)
class RecordingFile:
    """One recording file (bag, bag folder or table) with the reader's options.

    label: its name in results and errors; rows: (start, stop) to keep only those samples (a part
    of the file held out as test data), None for all.
    """

    label: str
    path: str
    topic: str
    arm: str | None = None
    rate_hz: float | None = None
    rows: tuple[int, int] | None = None

    def read(self, note=None) -> Recording:
        """The recording (RecordingFileError naming the path if the file cannot be read); note: the
        reader's messages for the user (None: dropped)."""
        from msg_adapters.recording_files import read_recording

        rec = read_recording(self.path, topic=self.topic, arm=self.arm, rate_hz=self.rate_hz, note=note)
        if self.rows is None:
            return rec
        a, b = self.rows
        return Recording(rec.side, rec.joint_names, rec.stamps_ns[a:b], rec.q[a:b], rec.qd[a:b], rec.effort[a:b])


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
