"""End-to-end speed of the live node, against a bare JointState ping-pong measured in the same run.

Issue 3 §7. This process publishes Baxter-like ``/robot/joint_states`` (21 joints, alphabetical,
header stamps counting the samples) at each rate and listens to ``/baxter_dynamics/residual`` from
the node, a subprocess (``python -m baxter_dynamics_ros.ros.node``). Latency is publish → residual
received, both timed here on the monotonic clock; loss counts residuals that never came (1 s drain
after the last publish); node CPU is its utime + stime from /proc/<pid>/stat over the run, in % of
one core, split by thread (the node's joint-state thread, its executor, Fast DDS's threads); the
node's own time per sample (read + dynamics + writes) comes from its /diagnostics. The reference:
the same messages sent to an echo subprocess (``--echo``, a plain rclpy node whose executor hands
each message to ``publish``) that sends each one straight back, with the node's QoS, timed the
same way. The floor: a peer (``--floor``) that takes the messages as the node does (CDR bytes,
the node's :class:`~baxter_dynamics_ros.ros.node.SubscriptionThread`, its QoS) and answers each
with one fixed 7-joint message carrying its stamp, doing nothing else: its CPU is what rclpy and
Fast DDS cost per sample, and node CPU − floor CPU is the node's own work. Only ``~/residual`` has
a subscriber, as when a user plots it (the node writes only to topics someone listens to). Each
rate is measured in ``--repeat`` rounds, echo, floor and node in each, so that a change of the
machine's load (it is shared) shows in all; every row gives the load average (1 min) at its end.

Goals (issue 14 §5): at every rate the node's p99 ≤ 1.1 × the echo's of the same round; at 1 kHz
no loss, p99 ≤ 2 ms and node CPU ≤ 15 % of one core.
Usage: ``python -m bench.bench_node [--duration S] [--rates HZ ...] [--repeat N]`` (default 60 s
at 100 and 1000 Hz, 2 rounds); ``./dev bench node`` runs the defaults.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.ros.ros_env import isolated_ros_env

# The tests' way of stopping a node (SIGINT, then kill), shared with the benchmark's peers.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
from processes import interrupt  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
JOINTS = sorted(
    ["head_nod", "head_pan", "l_gripper_l_finger_joint", "l_gripper_r_finger_joint", "r_gripper_l_finger_joint",
     "r_gripper_r_finger_joint", "torso_t0"]
    + [f"{side}_{j}" for side in ("left", "right") for j in ("e0", "e1", "s0", "s1", "w0", "w1", "w2")]
)
PING, PONG = "/bench/ping", "/bench/pong"
INPUT, RESIDUAL = "/robot/joint_states", "/baxter_dynamics/residual"
FLOOR_IN, FLOOR = "/bench/floor_in", "/bench/floor"  # the floor peer's input and answers
T0_NS = 1_700_000_000_000_000_000
QOS_DEPTH = 100
DRAIN_S = 1.0
CLOCK_TICKS_S = os.sysconf("SC_CLK_TCK")
GOALS_1KHZ = {"lost": 0, "p99_ms": 2.0, "cpu_percent": 15.0}
GOAL_P99_RATIO = 1.1  # node p99 / echo p99, at every rate


def _qos():
    """(subscription, publisher) QoS as the node uses them: sensor data in, reliable out."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    return (
        QoSProfile(depth=QOS_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT),
        QoSProfile(depth=QOS_DEPTH, reliability=ReliabilityPolicy.RELIABLE),
    )


