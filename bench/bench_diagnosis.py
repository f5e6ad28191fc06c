"""Speed of the gap diagnosis on one hour of 100 Hz data (goal ≤ 15 s: issue 20; issue 5 §8 asked ≤ 60 s).

Four simulated 15-minute recordings of the right arm (random joint-space excitation, the s1
spring and viscous friction, Baxter-like quantisation and noise) make the hour: three to train on,
one to test on. Measured in the same run:

- ``diagnose`` on them, in this process (recordings already in memory): every candidate's
  regressor, the statistics of both q̈ worlds, the forward selection and the held-out figures;
- reference: one rigid-body inverse-dynamics pass over the same hour (the least any diagnosis of
  the model's residual must do), and the ratio of the two.

Run: ``./dev bench diagnosis`` (or ``python -m bench.bench_diagnosis --minutes 5`` for a shorter one).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.acceleration import first_difference
from baxter_dynamics_ros.core.effect_specs import effects_from_dict
from baxter_dynamics_ros.diagnosis.procedure import diagnose
from baxter_dynamics_ros.errors import BaxterDynamicsError
from baxter_dynamics_ros.simulation.plant import simulate
from baxter_dynamics_ros.simulation.spec import SensorModel, SimulationSpec

GOAL_S = 15.0
EFFECTS = {"s1_spring": {}, "viscous_friction": {"damping_nm_s_rad": [1.0, 1.5, 0.6, 0.6, 0.15, 0.15, 0.05]}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_diagnosis")
    parser.add_argument("--minutes", type=float, default=60.0, help="total recorded time, min (default 60)")
    args = parser.parse_args(argv)
    if not (np.isfinite(args.minutes) and args.minutes > 0):
        print(f"ERROR: --minutes must be a positive number of minutes, got {args.minutes:g}", file=sys.stderr)
        return 1
    try:
        return _run(args.minutes)
    except BaxterDynamicsError as err:  # e.g. recordings too short for a diagnosis
        print(f"ERROR: --minutes {args.minutes:g}: {err}", file=sys.stderr)
        return 1


def _run(minutes: float) -> int:
    """Simulate ``minutes`` of data in four recordings, diagnose them, print the figures."""
    arm = load_arm_model("right")
    each_s = minutes * 60.0 / 4
    start = time.perf_counter()
    recordings = []
    for k in range(4):
        spec = SimulationSpec(
            trajectory="random", duration_s=each_s, rate_hz=100.0, seed=100 + k, side="right",
            effects=effects_from_dict(EFFECTS), sensor=SensorModel(effort_noise_nm=0.1),
        )
        recordings.append((f"random-{k}", simulate(spec, arm).recording()))
    simulated_s = time.perf_counter() - start
    samples = sum(len(r) for _, r in recordings)

    def reference() -> float:
        start = time.perf_counter()
        for _, rec in recordings:
            arm.inverse_dynamics(rec.q, rec.qd, first_difference(rec.qd, rec.stamps_s))
        return time.perf_counter() - start

    reference()  # compiles (or loads) the kernels, which the diagnosis then finds ready
    reference_s = reference()

    start = time.perf_counter()
    result = diagnose(arm, recordings[:3], recordings[3:])
    diagnosis_s = time.perf_counter() - start

    print(f"diagnosis: {minutes:g} min of 100 Hz data ({samples:,} samples, 4 recordings simulated in {simulated_s:.1f} s)")
    print(f"  diagnose (3 train + 1 test)      {diagnosis_s:8.2f} s   {samples / diagnosis_s:12,.0f} samples/s")
    print(f"  reference: one inverse-dynamics pass {reference_s:8.3f} s   {samples / reference_s:12,.0f} samples/s")
    print(f"  ratio diagnose / reference       {diagnosis_s / reference_s:8.1f}")
    print(f"  selected: {', '.join(e.name for e in result.selected())}")
    print(f"  held-out RMS [N·m] rigid {np.round(result.baseline_test_rms, 3).tolist()} -> {np.round(result.final_test_rms, 3).tolist()}")
    minutes_ok = diagnosis_s * 60.0 / minutes
    print(f"  goal: one hour <= {GOAL_S:g} s: {'met' if minutes_ok <= GOAL_S else 'NOT met'} ({minutes_ok:.1f} s per hour of data)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
