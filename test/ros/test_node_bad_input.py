"""The live node against absurd samples, broken files and out-of-range parameters (issue 12).

Real node processes (test/conftest.py's harness), real messages over loopback. Expected outputs
come from the core fed the good samples only (test_node's helpers), so "back to normal" is checked
exactly, from the first sample after the absurd one (10 ms later at 100 Hz).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_node import (
    CONFIG,
    DIAGNOSTICS_PERIOD_S,
    JOINTS,
    RIGHT,
    LiveNode,
    Samples,
    expected_external_torque,
    expected_torques,
    joint_state,
    set_parameter,
)

from baxter_dynamics_ros.ros.node_settings import NodeSettings

rclpy = pytest.importorskip("rclpy")
from rcl_interfaces.srv import DescribeParameters  # noqa: E402

N = 40
ABSURD = 10  # index of the absurd sample
ZEROS = np.zeros(len(JOINTS))


def probe(stamp: int):
    return joint_state(JOINTS, stamp, ZEROS, ZEROS, ZEROS)


def start_node(ros_client, node_processes, namespace: str, *ros_args: str) -> LiveNode:
    """A node in ``namespace`` (its input there too) with fast diagnostics, answering."""
    process = node_processes.start(
        [*ros_args, "-p", f"diagnostics_period_s:={DIAGNOSTICS_PERIOD_S}",
         "-p", f"joint_states_topic:={namespace}/joint_states", "-r", f"__ns:={namespace}"]
    )  # fmt: skip
    live = LiveNode(ros_client, process, namespace=namespace, input_topic=f"{namespace}/joint_states")
    live.wait_ready(probe)
    return live


@pytest.fixture(scope="module")
def node(ros_client, node_processes) -> LiveNode:
    return start_node(ros_client, node_processes, "/absurd", "--params-file", str(CONFIG))


def _spoil(samples: Samples, kind: str) -> None:
    """Make sample ABSURD of ``samples`` absurd at one right-arm joint, in place."""
    k = ABSURD
    column = {"velocity_1e3": "right_s1", "velocity_1e100": "right_w1", "effort_1e30": "right_e0", "position_far": "right_s0"}[kind]
    j = JOINTS.index(column)
    if kind == "velocity_1e3":
        samples.velocity[k, j] = 1e3
    elif kind == "velocity_1e100":
        samples.velocity[k, j] = -1e100
    elif kind == "effort_1e30":
        samples.effort[k, j] = 1e30
    else:
        samples.position[k, j] = 10.0  # s0's limits are ±1.70 rad


@pytest.mark.parametrize("kind", ["velocity_1e3", "velocity_1e100", "effort_1e30", "position_far"])
def test_an_absurd_sample_is_skipped_and_leaves_no_trace(node: LiveNode, kind: str) -> None:
    node.process.check_alive()
    node.reset()
    before = node.idle_report()[2]
    samples = Samples(N, seed=20)
    good = [k for k in range(N) if k != ABSURD]
    q, qd, effort = (a[good] for a in samples.arm(RIGHT.joint_names))
    _spoil(samples, kind)
    node.send([samples.message(k) for k in range(N)])

    stamps = samples.stamps_ns[good]
    expected = expected_torques(RIGHT, stamps, q, qd, effort)
    expected["external_torque"] = expected_external_torque(RIGHT, stamps, q, qd, effort)
    # Every output of every good sample, from the first one after the absurd sample, is what the
    # core gives without it (within 1e-9): back to normal within 10 ms, nothing absorbed.
    node.check(stamps, q, qd, expected, RIGHT.joint_names)
    after = node.idle_report()[2]
    assert int(after["skipped_total.implausible_input"]) == int(before["skipped_total.implausible_input"]) + 1
    for key in before:
        if key.startswith(("skipped_total.", "resets_total.")) and key != "skipped_total.implausible_input":
            assert after[key] == before[key], key
    published = {int(m.header.stamp.sec) * 10**9 + m.header.stamp.nanosec for m in node.outputs["external_torque"].messages}
    assert int(samples.stamps_ns[ABSURD]) not in published


# --------------------------------------------------------------------------- files and parameters
def run_node(*ros_args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "baxter_dynamics_ros.ros.node", "--ros-args", *ros_args], capture_output=True, text=True, timeout=60)


def the_error(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("ERROR:")]
    assert len(errors) == 1 and result.stderr.strip().splitlines()[-1] == errors[0], result.stderr
    return errors[0]


@pytest.mark.parametrize(("parameter", "what"), [("model_file", "model file"), ("effects_file", "effects file"), ("thresholds_file", "thresholds file")])
@pytest.mark.parametrize("content", [bytes(range(256)) * 4, b"# only a comment\n"], ids=["binary", "empty"])
def test_a_binary_or_empty_file_parameter_stops_the_node_with_one_error(ros_domain, tmp_path: Path, parameter: str, what: str, content: bytes) -> None:
    path = tmp_path / "file.yaml"
    path.write_bytes(content)
    line = the_error(run_node("-p", f"{parameter}:={path}"))
    assert line.startswith(f"ERROR: {path}: the {what} is ") and ("not UTF-8" in line or "empty" in line)


#: Files no real Baxter could have produced (issue 22 item 1): calibrate once wrote the s1 threshold
#: of the first file from one effort sample of 1e30 N·m; the damping of the second overflows τ.
ABSURD_FILES = {
    "thresholds_file": (
        "offset_nm: {s0: 5.4, s1: 1.2e+27, e0: 3.8, e1: 2.9, w0: 0.42, w1: 0.91, w2: 0.16}\n"
        "slope_nm_s_rad: {s0: 9.1, s1: 0.0, e0: 0.0, e1: 0.92, w0: 0.68, w1: 0.71, w2: 0.07}\n",
        "the s1 threshold at its velocity limit is 1.2e+27 N·m, above 300 N·m (3 × the joint's effort limit",
    ),
    "effects_file": (
        "arm: right\neffects:\n  viscous_friction: {damping_nm_s_rad: [1.0e+308, 1.0e+308, 1.0e+308, 1.0e+308, 1.0e+308, 1.0e+308, 1.0e+308]}\n",
        "with these effects the model's torque at right_s0 reaches 1.5e+308 N·m within the joint and velocity limits, above 150 N·m",
    ),
}


@pytest.mark.parametrize("parameter", sorted(ABSURD_FILES))
def test_a_file_beyond_what_a_real_baxter_gives_stops_the_node_with_one_error(ros_domain, tmp_path: Path, parameter: str) -> None:
    text, expected = ABSURD_FILES[parameter]
    path = tmp_path / "file.yaml"
    path.write_text(text)
    line = the_error(run_node("-p", f"{parameter}:={path}"))
    assert line.startswith(f"ERROR: {path}: {expected}"), line


@pytest.mark.parametrize(
    "override", ["cutoff_hz:=1e300", "cutoff_hz:=1e9", "qos_depth:=1000000000", "calibration_window_s:=1e6", "observer_gain_1_s:=1e5", "diagnostics_period_s:=0.0"]
)
def test_a_parameter_out_of_its_range_stops_the_node_with_one_error(ros_domain, override: str) -> None:
    line = the_error(run_node("-p", override))
    assert "out of range" in line and override.split(":=")[0] in line


def test_every_numeric_parameter_shows_its_range_and_refuses_values_outside(node: LiveNode) -> None:
    numeric = {f.name: f.metadata["bounds"] for f in NodeSettings.fields() if isinstance(f.default, (int, float))}
    assert set(numeric) == {"qos_depth", "cutoff_hz", "diagnostics_period_s", "observer_gain_1_s", "calibration_window_s"}
    assert all(bounds is not None for bounds in numeric.values())
    response = node.client.call(DescribeParameters, f"{node.prefix}/describe_parameters", DescribeParameters.Request(names=list(numeric)))
    for descriptor in response.descriptors:
        ranges = list(descriptor.floating_point_range) + list(descriptor.integer_range)
        assert len(ranges) == 1, descriptor.name
        assert (ranges[0].from_value, ranges[0].to_value) == numeric[descriptor.name]
    for value in (1e300, 1e9, 0.0, -1.0):
        ok, reason = set_parameter(node, "cutoff_hz", value)
        assert not ok and "cutoff_hz" in reason and "range" in reason
    assert set_parameter(node, "cutoff_hz", 1000.0)[0] and set_parameter(node, "cutoff_hz", 10.0)[0]


def test_an_override_naming_no_parameter_is_warned_about(ros_client, node_processes) -> None:
    typo = start_node(ros_client, node_processes, "/typo", "-p", "cuttof_hz:=5.0")
    assert "ignoring parameters this node does not have: cuttof_hz (cuttof_hz: did you mean cutoff_hz?)" in typo.process.output()
    assert typo.process.stop() == 0
