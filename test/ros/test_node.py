"""The live node against the core, in real processes over loopback (issue 3, §1–6).

The node runs as ``python -m baxter_dynamics_ros.ros.node`` in its own process; this process publishes
Baxter-like joint states (all 21 joints, alphabetical, 100 Hz) and listens to the outputs. Expected
values come from the core directly — ``arm.gravity``, ``arm.inverse_dynamics`` and the q̈
estimator fed the same samples and stamps — not from the node's pipeline. Discovery stays on this
machine in a domain of the module's own (test/conftest.py).
"""

from __future__ import annotations

import itertools
import math
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from processes import interrupt
from repo_paths import REPO
from recorded_bags import START_NS, joint_states
from reference_models import dahl_state_of_steps

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.acceleration import FirstDifference, LowPassDifferentiator
from baxter_dynamics_ros.monitoring.observer import DEFAULT_GAIN_1_S, MomentumObserver
from msg_adapters.robot_joint_states import BAXTER_JOINT_NAMES

rclpy = pytest.importorskip("rclpy")
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import SetParameters  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

CONFIG = REPO / "config" / "baxter_dynamics.yaml"
JOINTS = tuple(sorted(BAXTER_JOINT_NAMES))  # as a real Baxter sends them
RATE_HZ = 100.0
DIAGNOSTICS_PERIOD_S = 0.25
TOL = 1e-9
RIGHT = load_arm_model("right")
LEFT = load_arm_model("left")
_starts = itertools.count(1)


def next_start_ns() -> int:
    """A fresh time base for a test's samples: 100 s after the previous one."""
    return START_NS + next(_starts) * 100_000_000_000


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def joint_state(names: Sequence[str], stamp_ns: int, position=(), velocity=(), effort=()) -> JointState:
    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
    msg.name = list(names)
    msg.position = [float(x) for x in position]
    msg.velocity = [float(x) for x in velocity]
    msg.effort = [float(x) for x in effort]
    return msg


