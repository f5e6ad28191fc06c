"""``baxter-dynamics play`` into the live node, against ``process`` on the same bag, sample by sample.

Real processes over loopback: the node (``python -m baxter_dynamics_ros.ros.node`` on use_sim_time),
the player (the console command) and this process's client, all on the private local ROS graph
that test/conftest.py sets up (LOCALHOST discovery, a domain id of the module's own, ROS_LOG_DIR in
a temporary folder), which the subprocesses inherit through os.environ.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from repo_paths import REPO
from recorded_bags import BAXTER_JOINTS, joint_states, read_output_bag, write_reference_bag

from baxter_dynamics_ros.cli.main import main
from msg_adapters.bag_io import RESULT_TOPICS

N = 200  # 2 s at 100 Hz, played at twice real time
CUTOFF_HZ = 8.0
TIMEOUT_S = 60.0


def _stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _play(bag: Path, *options: str, sigint_ignored: bool = False) -> subprocess.Popen:
    """``baxter-dynamics play BAG`` in a subprocess; sigint_ignored: started with SIGINT ignored, as a
    shell starts a background job."""
    command = [sys.executable, "-m", "baxter_dynamics_ros.cli", "play", str(bag), "--wait-for-subscribers", "30", *options]
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if sigint_ignored else None
    return subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=ignore)


def _wait_for_publishers(client, topics, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if all(client.node.count_publishers(topic) > 0 for topic in topics):
            return True
        time.sleep(0.05)
    return False


def test_play_into_the_node_matches_process_sample_by_sample(tmp_path: Path, ros_client, node_processes) -> None:
    from sensor_msgs.msg import JointState

    states = joint_states(N)
    bag = write_reference_bag(tmp_path / "baxter.bag", "ros1", states)  # a ROS 1 bag, as Baxter records
    inboxes = {topic: ros_client.collect(JointState, topic) for topic in RESULT_TOPICS.values()}
    node = node_processes.start(
        ["-p", "arm:=right", "-p", "use_sim_time:=true", "-p", "estimator:=lowpass", "-p", f"cutoff_hz:={CUTOFF_HZ}"]
    )
    if not _wait_for_publishers(ros_client, inboxes, TIMEOUT_S):
        node.check_alive()
        pytest.fail(f"the node's outputs never appeared:\n{node.output()}")

    play = _play(bag, "--speed", "2")
    _, err = play.communicate(timeout=TIMEOUT_S)
    assert play.returncode == 0, err
    deadline = time.monotonic() + 10.0  # played in 1 s: the last outputs follow within milliseconds
    while time.monotonic() < deadline and any(len(inbox.messages) < N for inbox in inboxes.values()):
        time.sleep(0.05)
    live = {topic: list(inbox.messages) for topic, inbox in inboxes.items()}
    if any(len(messages) != N for messages in live.values()):
        expected = states["stamps_ns"].tolist()
        missing = {t: sorted(set(expected) - {_stamp_ns(m.header.stamp) for m in ms}) for t, ms in live.items()}
        lost = {t: f"{len(ms)} of {N} received, missing samples {[expected.index(s) for s in missing[t]][:10]}" for t, ms in live.items()}
        pytest.fail(f"outputs lost: {lost}\nnode output:\n{node.output()}")

    processed = tmp_path / "processed.mcap"
    command = ["process", str(bag), "--out", str(processed), "--acceleration", "lowpass", "--cutoff-hz", str(CUTOFF_HZ)]
    assert main(command) == 0
    offline = read_output_bag(processed)
    for topic, messages in live.items():
        by_stamp = {_stamp_ns(m.header.stamp): np.array(m.effort) for m in messages}
        stamps = offline[topic]["stamps_ns"].tolist()
        assert len(messages) == N and sorted(by_stamp) == stamps
        # Same estimator, same stamps, same compiled core: equal but for rounding.
        got = np.array([by_stamp[s] for s in stamps])
        np.testing.assert_allclose(got, offline[topic]["effort"], rtol=0, atol=1e-9, err_msg=topic)
    # The comparison has teeth: τ − G (the q̈ and q̇ terms) is not small here, so another estimator
    # or cutoff on either side would show in the inverse dynamics and the residual.
    inverse = offline["/baxter_dynamics/inverse_dynamics"]["effort"]
    gravity = offline["/baxter_dynamics/gravity"]["effort"]
    assert np.abs(inverse - gravity).max() > 0.1


def test_play_publishes_joint_states_and_clock_and_loops_until_interrupted(tmp_path: Path, ros_client) -> None:
    """The player alone: a ROS 1 SEAJointState topic as JointState, /clock at the receive times."""
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    states = joint_states(20)
    topic = "/robot/limb/right/state"
    bag = write_reference_bag(tmp_path / "sea.bag", "ros1", states, topic=topic, sea=True)
    inbox = ros_client.collect(JointState, topic)
    clock = ros_client.collect(Clock, "/clock")
    first_ns = int(states["stamps_ns"][0])

    # Started with SIGINT ignored, as a background job: the player still stops at SIGINT, cleanly.
    play = _play(bag, "--speed", "5", "--loop", sigint_ignored=True)
    # Looping: the clock comes back to the first stamp after the last one.
    clock.wait_for(lambda m: [_stamp_ns(c.clock) for c in m].count(first_ns) >= 2, TIMEOUT_S, "a second pass")
    play.send_signal(signal.SIGINT)
    _, err = play.communicate(timeout=TIMEOUT_S)
    assert play.returncode == 0, err

    received = {_stamp_ns(m.header.stamp): m for m in inbox.messages}
    assert sorted(received) == states["stamps_ns"].tolist()
    first = received[first_ns]
    assert list(first.name) == list(BAXTER_JOINTS)
    np.testing.assert_array_equal(first.position, states["position"][0])
    np.testing.assert_array_equal(first.effort, states["effort"][0])
    assert {_stamp_ns(c.clock) for c in clock.messages} == set(states["stamps_ns"].tolist())


def test_play_errors_are_one_line(tmp_path: Path, capsys) -> None:
    bag = write_reference_bag(tmp_path / "a.bag", "ros1", joint_states(5))
    assert main(["play", str(bag), "--topics", "/nope"]) == 1
    assert capsys.readouterr().err.startswith(f"ERROR: {bag}: no topic /nope; joint-state topics in this bag: /robot/joint_states")
    assert main(["play", str(bag), "--speed", "0"]) == 1
    assert capsys.readouterr().err == "ERROR: --speed must be positive, got 0.0\n"