def echo() -> int:
    """The reference peer: publish every JointState of PING back on PONG, unchanged."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from sensor_msgs.msg import JointState

    rclpy.init()
    node = rclpy.create_node("bench_echo")
    sub_qos, pub_qos = _qos()
    publisher = node.create_publisher(JointState, PONG, pub_qos)
    node.create_subscription(JointState, PING, publisher.publish, sub_qos)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def floor() -> int:
    """The floor peer: the node's transport path and nothing else.

    Joint states (on FLOOR_IN, so that the node does not take them too) are taken as CDR bytes, on
    the node's input QoS, by the node's own :class:`~baxter_dynamics_ros.ros.node.SubscriptionThread`;
    each is answered on FLOOR with one fixed JointState of the right arm's 7 joints (the size of the
    node's answer) carrying the input's stamp, on the node's output QoS: no reading, no dynamics, no
    bookkeeping. Its CPU is what rclpy and Fast DDS cost per sample on this machine, below which no
    rclpy node on this path can go."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from baxter_dynamics_ros.ros.node import OwnThreadGroup, SubscriptionThread

    rclpy.init()
    node = rclpy.create_node("bench_floor")
    sub_qos, pub_qos = _qos()
    publisher = node.create_publisher(JointState, FLOOR, pub_qos)
    zeros = [0.0] * 7
    arm = [name for name in JOINTS if name.startswith("right_")]
    answer = bytearray(serialize_message(JointState(name=arm, position=zeros, velocity=zeros, effort=zeros)))

    def relay(raw: bytes) -> None:
        answer[4:12] = raw[4:12]  # the header stamp (after the 4-byte CDR encapsulation), byte for byte
        publisher.publish(bytes(answer))

    subscription = node.create_subscription(JointState, FLOOR_IN, relay, sub_qos, callback_group=OwnThreadGroup(), raw=True)
    taker = SubscriptionThread(subscription, node.context, relay, node.get_logger())
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        taker.stop()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def _cpu_s(stat_path: Path) -> float:
    """CPU time (user + system) of a /proc stat file, s (utime, stime: fields 14, 15)."""
    fields = stat_path.read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS_S


def cpu_s(pid: int) -> dict[str, float]:
    """CPU time used so far by process pid, s: in total, and by its main thread (the executor),
    its DDS threads and its other threads."""
    out = {"total": _cpu_s(Path(f"/proc/{pid}/stat")), "main": 0.0, "dds": 0.0, "other": 0.0}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            comm = (task / "comm").read_text().strip()
            used = _cpu_s(task / "stat")
        except FileNotFoundError:  # the thread ended meanwhile
            continue
        out["main" if task.name == str(pid) else "dds" if comm.startswith("dds") else "other"] += used
    return out


@dataclass(frozen=True)
class Result:
    """One run: samples sent and lost, latency percentiles in ms, peer CPU in % of one core, the
    machine's load average (1 min) at its end."""

    sent: int
    lost: int
    p50_ms: float
    p99_ms: float
    max_ms: float
    cpu_percent: float
    cpu_by_thread: dict[str, float]
    processing_us: tuple[float, float] | None  # node's own mean and max per sample, from /diagnostics
    load_average: float


