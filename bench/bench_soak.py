"""Soak of the live node: memory and loss over minutes of input (issue 12).

This process publishes Baxter-like ``/robot/joint_states`` (21 joints, as :mod:`bench.bench_node`
sends them) at ``--rate`` for ``--duration`` seconds into the node, a subprocess (``python -m
baxter_dynamics_ros.ros.node``, default parameters), and listens to ``~/residual``. Every ``--every``
seconds it reads the node's resident memory (VmRSS of /proc/<pid>/status) and its CPU time; at the
end it counts, per interval, the residuals that never came (after a 1 s drain) and their latency.
The reference, measured in the same run: the node's RSS after a 5 s warm-up at the same rate,
against which the growth is given.

Usage: ``python -m bench.bench_soak [--duration S] [--rate HZ] [--every S]`` (default 300 s at
500 Hz, a row every 30 s); ``./dev bench soak`` runs the defaults.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.ros.ros_env import isolated_ros_env

from .bench_node import DRAIN_S, RESIDUAL, Bench, cpu_s, start_peer, stop_peer

WARM_UP_S = 5.0


def rss_mb(pid: int) -> float:
    """Resident memory of process pid, MB (VmRSS)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for process {pid}")


@dataclass(frozen=True)
class Row:
    """One interval of the soak: its end (s since the start), the node's RSS then (MB), its CPU over the
    interval (% of one core), samples sent and lost in it, latency p50 / p99 (ms)."""

    t_s: float
    rss_mb: float
    cpu_percent: float
    sent: int
    lost: int
    p50_ms: float
    p99_ms: float


def soak(duration_s: float, rate_hz: float, every_s: float) -> tuple[float, list[Row]]:
    """(RSS after the warm-up, MB; one Row per interval)."""
    node = start_peer(["-m", "baxter_dynamics_ros.ros.node", "--ros-args", "-p", "arm:=right"])
    bench = Bench()
    try:
        bench.wait_matched(RESIDUAL)
        bench.run(RESIDUAL, rate_hz, WARM_UP_S, node.pid)
        reference_mb = rss_mb(node.pid)
        marks: list[tuple[int, float, float, float]] = []  # (samples sent, time s, RSS MB, CPU s)
        start_ns = time.perf_counter_ns()

        def mark(sent: int) -> None:
            marks.append((sent, (time.perf_counter_ns() - start_ns) * 1e-9, rss_mb(node.pid), cpu_s(node.pid)["total"]))

        mark(0)
        sent_ns = bench.send(RESIDUAL, rate_hz, int(rate_hz * duration_s), int(rate_hz * every_s), mark)
        time.sleep(DRAIN_S)
        received = bench.received_ns.copy()
    finally:
        bench.close()
        stop_peer(node)
    rows = []
    for (a, t0, _, cpu0), (b, t1, mb, cpu1) in zip(marks, marks[1:]):
        got = received[a:b] > 0
        latency_ms = (received[a:b][got] - sent_ns[a:b][got]) * 1e-6 if got.any() else np.array([np.nan])
        p50, p99 = np.percentile(latency_ms, [50, 99])
        rows.append(Row(t1, mb, 100 * (cpu1 - cpu0) / (t1 - t0), b - a, int((~got).sum()), float(p50), float(p99)))
    return reference_mb, rows


def report(reference_mb: float, rows: list[Row], rate_hz: float) -> None:
    load = os.getloadavg()
    print(f"Live node soak at {rate_hz:g} Hz, 21-joint JointState in, ~/residual out (load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f})")
    print(f"  reference: the node's RSS after a {WARM_UP_S:g} s warm-up, {reference_mb:.1f} MB")
    print(f"{'t [s]':>7} {'RSS MB':>8} {'vs ref':>7} {'CPU %':>6} {'sent':>7} {'lost':>5} {'p50 ms':>7} {'p99 ms':>7}")
    for r in rows:
        print(f"{r.t_s:>7.0f} {r.rss_mb:>8.1f} {r.rss_mb - reference_mb:>+7.1f} {r.cpu_percent:>6.1f} {r.sent:>7} {r.lost:>5} {r.p50_ms:>7.3f} {r.p99_ms:>7.3f}")
    sent, lost = sum(r.sent for r in rows), sum(r.lost for r in rows)
    if len(rows) >= 2:
        minutes = (rows[-1].t_s - rows[0].t_s) / 60
        slope = (rows[-1].rss_mb - rows[0].rss_mb) / minutes if minutes > 0 else float("nan")
        print(f"total: {sent} sent, {lost} lost; RSS {rows[0].rss_mb:.1f} → {rows[-1].rss_mb:.1f} MB ({slope:+.2f} MB/min after the first interval)")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_soak", description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=300.0, help="seconds of input (default 300)")
    parser.add_argument("--rate", type=float, default=500.0, help="input rate in Hz (default 500)")
    parser.add_argument("--every", type=float, default=30.0, help="seconds per row (default 30)")
    args = parser.parse_args([] if argv is None else argv)
    with tempfile.TemporaryDirectory(prefix="bench_soak-roslog-") as log_dir, isolated_ros_env(log_dir) as env:
        os.environ.update(env)  # this process and the node: a private domain, discovery on localhost
        report(*soak(args.duration, args.rate, args.every), args.rate)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
