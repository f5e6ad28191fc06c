"""A ROS 2 environment that stays on this machine, for tests, benchmarks and demos.

With the defaults, Fast DDS sends discovery traffic onto the local network and every process of
domain 0 sees every other. :func:`isolated_ros_env` gives a process tree its own
``ROS_DOMAIN_ID``, ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a ``ROS_LOG_DIR``. Domain ids
are leased with an exclusive lock on a file per id (released by the OS when the holder exits, even
on a crash), so concurrent test runs and benchmarks on one machine never share a domain.
Environment variables only: nothing here imports rclpy.
"""

from __future__ import annotations

import fcntl
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["DOMAIN_IDS", "isolated_ros_env", "lease_domain_id"]

#: Domain ids handed out: 1..101 (0 is everyone's default; Fast DDS's ports stay valid up to 232).
DOMAIN_IDS = range(1, 102)
LOCK_DIR = Path(tempfile.gettempdir()) / "baxter_dynamics_ros-domains"


@contextmanager
def lease_domain_id(first: int | None = None) -> Iterator[int]:
    """A ROS domain id no other holder of a lease on this machine uses, until the block exits.

    The search starts at ``first`` (default: from the process id, so that concurrent runs rarely
    contend for the same lock) and wraps around :data:`DOMAIN_IDS`.
    """
    LOCK_DIR.mkdir(exist_ok=True)
    start = (os.getpid() if first is None else first - DOMAIN_IDS[0]) % len(DOMAIN_IDS)
    for offset in range(len(DOMAIN_IDS)):
        domain_id = DOMAIN_IDS[(start + offset) % len(DOMAIN_IDS)]
        fd = os.open(LOCK_DIR / f"{domain_id}.lock", os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        try:
            yield domain_id
        finally:
            os.close(fd)  # releases the lock
        return
    raise RuntimeError(f"every ROS domain id in {DOMAIN_IDS} is leased (locks in {LOCK_DIR})")


@contextmanager
def isolated_ros_env(log_dir: str | os.PathLike[str]) -> Iterator[dict[str, str]]:
    """The variables (to merge into os.environ or a subprocess's env) for a private, local ROS graph."""
    with lease_domain_id() as domain_id:
        yield {
            "ROS_DOMAIN_ID": str(domain_id),
            "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
            "ROS_LOG_DIR": str(log_dir),
        }