class Samples:
    """n Baxter-like samples: stamps_ns (n,), position/velocity/effort (n, 21) in JOINTS order."""

    def __init__(self, n: int, seed: int = 0, names: Sequence[str] = JOINTS) -> None:
        data = joint_states(n, names, RATE_HZ, seed)
        self.names = list(names)
        self.stamps_ns = data["stamps_ns"] - START_NS + next_start_ns()
        self.position, self.velocity, self.effort = data["position"], data["velocity"], data["effort"]

    def message(self, k: int) -> JointState:
        return joint_state(self.names, self.stamps_ns[k], self.position[k], self.velocity[k], self.effort[k])

    def arm(self, arm_names: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        cols = [self.names.index(j) for j in arm_names]
        return self.position[:, cols], self.velocity[:, cols], self.effort[:, cols]


def expected_torques(
    arm, stamps_ns, q, qd, effort, estimator: Callable[[], object] = lambda: LowPassDifferentiator(10.0), resets=(), compensation=None
) -> dict[str, np.ndarray]:
    """The core's gravity, τ and residual (N, 7) for samples the node accepted in this order.

    The estimator restarts at the samples whose index is in ``resets`` (and at 0). With a
    compensation, τ and G are those of its model; Dahl's friction state restarts with the estimator
    (``reference_models.dahl_state_of_steps`` of the trapezoid of q̇)."""
    est = estimator()
    qdd = np.zeros_like(qd)
    steps = np.zeros_like(qd)  # the angle turned into each sample since the last, rad
    for k in range(len(stamps_ns)):
        if k in resets:
            est.reset()
        dt_s = 0.0 if k == 0 or k in resets else (int(stamps_ns[k]) - int(stamps_ns[k - 1])) * 1e-9
        qdd[k] = est.update(qd[k], dt_s)
        steps[k] = 0.0 if dt_s == 0.0 else 0.5 * (qd[k] + qd[k - 1]) * dt_s
    if compensation is None:
        tau = arm.inverse_dynamics(q, qd, qdd)
    else:
        arm = compensation.arm
        presliding = None
        if compensation.presliding is not None:
            starts = sorted({0, *resets, len(qd)})
            presliding = np.vstack([
                dahl_state_of_steps(steps[a:b], compensation.presliding.presliding_rad) for a, b in itertools.pairwise(starts)
            ])  # fmt: skip
        tau = arm.inverse_dynamics(q, qd, qdd) + compensation.torque(q, qd, qdd, presliding)
    return {"gravity": arm.gravity(q), "inverse_dynamics": tau, "residual": effort - tau}


def expected_external_torque(arm, stamps_ns, q, qd, effort, gain_1_s: float = DEFAULT_GAIN_1_S, compensation=None) -> np.ndarray:
    """The momentum observer's r (N, 7) fed the samples the node accepted, in order, from a reset."""
    observer = MomentumObserver(arm, gain_1_s, compensation)
    dt_s = np.diff(np.asarray(stamps_ns, dtype=np.int64), prepend=int(stamps_ns[0])) * 1e-9
    return np.array([observer.update(q[k], qd[k], effort[k], float(dt_s[k])) for k in range(len(stamps_ns))])


def status_of(msg: DiagnosticArray, name: str):
    """(level, message, {key: value}) of the status called ``name``, or None."""
    for status in msg.status:
        if status.name == name:
            return status.level[0], status.message, {kv.key: kv.value for kv in status.values}
    return None


class LiveNode:
    """A running node and this process's publisher and inboxes around it."""

    def __init__(self, client, process, *, namespace: str = "", input_topic: str = "/robot/joint_states") -> None:
        self.client, self.process = client, process
        self.prefix = f"{namespace}/baxter_dynamics"
        self.status_name = f"{self.prefix}: {{}} arm dynamics"
        self.publisher = client.publisher(JointState, input_topic)
        self.outputs = {t: client.collect(JointState, f"{self.prefix}/{t}") for t in ("gravity", "inverse_dynamics", "residual", "external_torque")}
        self.diagnostics = client.collect(DiagnosticArray, "/diagnostics")
        self.side = "right"

    def wait_ready(self, probe: Callable[[int], JointState], timeout_s: float = 60.0) -> None:
        """Send probe samples until the node answers on all three outputs: every link is then matched."""
        deadline = time.monotonic() + timeout_s
        start = next_start_ns()
        for k in itertools.count():
            self.process.check_alive()
            if all(inbox.messages for inbox in self.outputs.values()):
                break
            if time.monotonic() > deadline:
                pytest.fail(f"node gave no output within {timeout_s} s:\n{self.process.output()}")
            self.publisher.publish(probe(start + k * 10_000_000))
            time.sleep(0.1)
        self.reset()

    def send(self, messages: Sequence[JointState], rate_hz: float = RATE_HZ) -> None:
        """Publish at rate_hz, paced on the monotonic clock."""
        t0 = time.monotonic()
        for k, msg in enumerate(messages):
            delay = t0 + k / rate_hz - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            self.publisher.publish(msg)

    def reset(self) -> None:
        """~/reset, then forget what was received so far."""
        response = self.client.call(Trigger, f"{self.prefix}/reset", Trigger.Request())
        assert response.success, response.message
        for inbox in self.outputs.values():
            inbox.clear()

    def received(self, topic: str, stamps: Sequence[int], timeout_s: float = 10.0) -> list[JointState]:
        """The messages on an output topic with these stamps, in that order (waits for them all)."""
        wanted = [int(s) for s in stamps]

        def found(messages):
            by_stamp = {_ns(m.header.stamp): m for m in messages}
            return [by_stamp[s] for s in wanted] if all(s in by_stamp for s in wanted) else None

        return self.outputs[topic].wait_for(found, timeout_s, f"{len(wanted)} samples")

    def check(self, stamps, q, qd, expected: dict[str, np.ndarray], names: Sequence[str]) -> None:
        """Every output of the samples at ``stamps`` equals ``expected`` (residual only if given)."""
        for topic, want in expected.items():
            msgs = self.received(topic, stamps)
            for k, msg in enumerate(msgs):
                assert list(msg.name) == list(names)
                assert _ns(msg.header.stamp) == int(stamps[k])
                np.testing.assert_array_equal(msg.position, q[k])
                np.testing.assert_allclose(msg.velocity, qd[k], rtol=0, atol=TOL)
                np.testing.assert_allclose(msg.effort, want[k], rtol=0, atol=TOL, err_msg=f"{topic} sample {k}")

    def report(self, after: int, done: Callable[[tuple], bool] = lambda s: True, timeout_s: float = 10.0):
        """The first of this node's diagnostics statuses received after message index ``after`` with done(status)."""
        name = self.status_name.format(self.side)

        def find(messages):
            for msg in messages[after:]:
                status = status_of(msg, name)
                if status is not None and done(status):
                    return status
            return None

        return self.diagnostics.wait_for(find, timeout_s, f"a diagnostics status of {name}")

    def idle_report(self):
        """A report of a window in which nothing came in: every earlier count is in its totals."""
        return self.report(len(self.diagnostics.messages), lambda s: s[2]["samples_received"] == "0")


@pytest.fixture(scope="module")
def live(ros_client, node_processes) -> LiveNode:
    """The node with the packaged parameters file (right arm, lowpass 10 Hz), fast diagnostics."""
    process = node_processes.start(["--params-file", str(CONFIG), "-p", f"diagnostics_period_s:={DIAGNOSTICS_PERIOD_S}"])
    node = LiveNode(ros_client, process)
    node.wait_ready(lambda stamp: joint_state(JOINTS, stamp, np.zeros(len(JOINTS)), np.zeros(len(JOINTS)), np.zeros(len(JOINTS))))
    return node


@pytest.fixture
def fresh(live: LiveNode) -> LiveNode:
    """The node reset, alive, with no output of earlier tests left."""
    live.process.check_alive()
    live.reset()
    yield live
    live.process.check_alive()


def set_parameter(live: LiveNode, name: str, value) -> tuple[bool, str]:
    if isinstance(value, str):
        pv = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
    else:
        pv = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
    request = SetParameters.Request(parameters=[Parameter(name=name, value=pv)])
    result = live.client.call(SetParameters, f"{live.prefix}/set_parameters", request).results[0]
    return result.successful, result.reason


# ----------------------------------------------------------------------------- outputs
def test_outputs_equal_the_core_at_100_hz(fresh: LiveNode) -> None:
    samples = Samples(100, seed=1)
    fresh.send([samples.message(k) for k in range(100)])
    q, qd, effort = samples.arm(RIGHT.joint_names)
    expected = expected_torques(RIGHT, samples.stamps_ns, q, qd, effort)
    expected["external_torque"] = expected_external_torque(RIGHT, samples.stamps_ns, q, qd, effort)
    assert np.abs(expected["external_torque"]).max() > 1.0  # a real check, not zeros against zeros
    fresh.check(samples.stamps_ns, q, qd, expected, RIGHT.joint_names)


def test_estimator_and_cutoff_change_live_and_bad_values_are_refused(fresh: LiveNode) -> None:
    ok, reason = set_parameter(fresh, "estimator", "bogus")
    assert not ok and "estimator" in reason
    ok, reason = set_parameter(fresh, "cutoff_hz", -1.0)
    assert not ok and "cutoff_hz" in reason
    ok, reason = set_parameter(fresh, "arm", "left")
    assert not ok and "read-only" in reason
    try:
        for estimator, cutoff_hz, make in (
            ("lowpass", 5.0, lambda: LowPassDifferentiator(5.0)),
            ("first_difference", 5.0, FirstDifference),
        ):
            assert set_parameter(fresh, "cutoff_hz", cutoff_hz)[0]
            assert set_parameter(fresh, "estimator", estimator)[0]
            samples = Samples(30, seed=2)
            fresh.send([samples.message(k) for k in range(30)])
            q, qd, effort = samples.arm(RIGHT.joint_names)
            fresh.check(samples.stamps_ns, q, qd, expected_torques(RIGHT, samples.stamps_ns, q, qd, effort, make), RIGHT.joint_names)
            fresh.reset()
    finally:
        assert set_parameter(fresh, "estimator", "lowpass")[0]
        assert set_parameter(fresh, "cutoff_hz", 10.0)[0]


def test_reset_service_restarts_the_estimator(fresh: LiveNode) -> None:
    samples = Samples(20, seed=3)
    q, qd, effort = samples.arm(RIGHT.joint_names)
    before = fresh.idle_report()[2]
    fresh.send([samples.message(k) for k in range(10)])
    fresh.received("gravity", samples.stamps_ns[:10])
    response = fresh.client.call(Trigger, f"{fresh.prefix}/reset", Trigger.Request())
    assert response.success and "reset" in response.message
    fresh.send([samples.message(k) for k in range(10, 20)])
    expected = expected_torques(RIGHT, samples.stamps_ns, q, qd, effort, resets={10})
    fresh.check(samples.stamps_ns, q, qd, expected, RIGHT.joint_names)
    # Right after the reset q̈ = 0: τ is the model at rest acceleration.
    np.testing.assert_allclose(expected["inverse_dynamics"][10], RIGHT.inverse_dynamics(q[10], qd[10], np.zeros(7)), atol=TOL)
    after = fresh.idle_report()[2]
    assert int(after["resets_total.service"]) == int(before["resets_total.service"]) + 1


# ----------------------------------------------------------------------------- bad input
BAD = 5  # index of the bad sample among 11


def _corrupt(kind: str, samples: Samples) -> JointState | bytes:
    """Sample BAD of ``samples`` spoilt in one way (as bytes when no JointState can hold it)."""
    k, names = BAD, list(samples.names)
    pos, vel, eff = samples.position[k].copy(), samples.velocity[k].copy(), samples.effort[k].copy()
    stamp = samples.stamps_ns[k]
    w1 = names.index("right_w1")
    if kind == "nan_position":
        pos[names.index("right_s0")] = math.nan
    elif kind == "inf_velocity":
        vel[names.index("right_e1")] = math.inf
    elif kind == "nan_effort":
        eff[w1] = -math.inf
    elif kind == "short_position":
        pos = pos[:-1]
    elif kind == "short_effort":
        eff = eff[:3]
    elif kind == "missing_joint":
        names, pos, vel, eff = (np.delete(np.asarray(a), w1).tolist() for a in (names, pos, vel, eff))
    elif kind == "repeated_joint":
        names[names.index("torso_t0")] = "right_w1"
    elif kind == "duplicate_stamp":
        stamp = samples.stamps_ns[k - 1]
    elif kind == "stamp_backwards":
        stamp = samples.stamps_ns[k - 1] - 5_000_000
    elif kind == "huge_velocity":
        vel[names.index("right_s1")] = 1e200
    elif kind == "far_position":
        pos[names.index("right_e1")] = -1.0
    elif kind == "truncated_bytes":
        return bytes(serialize_message(samples.message(k)))[:-100]
    return joint_state(names, stamp, pos, vel, eff)


# kind -> (skip cause counted, whether the estimator restarts after it)
BAD_INPUTS = {
    "nan_position": ("non_finite_input", False),
    "inf_velocity": ("non_finite_input", False),
    "nan_effort": ("non_finite_input", False),
    "short_position": ("array_length", False),
    "short_effort": ("array_length", False),
    "missing_joint": ("missing_joint", False),
    "repeated_joint": ("missing_joint", False),
    "duplicate_stamp": ("duplicate_stamp", False),
    "stamp_backwards": ("stamp_backwards", True),
    "huge_velocity": ("implausible_input", False),
    "far_position": ("implausible_input", False),
    "truncated_bytes": ("unreadable", False),
}


@pytest.mark.parametrize("kind", BAD_INPUTS)
def test_bad_sample_is_skipped_counted_and_the_next_ones_are_right(fresh: LiveNode, kind: str) -> None:
    cause, restarts = BAD_INPUTS[kind]
    samples = Samples(11, seed=4)
    before = fresh.idle_report()[2]
    messages = [samples.message(k) for k in range(11)]
    messages[BAD] = _corrupt(kind, samples)
    fresh.send(messages)

    good = [k for k in range(11) if k != BAD]
    q, qd, effort = (a[good] for a in samples.arm(RIGHT.joint_names))
    stamps = samples.stamps_ns[good]
    expected = expected_torques(RIGHT, stamps, q, qd, effort, resets={BAD} if restarts else ())
    fresh.check(stamps, q, qd, expected, RIGHT.joint_names)
    after = fresh.idle_report()[2]
    for key in before:
        if key.startswith("skipped_total."):
            delta = int(after[key]) - int(before[key])
            assert delta == (1 if key == f"skipped_total.{cause}" else 0), (key, delta)
    if kind not in ("duplicate_stamp", "stamp_backwards"):  # those reuse or precede a good sample's stamp
        assert int(samples.stamps_ns[BAD]) not in {_ns(m.header.stamp) for m in fresh.outputs["gravity"].messages}


def test_non_finite_value_of_another_joint_does_not_matter(fresh: LiveNode) -> None:
    samples = Samples(10, seed=5)
    samples.position[:, JOINTS.index("head_pan")] = math.nan
    samples.effort[:, JOINTS.index("l_gripper_l_finger_joint")] = math.inf
    fresh.send([samples.message(k) for k in range(10)])
    q, qd, effort = samples.arm(RIGHT.joint_names)
    fresh.check(samples.stamps_ns, q, qd, expected_torques(RIGHT, samples.stamps_ns, q, qd, effort), RIGHT.joint_names)


def test_without_effort_no_residual_is_published_and_diagnostics_warn(fresh: LiveNode) -> None:
    samples = Samples(40, seed=6)
    start = len(fresh.diagnostics.messages)
    fresh.send([joint_state(JOINTS, samples.stamps_ns[k], samples.position[k], samples.velocity[k]) for k in range(40)])
    q, qd, effort = samples.arm(RIGHT.joint_names)
    expected = expected_torques(RIGHT, samples.stamps_ns, q, qd, effort)
    del expected["residual"]
    fresh.check(samples.stamps_ns, q, qd, expected, RIGHT.joint_names)
    assert fresh.outputs["residual"].messages == [] and fresh.outputs["external_torque"].messages == []
    level, message, _ = fresh.report(start, lambda s: s[2]["samples_published"] != "0")
    assert level == 1 and "no effort" in message


def test_without_velocity_it_is_differenced_from_positions(fresh: LiveNode) -> None:
    samples = Samples(20, seed=7)
    before = fresh.idle_report()[2]
    fresh.send([joint_state(JOINTS, samples.stamps_ns[k], samples.position[k], (), samples.effort[k]) for k in range(20)])
    q, _, effort = samples.arm(RIGHT.joint_names)
    dt_s = np.diff(samples.stamps_ns) * 1e-9
    qd = np.diff(q, axis=0) / dt_s[:, None]  # backward difference: q̇_k = (q_k − q_{k−1}) / Δt_k, k ≥ 1
    stamps = samples.stamps_ns[1:]
    fresh.check(stamps, q[1:], qd, expected_torques(RIGHT, stamps, q[1:], qd, effort[1:]), RIGHT.joint_names)
    after = fresh.idle_report()[2]
    assert int(after["skipped_total.velocity_warm_up"]) == int(before["skipped_total.velocity_warm_up"]) + 1


def test_malformed_messages_never_crash_or_hang_the_node(fresh: LiveNode) -> None:
    floats = st.floats() | st.sampled_from([0.0, 1e308, -1e308, 1e200, 5e-324])
    text = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"), max_size=6)
    names = st.one_of(
        st.permutations(JOINTS),
        st.lists(st.sampled_from(JOINTS) | text, max_size=24),
        st.permutations(JOINTS).map(lambda n: [*n, n[0]]),
    )

    @st.composite
    def messages(draw) -> JointState:
        msg_names = draw(names)
        n = len(msg_names)

        def values():
            size = draw(st.sampled_from([n, n, 0, max(n - 1, 0), n + 1]))
            return draw(st.lists(floats, min_size=size, max_size=size))

        msg = joint_state(msg_names, 0, values(), values(), values())
        msg.header.stamp.sec = draw(st.integers(-(2**31), 2**31 - 1) | st.integers(1_700_000_000, 1_700_000_010))
        msg.header.stamp.nanosec = draw(st.integers(0, 2**32 - 1))
        return msg

    def spoilt(raw: bytes, cut: int, flips: list[tuple[int, int]]) -> bytes:
        data = bytearray(raw[: max(cut, 0)] if cut < len(raw) else raw)
        for position, value in flips:
            if data:
                data[position % len(data)] = value
        return bytes(data)

    good_bytes = bytes(serialize_message(Samples(1, seed=14).message(0)))
    raw_bytes = st.binary(max_size=600) | st.builds(
        spoilt, st.just(good_bytes), st.integers(0, len(good_bytes) + 1),
        st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)), max_size=4),
    )
    sent = []

    @settings(max_examples=200, deadline=None, database=None)
    @given(messages() | raw_bytes)
    def publish(msg: JointState | bytes) -> None:
        fresh.publisher.publish(msg)
        sent.append(msg)
        time.sleep(0.002)

    publish()
    assert len(sent) >= 100
    fresh.process.check_alive()
    # Still answering, and right, for good samples after the storm.
    fresh.reset()
    samples = Samples(10, seed=8)
    fresh.send([samples.message(k) for k in range(10)])
    q, qd, effort = samples.arm(RIGHT.joint_names)
    fresh.check(samples.stamps_ns, q, qd, expected_torques(RIGHT, samples.stamps_ns, q, qd, effort), RIGHT.joint_names)


