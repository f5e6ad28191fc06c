"""Collision monitoring in the live node (issue 6, §2 and §5): ~/collision, diagnostics, ~/set_monitoring, ~/calibrate.

The node runs in its own process; this process plays a smooth 100 Hz motion of the right arm whose
effort is exactly the model's τ (so the observer's r stays near 0), optionally with a sustained
external torque on e1: the effort then lacks CONTACT_NM there, and r ≈ −CONTACT_NM. Times of
~/collision messages are taken on arrival and compared with the times the contact's samples were sent.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from test_node import JOINTS, RATE_HZ, RIGHT, LiveNode, joint_state, next_start_ns

from baxter_dynamics_ros.monitoring.thresholds import Thresholds, write_thresholds

rclpy = pytest.importorskip("rclpy")
from std_msgs.msg import Bool  # noqa: E402
from std_srvs.srv import SetBool, Trigger  # noqa: E402

DIAGNOSTICS_PERIOD_S = 0.25
N_SAMPLES = 150  # 1.5 s at 100 Hz
CONTACT = slice(60, 90)  # 0.6 s to 0.9 s: 0.3 s of contact
CONTACT_NM = 5.0
E1 = RIGHT.joint_names.index("right_e1")
DELAY_BUDGET_S = 0.1


def motion(contact: bool, n: int = N_SAMPLES) -> tuple[np.ndarray, list]:
    """Stamps (n,) and the JointStates of a smooth swing whose effort is the model's τ (minus the contact)."""
    t = np.arange(n) / RATE_HZ
    w = 2 * np.pi * np.linspace(0.3, 0.6, 7)
    amp = np.array([0.3, 0.2, 0.3, 0.3, 0.4, 0.3, 0.5])
    q0 = np.array([0.0, -0.5, 0.0, 1.2, 0.0, 0.5, 0.0])
    q = q0 + amp * np.sin(np.outer(t, w))
    qd = amp * w * np.cos(np.outer(t, w))
    qdd = -amp * w**2 * np.sin(np.outer(t, w))
    effort = RIGHT.inverse_dynamics(q, qd, qdd)
    if contact:
        effort[CONTACT, E1] -= CONTACT_NM
    stamps = next_start_ns() + np.round(t * 1e9).astype(np.int64)
    cols = [JOINTS.index(j) for j in RIGHT.joint_names]
    messages = []
    for k in range(n):
        full = np.zeros((3, len(JOINTS)))
        full[:, cols] = q[k], qd[k], effort[k]
        messages.append(joint_state(JOINTS, stamps[k], *full))
    return stamps, messages


class Monitored(LiveNode):
    """A LiveNode that also records ~/collision with arrival times (monotonic, s)."""

    def __init__(self, client, process, namespace: str) -> None:
        super().__init__(client, process, namespace=namespace, input_topic=f"{namespace}/joint_states")
        self.collisions: list[tuple[float, bool]] = []
        client.node.create_subscription(Bool, f"{self.prefix}/collision", lambda m: self.collisions.append((time.monotonic(), m.data)), 100)

    def play(self, contact: bool) -> tuple[float, float]:
        """Reset, play a motion (with or without contact); (start, end) of the contact as sent (monotonic s).

        ``played_at``: when the motion began (monotonic s)."""
        self.reset()
        _, messages = motion(contact)
        t0 = self.played_at = time.monotonic()
        sent = []
        for k, msg in enumerate(messages):
            delay = t0 + k / RATE_HZ - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            self.publisher.publish(msg)
            sent.append(time.monotonic())
        time.sleep(0.3)  # let the last answers and a diagnostics report arrive
        return sent[CONTACT.start], sent[CONTACT.stop]

    def received_since_play(self) -> list[tuple[float, bool]]:
        """~/collision messages (arrival, data) since the last motion began."""
        return [(at, on) for at, on in self.collisions if at >= self.played_at]

    def call(self, srv_type, name: str, request):
        return self.client.call(srv_type, f"{self.prefix}/{name}", request)


