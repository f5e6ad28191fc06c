"""Where the per-file work runs: in this process, in worker processes, or on a dask cluster.

:func:`file_mapper` gives a :data:`~baxter_dynamics_ros.diagnosis.sources.Mapper` for the
commands' ``--jobs N`` and ``--scheduler ADDRESS`` options. Every mapper returns the results in the
items' order, whatever order they finish in, so that the sums made of them are the same in every
way of running. Worker processes are spawned (numba's and OpenMP's threads do not survive a fork
of a process that runs them, and a fork server would be one more process holding the imports), run
their numba kernels and BLAS on one thread each (:func:`one_thread`: the processes already share
the cores; more threads only contend) and hand their freed heap back after each task.
On an interrupt (Ctrl-C, SIGTERM) the worker processes are terminated, not waited for.
``--scheduler`` takes ``local`` or ``tcp://HOST:PORT``; a scheduler that does not answer as dask
does within :data:`CONNECT_TIMEOUT_S` is an error. ``local`` starts a one-machine dask cluster on
127.0.0.1 without any HTTP server (:mod:`.local_cluster`), its workers' scratch inside the run's
scratch folder (or a temporary folder of its own), its workers on one thread each too, and closes it
at the end, also on error and interrupt. A worker's
error (a corrupt file) comes back as the error it raised; a worker that dies, or a scheduler that
cannot be reached, is a :class:`~baxter_dynamics_ros.errors.WorkerError`. No worker imports rclpy.
"""

from __future__ import annotations

import argparse
import ctypes
import logging
import os
import re
import tempfile
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future
from contextlib import ExitStack, contextmanager
from functools import partial
from typing import Any

from ..diagnosis.sources import Mapper, serial_map
from ..errors import WorkerError
from .signals import signals_deferred

__all__ = ["CONNECT_TIMEOUT_S", "add_worker_arguments", "check_scheduler", "default_jobs", "file_mapper", "one_thread"]

#: how long a --scheduler ADDRESS has to answer as a dask scheduler, s
CONNECT_TIMEOUT_S = 5.0
_ADDRESS = re.compile(r"tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+):(\d{1,5})")
_ADDRESS_FORMS = "'local' or tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786)"


def check_scheduler(address: str) -> None:
    """Refuse a ``--scheduler`` that is neither ``local`` nor ``tcp://HOST:PORT`` (dask would raise
    ValueError on some, take others for a file to load)."""
    match = _ADDRESS.fullmatch(address)
    if address != "local" and (match is None or not 0 < int(match.group(2)) < 65536):
        raise WorkerError(f"--scheduler {address!r}: expected {_ADDRESS_FORMS}")


def default_jobs() -> int:
    """The cores this process may run on."""
    count = getattr(os, "process_cpu_count", None)
    return count() if count is not None else len(os.sched_getaffinity(0))


def one_thread() -> None:
    """Run this process' numba parallel kernels and BLAS calls on one thread (a worker's setup)."""
    import numba
    from threadpoolctl import threadpool_limits

    numba.set_num_threads(1)
    threadpool_limits(1)


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def add_worker_arguments(parser: argparse.ArgumentParser, cluster: bool = True) -> None:
    """``--jobs``, and ``--scheduler`` if cluster."""
    parser.add_argument(
        "--jobs", "-j", type=_positive, default=None, metavar="N",
        help="worker processes for the per-file work (default: every core; 1: in this process; with --scheduler local: its workers)",
    )  # fmt: skip
    if not cluster:
        return
    parser.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run the per-file work on a dask.distributed cluster at ADDRESS (tcp://HOST:PORT, e.g. tcp://host:8786; the files must be "
        f"at the same paths on its workers: a shared filesystem; it must answer within {CONNECT_TIMEOUT_S:g} s), or 'local' for a "
        "cluster of --jobs worker processes on this machine (127.0.0.1, no dashboard nor other HTTP server)",
    )  # fmt: skip


@contextmanager
def file_mapper(jobs: int | None, scheduler: str | None, scratch: str | None = None) -> Iterator[Mapper]:
    """The mapper for ``--jobs`` (None: every core) and ``--scheduler``; whatever it started is stopped
    on leaving. scratch: the run's scratch folder, where ``--scheduler local`` puts its workers'
    (None: a temporary folder of its own)."""
    jobs = default_jobs() if jobs is None else jobs
    if scheduler is not None:
        check_scheduler(scheduler)
        with _dask_client(scheduler, jobs, scratch) as client:
            yield partial(_dask_map, client)
    elif jobs == 1:
        yield serial_map
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        context = multiprocessing.get_context("spawn")
        executor = ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=one_thread)
        try:
            yield partial(_pool_map, executor)
        except KeyboardInterrupt:  # also SIGTERM (cli.main): stop the workers now, not after their file
            _stop_worker_processes()
            raise
        finally:
            executor.shutdown(wait=True, cancel_futures=True)


def _pool_map(executor, function: Callable[[Any], Any], items: Sequence[Any]) -> list:
    from concurrent.futures.process import BrokenProcessPool

    with signals_deferred():  # submitting spawns the workers
        futures: list[Future] = [executor.submit(_trimmed, function, item) for item in items]
    try:
        return [f.result() for f in futures]
    except BrokenProcessPool as err:
        raise WorkerError(f"a worker process died ({err}); run with --jobs 1 to see which file it was reading") from err
    finally:
        for f in futures:
            f.cancel()


