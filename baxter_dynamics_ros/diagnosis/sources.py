"""Where the diagnosis gets its recordings: sources it reads one at a time, and how it maps over them.

A :class:`Source` is a small picklable description of one recording (a file and its reader's
options, or a recording already in memory) whose ``read()`` gives the :class:`Recording`; the
command line makes them for files (:mod:`baxter_dynamics_ros.cli.recording_sources`), so that a
worker process or a cluster's worker can read a file itself and nothing here needs to know file
formats. A :data:`Mapper` runs a function of one source over many and returns the results in the
sources' order (:func:`serial_map` here; worker processes and dask in the command line).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

from ..core.recording import Recording

__all__ = ["InMemory", "Mapper", "Source", "serial_map"]

R = TypeVar("R")

#: map(function, items) -> [function(item) for item in items], in the items' order.
Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], list]


class Source(Protocol):
    """One recording the diagnosis reads when it needs it; ``label`` names it in results and errors."""

    label: str

    def read(self) -> Recording: ...


@dataclass(frozen=True)
class InMemory:
    """A recording already in memory, as a source (the in-memory API and the validation)."""

    label: str
    recording: Recording

    def read(self) -> Recording:
        return self.recording


def serial_map(function: Callable[[Any], R], items: Sequence[Any]) -> list[R]:
    """The mapper of one process: each item in turn."""
    return [function(item) for item in items]
