"""The commands' one check of their paths before any work: inputs exist, no output destroys one."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..errors import OutputError, RecordingFileError

__all__ = ["check_paths"]


def check_paths(inputs: Sequence[Path], outputs: Sequence[Path]) -> None:
    """Refuse an input that does not exist (RecordingFileError) and an output that would destroy or
    change an input (OutputError): the same path, a folder holding the input, or a path inside an
    input folder (a ROS 2 bag). ``--force`` never overrides this. What an output may otherwise be
    is :func:`~baxter_dynamics_ros.core.output_files.check_outputs`' to say."""
    from msg_adapters.pointer_files import pointer_file
    from msg_adapters.recording_files import source_file

    for path in inputs:
        if not (source := source_file(path)).exists():
            raise RecordingFileError(f"{path}: {pointer_file(source) or 'no such file or directory'}")
    for out in outputs:
        target = out.resolve()
        for path in inputs:
            source = source_file(path).resolve()
            if target == source or target in source.parents or source in target.parents:
                raise OutputError(f"{out}: refusing to overwrite the input {path}; choose another output")
