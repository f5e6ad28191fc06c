"""Which reader and writer a path calls for, and output written whole or not at all.

Inputs, by what their suffix says they hold (:func:`~msg_adapters.text_files.kind_suffix`): ``.csv``,
``.txt``, ``.tsv``, ``.dat`` (each also compressed: ``.gz``, ``.bz2``, ``.xz`` after it;
:mod:`msg_adapters.text_files`) and ``.parquet`` are tables (:mod:`msg_adapters.csv_io`; joint states
dumped to text by ``rostopic echo -p``, bagpy or echo, recognised by their first line: :mod:`msg_adapters.topic_dumps`);
``.mat``, ``.npz``, ``.h5`` and ``.hdf5`` are files of arrays of one or more recordings,
``<file>.mat:<part>`` naming one (:mod:`msg_adapters.array_files`); ``.bag``, ``.mcap``, ``.db3`` and folders are bags
(:mod:`msg_adapters.bag_io`; a ROS 2 bag is a folder); a file of any other kind is refused, naming the kinds.

Outputs, by the path's extension:

- ``.mcap``: one mcap file holding a ROS 2 bag (readable by rosbags, ``ros2 bag`` and Foxglove);
- ``.csv`` / ``.parquet``: a table.

Output is written whole or not at all (:mod:`baxter_dynamics_ros.core.output_files`): into a temporary
folder beside its destination, renamed into place at the end, so a failure leaves nothing partial
behind (and an existing output, replaced only on success).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.core.output_files import check_outputs, staged_outputs
from baxter_dynamics_ros.core.recording import ProcessedRecording, Recording
from baxter_dynamics_ros.errors import RecordingError, RecordingFileError

from .bag_io import DEFAULT_TOPIC, Progress, read_bag_recording, write_joint_state_bag, write_processed_bag
from .csv_io import Note, joint_state_columns, read_table_recording, write_processed_table, write_table
from .array_files import ARRAY_FILES, array_parts, read_array_recording, split_part
from .pointer_files import pointer_file
from .topic_dumps import is_topic_dump, read_topic_dump_recording
from .text_files import COMPRESSION_SUFFIXES, TEXT_SUFFIXES, kind_suffix

__all__ = [
    "BAG_SUFFIXES", "INPUT_KINDS", "INPUT_SUFFIXES", "OUTPUT_FORMATS", "TABLE_SUFFIXES", "is_bag_folder", "check_output", "print_to_stderr", "read_recording",
    "recordings_in", "source_file", "write_joint_states", "write_processed",
]  # fmt: skip

TABLE_SUFFIXES = (*TEXT_SUFFIXES, ".parquet")
#: Bag files the readers know (a ROS 2 bag folder, holding metadata.yaml, is read too).
BAG_SUFFIXES = (".bag", ".mcap", ".db3")
#: Every kind of file an input may be (:func:`~msg_adapters.text_files.kind_suffix`; a ROS 2 bag folder besides).
INPUT_SUFFIXES = (*BAG_SUFFIXES, *TABLE_SUFFIXES, *ARRAY_FILES)
#: The kinds of input, in words for messages.
INPUT_KINDS = (
    f"bags {', '.join(BAG_SUFFIXES)}, ROS 2 bag folders, tables {', '.join(TABLE_SUFFIXES)} "
    f"(text tables also compressed: {', '.join(COMPRESSION_SUFFIXES)}), files of arrays .mat (MATLAB), .npz (NumPy), .h5, .hdf5 (HDF5)"
)
#: Output extension -> format.
OUTPUT_FORMATS = {".mcap": "mcap", ".csv": "csv", ".parquet": "parquet"}


def print_to_stderr(message: str) -> None:
    """Print a one-line message for the user on stderr (the default ``note`` of read_recording)."""
    print(message, file=sys.stderr)


def read_recording(
    path: str | os.PathLike[str],
    *,
    topic: str = DEFAULT_TOPIC,
    arm: str | None = None,
    rate_hz: float | None = None,
    progress: Progress | None = None,
    note: Note | None = print_to_stderr,
) -> Recording:
    """One arm's recording from a bag (joint states on ``topic``) or a table.

    rate_hz: the sample rate of a table without a time column (None: estimated, and the estimate
    said through ``note``; see :mod:`msg_adapters.csv_io`). Raises RecordingFileError naming the
    path for anything wrong with the file's contents.
    """
    path, part = split_part(path)
    kind = kind_suffix(path)
    try:
        if (pointer := pointer_file(path)) is not None:
            raise RecordingError(pointer)
        if kind in ARRAY_FILES:
            return read_array_recording(path, part, arm=arm, rate_hz=rate_hz, note=note)
        if kind in TABLE_SUFFIXES:
            if is_topic_dump(path):
                return read_topic_dump_recording(path, arm=arm, note=note)
            return read_table_recording(path, arm=arm, rate_hz=rate_hz, note=note)
        if path.is_file() and kind not in BAG_SUFFIXES:
            raise RecordingError(f"not a kind of recording this package reads ({kind or 'no suffix'}); it reads {INPUT_KINDS}")
        return read_bag_recording(path, topic=topic, arm=arm, progress=progress, note=note)
    except RecordingError as err:
        raise RecordingFileError(f"{path if part is None else f'{path}:{part}'}: {err}") from err


def source_file(path: str | os.PathLike[str]) -> Path:
    """The file or folder on disk that an input is read from: the file of arrays of ``<file>.mat:<part>``."""
    return split_part(path)[0]


def recordings_in(path: str | os.PathLike[str], *, listed: bool = False) -> list[Path]:
    """The recordings an input file stands for: a file of arrays of several recordings, each as
    ``<file>.mat:<part>``; any other path, itself. listed (a file found in a folder or by a
    pattern, not named): [] for a file of arrays that holds no recording, instead of itself (whose
    read then says so). RecordingFileError for a file of arrays that cannot be read, or that a file
    named like one of its parts would hide."""
    path = Path(path)
    if kind_suffix(path) not in ARRAY_FILES or not path.is_file() or pointer_file(path) is not None:
        return [path]
    parts = array_parts(path)
    if len(parts) <= 1:
        return [] if listed and not parts else [path]
    addresses = [Path(f"{path}:{part}") for part in parts]
    hiding = next((a for a in addresses if a.exists()), None)
    if hiding is not None:
        raise RecordingFileError(f"{hiding}: a file of this name hides the recording {hiding.name.rsplit(':', 1)[1]} of {path}; rename it")
    return addresses


def is_bag_folder(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a ROS 2 bag folder (holds metadata.yaml): one recording, not a folder of them."""
    return Path(path, "metadata.yaml").is_file()