def _trimmed(function: Callable[[Any], Any], item: Any) -> Any:
    """function(item), then the freed heap handed back to the system (glibc's ``malloc_trim``): a
    worker that has reduced an hour-long file would otherwise keep its peak for the rest of the run."""
    try:
        return function(item)
    finally:
        try:
            ctypes.CDLL(None).malloc_trim(0)
        except (OSError, AttributeError):  # not glibc
            pass


@contextmanager
def _dask_client(address: str, jobs: int, scratch: str | None) -> Iterator[Any]:
    try:
        import dask.distributed  # noqa: F401
    except ImportError as err:
        raise WorkerError(f"--scheduler needs dask.distributed ({err}); install the package's 'cluster' extra") from err
    try:
        with ExitStack() as stack:
            try:
                yield _started_client(stack, address, jobs, scratch)
            except KeyboardInterrupt:  # also SIGTERM: the cluster is stopped as the stack unwinds, and what
                for name in ("asyncio", "distributed", "tornado"):  # dask's tasks say as they are cut short is no news
                    logging.getLogger(name).setLevel(logging.CRITICAL)
                raise
    except KeyboardInterrupt:  # a cluster interrupted while it started is not in the stack: its workers
        _stop_worker_processes()  # would live on a moment and write into the scratch folder once removed
        raise


def _started_client(stack: ExitStack, address: str, jobs: int, scratch: str | None) -> Any:
    """A dask client of the scheduler at address or of a new local cluster, entered into stack."""
    import dask
    from dask.distributed import Client

    settings = {"distributed.comm.timeouts.connect": f"{CONNECT_TIMEOUT_S}s"}
    try:
        if address == "local":
            from .local_cluster import local_cluster

            where = scratch if scratch is not None else stack.enter_context(tempfile.TemporaryDirectory(prefix="baxter-dynamics-"))
            scratch = tempfile.mkdtemp(prefix="dask-", dir=where)  # removed with where
            stack.enter_context(dask.config.set({**settings, "temporary-directory": scratch}))
            with signals_deferred():  # the nannies spawn the workers; stopped once they are up, with the stack
                cluster = stack.enter_context(local_cluster(jobs, scratch))
                client = stack.enter_context(Client(cluster))
            client.run(one_thread)
        else:
            stack.enter_context(dask.config.set(settings))
            _probe(address)
            client = stack.enter_context(Client(address, timeout=CONNECT_TIMEOUT_S))
    except (OSError, TimeoutError) as err:
        raise WorkerError(f"cannot reach a dask scheduler at {address} within {CONNECT_TIMEOUT_S:g} s: {err}") from err
    return client


def _stop_worker_processes(rounds: int = 3, wait_s: float = 5.0) -> None:
    """Terminate this process' multiprocessing children (pool workers, dask's nanny-started workers)
    and wait for them; again while new ones appear (a starting cluster may spawn one more)."""
    import multiprocessing

    for _ in range(rounds):
        children = multiprocessing.active_children()
        if not children:
            return
        for child in children:
            child.terminate()
        for child in children:
            child.join(wait_s)
            if child.is_alive():
                child.kill()
                child.join(wait_s)


def _probe(address: str) -> None:
    """Refuse, within CONNECT_TIMEOUT_S, an address where no dask scheduler answers: dask's own
    handshake waits for ever on a service that accepts the connection and says nothing, and takes
    what another service says for the length of a message to allocate (issue 22 item 3)."""
    import asyncio

    from distributed.comm import connect

    async def identity() -> Any:
        comm = await connect(address, timeout=CONNECT_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        answer = asyncio.run(asyncio.wait_for(identity(), CONNECT_TIMEOUT_S))
    except (OSError, TimeoutError, asyncio.TimeoutError) as err:
        raise WorkerError(f"cannot reach a dask scheduler at {address} within {CONNECT_TIMEOUT_S:g} s ({str(err) or type(err).__name__})") from err
    except Exception as err:  # whatever the other service sent, read as a dask message
        raise WorkerError(f"{address} does not answer as a dask scheduler does ({type(err).__name__}); is it the scheduler's address?") from err
    if not (isinstance(answer, dict) and answer.get("type") == "Scheduler"):
        kind = answer.get("type") if isinstance(answer, dict) else None
        raise WorkerError(f"{address} is not a dask scheduler ({f'a {kind}' if kind else 'an unknown service'}); give the scheduler's address")


def _dask_map(client, function: Callable[[Any], Any], items: Sequence[Any]) -> list:
    from distributed.scheduler import KilledWorker

    futures = client.map(function, items, pure=False)
    interrupted = False
    try:
        return client.gather(futures)
    except KilledWorker as err:
        raise WorkerError(f"a dask worker died while working on a file ({err})") from err
    except KeyboardInterrupt:  # also SIGTERM: the workers are stopped with the cluster, not task by task
        interrupted = True
        raise
    finally:
        if not interrupted:
            client.cancel(futures)