# ----------------------------------------------------------------------------- diagnostics
def test_diagnostics_report_rate_latency_and_residual_rms(fresh: LiveNode) -> None:
    samples = Samples(80, seed=9)
    q, qd, effort = samples.arm(RIGHT.joint_names)
    # Effort = model τ + a known offset: every residual is that offset, whatever samples a window holds.
    offset = np.array([1.0, -2.0, 0.5, 3.0, -0.25, 0.125, 4.0])
    tau = expected_torques(RIGHT, samples.stamps_ns, q, qd, effort)["inverse_dynamics"]
    cols = [JOINTS.index(j) for j in RIGHT.joint_names]
    samples.effort[:, cols] = tau + offset
    fresh.idle_report()  # earlier tests' samples are out of the window
    start = len(fresh.diagnostics.messages)
    fresh.send([samples.message(k) for k in range(80)])
    fresh.received("residual", samples.stamps_ns)
    level, message, values = fresh.report(start, lambda s: int(s[2]["samples_received"]) >= 15)
    assert level == 0, message
    assert 50.0 < float(values["input_rate_hz"]) < 150.0
    assert values["topic"] == "/robot/joint_states"
    assert 0.0 < float(values["latency_mean_us"]) <= float(values["latency_max_us"])
    rms = [float(values[f"residual_rms_nm.{j}"]) for j in RIGHT.joint_names]
    np.testing.assert_allclose(rms, np.abs(offset), rtol=1e-3)  # printed with 4 significant digits
    level, message, values = fresh.idle_report()
    assert level == 1 and "no joint states on /robot/joint_states" in message
    assert values["residual_rms_nm.right_s0"] == "n/a"


