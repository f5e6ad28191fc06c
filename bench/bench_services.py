"""Round trip of the node's dynamics services, against a std_srvs/Trigger echo served the same way.

Issue 21 §2. This process calls ``/baxter_dynamics/compute_gravity`` of the node (a subprocess,
``python -m baxter_dynamics_ros.ros.node``) with one state and with 1,000 states (the arm's 7
joint names, random positions), one call at a time, and times each from ``call_async`` to the
answer on the monotonic clock. The reference: ``/bench_echo/echo``, a ``std_srvs/Trigger`` service
of a peer process (``--echo``) served exactly as the node serves its dynamics services (a callback
group no executor takes and :class:`~baxter_dynamics_ros.ros.dynamics_services.ServiceThread`),
answering at once. The client is the same for all three: one rclpy client per service, made once,
a SingleThreadedExecutor spinning in a thread of its own, the caller waiting on each answer's
future (as an application calls a service). Each round measures echo, one state and
1,000 states in turn, so that a change of the machine's load shows in all three; every row gives
the load average (1 min) at its end.

Goal (issue 21 §2): one-state gravity p50 and p99 ≤ 1.5 × the echo's of the same round.
Usage: ``python -m bench.bench_services [--calls N] [--repeat R]`` (default 2,000 calls per
round and path, 200 for 1,000 states, 3 rounds); ``./dev bench services`` runs the defaults.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time
from collections.abc import Sequence

import numpy as np

from baxter_dynamics_ros.ros.ros_env import isolated_ros_env
from bench.bench_node import start_peer, stop_peer

JOINTS = ["right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"]
GOAL_RATIO = 1.5
ECHO, GRAVITY = "/bench_echo/echo", "/baxter_dynamics/compute_gravity"


def echo() -> int:
    """The reference peer: a Trigger service answered at once, served like the node's services."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from std_srvs.srv import Trigger

    from baxter_dynamics_ros.ros.dynamics_services import ServiceThread
    from baxter_dynamics_ros.ros.node import OwnThreadGroup

    def answer(request, response):
        response.success, response.message = True, "echo"
        return response

    rclpy.init()
    node = rclpy.create_node("bench_echo")
    service = node.create_service(Trigger, "~/echo", answer, callback_group=OwnThreadGroup())
    thread = ServiceThread([service], node.context, node.get_logger())
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        thread.stop()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