class Bench:
    """This process's side: publishers to both peers, and the receive times of their answers."""

    def __init__(self) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.executors import SingleThreadedExecutor
        from sensor_msgs.msg import JointState

        rclpy.init()
        self.node = rclpy.create_node("bench_node_client")
        sub_qos, pub_qos = _qos()
        self.publishers = {
            PONG: self.node.create_publisher(JointState, PING, pub_qos),
            RESIDUAL: self.node.create_publisher(JointState, INPUT, pub_qos),
            FLOOR: self.node.create_publisher(JointState, FLOOR_IN, pub_qos),
        }
        self.received_ns = np.zeros(0, dtype=np.int64)
        self.period_ns = 1
        self.base_ns = T0_NS  # stamp of sample 0 of the current run; runs never go back in time
        for topic in (PONG, RESIDUAL, FLOOR):
            self.node.create_subscription(JointState, topic, self.on_answer, pub_qos)
        self.diagnostics: list[tuple[int, dict[str, str]]] = []  # (receipt ns, the node's status values)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self.on_diagnostics, 10)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()
        rng = np.random.default_rng(0)
        # position, velocity, effort of 1000 samples, uniform in ±1 (rad, rad/s, N·m); e1's about 1.2
        # rad, inside its limits (−0.05 to 2.618 rad): the node skips positions a Baxter cannot have.
        e1 = np.array([name.endswith("_e1") for name in JOINTS]) * 1.2
        self.table = [array("d", rng.uniform(-1, 1, len(JOINTS)) + (e1 if k % 3 == 0 else 0.0)) for k in range(3 * 1000)]
        self.msg = JointState(name=JOINTS)

    def on_answer(self, msg) -> None:
        now = time.perf_counter_ns()
        i = (msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec - self.base_ns) // self.period_ns
        if 0 <= i < len(self.received_ns):
            self.received_ns[i] = now

    def on_diagnostics(self, msg) -> None:
        for status in msg.status:
            if "baxter_dynamics" in status.name:
                self.diagnostics.append((time.perf_counter_ns(), {kv.key: kv.value for kv in status.values}))

    def processing_us(self, start_ns: int, end_ns: int) -> tuple[float, float] | None:
        """Sample-weighted mean and max of the node's processing time over reports in [start, end]."""
        windows = [v for t, v in self.diagnostics if start_ns < t <= end_ns and v["samples_received"] != "0"]
        if not windows:
            return None
        n = np.array([int(v["samples_received"]) for v in windows])
        mean = np.array([float(v["latency_mean_us"]) for v in windows])
        return float((n * mean).sum() / n.sum()), max(float(v["latency_max_us"]) for v in windows)

    def publish(self, topic: str, i: int) -> None:
        """Sample i of the current run (stamped base + i periods) on the topic of the peer answering on ``topic``."""
        msg = self.msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(self.base_ns + i * self.period_ns, 1_000_000_000)
        k = 3 * (i % 1000)
        msg.position, msg.velocity, msg.effort = self.table[k], self.table[k + 1], self.table[k + 2]
        self.publishers[topic].publish(msg)

    def new_run(self, n: int, period_ns: int) -> None:
        """Stamps of the next n samples: period_ns apart, 1 s after the last run's."""
        self.base_ns += len(self.received_ns) * self.period_ns + 1_000_000_000
        self.period_ns, self.received_ns = period_ns, np.zeros(n, dtype=np.int64)

    def wait_matched(self, topic: str, timeout_s: float = 60.0) -> None:
        """Probe until the peer answers (both directions matched)."""
        self.new_run(10_000, 1_000_000)
        deadline = time.monotonic() + timeout_s
        for i in range(10_000):
            self.publish(topic, i)
            time.sleep(0.05)
            if self.received_ns.any():
                return
            if time.monotonic() > deadline:
                break
        raise RuntimeError(f"no answer on {topic} within {timeout_s} s")

    def send(self, topic: str, rate_hz: float, n: int, every: int = 0, mark: Callable[[int], None] | None = None) -> np.ndarray:
        """A new run: n samples on ``topic``'s peer at rate_hz, paced on the monotonic clock;
        ``mark(samples sent)`` after every ``every`` samples. Returns the send times (n,) ns."""
        self.new_run(n, round(1e9 / rate_hz))
        sent_ns = np.zeros(n, dtype=np.int64)
        start_ns = time.perf_counter_ns()
        for i in range(n):
            delay_ns = start_ns + i * self.period_ns - time.perf_counter_ns()
            if delay_ns > 0:
                time.sleep(delay_ns * 1e-9)
            sent_ns[i] = time.perf_counter_ns()
            self.publish(topic, i)
            if mark is not None and (i + 1) % every == 0:
                mark(i + 1)
        return sent_ns

    def run(self, topic: str, rate_hz: float, duration_s: float, pid: int) -> Result:
        n = int(rate_hz * duration_s)
        cpu0, wall0 = cpu_s(pid), time.perf_counter()
        start_ns = time.perf_counter_ns()
        sent_ns = self.send(topic, rate_hz, n)
        cpu1, wall1 = cpu_s(pid), time.perf_counter()
        end_ns = time.perf_counter_ns()
        time.sleep(DRAIN_S)
        got = self.received_ns > 0
        latency_ms = (self.received_ns[got] - sent_ns[got]) * 1e-6
        if not latency_ms.size:
            latency_ms = np.array([np.nan])
        cpu_percent = {k: 100 * (cpu1[k] - cpu0[k]) / (wall1 - wall0) for k in cpu0}
        return Result(
            n,
            int(n - got.sum()),
            *np.percentile(latency_ms, [50, 99, 100]),
            cpu_percent.pop("total"),
            cpu_percent,
            self.processing_us(start_ns, end_ns + 1_000_000_000),  # the report closing the run's last window
            os.getloadavg()[0],
        )

    def close(self) -> None:
        import rclpy

        self.executor.shutdown()
        self.thread.join()
        self.node.destroy_node()
        rclpy.try_shutdown()