def test_diagnostics_error_when_every_sample_is_skipped(fresh: LiveNode) -> None:
    samples = Samples(60, seed=10)
    start = len(fresh.diagnostics.messages)
    warning = "[baxter_dynamics.missing_joint]: sample skipped"
    warnings_before = fresh.process.output().count(warning)
    no_w2 = [j for j in JOINTS if j != "right_w2"]
    fresh.send([joint_state(no_w2, samples.stamps_ns[k], np.zeros(len(no_w2)), np.zeros(len(no_w2)), np.zeros(len(no_w2))) for k in range(60)])
    level, message, values = fresh.report(start, lambda s: s[0] == 2, timeout_s=5.0)
    assert "missing_joint" in message and values["samples_published"] == "0"
    # 60 skips in 0.6 s: at most one warning (one per second per cause), and one was given at some point.
    assert fresh.process.output().count(warning) - warnings_before <= 1
    assert fresh.process.output().count(warning) >= 1


# ----------------------------------------------------------------------------- simulated time
@pytest.fixture(scope="module")
def sim_node(ros_client, node_processes) -> LiveNode:
    """A second node on use_sim_time, on topics of its own."""
    process = node_processes.start(
        ["-p", "use_sim_time:=true", "-p", "joint_states_topic:=/sim/joint_states",
         "-p", f"diagnostics_period_s:={DIAGNOSTICS_PERIOD_S}", "-r", "__ns:=/sim"]
    )
    node = LiveNode(ros_client, process, namespace="/sim", input_topic="/sim/joint_states")
    node.wait_ready(lambda stamp: joint_state(JOINTS, stamp, np.zeros(len(JOINTS)), np.zeros(len(JOINTS)), np.zeros(len(JOINTS))))
    return node


