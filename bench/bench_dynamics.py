"""Speed of the batched Lagrange-Euler core against Pinocchio, compiled and called from Python.

Issues 2 §5 and 14 §4. On N = 100,000 random states of the right arm: batched
``inverse_dynamics``, ``gravity`` and ``mass_matrix`` on one thread and on all cores, against
Pinocchio's ``rnea``, ``crba`` and ``computeGeneralizedGravity`` on a model with the same
parameters, (a) compiled from the pin wheel's headers (``bench/pinocchio_anchor.py``; skipped,
with the reason, without a C++ compiler or the headers) on the same states and (b) called once
per sample from Python (timed on the first 20,000 samples). All in the same run, times per
sample, the best of a few repeats after warm-up. Also: the cost of waking numba's thread pool and
the batch at the parallel threshold on one thread and on all cores (the threshold's
justification), and the single-sample latency of ``arm.inverse_dynamics``.
Goals: ≥ 2× compiled Pinocchio per sample on all cores; single-sample τ < 100 µs.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin
from numba import njit, prange

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core import lagrange_euler

from . import pinocchio_anchor

# The tests' reference models: a Pinocchio model built from the arm's own YAML parameters.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
from reference_models import pinocchio_from_arm, random_states  # noqa: E402

N_STATES = 100_000
N_PINOCCHIO = 20_000
N_LATENCY = 20_000
N_WAKE = 2_000
REPEATS = 3
ANCHOR_REPEATS = 5
TAU_LATENCY_GOAL_US = 100.0
ANCHOR_RATIO_GOAL = 2.0
ANCHOR_AGREEMENT = 1e-9  # relative: the anchor must compute what the L-E core computes


def _best_s(run: Callable[[], object], repeats: int = REPEATS) -> float:
    """Best wall-clock time of ``repeats`` calls of run, in s."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


@njit(parallel=True)
def _wake_pool(out: np.ndarray) -> None:
    """A parallel region with next to no work: what a split batch pays to start the threads."""
    for i in prange(out.shape[0]):
        out[i] = i


def _median_us(run: Callable[[], object], calls: int) -> float:
    """Median wall-clock time of one call of run over ``calls`` calls, µs."""
    times = np.empty(calls)
    for i in range(calls):
        start = time.perf_counter_ns()
        run()
        times[i] = time.perf_counter_ns() - start
    return float(np.median(times)) / 1e3


