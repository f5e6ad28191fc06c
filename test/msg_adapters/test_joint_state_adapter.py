"""Serialized JointState messages ↔ one arm's arrays, and the node's output messages.

Inputs are CDR bytes made by rclpy's own serializer (what a raw subscription receives) and, for the
big-endian case, by rosbags' independent one; outputs are read back with rclpy's deserializer.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.core.samples import ArmSample, Health, HealthReport, ModelTorques, SkipReason
from msg_adapters.robot_joint_states import BAXTER_JOINT_NAMES

pytest.importorskip("rclpy")
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from msg_adapters.joint_state import ArmJointStateWriter, JointStateReader, diagnostic_array  # noqa: E402
from msg_adapters.serialized_joint_states import JOINT_STATE, typestore  # noqa: E402

ARM = load_arm_model("right")
JOINTS = sorted(BAXTER_JOINT_NAMES)
STAMP_NS = 1_700_000_000_123_456_789


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def cdr(names=JOINTS, stamp=STAMP_NS, position=None, velocity=None, effort=None, frame_id="") -> bytes:
    """CDR bytes of a JointState; by default every joint's values encode its index i in JOINTS:
    position i, velocity 100 + i, effort 200 + i."""
    index = np.array([JOINTS.index(n) if n in JOINTS else -1 for n in names], dtype=float)
    msg = JointState(name=list(names))
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
    msg.header.frame_id = frame_id
    msg.position = list(index if position is None else position)
    msg.velocity = list(100 + index if velocity is None else velocity)
    msg.effort = list(200 + index if effort is None else effort)
    return bytes(serialize_message(msg))


ARM_INDEX = np.array([JOINTS.index(j) for j in ARM.joint_names], dtype=float)


def assert_arm_values(sample, velocity: bool = True, effort: bool = True) -> None:
    assert isinstance(sample, ArmSample), sample
    np.testing.assert_array_equal(sample.q, ARM_INDEX)
    if velocity:
        np.testing.assert_array_equal(sample.qd, 100 + ARM_INDEX)
    if effort:
        np.testing.assert_array_equal(sample.effort, 200 + ARM_INDEX)


@settings(max_examples=50, deadline=None)
@given(st.permutations(JOINTS), st.integers(0, 2**31 - 1), st.integers(0, 999_999_999))
def test_reader_maps_any_order_by_name(names, sec: int, nanosec: int) -> None:
    sample = JointStateReader(ARM.joint_names).read(cdr(names, sec * 1_000_000_000 + nanosec))
    assert_arm_values(sample)
    assert sample.stamp_ns == sec * 1_000_000_000 + nanosec


@pytest.mark.parametrize("stamp_ns", [-1_500_000_000, -(2**31) * 1_000_000_000, (2**31 - 1) * 1_000_000_000 + 999_999_999])
def test_reader_reads_stamps_over_the_whole_int32_range(stamp_ns: int) -> None:
    sample = JointStateReader(ARM.joint_names).read(cdr(JOINTS, stamp_ns))
    assert sample.stamp_ns == stamp_ns


def test_reader_reads_big_endian_cdr_from_another_serializer() -> None:
    store = typestore(ros1=False)
    types = store.types
    header = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=-5, nanosec=7), frame_id="b")
    index = np.arange(len(JOINTS), dtype=float)
    msg = types[JOINT_STATE](header=header, name=JOINTS, position=index, velocity=100 + index, effort=200 + index)
    raw = bytes(store.serialize_cdr(msg, JOINT_STATE, little_endian=False))
    sample = JointStateReader(ARM.joint_names).read(raw)
    assert_arm_values(sample)
    assert sample.stamp_ns == -5 * 1_000_000_000 + 7


def test_reader_rebuilds_its_index_map_only_when_the_names_change(monkeypatch: pytest.MonkeyPatch) -> None:
    reader = JointStateReader(ARM.joint_names)
    builds = []
    original = reader.index_map
    monkeypatch.setattr(reader, "index_map", lambda names: builds.append(list(names)) or original(names))
    for k in range(3):
        assert_arm_values(reader.read(cdr(stamp=STAMP_NS + k)))
    assert_arm_values(reader.read(cdr(frame_id="elsewhere")))  # new layout, same names
    assert_arm_values(reader.read(cdr(effort=[])), effort=False)
    assert len(builds) == 1
    assert_arm_values(reader.read(cdr(list(reversed(JOINTS)))))
    assert len(builds) == 2


def test_one_reader_follows_the_layout_from_message_to_message() -> None:
    """Each array's place changes with the arrays before it: velocity empty, effort empty, both, neither."""
    reader = JointStateReader(ARM.joint_names)
    for velocity, effort in [(True, True), (False, True), (True, False), (False, False), (False, True), (True, True)]:
        sample = reader.read(cdr(velocity=None if velocity else [], effort=None if effort else []))
        assert_arm_values(sample, velocity=velocity, effort=effort)
        assert (sample.qd is None, sample.effort is None) == (not velocity, not effort)


def test_empty_velocity_or_effort_read_as_none() -> None:
    sample = JointStateReader(ARM.joint_names).read(cdr(velocity=[], effort=[]))
    assert sample.qd is None and sample.effort is None
    assert_arm_values(sample, velocity=False, effort=False)