def test_sim_time_is_followed_and_a_backwards_clock_jump_resets_the_estimator(ros_client, sim_node: LiveNode) -> None:
    clock = ros_client.publisher(Clock, "/clock", 10)

    def publish_clock(t_s: int) -> None:
        msg = Clock()
        msg.clock.sec = t_s
        clock.publish(msg)

    # Diagnostics are stamped with the simulated time.
    deadline = time.monotonic() + 20
    start = len(sim_node.diagnostics.messages)
    while not any(m.header.stamp.sec == 5000 for m in sim_node.diagnostics.messages[start:]):
        assert time.monotonic() < deadline, "diagnostics never stamped with the /clock time"
        publish_clock(5000)
        time.sleep(0.05)
    before = sim_node.idle_report()[2]

    late, early = Samples(10, seed=11), Samples(10, seed=12)
    early.stamps_ns -= early.stamps_ns[0] - 10_000_000_000  # 10 s: far before `late`
    sim_node.send([late.message(k) for k in range(10)])
    sim_node.received("gravity", late.stamps_ns)

    publish_clock(10)  # the recording loops: the clock jumps back by 4990 s
    sim_node.report(len(sim_node.diagnostics.messages), lambda s: s[2]["resets_total.clock_jump"] == str(int(before["resets_total.clock_jump"]) + 1))
    sim_node.send([early.message(k) for k in range(10)])
    q, qd, effort = early.arm(RIGHT.joint_names)
    sim_node.check(early.stamps_ns, q, qd, expected_torques(RIGHT, early.stamps_ns, q, qd, effort), RIGHT.joint_names)
    after = sim_node.idle_report()[2]
    assert after["skipped_total.stamp_backwards"] == before["skipped_total.stamp_backwards"]  # reset, not skipped