def check_output(path: str | os.PathLike[str], replace: bool = False) -> str:
    """The format :func:`write_processed` would write at ``path``, once checked that it may.

    Refuses an unknown extension, then what :func:`~baxter_dynamics_ros.core.output_files.check_outputs`
    refuses (a missing folder, a folder in the way, an existing file unless ``replace``, a folder
    the user may not write).
    """
    path = Path(path)
    if path.suffix not in OUTPUT_FORMATS:
        raise RecordingFileError(f"{path}: unknown output type {path.suffix!r}; use .mcap (ROS 2 bag), .csv or .parquet")
    check_outputs([path], replace=replace)
    return OUTPUT_FORMATS[path.suffix]


def write_processed(
    path: str | os.PathLike[str], processed: ProcessedRecording, *, input_topic: str = DEFAULT_TOPIC, replace: bool = False
) -> None:
    """Write ``processed`` at ``path`` in the format its extension names (module docstring).

    replace: overwrite an existing output file (only once the new one is complete).
    """
    path = Path(path)
    fmt = check_output(path, replace)
    with staged_outputs([path], replace=replace) as (staged,):
        if fmt == "mcap":
            write_processed_bag(staged, processed, input_topic)
        else:
            write_processed_table(staged, processed, fmt)


def write_joint_states(
    path: str | os.PathLike[str],
    stamps_ns: np.ndarray,
    names: Sequence[str],
    position: np.ndarray,
    velocity: np.ndarray,
    effort: np.ndarray,
    *,
    topic: str = DEFAULT_TOPIC,
    replace: bool = False,
) -> None:
    """Write joint states (stamps_ns (N,), names (m,), arrays (N, m)) at ``path`` by its extension:
    a ``.mcap`` bag with JointState on ``topic``, or a ``.csv`` / ``.parquet`` table (generic layout).
    Whole or not at all, as :func:`write_processed`."""
    path = Path(path)
    fmt = check_output(path, replace)
    with staged_outputs([path], replace=replace) as (staged,):
        if fmt == "mcap":
            write_joint_state_bag(staged, stamps_ns, {topic: (names, position, velocity, effort)})
        else:
            write_table(staged, joint_state_columns(stamps_ns, names, position, velocity, effort), fmt)
