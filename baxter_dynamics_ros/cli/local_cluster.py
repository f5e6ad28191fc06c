"""``--scheduler local``: a one-machine dask cluster that serves nothing but dask's own messages.

dask's :class:`~distributed.LocalCluster` starts an HTTP server with its scheduler (on 8787, also
with ``dashboard_address=None``: dask/distributed issues 5634 and 7207) and one with each worker (on
a random port), and puts its workers' scratch in ``$TMPDIR/dask-scratch-space``, left behind. This
cluster is a :class:`~distributed.SpecCluster` of the same scheduler and nanny-supervised workers,
on 127.0.0.1 only, whose scheduler and workers start no HTTP server at all, and whose workers' scratch
is a folder the caller gives (and removes). Imports dask.distributed: import this module only when
``--scheduler local`` is given; its worker class is imported by the worker processes.
"""

from __future__ import annotations

import logging
from typing import Any

from distributed import Nanny, Scheduler, SpecCluster, Worker

__all__ = ["local_cluster"]


class _Scheduler(Scheduler):
    """A scheduler without HTTP server (no dashboard, no /health, no /metrics)."""

    def start_http_server(self, *args: Any, **kwargs: Any) -> None:
        pass


class _Worker(Worker):
    """A worker without HTTP server."""

    def start_http_server(self, *args: Any, **kwargs: Any) -> None:
        pass


def local_cluster(jobs: int, scratch: str) -> SpecCluster:
    """A started cluster of ``jobs`` single-threaded worker processes on 127.0.0.1, their scratch in
    the folder ``scratch``; close it (a context manager) to stop them. The workers log nothing (a
    task's error comes back to the client, which raises it: their "Compute Failed" with its traceback
    would only repeat it), the scheduler its errors."""
    common = {"host": "127.0.0.1", "protocol": "tcp://", "dashboard": False, "dashboard_address": None}
    worker = {
        "cls": Nanny,
        "options": {**common, "nthreads": 1, "local_directory": scratch, "worker_class": _Worker, "silence_logs": logging.CRITICAL},
    }
    return SpecCluster(
        scheduler={"cls": _Scheduler, "options": {**common, "port": 0}},
        workers={k: worker for k in range(jobs)},
        worker=worker,
        silence_logs=logging.ERROR,
    )