# ----------------------------------------------------------------------------- start-up and shutdown
def test_left_arm_namespaced_from_the_params_file_then_ctrl_c(ros_client, node_processes) -> None:
    process = node_processes.start(
        ["--params-file", str(CONFIG), "-p", "arm:=left", "-p", "joint_states_topic:=/left_test/joint_states",
         "-p", f"diagnostics_period_s:={DIAGNOSTICS_PERIOD_S}", "-r", "__ns:=/left_test"]
    )
    node = LiveNode(ros_client, process, namespace="/left_test", input_topic="/left_test/joint_states")
    node.side = "left"
    node.wait_ready(lambda stamp: joint_state(JOINTS, stamp, np.zeros(len(JOINTS)), np.zeros(len(JOINTS)), np.zeros(len(JOINTS))))
    samples = Samples(30, seed=13)
    node.send([samples.message(k) for k in range(30)])
    q, qd, effort = samples.arm(LEFT.joint_names)
    node.check(samples.stamps_ns, q, qd, expected_torques(LEFT, samples.stamps_ns, q, qd, effort), LEFT.joint_names)
    assert process.stop() == 0
    assert "Traceback" not in process.output()


# A Ctrl-C at each point where the node has been seen, or could be, to leave by KeyboardInterrupt (an
# exit by SIGINT, code -2, with a traceback): the node sends it to itself there, then lets Python's and
# rclpy's handlers act (0.5 s) before going on.
CTRL_C_AT = {
    "before rclpy's handler is in": "rclpy.init",
    "under the constructor": "baxter_dynamics_ros.ros.node.DynamicsNode.__init__",
    "again in the shutdown": "baxter_dynamics_ros.ros.node.DynamicsNode.destroy_node",
}