def start_peer(args: Sequence[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def measure(duration_s: float, rates_hz: Sequence[float], repeat: int) -> dict[tuple[float, int, str], Result]:
    """Results by (rate, round, answering topic): per rate, ``repeat`` rounds of echo, floor and node."""
    peers = {
        PONG: start_peer(["-m", "bench.bench_node", "--echo"]),
        FLOOR: start_peer(["-m", "bench.bench_node", "--floor"]),
        RESIDUAL: start_peer(["-m", "baxter_dynamics_ros.ros.node", "--ros-args", "-p", "arm:=right"]),
    }
    bench = Bench()
    results = {}
    try:
        for topic in peers:
            bench.wait_matched(topic)
        for rate_hz in rates_hz:
            for round_ in range(repeat):
                for topic, process in peers.items():
                    bench.run(topic, rate_hz, min(2.0, duration_s), process.pid)  # warm-up
                    results[rate_hz, round_, topic] = bench.run(topic, rate_hz, duration_s, process.pid)
    finally:
        bench.close()
        for process in peers.values():
            interrupt(process)
    return results


def report(results: dict[tuple[float, int, str], Result], duration_s: float) -> None:
    print(f"Live node end to end, {len(JOINTS)}-joint JointState, {duration_s:g} s per rate, path and round")
    print(f"  node: {INPUT} -> {RESIDUAL};  references: echo {PING} -> {PONG}, floor {FLOOR_IN} -> {FLOOR}")
    print(f"{'rate':>8} {'round':>5} {'path':>10} {'sent':>7} {'lost':>5} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8} {'CPU %':>6} {'load':>5}")
    verdict = {}
    for rate_hz, round_ in sorted({(r, k) for r, k, _ in results}):
        rows = {"echo": results[rate_hz, round_, PONG], "floor": results[rate_hz, round_, FLOOR], "node": results[rate_hz, round_, RESIDUAL]}
        for name, r in rows.items():
            print(
                f"{rate_hz:>6g}Hz {round_ + 1:>5} {name:>10} {r.sent:>7} {r.lost:>5} {r.p50_ms:>8.3f} {r.p99_ms:>8.3f}"
                f" {r.max_ms:>8.2f} {r.cpu_percent:>6.1f} {r.load_average:>5.2f}"
            )
        node, ref, bare = rows["node"], rows["echo"], rows["floor"]
        print(
            f"{'':>14} {'node/echo':>10} {'':>7} {'':>5} {node.p50_ms / ref.p50_ms:>7.2f}x {node.p99_ms / ref.p99_ms:>7.2f}x"
            f" {'':>8} {node.cpu_percent / ref.cpu_percent:>5.2f}x"
        )
        threads = node.cpu_by_thread
        line = (
            f"{'':>14} node CPU by thread: joint-state thread {threads['other']:.1f} %, executor {threads['main']:.1f} %,"
            f" DDS {threads['dds']:.1f} %"
        )
        if node.processing_us is not None:
            line += f"; read + dynamics + writes per sample: mean {node.processing_us[0]:.0f} µs, max {node.processing_us[1]:.0f} µs"
        print(line)
        print(
            f"{'':>14} node CPU − floor CPU (the node's own work): {node.cpu_percent - bare.cpu_percent:.1f} % of a core;"
            f" floor by thread: taking thread {bare.cpu_by_thread['other']:.1f} %, DDS {bare.cpu_by_thread['dds']:.1f} %"
        )
        tag = f"{rate_hz:g} Hz round {round_ + 1}"
        verdict[f"{tag}: p99 ≤ {GOAL_P99_RATIO} × echo ({node.p99_ms / ref.p99_ms:.2f})"] = node.p99_ms <= GOAL_P99_RATIO * ref.p99_ms
        if rate_hz == 1000.0:
            verdict[f"{tag}: no loss (lost {node.lost})"] = node.lost <= GOALS_1KHZ["lost"]
            verdict[f"{tag}: p99 ≤ {GOALS_1KHZ['p99_ms']} ms ({node.p99_ms:.3f})"] = node.p99_ms <= GOALS_1KHZ["p99_ms"]
            verdict[f"{tag}: CPU ≤ {GOALS_1KHZ['cpu_percent']} % ({node.cpu_percent:.1f}; floor {bare.cpu_percent:.1f})"] = (
                node.cpu_percent <= GOALS_1KHZ["cpu_percent"]
            )
    print("goals:")
    for text, ok in verdict.items():
        print(f"  {text}: {'met' if ok else 'MISSED'}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_node", description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=60.0, help="seconds per rate and path (default 60)")
    parser.add_argument("--rates", type=float, nargs="+", default=[100.0, 1000.0], help="input rates in Hz")
    parser.add_argument("--repeat", type=int, default=2, help="rounds of echo, floor and node per rate (default 2)")
    parser.add_argument("--echo", action="store_true", help=argparse.SUPPRESS)  # run as the reference peer
    parser.add_argument("--floor", action="store_true", help=argparse.SUPPRESS)  # run as the floor peer
    args = parser.parse_args([] if argv is None else argv)
    if args.echo:
        return echo()
    if args.floor:
        return floor()
    with tempfile.TemporaryDirectory(prefix="bench_node-roslog-") as log_dir, isolated_ros_env(log_dir) as env:
        os.environ.update(env)  # this process and the peers: a private domain, discovery on localhost
        report(measure(args.duration, args.rates, args.repeat), args.duration)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
