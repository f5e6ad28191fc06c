"""The commands' input arguments as recordings: files, ROS 2 bag folders, folders of them, globs.

One expansion for ``process``, ``diagnose`` and ``calibrate``: a file stays itself, but a MATLAB
file of several recordings stands for each (``<file>.mat:<part>``, :mod:`msg_adapters.array_files`),
and ``<file>.mat:<part>`` names one (a file of arrays of no recording found in a folder or by a
pattern is passed over, as a file of another kind is); a ROS 2 bag
folder (it holds ``metadata.yaml``) is one recording; any other folder stands for the recordings
directly in it (bag files, bag folders and tables, by name; not its subfolders' contents: a folder
of folders of bags would mix unrelated sessions by accident); a pattern with ``*``, ``?`` or ``[``
that the shell left unexpanded (quoted) is expanded here, sorted, each match as above. A folder or
pattern that yields no recording is refused (RecordingFileError); a path that does not exist is
left for :func:`~baxter_dynamics_ros.cli.paths.check_paths` to refuse.

A recording too short for the offline methods that the user did not name (found in a folder, by a
pattern, or one part of a file of arrays of several) is passed over with a note
(:func:`too_short_found`); one named is refused by the method, as it cannot be used.
"""

from __future__ import annotations

import glob
import sys
from collections.abc import Sequence
from pathlib import Path

from ..errors import RecordingFileError

__all__ = ["expand_inputs", "too_short_found"]

_PATTERN_CHARACTERS = frozenset("*?[")


def expand_inputs(paths: Sequence[Path]) -> list[Path]:
    """The recordings that ``paths`` stand for, in the given order (each folder's and pattern's sorted)."""
    from msg_adapters.recording_files import INPUT_KINDS

    out: list[Path] = []
    for path in paths:
        if path.exists() or not _PATTERN_CHARACTERS & set(str(path)):
            out += _recordings_at(path, quiet=False)
            continue
        found = [r for match in sorted(glob.glob(str(path))) for r in _recordings_at(Path(match), quiet=True)]
        if not found:
            raise RecordingFileError(f"{path}: no recording matches this pattern ({INPUT_KINDS})")
        out += found
    return out


def _recordings_at(path: Path, *, quiet: bool) -> list[Path]:
    """path itself, or for a folder that is no bag the recordings in it. quiet (a pattern's match):
    [] for a file of another kind or a folder without recordings, instead of path or an error."""
    from msg_adapters.pointer_files import pointer_file
    from msg_adapters.recording_files import INPUT_KINDS, INPUT_SUFFIXES, is_bag_folder, recordings_in
    from msg_adapters.text_files import kind_suffix

    if is_bag_folder(path):
        return [path]
    if path.is_file():
        return recordings_in(path, listed=quiet) if not quiet or kind_suffix(path) in INPUT_SUFFIXES else []
    if not path.is_dir():
        return [] if quiet else [path]
    # a git-annex link whose content was not fetched is listed too: its read says so
    found = sorted(p for p in path.iterdir() if ((p.is_file() or pointer_file(p)) and kind_suffix(p) in INPUT_SUFFIXES) or is_bag_folder(p))
    found = [r for p in found for r in recordings_in(p, listed=True)]
    if not found and not quiet:
        raise RecordingFileError(f"{path}: a folder with no recording in it ({INPUT_KINDS}); give files, bag folders or a folder of them")
    return found


def too_short_found(paths: Sequence[Path], sizes: Sequence[tuple[int, float]], given: Sequence[Path]) -> dict[int, str]:
    """The expanded inputs of ``paths`` (with their (samples, span in s) of ``sizes``) to pass over,
    as {index: why}: those too short for the offline methods
    (:func:`~baxter_dynamics_ros.core.recording.length_shortfall`) and not one of ``given`` (the
    arguments as typed), each also said on stderr."""
    from ..core.recording import length_shortfall

    named = {str(p) for p in given}
    out = {}
    for k, (path, (samples, span_s)) in enumerate(zip(paths, sizes)):
        short = length_shortfall(samples, span_s)
        if short is not None and str(path) not in named:
            out[k] = short
            print(f"{path}: passed over, too short: {short}", file=sys.stderr)
    return out