def _relative_error(ours: np.ndarray, theirs: np.ndarray) -> float:
    """max |ours − theirs| / max(max |theirs|, 1)."""
    return float(np.max(np.abs(ours - theirs)) / max(float(np.max(np.abs(theirs))), 1.0))


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(prog="python -m bench.bench_dynamics", description=__doc__.splitlines()[0]).parse_args(argv)
    arm = load_arm_model("right")
    ref = pinocchio_from_arm(arm)
    model, data = ref.model, ref.data
    q, qd, qdd = random_states(arm, N_STATES, seed=0, qdd_max_rad_s2=10.0)
    n_pin = N_PINOCCHIO
    threads = numba.config.NUMBA_NUM_THREADS

    cases = [
        ("inverse dynamics", "rnea", lambda: arm.inverse_dynamics(q, qd, qdd),
         lambda: [pin.rnea(model, data, q[i], qd[i], qdd[i]) for i in range(n_pin)]),
        ("gravity", "gravity", lambda: arm.gravity(q),
         lambda: [pin.computeGeneralizedGravity(model, data, q[i]) for i in range(n_pin)]),
        ("mass matrix", "crba", lambda: arm.mass_matrix(q),
         lambda: [pin.crba(model, data, q[i]) for i in range(n_pin)]),
    ]
    for _, _, ours, pinocchio_run in cases:  # warm-up: numba compiles (or loads its cache), Pinocchio's first calls
        ours()
        pinocchio_run()

    print(
        f"dynamics: right arm, N = {N_STATES:,} random states; L-E batched (numba {numba.__version__}, "
        f"threading layer {numba.threading_layer()}, parallel from {lagrange_euler.PARALLEL_MIN_SAMPLES:,} samples) "
        f"vs Pinocchio {pin.__version__}; best of {REPEATS}; {os.cpu_count()} CPUs; load average "
        + " ".join(f"{x:.2f}" for x in os.getloadavg())
    )
    le_us = {}
    for label, n_threads in (("1 thread", 1), (f"{threads} threads", threads)):
        numba.set_num_threads(n_threads)
        le_us[label] = {key: _best_s(ours) / N_STATES * 1e6 for _, key, ours, _ in cases}
    numba.set_num_threads(threads)
    python_us = {key: _best_s(theirs) / n_pin * 1e6 for _, key, _, theirs in cases}

    binary, why = pinocchio_anchor.build()
    anchor_us: dict[str, float] = {}
    if binary is None:
        print(f"  compiled-Pinocchio anchor SKIPPED: {why}")
    else:
        anchor = pinocchio_anchor.run(binary, arm, q, qd, qdd, ANCHOR_REPEATS)
        errors = {
            "rnea": _relative_error(arm.inverse_dynamics(q, qd, qdd), anchor.tau),
            "crba": _relative_error(arm.mass_matrix(q), anchor.mass),
            "gravity": _relative_error(arm.gravity(q), anchor.grav),
        }
        worst = max(errors.values())
        if worst > ANCHOR_AGREEMENT:
            print(f"  compiled-Pinocchio anchor REJECTED: its results differ from L-E by {worst:.1e} (relative)")
        else:
            anchor_us = {"rnea": anchor.rnea_us, "crba": anchor.crba_us, "gravity": anchor.gravity_us}
            print(
                f"  compiled-Pinocchio anchor: {binary.name} (-O3 -march=native), best of {ANCHOR_REPEATS} "
                f"on the same {N_STATES:,} states; agrees with L-E to {worst:.1e} (relative)"
            )

    all_cores = f"{threads} threads"
    print(
        f"  {'[µs per sample]':28}{'L-E 1 thread':>13}{'L-E ' + all_cores:>15}{'Pin. C++':>10}{'Pin. Python':>13}"
        f"{'C++/L-E 1 thr':>15}{'C++/L-E all':>13}{'Python/L-E all':>16}"
    )
    verdicts = []
    for name, key, _, _ in cases:
        one, every = le_us["1 thread"][key], le_us[all_cores][key]
        line = f"  {name + ' (' + key + ')':28}{one:13.3f}{every:15.3f}"
        if anchor_us:
            c = anchor_us[key]
            line += f"{c:10.3f}{python_us[key]:13.3f}{c / one:15.2f}{c / every:13.2f}"
            verdicts.append(f"{key} {'met' if c / every >= ANCHOR_RATIO_GOAL else 'NOT MET'}")
        else:
            line += f"{'—':>10}{python_us[key]:13.3f}{'—':>15}{'—':>13}"
        print(line + f"{python_us[key] / every:16.2f}")

    # The parallel threshold: what the pool costs to wake against what a batch at the threshold takes.
    marker = np.empty(threads)
    _wake_pool(marker)
    wake_us = _median_us(lambda: _wake_pool(marker), N_WAKE)
    n_min = lagrange_euler.PARALLEL_MIN_SAMPLES
    at_min = (q[:n_min], qd[:n_min], qdd[:n_min])
    split = {}
    for n_threads in (1, threads):
        numba.set_num_threads(n_threads)
        split[n_threads] = (
            _median_us(lambda: arm.inverse_dynamics(*at_min), 200),
            _median_us(lambda: arm.gravity(at_min[0]), 200),
            _median_us(lambda: arm.mass_matrix(at_min[0]), 200),
        )
    numba.set_num_threads(threads)
    print(
        f"  thread pool: waking it costs {wake_us:.1f} µs per call (median of {N_WAKE:,}); a batch of {n_min:,} "
        f"samples (τ, G, M) takes " + ", ".join(f"{x:.0f}" for x in split[1]) + " µs on 1 thread and "
        + ", ".join(f"{x:.0f}" for x in split[threads]) + f" µs on {threads} (medians of 200)"
    )

    latency_ns = np.empty(N_LATENCY)
    for i in range(N_LATENCY):
        start = time.perf_counter_ns()
        arm.inverse_dynamics(q[i], qd[i], qdd[i])
        latency_ns[i] = time.perf_counter_ns() - start
    median_us, p99_us = np.percentile(latency_ns, [50, 99]) / 1e3
    print(
        f"  single-sample arm.inverse_dynamics (calling thread): median {median_us:.1f} µs, p99 {p99_us:.1f} µs "
        f"over {N_LATENCY:,} warm calls"
    )
    latency_ok = median_us < TAU_LATENCY_GOAL_US
    anchor_goal = "; ".join(verdicts) if verdicts else "not measured (no anchor)"
    print(
        f"  goals: >= {ANCHOR_RATIO_GOAL:.0f}x compiled Pinocchio per sample on all cores: {anchor_goal}; "
        f"single-sample tau < {TAU_LATENCY_GOAL_US:.0f} µs: {'met' if latency_ok else 'NOT MET'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