class Caller:
    """This process's client side: one client per service, an executor to wait on answers."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        rclpy.init()
        self.node = rclpy.create_node("bench_services")
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()
        self.clients = {}

    def client(self, srv_type, name: str):
        if name not in self.clients:
            client = self.clients[name] = self.node.create_client(srv_type, name)
            if not client.wait_for_service(timeout_sec=60.0):
                raise RuntimeError(f"service {name} not available after 60 s")
        return self.clients[name]

    def round_trips_ms(self, srv_type, name: str, request, calls: int) -> np.ndarray:
        """Milliseconds from call_async to the answer, for ``calls`` calls one after another."""
        client = self.client(srv_type, name)
        out = np.empty(calls)
        answered = threading.Event()
        for k in range(calls):
            answered.clear()
            t0 = time.perf_counter_ns()
            future = client.call_async(request)
            future.add_done_callback(lambda _: answered.set())
            answered.wait(30.0)
            out[k] = (time.perf_counter_ns() - t0) * 1e-6
            response = future.result()
            if response is None or not response.success:
                raise RuntimeError(f"{name}: {response and response.message or 'no answer within 30 s'}")
        return out

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.thread.join()
        self.node.destroy_node()
        rclpy.try_shutdown()


def measure(calls: int, repeat: int) -> list[dict[str, np.ndarray | float]]:
    """Per round: round trips (ms) of echo, 1-state and 1,000-state gravity, and the load average."""
    from baxter_dynamics_interfaces.srv import Gravity
    from std_srvs.srv import Trigger

    rng = np.random.default_rng(0)
    one = Gravity.Request(name=JOINTS, position=rng.uniform(-1.0, 1.0, 7).tolist())
    many = Gravity.Request(name=JOINTS, position=rng.uniform(-1.0, 1.0, 7000).tolist())
    peers = [start_peer(["-m", "bench.bench_services", "--echo"]), start_peer(["-m", "baxter_dynamics_ros.ros.node"])]
    caller = Caller()
    rounds = []
    try:
        for warm_up in (True, False):
            for _ in range(1 if warm_up else repeat):
                n = max(50, calls // 20) if warm_up else calls
                row = {
                    "echo": caller.round_trips_ms(Trigger, ECHO, Trigger.Request(), n),
                    "gravity, 1 state": caller.round_trips_ms(Gravity, GRAVITY, one, n),
                    "gravity, 1,000 states": caller.round_trips_ms(Gravity, GRAVITY, many, max(20, n // 10)),
                    "load": os.getloadavg()[0],
                }
                if not warm_up:
                    rounds.append(row)
    finally:
        caller.close()
        for process in peers:
            stop_peer(process)
    return rounds


def report(rounds: list[dict[str, np.ndarray | float]], calls: int) -> None:
    print(f"Dynamics services, round trip from a Python client (rclpy), {calls} calls per round and path (1,000 states: {max(20, calls // 10)})")
    print(f"  node: {GRAVITY} (baxter_dynamics_interfaces/srv/Gravity);  reference: {ECHO} (std_srvs/Trigger), served the same way")
    print(f"{'round':>5} {'path':>22} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8} {'load':>5}")
    verdict = {}
    for k, row in enumerate(rounds):
        stats = {}
        for path in ("echo", "gravity, 1 state", "gravity, 1,000 states"):
            p50, p99 = np.percentile(row[path], [50, 99])
            stats[path] = (p50, p99)
            print(f"{k + 1:>5} {path:>22} {p50:>8.3f} {p99:>8.3f} {row[path].max():>8.3f} {row['load']:>5.2f}")
        (e50, e99), (g50, g99) = stats["echo"], stats["gravity, 1 state"]
        (m50, m99) = stats["gravity, 1,000 states"]
        print(f"{'':>5} {'1 state / echo':>22} {g50 / e50:>7.2f}x {g99 / e99:>7.2f}x")
        print(f"{'':>5} {'1,000 states / echo':>22} {m50 / e50:>7.2f}x {m99 / e99:>7.2f}x")
        verdict[f"round {k + 1}: 1 state p50 ≤ {GOAL_RATIO} × echo ({g50 / e50:.2f})"] = g50 <= GOAL_RATIO * e50
        verdict[f"round {k + 1}: 1 state p99 ≤ {GOAL_RATIO} × echo ({g99 / e99:.2f})"] = g99 <= GOAL_RATIO * e99
    print("goals:")
    for text, ok in verdict.items():
        print(f"  {text}: {'met' if ok else 'MISSED'}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_services", description=__doc__.split("\n")[0])
    parser.add_argument("--calls", type=int, default=2000, help="calls per round and path (default 2000; 1,000 states: a tenth)")
    parser.add_argument("--repeat", type=int, default=3, help="rounds of echo, 1 state and 1,000 states (default 3)")
    parser.add_argument("--echo", action="store_true", help=argparse.SUPPRESS)  # run as the reference peer
    args = parser.parse_args([] if argv is None else argv)
    if args.echo:
        return echo()
    try:
        import baxter_dynamics_interfaces  # noqa: F401
    except ImportError:
        print("ERROR: baxter_dynamics_interfaces is not built: run ./dev (it builds it given cmake and a C++ compiler)", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory(prefix="bench_services-roslog-") as log_dir, isolated_ros_env(log_dir) as env:
        os.environ.update(env)  # this process and the peers: a private domain, discovery on localhost
        report(measure(args.calls, args.repeat), args.calls)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
