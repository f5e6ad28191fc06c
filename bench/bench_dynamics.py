"""Speed of the batched Lagrange-Euler core against Pinocchio called per sample from Python.

Issue 2 §5. On N = 100,000 random states of the right arm: batched ``inverse_dynamics``,
``gravity`` and ``mass_matrix`` against Pinocchio's ``rnea``, ``computeGeneralizedGravity`` and
``crba`` on a model with the same parameters, called once per sample from Python (timed on the first
20,000 samples and scaled per sample), in the same run. Also the single-sample latency of
``arm.inverse_dynamics``. Times are the best of a few repeats, after warm-up (numba compilation).
Goals: ratio >= 1.0 for inverse dynamics; single-sample τ < 100 µs.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin

from baxter_dynamics_ros import load_arm_model

# The tests' reference models: a Pinocchio model built from the arm's own YAML parameters.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test"))
from reference_models import pinocchio_from_arm, random_states  # noqa: E402

N_STATES = 100_000
N_PINOCCHIO = 20_000
N_LATENCY = 20_000
REPEATS = 3
TAU_LATENCY_GOAL_US = 100.0


def _best_s(run: Callable[[], object], repeats: int = REPEATS) -> float:
    """Best wall-clock time of ``repeats`` calls of run, in s."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    arm = load_arm_model("right")
    ref = pinocchio_from_arm(arm)
    model, data = ref.model, ref.data
    q, qd, qdd = random_states(arm, N_STATES, seed=0, qdd_max_rad_s2=10.0)
    n_pin = N_PINOCCHIO

    cases = [
        (
            "inverse dynamics",
            lambda: arm.inverse_dynamics(q, qd, qdd),
            "rnea",
            lambda: [pin.rnea(model, data, q[i], qd[i], qdd[i]) for i in range(n_pin)],
        ),
        (
            "gravity",
            lambda: arm.gravity(q),
            "computeGeneralizedGravity",
            lambda: [pin.computeGeneralizedGravity(model, data, q[i]) for i in range(n_pin)],
        ),
        (
            "mass matrix",
            lambda: arm.mass_matrix(q),
            "crba",
            lambda: [pin.crba(model, data, q[i]) for i in range(n_pin)],
        ),
    ]
    for _, _, _, pinocchio_run in cases:  # warm-up: numba compiles (or loads its cache), Pinocchio's first calls
        arm.inverse_dynamics(q[:2], qd[:2], qdd[:2]), arm.gravity(q[:2]), arm.mass_matrix(q[:2])
        pinocchio_run()

    print(
        f"dynamics: right arm, N = {N_STATES:,} random states; L-E batched (numba {numba.__version__}, one thread) "
        f"vs Pinocchio {pin.__version__} per sample from Python on {n_pin:,}; best of {REPEATS}; "
        f"{os.cpu_count()} CPUs"
    )
    print(f"  {'':17}{'L-E [samples/s]':>17}{'Pinocchio [samples/s]':>23}   {'ratio':>6}")
    ratios = {}
    for name, ours, pin_name, theirs in cases:
        ours_rate = N_STATES / _best_s(ours)
        pin_rate = n_pin / _best_s(theirs)
        ratios[name] = ours_rate / pin_rate
        print(f"  {name:17}{ours_rate:17,.0f}{pin_rate:23,.0f}   {ratios[name]:6.2f}  ({pin_name})")

    latency_ns = np.empty(N_LATENCY)
    for i in range(N_LATENCY):
        start = time.perf_counter_ns()
        arm.inverse_dynamics(q[i], qd[i], qdd[i])
        latency_ns[i] = time.perf_counter_ns() - start
    median_us, p99_us = np.percentile(latency_ns, [50, 99]) / 1e3
    print(
        f"  single-sample arm.inverse_dynamics: median {median_us:.1f} µs, p99 {p99_us:.1f} µs "
        f"over {N_LATENCY:,} warm calls"
    )
    id_ok = ratios["inverse dynamics"] >= 1.0
    latency_ok = median_us < TAU_LATENCY_GOAL_US
    print(
        f"  goals: inverse-dynamics ratio >= 1.0: {'met' if id_ok else 'NOT MET'}; "
        f"single-sample tau < {TAU_LATENCY_GOAL_US:.0f} µs: {'met' if latency_ok else 'NOT MET'}"
    )


if __name__ == "__main__":
    main()
