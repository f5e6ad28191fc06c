"""The ROS test harness: a private, local ROS graph for every run, and helpers to drive real nodes.

Network safety first: at session start this sets, in ``os.environ`` (so every subprocess and every
rclpy context of the run inherits them), ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, a
``ROS_DOMAIN_ID`` leased for this run only (:mod:`baxter_dynamics_ros.ros.ros_env`: concurrent runs on
the machine never share one) and ``ROS_LOG_DIR`` in a temporary folder.

Property-based tests (hypothesis) draw the same examples every run; ``HYPOTHESIS_PROFILE=shakeout``
draws new ones.

Fixtures:

- ``ros_domain`` (module): a further domain id of the module's own, set in os.environ while the
  module's tests run, so that a module's node processes cannot hear another module's;
- ``ros_client`` (module): a :class:`RosClient`, an rclpy context and node of this process spun by
  an executor thread, to publish, collect messages and call services;
- ``node_processes`` (module): a :class:`NodeProcesses` starting ``python -m <module> --ros-args
  ...`` subprocesses and stopping them (SIGINT, then kill) at the end.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

from baxter_dynamics_ros.ros.ros_env import isolated_ros_env, lease_domain_id
from processes import interrupt
from repo_paths import REPO

_session = ExitStack()

# Property-based tests draw the same examples on every run, so that a run passes or fails on the code
# alone; HYPOTHESIS_PROFILE=shakeout draws new ones (a search for new failures, run by hand).
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("shakeout", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


def pytest_configure(config: pytest.Config) -> None:
    log_dir = tempfile.mkdtemp(prefix="baxter_dynamics_ros-roslog-")
    _session.callback(shutil.rmtree, log_dir, ignore_errors=True)
    os.environ.update(_session.enter_context(isolated_ros_env(log_dir)))


def pytest_unconfigure(config: pytest.Config) -> None:
    _session.close()


@pytest.fixture(scope="module")
def ros_domain() -> Iterator[int]:
    """A ROS domain id of this module's own, in os.environ for the module's tests and subprocesses."""
    previous = os.environ["ROS_DOMAIN_ID"]
    with lease_domain_id() as domain_id:
        os.environ["ROS_DOMAIN_ID"] = str(domain_id)
        try:
            yield domain_id
        finally:
            os.environ["ROS_DOMAIN_ID"] = previous


class Inbox:
    """Messages received on one topic, in order, with a wait that gives up after a timeout."""

    def __init__(self, topic: str) -> None:
        self.topic = topic
        self.messages: list[Any] = []
        self._changed = threading.Condition()

    def put(self, msg: Any) -> None:
        with self._changed:
            self.messages.append(msg)
            self._changed.notify_all()

    def clear(self) -> None:
        with self._changed:
            self.messages.clear()

    def wait_for(self, done: Callable[[list[Any]], Any], timeout_s: float = 10.0, what: str = "") -> Any:
        """Wait until ``done(messages)`` is truthy and return its value; fail the test at the timeout."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                value = done(list(self.messages))
                if value:
                    return value
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    pytest.fail(
                        f"timed out after {timeout_s} s waiting on {self.topic} for {what or done}; "
                        f"{len(self.messages)} messages received"
                    )
                self._changed.wait(min(remaining, 0.1))

    def wait_count(self, n: int, timeout_s: float = 10.0) -> list[Any]:
        """Wait for at least n messages; returns them all."""
        return self.wait_for(lambda m: m if len(m) >= n else None, timeout_s, f"{n} messages")


class RosClient:
    """An rclpy context and node of this process, spun in a thread: the tests' side of the graph."""

    def __init__(self, name: str = "test_client") -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self.executor.spin, daemon=True)
        self._thread.start()

    def collect(self, msg_type: type, topic: str, qos: Any = None) -> Inbox:
        """An inbox filled by a subscription to ``topic`` (default: reliable, depth 1000)."""
        inbox = Inbox(topic)
        self.node.create_subscription(msg_type, topic, inbox.put, qos if qos is not None else 1000)
        return inbox

    def publisher(self, msg_type: type, topic: str, qos: Any = 100) -> Any:
        return self.node.create_publisher(msg_type, topic, qos)

    def call(self, srv_type: type, name: str, request: Any, timeout_s: float = 10.0) -> Any:
        """Call a service and return its response; fails the test if it is not there or times out."""
        client = self.node.create_client(srv_type, name)
        try:
            if not client.wait_for_service(timeout_sec=timeout_s):
                pytest.fail(f"service {name} not available after {timeout_s} s")
            future = client.call_async(request)
            deadline = time.monotonic() + timeout_s
            while not future.done():
                if time.monotonic() > deadline:
                    pytest.fail(f"service {name} did not answer within {timeout_s} s")
                time.sleep(0.01)
            return future.result()
        finally:
            self.node.destroy_client(client)

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self._thread.join(timeout=10)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture(scope="module")
def ros_client(ros_domain: int) -> Iterator[RosClient]:
    """This process's side of the module's ROS graph."""
    pytest.importorskip("rclpy")
    client = RosClient()
    yield client
    client.close()


class NodeProcess:
    """A node running as ``python -m <module> --ros-args <args>``, its output in a log file."""

    def __init__(self, module: str, ros_args: Sequence[str], log_path: Path) -> None:
        self.command = [sys.executable, "-m", module, "--ros-args", *ros_args]
        self.log_path = log_path
        with log_path.open("w") as log:  # the child writes through its own copy of the descriptor
            self.process = subprocess.Popen(self.command, cwd=REPO, stdout=log, stderr=subprocess.STDOUT)

    @property
    def pid(self) -> int:
        return self.process.pid

    def alive(self) -> bool:
        return self.process.poll() is None

    def output(self) -> str:
        return self.log_path.read_text(errors="replace")

    def check_alive(self) -> None:
        """Fail the test, showing the node's output, if the node has exited."""
        if not self.alive():
            pytest.fail(f"node exited with code {self.process.returncode}:\n{self.output()}")

    def stop(self, timeout_s: float = 15.0) -> int:
        """Ctrl-C (SIGINT), as a user stops it; kill if it does not exit in time. Returns the exit code."""
        return interrupt(self.process, timeout_s)


class NodeProcesses:
    """Starts node subprocesses for a module and stops every one of them at its end."""

    def __init__(self, log_dir: Path) -> None:
        self.log_dir = log_dir
        self.started: list[NodeProcess] = []

    def start(self, ros_args: Sequence[str] = (), module: str = "baxter_dynamics_ros.ros.node") -> NodeProcess:
        node = NodeProcess(module, ros_args, self.log_dir / f"node-{len(self.started)}.log")
        self.started.append(node)
        return node

    def stop_all(self) -> None:
        for node in self.started:
            node.stop()


@pytest.fixture(scope="module")
def node_processes(ros_domain: int, tmp_path_factory: pytest.TempPathFactory) -> Iterator[NodeProcesses]:
    processes = NodeProcesses(tmp_path_factory.mktemp("nodes"))
    yield processes
    processes.stop_all()