@pytest.mark.parametrize("where", sorted(CTRL_C_AT))
def test_ctrl_c_at_any_point_stops_the_node_cleanly(where: str, ros_domain, tmp_path: Path) -> None:
    owner, name = CTRL_C_AT[where].rsplit(".", 1)
    code = (
        "import functools, os, pydoc, signal, sys, time\n"
        "from baxter_dynamics_ros.ros.node import main\n"
        f"owner = pydoc.locate({owner!r})\n"
        f"original = getattr(owner, {name!r})\n"
        "@functools.wraps(original)\n"
        "def interrupted(*args, **kwargs):\n"
        "    os.kill(os.getpid(), signal.SIGINT)\n"
        "    time.sleep(0.5)\n"
        "    return original(*args, **kwargs)\n"
        f"setattr(owner, {name!r}, interrupted)\n"
        "sys.exit(main())\n"
    )
    log = tmp_path / "node.log"
    with log.open("w") as out:
        process = subprocess.Popen([sys.executable, "-c", code, "--ros-args", "-r", "__ns:=/ctrl_c"], cwd=REPO, stdout=out, stderr=subprocess.STDOUT)
    try:
        if name == "destroy_node":  # the first Ctrl-C from here, once the node is up
            deadline = time.monotonic() + 60.0
            while "right arm (" not in log.read_text() and time.monotonic() < deadline:
                assert process.poll() is None, log.read_text()
                time.sleep(0.2)
            process.send_signal(signal.SIGINT)
        assert process.wait(timeout=60) == 0, log.read_text()
    finally:
        interrupt(process)
    assert "Traceback" not in log.read_text()