@pytest.mark.parametrize("field", ["position", "velocity", "effort"])
@pytest.mark.parametrize("size", [0, len(JOINTS) - 1, len(JOINTS) + 1])
def test_arrays_not_matching_the_names_are_refused(field: str, size: int) -> None:
    raw = cdr(**{field: [0.0] * size})
    expected = None if size == 0 and field != "position" else SkipReason.ARRAY_LENGTH
    result = JointStateReader(ARM.joint_names).read(raw)
    assert result is expected if expected else isinstance(result, ArmSample)


@pytest.mark.parametrize(
    "names",
    [[j for j in JOINTS if j != "right_e1"], [*JOINTS, "right_e1"], ["left_s0", "left_s1"], []],
    ids=["missing", "repeated", "other arm", "empty"],
)
def test_names_lacking_or_repeating_an_arm_joint_are_refused(names) -> None:
    assert JointStateReader(ARM.joint_names).read(cdr(names)) is SkipReason.MISSING_JOINT


@pytest.mark.parametrize(
    "raw",
    [b"", b"\x00\x01", cdr()[:-9], cdr()[:40], b"\x00\x07\x00\x00" + bytes(64), bytes(range(256))],
    ids=["empty", "header only", "truncated arrays", "truncated names", "unknown encapsulation", "garbage"],
)
def test_bytes_that_are_not_a_joint_state_are_unreadable(raw: bytes) -> None:
    reader = JointStateReader(ARM.joint_names)
    assert reader.read(raw) is SkipReason.UNREADABLE
    assert_arm_values(reader.read(cdr()))  # and the next good message reads


def test_non_finite_values_pass_through_for_the_pipeline_to_judge() -> None:
    position = np.arange(len(JOINTS), dtype=float)
    position[JOINTS.index("right_w0")] = math.nan
    sample = JointStateReader(ARM.joint_names).read(cdr(position=position))
    assert math.isnan(sample.q[ARM.joint_names.index("right_w0")])


def _torques(residual) -> ModelTorques:
    k = np.arange(7.0)
    return ModelTorques(STAMP_NS, k, 10 + k, 20 + k, 30 + k, 40 + k, residual, False)


def test_writer_messages_carry_the_arm_names_stamp_state_and_torque() -> None:
    writer = ArmJointStateWriter(ARM.joint_names)
    messages = writer.messages(_torques(50 + np.arange(7.0)))
    for raw, effort in zip(messages, (30, 40, 50)):
        msg = deserialize_message(raw, JointState)
        assert list(msg.name) == list(ARM.joint_names)
        assert _ns(msg.header.stamp) == STAMP_NS and msg.header.frame_id == ""
        np.testing.assert_array_equal(msg.position, np.arange(7.0))
        np.testing.assert_array_equal(msg.velocity, 10 + np.arange(7.0))
        np.testing.assert_array_equal(msg.effort, effort + np.arange(7.0))
    assert writer.messages(_torques(None))[2] is None


def test_writer_writes_only_the_wanted_messages_and_each_sample_afresh() -> None:
    writer = ArmJointStateWriter(ARM.joint_names)
    first = writer.messages(_torques(50 + np.arange(7.0)))
    later = _torques(None)._replace(stamp_ns=STAMP_NS + 1, q=-np.arange(7.0))
    only_tau = writer.messages(later, (False, True, False, False))
    assert only_tau[0] is None and only_tau[2] is None and only_tau[3] is None
    msg = deserialize_message(only_tau[1], JointState)
    assert _ns(msg.header.stamp) == STAMP_NS + 1
    np.testing.assert_array_equal(msg.position, -np.arange(7.0))
    np.testing.assert_array_equal(msg.effort, 40 + np.arange(7.0))
    assert writer.messages(_torques(50 + np.arange(7.0))) == first  # nothing of the later sample left behind
    np.testing.assert_array_equal(deserialize_message(first[2], JointState).effort, 50 + np.arange(7.0))


def test_writer_handles_negative_stamps() -> None:
    torques = _torques(None)._replace(stamp_ns=-1_500_000_000)
    msg = deserialize_message(ArmJointStateWriter(ARM.joint_names).messages(torques)[0], JointState)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (-2, 500_000_000)


@pytest.mark.parametrize("level", list(Health))
def test_diagnostic_array_holds_the_report(level: Health) -> None:
    report = HealthReport(level, "all fine", (("input_rate_hz", "100.0"), ("residual_rms_nm.right_s0", "n/a")))
    stamp = deserialize_message(cdr(), JointState).header.stamp
    msg = diagnostic_array(report, name="/baxter_dynamics: right arm dynamics", hardware_id="baxter", stamp=stamp)
    msg = deserialize_message(serialize_message(msg), type(msg))
    assert _ns(msg.header.stamp) == STAMP_NS
    (status,) = msg.status
    levels = {Health.OK: DiagnosticStatus.OK, Health.WARN: DiagnosticStatus.WARN, Health.ERROR: DiagnosticStatus.ERROR}
    assert status.level == levels[level]
    assert (status.name, status.hardware_id, status.message) == ("/baxter_dynamics: right arm dynamics", "baxter", "all fine")
    assert [(kv.key, kv.value) for kv in status.values] == list(report.values)
