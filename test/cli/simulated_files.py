"""Simulated right-arm recordings as the robot publishes them, written by the project's writer, and
a comparison of two diagnosis.json documents (numbers to 1e-9)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def simulated(duration_s: float, seed: int):
    from baxter_dynamics_ros.simulation.plant import simulate
    from baxter_dynamics_ros.simulation.spec import SimulationSpec
    from msg_adapters.robot_joint_states import robot_joint_states

    result = simulate(SimulationSpec("random", duration_s, 100.0, seed=seed))
    return robot_joint_states(result.recording(), result.other_q, result.other_effort)


def write_states(path: Path, states) -> Path:
    from msg_adapters.recording_files import write_joint_states

    write_joint_states(path, states.stamps_ns, states.names, states.position, states.velocity, states.effort)
    return path


def assert_json_close(a, b, path: str = "") -> None:
    """Equal JSON documents, numbers to 1e-9 (relative where larger than 1); NaN written as null."""
    a, b = (None if isinstance(x, float) and np.isnan(x) else x for x in (a, b))
    if isinstance(a, dict):
        assert set(a) == set(b), path
        for k in a:
            assert_json_close(a[k], b[k], f"{path}/{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            assert_json_close(x, y, f"{path}[{k}]")
    elif isinstance(a, float) and isinstance(b, float):
        assert abs(a - b) <= 1e-9 * max(1.0, abs(a)), (path, a, b)
    else:
        assert a == b, (path, a, b)