def test_effects_file_from_the_diagnosis_is_compensated(ros_client, node_processes, tmp_path: Path) -> None:
    """An effects.yaml as `diagnose` writes it: the residual is taken against the compensated model."""
    from baxter_dynamics_ros.core.compensation import load_compensation

    effects = tmp_path / "effects.yaml"
    effects.write_text(
        "arm: right\neffects:\n"
        "  s1_spring: {preload_nm: 20.0, cosine_nm: 12.0, sine_nm: 18.0}\n"
        "  viscous_friction: {damping_nm_s_rad: [1.0, 1.5, 0.5, 0.5, 0.1, 0.1, 0.05]}\n"
        "  payload: {mass_kg: 0.5, com_m: [0.0, 0.0, 0.05]}\n"
        "  delay: {delay_s: 0.01}\n"
        "  dahl_friction: {friction_nm: {s1: 1.0, e0: 0.5, w0: 0.2}, presliding_rad: 0.05}\n"
    )
    process = node_processes.start(
        ["-p", f"effects_file:={effects}", "-p", "joint_states_topic:=/fx_test/joint_states", "-r", "__ns:=/fx_test"]
    )
    node = LiveNode(ros_client, process, namespace="/fx_test", input_topic="/fx_test/joint_states")
    node.wait_ready(lambda stamp: joint_state(JOINTS, stamp, np.zeros(len(JOINTS)), np.zeros(len(JOINTS)), np.zeros(len(JOINTS))))
    samples = Samples(30, seed=17)
    node.send([samples.message(k) for k in range(30)])
    q, qd, effort = samples.arm(RIGHT.joint_names)
    compensation = load_compensation(RIGHT, effects)
    expected = expected_torques(RIGHT, samples.stamps_ns, q, qd, effort, compensation=compensation)
    expected["external_torque"] = expected_external_torque(RIGHT, samples.stamps_ns, q, qd, effort, compensation=compensation)
    rigid = expected_external_torque(RIGHT, samples.stamps_ns, q, qd, effort)
    assert np.abs(expected["external_torque"] - rigid).max() > 1.0
    node.check(samples.stamps_ns, q, qd, expected, RIGHT.joint_names)
    assert np.abs(expected["inverse_dynamics"] - expected_torques(RIGHT, samples.stamps_ns, q, qd, effort)["inverse_dynamics"]).max() > 1.0
    assert process.stop() == 0
    assert "not compensated live: delay" in process.output()


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (["-p", "effects_file:=/nonexistent/effects.yaml"], "effects.yaml"),
        (["-p", "estimator:=kalman"], "estimator"),
        (["-p", "cutoff_hz:=0.0"], "cutoff_hz"),
        (["-p", "arm:=middle"], "arm"),
        (["-p", "model_file:=/nonexistent/model.yaml"], "model.yaml"),
        (["-p", "thresholds_file:=/nonexistent/thresholds.yaml"], "thresholds.yaml"),
    ],
)
def test_bad_parameters_stop_the_node_with_one_error_line(ros_domain, args: list[str], field: str) -> None:
    script = Path(sys.executable).parent / "baxter_dynamics_node"
    command = [str(script)] if script.exists() else [sys.executable, "-m", "baxter_dynamics_ros.ros.node"]
    result = subprocess.run([*command, "--ros-args", *args], capture_output=True, text=True, timeout=60)
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert lines[-1].startswith("ERROR: ") and field in lines[-1], result.stderr
    assert "Traceback" not in result.stderr


# ----------------------------------------------------------------------------- the joint-state thread
def test_subscription_thread_takes_every_message_in_order_and_stops(ros_domain) -> None:
    from baxter_dynamics_ros.ros.node import OwnThreadGroup, SubscriptionThread

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("thread_test", context=context)
    try:
        taken: list[int] = []
        sub = node.create_subscription(
            JointState, "/thread_test", lambda m: None, 100, callback_group=OwnThreadGroup(), raw=True
        )
        taker = SubscriptionThread(sub, context, lambda raw: taken.append(raw), node.get_logger())
        publisher = node.create_publisher(JointState, "/thread_test", 100)
        deadline = time.monotonic() + 20
        while publisher.get_subscription_count() == 0:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        for k in range(50):
            publisher.publish(joint_state(["a"], k, [float(k)]))
        while len(taken) < 50:
            assert time.monotonic() < deadline, f"{len(taken)} of 50 taken"
            time.sleep(0.01)
        from rclpy.serialization import deserialize_message

        assert [deserialize_message(raw, JointState).position[0] for raw in taken] == list(range(50))
        taker.stop()
        assert taker.error is None
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def test_a_defect_in_the_joint_state_thread_stops_the_program(ros_domain) -> None:
    from baxter_dynamics_ros.ros.node import OwnThreadGroup, SubscriptionThread

    context = rclpy.Context()
    rclpy.init(context=context)
    node = rclpy.create_node("thread_defect_test", context=context)
    try:
        sub = node.create_subscription(
            JointState, "/thread_defect_test", lambda m: None, 10, callback_group=OwnThreadGroup(), raw=True
        )

        def defect(raw: bytes) -> None:
            raise RuntimeError("defect")

        taker = SubscriptionThread(sub, context, defect, node.get_logger())
        publisher = node.create_publisher(JointState, "/thread_defect_test", 10)
        deadline = time.monotonic() + 20
        while context.ok():  # the thread shuts the context down on the first message
            assert time.monotonic() < deadline, "the thread did not stop the program"
            publisher.publish(joint_state(["a"], 0, [0.0]))
            time.sleep(0.05)
        assert isinstance(taker.error, RuntimeError)
        taker.stop()
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