def start_node(ros_client, node_processes, namespace: str, extra: list[str]) -> Monitored:
    process = node_processes.start(
        ["-p", f"joint_states_topic:={namespace}/joint_states", "-p", f"diagnostics_period_s:={DIAGNOSTICS_PERIOD_S}",
         "-r", f"__ns:={namespace}", *extra]
    )
    node = Monitored(ros_client, process, namespace)
    node.wait_ready(lambda stamp: joint_state(JOINTS, stamp, np.zeros(len(JOINTS)), np.zeros(len(JOINTS)), np.zeros(len(JOINTS))))
    return node


@pytest.fixture(scope="module")
def guarded(ros_client, node_processes, tmp_path_factory) -> Monitored:
    """A node detecting with a thresholds file of 2 N·m on every joint."""
    path = tmp_path_factory.mktemp("thresholds") / "thresholds.yaml"
    write_thresholds(path, Thresholds(np.full(7, 2.0)))
    return start_node(ros_client, node_processes, "/guarded", ["-p", f"thresholds_file:={path}"])


def assert_contact_detected(node: Monitored, start: float, end: float, since_diag: int) -> None:
    changes = node.received_since_play()
    on = [at for at, value in changes if value]
    assert on, f"no ~/collision true after the contact began: {changes}"
    assert start <= on[0] <= start + DELAY_BUDGET_S, f"detected {on[0] - start:.3f} s after the contact began"
    off = [at for at, value in changes if not value and at > on[0]]
    assert off and off[0] >= end, f"~/collision never back to false after the contact: {changes}"
    level, message, values = node.report(since_diag, lambda s: s[0] == 2)
    assert "right_e1" in message and values["collision_joints"] == "right_e1", message


def test_contact_turns_collision_on_within_budget_then_off_with_an_error_naming_e1(guarded: Monitored) -> None:
    since_diag = len(guarded.diagnostics.messages)
    start, end = guarded.play(contact=True)
    assert_contact_detected(guarded, start, end, since_diag)
    time.sleep(DIAGNOSTICS_PERIOD_S * 2)  # the steady message says false once the contact is over
    assert guarded.collisions[-1][1] is False and guarded.collisions[-1][0] > end + DIAGNOSTICS_PERIOD_S


def test_no_detection_on_a_collision_free_motion(guarded: Monitored) -> None:
    since_diag = len(guarded.diagnostics.messages)
    guarded.play(contact=False)
    assert not any(on for _, on in guarded.received_since_play())
    assert any(not on for _, on in guarded.received_since_play())  # the steady false keeps coming
    level, message, values = guarded.report(since_diag, lambda s: int(s[2]["samples_received"]) > 10)
    assert level == 0 and values["collision"] == "false" and values["monitoring"] == "on", message


def test_set_monitoring_off_suppresses_detection(guarded: Monitored) -> None:
    response = guarded.call(SetBool, "set_monitoring", SetBool.Request(data=False))
    assert response.success and "off" in response.message
    try:
        guarded.play(contact=True)
        assert not any(on for _, on in guarded.received_since_play())
    finally:
        assert guarded.call(SetBool, "set_monitoring", SetBool.Request(data=True)).success
    since_diag = len(guarded.diagnostics.messages)
    start, end = guarded.play(contact=True)  # on again: detected again
    assert_contact_detected(guarded, start, end, since_diag)


def test_calibrate_online_then_the_thresholds_apply(ros_client, node_processes) -> None:
    node = start_node(ros_client, node_processes, "/calibrated", ["-p", "calibration_window_s:=1.0"])
    node.reset()
    response = node.call(Trigger, "calibrate", Trigger.Request())
    assert not response.success and "too little data" in response.message
    node.play(contact=True)  # no thresholds yet: nothing detected
    assert not any(on for _, on in node.received_since_play())
    node.play(contact=False)
    response = node.call(Trigger, "calibrate", Trigger.Request())
    assert response.success, response.message
    since_diag = len(node.diagnostics.messages)
    start, end = node.play(contact=True)
    assert_contact_detected(node, start, end, since_diag)
    level, message, values = node.report(len(node.diagnostics.messages), lambda s: s[0] != 2)
    assert values["thresholds"].startswith("~/calibrate") and values["threshold_offset_nm.right_e1"] != "n/a"
    assert 0.0 < float(values["threshold_offset_nm.right_e1"]) < 2.0
