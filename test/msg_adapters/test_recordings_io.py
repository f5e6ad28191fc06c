"""Readers and writers of recordings: real bags and tables written into tmp_path and read back."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from recorded_bags import (
    BAG_KINDS,
    BAXTER_JOINTS,
    REAL_DATA,
    REAL_FILES,
    START_NS,
    bag_path,
    bag_storage_file,
    columns,
    joint_states,
    listing_of,
    message,
    write_bag,
    write_baxter_export,
    write_reference_bag,
)

from baxter_dynamics_ros.core.joints import arm_joint_names
from baxter_dynamics_ros.core.recording import Recording, detect_arm, summed_range_rad
from baxter_dynamics_ros.errors import OutputError, RecordingError, RecordingFileError
from msg_adapters import bag_io
from msg_adapters.bag_io import read_bag_recording, read_joint_state_messages
from msg_adapters.csv_io import read_table_recording
from msg_adapters.mcap_writer import write_mcap
from msg_adapters.recording_files import read_recording, write_joint_states
from msg_adapters.robot_joint_states import robot_joint_states
from msg_adapters.serialized_joint_states import (
    JOINT_STATE,
    SEA_JOINT_STATE,
    SEA_JOINT_STATE_MSG,
    decode_joint_states,
    encode_joint_states,
    typestore,
)

N = 300


def assert_recording_is(rec: Recording, states: dict, side: str, names: tuple[str, ...] = BAXTER_JOINTS) -> None:
    joints = arm_joint_names(side)
    assert rec.side == side and rec.joint_names == joints
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])
    for got, want in zip((rec.q, rec.qd, rec.effort), columns(states, joints, names)):
        np.testing.assert_array_equal(got, want)


# --------------------------------------------------------------------------------------------- bags
@pytest.mark.parametrize("kind", BAG_KINDS)
def test_joint_state_bag_reads_back_exactly_with_the_moving_arm_detected(tmp_path: Path, kind: str) -> None:
    states = joint_states(N)
    path = write_reference_bag(bag_path(tmp_path, kind), kind, states)
    assert_recording_is(read_bag_recording(path), states, "right")
    assert_recording_is(read_bag_recording(path, arm="left"), states, "left")


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_sea_joint_state_reads_its_actual_arrays(tmp_path: Path, kind: str) -> None:
    states = joint_states(N)
    path = write_reference_bag(bag_path(tmp_path, kind), kind, states, topic="/robot/limb/right/gravity_compensation_torques", sea=True)
    rec = read_bag_recording(path, topic="/robot/limb/right/gravity_compensation_torques")
    assert_recording_is(rec, states, "right")


def test_sea_joint_state_type_is_registered_from_its_definition_text() -> None:
    reference = REAL_DATA.parent.parent / "reference" / "SEAJointState.msg"
    if not reference.is_file():
        pytest.skip(f"{reference} absent: cannot compare the embedded definition with the reference")
    assert SEA_JOINT_STATE_MSG.strip() == reference.read_text().strip()
    for ros1 in (True, False):
        fields = [f[0] for f in typestore(ros1).fielddefs[SEA_JOINT_STATE][1]]
        assert fields[:2] == ["header", "name"] and fields[4:7] == ["commanded_effort", "actual_position", "actual_velocity"]


@pytest.mark.parametrize("decode_every", [None, 5])
@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_messages_of_other_layouts_and_without_the_arm_are_handled_by_name(
    tmp_path: Path, kind: str, decode_every: int | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Shuffled names, other frame_ids, gripper-only messages: matched by name, skipped if incomplete;
    the same when the reader decodes the messages a few at a time (every piece holding several layouts)."""
    if decode_every is not None:
        monkeypatch.setattr(bag_io, "DECODE_EVERY", decode_every)
    states = joint_states(N)
    rng = np.random.default_rng(1)
    msgs, kept = [], []
    for k, stamp in enumerate(states["stamps_ns"]):
        order = rng.permutation(len(BAXTER_JOINTS)) if k % 7 == 3 else np.arange(len(BAXTER_JOINTS))
        names = [BAXTER_JOINTS[i] for i in order]
        arrays = [states[f][k][order] for f in ("position", "velocity", "effort")]
        frame_id = "base" * (k % 5 == 1)
        msgs.append((int(stamp), message(kind, stamp, names, *arrays, frame_id=frame_id)))
        kept.append(k)
        if k % 11 == 5:  # a gripper-only message in between: skipped
            msgs.append((int(stamp) + 1, message(kind, stamp + 1, ["r_gripper_l_finger_joint"], [0.1], [0.0], [0.0])))
        if k % 13 == 6:  # a message without efforts: skipped
            msgs.append((int(stamp) + 2, message(kind, stamp + 2, names, arrays[0], arrays[1], [])))
    path = write_bag(bag_path(tmp_path, kind), kind, {"/robot/joint_states": msgs})
    assert_recording_is(read_bag_recording(path), states, "right")


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_messages_without_velocities_give_them_as_the_positions_difference(tmp_path: Path, kind: str) -> None:
    """A driver that leaves every message's velocity empty: q̇ is the central difference of q over
    the stamps, within the difference's truncation error of the true velocities (≤ A ω³ h² / 6 inside,
    A ω² h / 2 at the ends), and a note says so; q, effort, stamps exact."""
    states = joint_states(N)
    msgs = [
        (int(t), message(kind, t, BAXTER_JOINTS, states["position"][k], [], states["effort"][k]))
        for k, t in enumerate(states["stamps_ns"])
    ]
    path = write_bag(bag_path(tmp_path, kind), kind, {"/robot/joint_states": msgs})
    notes: list[str] = []
    rec = read_bag_recording(path, note=notes.append)
    q, qd, effort = columns(states, arm_joint_names("right"))
    assert rec.side == "right"
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])
    np.testing.assert_array_equal(rec.q, q)
    np.testing.assert_array_equal(rec.effort, effort)
    h, omega_max, amp = 0.01, 2 * np.pi * 0.8, 0.6
    np.testing.assert_allclose(rec.qd[1:-1], qd[1:-1], rtol=0, atol=amp * omega_max**3 * h**2 / 6)
    np.testing.assert_allclose(rec.qd[[0, -1]], qd[[0, -1]], rtol=0, atol=amp * omega_max**2 * h / 2)
    assert notes == [f"{path}: no message on /robot/joint_states gives velocities; q̇ is the central difference of q over the stamps"]


def test_stamps_that_go_back_take_the_recording_apart_there(tmp_path: Path) -> None:
    """A bag of two runs whose header stamps start again (a clock set back: a simulator reset):
    each run read as it is, the second moved to begin 10 periods after the first ends (a gap: the
    recording cut there), a note saying so; stamps that go back at most steps refused."""
    first, second = joint_states(N, seed=1), joint_states(N // 2, seed=2)
    msgs = [
        (k, message("ros1", t, BAXTER_JOINTS, *(states[f][i] for f in ("position", "velocity", "effort"))))
        for k, (states, i, t) in enumerate([(first, i, t) for i, t in enumerate(first["stamps_ns"])] + [(second, i, t) for i, t in enumerate(second["stamps_ns"])])
    ]
    path = write_bag(bag_path(tmp_path, "ros1"), "ros1", {"/robot/joint_states": msgs})
    notes: list[str] = []
    rec = read_bag_recording(path, note=notes.append)
    step = 10_000_000  # 100 Hz
    np.testing.assert_array_equal(rec.stamps_ns, first["stamps_ns"][0] + np.concatenate([np.arange(N), N - 1 + 10 + np.arange(N // 2)]) * step)
    for got, a, b in zip((rec.q, rec.qd, rec.effort), columns(first, arm_joint_names("right")), columns(second, arm_joint_names("right"))):
        np.testing.assert_array_equal(got, np.vstack([a, b]))
    assert [stop - start for start, stop in rec.segments] == [N, N // 2]
    assert notes == [
        f"{path}: the stamps of the messages on /robot/joint_states go back at 1 message(s) (first after sample {N - 1}): a clock set back, "
        "or recordings laid end to end; taken apart there (gaps of unknown length, 10 samples in the stamps)"
    ]
    shuffled = [(k, m) for k, (_, m) in enumerate(msgs[i] for i in np.random.default_rng(0).permutation(len(msgs)))]
    path = write_bag(tmp_path / "shuffled.bag", "ros1", {"/robot/joint_states": shuffled})
    with pytest.raises(RecordingFileError, match=r"the stamps of the messages on /robot/joint_states go back at \d+ of 449 steps: no time series"):
        read_bag_recording(path, note=None)


def test_bag_without_header_stamps_uses_receive_times(tmp_path: Path) -> None:
    states = joint_states(30)
    receive_ns = states["stamps_ns"] + 1234
    msgs = [
        (int(t), message("mcap", 0, BAXTER_JOINTS, p, v, e))
        for t, p, v, e in zip(receive_ns, states["position"], states["velocity"], states["effort"])
    ]
    path = write_bag(tmp_path / "unstamped", "mcap", {"/robot/joint_states": msgs})
    np.testing.assert_array_equal(read_bag_recording(path).stamps_ns, receive_ns)


@pytest.mark.parametrize("kind", ["ros1", "sqlite3"])
def test_bulk_decoding_equals_rosbags_deserialization(kind: str) -> None:
    """The numpy fast path against the typestore, message by message, on mixed layouts."""
    ros1 = kind == "ros1"
    store = typestore(ros1)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    deserialize = store.deserialize_ros1 if ros1 else store.deserialize_cdr
    rng = np.random.default_rng(2)
    raws, expected = [], []
    for k in range(200):
        m = int(rng.integers(1, 4)) if k % 3 else 17
        names = [f"j{i}" * int(rng.integers(1, 4)) for i in range(m)]
        arrays = [rng.normal(size=m) if rng.random() > 0.1 else np.zeros(0) for _ in range(3)]
        msg = message(kind, START_NS + k, names, *arrays, frame_id="x" * int(rng.integers(0, 6)))
        raws.append(bytes(serialize(msg, JOINT_STATE)))
        expected.append(msg)
    blocks = decode_joint_states(raws, JOINT_STATE, ros1, lambda raw: deserialize(raw, JOINT_STATE))
    seen = np.zeros(len(raws), dtype=int)
    for block in blocks:
        for row, i in enumerate(block.index):
            seen[i] += 1
            msg = expected[i]
            assert block.names == tuple(msg.name)
            assert block.stamps_ns[row] == msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            for got, field in zip((block.position, block.velocity, block.effort), ("position", "velocity", "effort")):
                want = getattr(msg, field)
                if len(want) == len(msg.name):
                    np.testing.assert_array_equal(got[row], want)
                else:
                    assert got is None
    assert (seen == 1).all()


def test_encoded_joint_states_are_what_rosbags_deserializes() -> None:
    states = joint_states(5, names=arm_joint_names("right"))
    rows = encode_joint_states(states["stamps_ns"], arm_joint_names("right"), states["position"], None, states["effort"])
    store = typestore(ros1=False)
    for k, row in enumerate(rows):
        msg = store.deserialize_cdr(row.tobytes(), JOINT_STATE)
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == states["stamps_ns"][k]
        assert list(msg.name) == list(arm_joint_names("right")) and msg.header.frame_id == ""
        np.testing.assert_array_equal(msg.position, states["position"][k])
        assert len(msg.velocity) == 0
        np.testing.assert_array_equal(msg.effort, states["effort"][k])


def test_mcap_writer_output_passes_the_official_mcap_reader(tmp_path: Path) -> None:
    """An independent reader (the mcap project's), checking CRCs, indexes and statistics."""
    from mcap.reader import make_reader

    states = joint_states(N)
    channels = [(topic, JOINT_STATE, typestore(False).generate_msgdef(JOINT_STATE, ros_version=2)[0]) for topic in ("/a", "/b")]
    payloads = [
        encode_joint_states(states["stamps_ns"], BAXTER_JOINTS, states["position"], states["velocity"], states["effort"]),
        encode_joint_states(states["stamps_ns"], BAXTER_JOINTS[:2], None, None, states["effort"][:, :2]),
    ]
    path = tmp_path / "out.mcap"
    write_mcap(path, channels, states["stamps_ns"], payloads, chunk_bytes=20_000)  # many chunks
    with path.open("rb") as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert reader.get_header().profile == "ros2"
        assert summary.statistics.channel_message_counts == {1: N, 2: N} and len(summary.chunk_indexes) > 10
        assert summary.statistics.message_start_time == states["stamps_ns"][0]
        messages = list(reader.iter_messages(log_time_order=True))
    assert [m.log_time for _, _, m in messages] == np.repeat(states["stamps_ns"], 2).tolist()
    for k, (schema, channel, msg) in enumerate(messages):
        assert schema.name == JOINT_STATE and schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
        assert msg.data == payloads[k % 2][k // 2].tobytes()


def test_playback_messages_of_a_ros1_bag_become_ros2_joint_states_in_time_order(tmp_path: Path) -> None:
    states = joint_states(50)
    other = joint_states(50, names=["head_pan"], seed=3)
    msgs = {
        "/robot/joint_states": [(int(s), message("ros1", s, BAXTER_JOINTS, p, v, e)) for s, p, v, e in zip(*states.values())],
        "/robot/head": [(int(s) + 5, message("ros1", s, ["head_pan"], p, v, e, sea=True)) for s, p, v, e in zip(*other.values())],
    }
    path = write_bag(tmp_path / "two.bag", "ros1", msgs)
    played = read_joint_state_messages(path)
    assert len(played) == 100
    assert [t for t, _, _ in played] == sorted(t for t, _, _ in played)
    store = typestore(ros1=False)
    first_head = next(raw for _, topic, raw in played if topic == "/robot/head")
    msg = store.deserialize_cdr(first_head, JOINT_STATE)
    assert list(msg.name) == ["head_pan"] and msg.position[0] == other["position"][0, 0]
    assert [topic for _, topic, _ in read_joint_state_messages(path, ["/robot/head"])] == ["/robot/head"] * 50


@pytest.mark.parametrize("kind", BAG_KINDS)
def test_truncated_bag_is_reported_as_corrupt(tmp_path: Path, kind: str) -> None:
    path = write_reference_bag(bag_path(tmp_path, kind), kind, joint_states(N))
    storage = bag_storage_file(path)
    data = storage.read_bytes()
    storage.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(RecordingFileError, match="corrupt or truncated"):
        read_bag_recording(path)


def test_bag_errors_name_the_path_and_the_fix(tmp_path: Path) -> None:
    left_only = [f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")]
    states = joint_states(20, names=left_only)
    path = write_reference_bag(tmp_path / "left.bag", "ros1", states, names=left_only)
    with pytest.raises(RecordingFileError, match=r"all 7 right arm joints .*right_s0.*joint names found: left_e0"):
        read_bag_recording(path, arm="right")
    with pytest.raises(RecordingFileError, match=r"no topic /joint_states; joint-state topics in this bag: /robot/joint_states"):
        read_bag_recording(path, topic="/joint_states")
    with pytest.raises(RecordingFileError, match="no such file"):
        read_bag_recording(tmp_path / "absent.bag")
    heads = write_reference_bag(tmp_path / "head.bag", "ros1", joint_states(20, names=["head_pan"]), names=["head_pan"])
    with pytest.raises(RecordingError, match="no arm has all 7 joints.*head_pan"):
        read_bag_recording(heads)


@pytest.mark.parametrize("kind", BAG_KINDS)
def test_a_bag_without_the_default_topic_is_read_on_its_only_joint_state_topic(tmp_path: Path, kind: str) -> None:
    """/joint_states alone (a driver's, a joint_state_publisher's): read exactly, said in a note; with
    a second joint-state topic beside it, which to read is asked, as for a topic asked for by name."""
    states = joint_states(N)
    path = write_reference_bag(bag_path(tmp_path, kind), kind, states, topic="/joint_states")
    notes: list[str] = []
    rec = read_bag_recording(path, note=notes.append)
    assert notes == [f"{path}: no topic /robot/joint_states; its only joint-state topic, /joint_states, read"]
    for got, want in zip((rec.q, rec.qd, rec.effort), columns(states, rec.joint_names)):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])
    msgs = [(int(t), message(kind, t, BAXTER_JOINTS, p, v, e)) for t, p, v, e in zip(states["stamps_ns"], states["position"], states["velocity"], states["effort"])]
    two = write_bag(bag_path(tmp_path, kind, "two"), kind, {"/joint_states": msgs, "/robot/limb/left/joint_states": msgs})
    with pytest.raises(RecordingFileError, match=r"no topic /robot/joint_states; joint-state topics in this bag: /joint_states, /robot/limb/left/joint_states$"):
        read_bag_recording(two)


def test_a_topic_of_another_type_is_refused(tmp_path: Path) -> None:
    store = typestore(ros1=False)
    string = store.types["std_msgs/msg/String"](data="hello")
    path = write_bag(tmp_path / "strings", "mcap", {"/robot/joint_states": [(1, string), (2, string)]})
    with pytest.raises(RecordingFileError, match="carries std_msgs/msg/String, not sensor_msgs/JointState"):
        read_bag_recording(path)


# ------------------------------------------------------------------------------------------- tables
def estimate_in(text: str) -> float:
    """The one rate in Hz a message names ("... 99.52 Hz ...")."""
    (rate,) = re.findall(r"(\d+(?:\.\d+)?) Hz", text)
    return float(rate)


def test_baxter_export_table_reads_at_the_given_rate(tmp_path: Path) -> None:
    states = joint_states(N, names=BAXTER_JOINTS, rate_hz=50.0)
    path = write_baxter_export(tmp_path / "export.csv", states)
    notes: list[str] = []
    rec = read_table_recording(path, rate_hz=50.0, note=notes.append)
    assert rec.side == "left" and rec.rate_hz == pytest.approx(50.0) and notes == []
    np.testing.assert_array_equal(rec.stamps_ns, np.arange(N) * 20_000_000)
    for got, want in zip((rec.q, rec.qd, rec.effort), columns(states, arm_joint_names("left"))):
        np.testing.assert_array_equal(got, want)


def test_table_rate_is_estimated_said_and_a_disagreeing_rate_refused(tmp_path: Path) -> None:
    states = joint_states(N, names=BAXTER_JOINTS, rate_hz=50.0)
    path = write_baxter_export(tmp_path / "export.csv", states)
    notes: list[str] = []
    rec = read_table_recording(path, note=notes.append)
    assert rec.rate_hz == pytest.approx(50.0, rel=1e-3)
    assert len(notes) == 1 and notes[0].startswith(f"{path}: ") and "estimated" in notes[0]
    assert estimate_in(notes[0]) == pytest.approx(rec.rate_hz, abs=0.005)
    assert read_table_recording(path, rate_hz=54.0).rate_hz == pytest.approx(54.0)  # within 10 %: the user's rate
    with pytest.raises(RecordingFileError, match=r"--rate-hz 56 disagrees with the sample rate estimated") as refused:
        read_table_recording(path, rate_hz=56.0)
    assert estimate_in(str(refused.value)) == pytest.approx(50.0, rel=1e-3)
    with pytest.raises(RecordingFileError, match=r"--rate-hz 44 disagrees"):
        read_table_recording(path, rate_hz=44.0)


def test_a_table_whose_velocities_do_not_match_its_positions_needs_the_rate(tmp_path: Path) -> None:
    states = joint_states(N, names=BAXTER_JOINTS)
    states["velocity"] = np.zeros_like(states["velocity"])  # a dataset without velocities
    path = write_baxter_export(tmp_path / "export.csv", states)
    with pytest.raises(RecordingFileError, match="sample rate cannot be estimated.*pass --rate-hz"):
        read_table_recording(path)
    assert read_table_recording(path, rate_hz=100.0).rate_hz == pytest.approx(100.0)


@pytest.mark.parametrize("layout", ["baxter export", "generic"])
def test_a_table_whose_columns_name_no_arm_is_read_with_the_arm_given(tmp_path: Path, layout: str) -> None:
    states = joint_states(N)
    q, qd, tau = columns(states, arm_joint_names("right"))
    prefixes = ("ang_", "vel_", "torq_") if layout == "baxter export" else ("position_", "velocity_", "effort_")
    header = [p + j for p in prefixes for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2")]
    path = tmp_path / "other_dataset.csv"
    np.savetxt(path, np.hstack([q, qd, tau]), header=",".join(header), delimiter=",", comments="", fmt="%.17g")
    with pytest.raises(RecordingFileError, match=f"the columns name no arm \\({prefixes[0]}s0 {prefixes[1]}s0 {prefixes[2]}s0 ...\\), nor does the file name; pass --arm right\\|left"):
        read_table_recording(path)
    for side in ("right", "left"):
        rec = read_table_recording(path, arm=side, note=lambda _: None)
        assert rec.side == side and rec.joint_names == arm_joint_names(side)
        np.testing.assert_array_equal(np.hstack([rec.q, rec.qd, rec.effort]), np.hstack([q, qd, tau]))
        assert rec.rate_hz == pytest.approx(100.0, rel=1e-3)
    # As the other unit's files are published (left_circle_p90_t105.csv): the file name names the arm.
    for name, side in (("left_circle_p90_t105.csv", "left"), ("Right-Arm.run2.csv", "right")):
        named = tmp_path / name
        named.write_bytes(path.read_bytes())
        notes: list[str] = []
        rec = read_table_recording(named, note=notes.append)
        assert rec.side == side and rec.joint_names == arm_joint_names(side)
        assert f"{named}: the columns name no arm ({prefixes[0]}s0 {prefixes[1]}s0 {prefixes[2]}s0 ...); read as the {side} arm, which the file name names (--arm sets it)" in notes
        assert read_table_recording(named, arm="right" if side == "left" else "left", note=None).side != side, "--arm sets it"
    for name in ("left_vs_right.csv", "leftover.csv", "bereft_arm.csv"):
        (tmp_path / name).write_bytes(path.read_bytes())
        with pytest.raises(RecordingFileError, match="name no arm .*, nor does the file name; pass --arm"):
            read_table_recording(tmp_path / name)


def test_simulated_500_hz_table_without_time_or_arm_names_reads_back_at_500_hz(tmp_path: Path) -> None:
    """Written by the simulator and msg_adapters' writer, then made into another dataset's file:
    the time columns dropped, the right arm's columns renamed without the arm."""
    from baxter_dynamics_ros.simulation.plant import simulate
    from baxter_dynamics_ros.simulation.spec import SimulationSpec

    result = simulate(SimulationSpec(trajectory="random", duration_s=3.0, rate_hz=500.0, seed=4, side="right"))
    states = robot_joint_states(result.recording(), result.other_q, result.other_effort)
    written = tmp_path / "simulated.csv"
    write_joint_states(written, states.stamps_ns, states.names, states.position, states.velocity, states.effort)
    header, *rows = written.read_text().splitlines()
    names = header.split(",")
    keep = [k for k, name in enumerate(names) if name not in ("stamp_ns", "time_s")]
    renamed = [names[k].replace("_right_", "_") for k in keep]
    assert "position_s0" in renamed and "position_left_s0" in renamed and "stamp_ns" not in renamed
    path = tmp_path / "other_dataset.csv"
    path.write_text("\n".join([",".join(renamed), *(",".join(row.split(",")[k] for k in keep) for row in rows)]) + "\n")
    notes: list[str] = []
    rec = read_recording(path, arm="right", note=notes.append)
    assert rec.side == "right" and len(rec) == 1500
    assert rec.rate_hz == pytest.approx(500.0, rel=2e-3)
    assert len(notes) == 1 and estimate_in(notes[0]) == pytest.approx(500.0, rel=2e-3)
    np.testing.assert_array_equal(rec.q, result.q)
    np.testing.assert_array_equal(rec.effort, result.effort)


def test_generic_table_with_a_time_column_in_any_column_order(tmp_path: Path) -> None:
    states = joint_states(N)
    joints = arm_joint_names("right")
    q, qd, tau = columns(states, joints)
    time_s = (states["stamps_ns"] - states["stamps_ns"][0]) * 1e-9
    cols = {"time_s": time_s, "head_pan": np.zeros(N)}
    for prefix, values in (("effort", tau), ("position", q), ("velocity", qd)):
        cols.update({f"{prefix}_{j}": values[:, k] for k, j in enumerate(joints)})
    path = tmp_path / "generic.csv"
    np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    rec = read_table_recording(path)
    assert rec.side == "right"
    np.testing.assert_array_equal(rec.stamps_ns, np.round(time_s * 1e9).astype(np.int64))
    np.testing.assert_array_equal(rec.q, q)
    np.testing.assert_array_equal(rec.effort, tau)


def test_table_errors_name_the_columns(tmp_path: Path) -> None:
    states = joint_states(20)
    path = write_baxter_export(tmp_path / "export.txt", states, side="right")
    text = path.read_text().replace("torq_right_w2", "torque_w2")
    path.write_text(text)
    with pytest.raises(RecordingError, match="no arm has all 7 joints"):
        read_table_recording(path)
    with pytest.raises(RecordingFileError, match="missing here: torq_right_w2"):
        read_table_recording(path, arm="right")
    (tmp_path / "words.csv").write_text("a,b\n1,x\n")
    with pytest.raises(RecordingFileError, match="not a table of numbers"):
        read_table_recording(tmp_path / "words.csv")
    (tmp_path / "other.csv").write_text("a,b\n1,2\n")
    with pytest.raises(RecordingFileError, match="no joint columns; expected a position, velocity and effort column per joint"):
        read_table_recording(tmp_path / "other.csv")


@pytest.mark.skipif(not REAL_FILES, reason=f"real Baxter recordings absent ({REAL_DATA})")
@pytest.mark.parametrize("path", REAL_FILES, ids=lambda p: p.name[:20])
def test_real_baxter_recordings_read_as_the_left_arm_at_100_hz(path: Path) -> None:
    """The files are 100 Hz (../shared/data/baxter_real/README.md) with no time column: the rate
    estimated from their positions and velocities must be 100 Hz within 1 %."""
    notes: list[str] = []
    rec = read_table_recording(path, note=notes.append)
    raw = np.loadtxt(path, skiprows=1)
    assert rec.side == "left" and len(rec) == len(raw) > 5000
    assert rec.rate_hz == pytest.approx(100.0, rel=0.01)
    assert len(notes) == 1 and notes[0].startswith(f"{path}: ") and estimate_in(notes[0]) == pytest.approx(rec.rate_hz, abs=0.005)
    assert read_table_recording(path, rate_hz=100.0).rate_hz == pytest.approx(100.0)
    np.testing.assert_array_equal(np.hstack([rec.q, rec.qd, rec.effort]), raw)
    # The export's quantisation survives reading: torques on the 0.004 N·m grid.
    np.testing.assert_allclose(rec.effort / 0.004, np.round(rec.effort / 0.004), atol=1e-6)


@pytest.mark.parametrize("suffix", [".mcap", ".csv", ".parquet"])
def test_joint_states_written_by_extension_read_back_exactly(tmp_path: Path, suffix: str) -> None:
    states = joint_states(N)
    path = tmp_path / f"states{suffix}"
    write_joint_states(path, states["stamps_ns"], BAXTER_JOINTS, states["position"], states["velocity"], states["effort"])
    assert listing_of(tmp_path) == [path.name]
    assert_recording_is(read_recording(path), states, "right")
    with pytest.raises(OutputError, match="exists already; choose another --out or pass --force"):
        write_joint_states(path, states["stamps_ns"], BAXTER_JOINTS, states["position"], states["velocity"], states["effort"])


# --------------------------------------------------------------------------------------- recording
def test_recording_validates_itself_quoting_sizes() -> None:
    joints = arm_joint_names("right")
    stamps = np.arange(4) * 10
    good = np.zeros((4, 7))
    with pytest.raises(RecordingError, match=r"q must be \(4, 7\) like stamps_ns, got \(4, 6\)"):
        Recording("right", joints, stamps, good[:, :6], good, good)
    with pytest.raises(RecordingError, match="sample 2 of 4 is at 10 ns after 10 ns"):
        Recording("right", joints, [0, 10, 10, 20], good, good, good)
    bad = good.copy()
    bad[2, 3] = np.nan
    with pytest.raises(RecordingError, match="effort has 1 non-finite values, the first at sample 2 joint right_e1"):
        Recording("right", joints, stamps, good, good, bad)
    with pytest.raises(RecordingError, match="joint_names must be the left arm's"):
        Recording("left", joints, stamps, good, good, good)
    rec = Recording("right", joints, stamps, good, good, good)
    assert not rec.q.flags.writeable and rec.rate_hz == pytest.approx(1e8)


def test_arm_detection_needs_a_choice_when_both_arms_move_alike() -> None:
    both = [*arm_joint_names("left"), *arm_joint_names("right")]
    assert detect_arm(arm_joint_names("left")) == "left"
    assert detect_arm(both, {"right": 0.1, "left": 2.0}) == "left"
    with pytest.raises(RecordingError, match="choose one with --arm"):
        detect_arm(both, {"right": 1.0, "left": 1.0})


def test_an_arm_range_counts_finite_angles_only() -> None:
    """One NaN or inf in the moving arm's angles made its summed range NaN or inf (and then the
    other arm, or a tie, was taken): each joint's range is over its finite samples."""
    q = np.array([[0.0, 1.0, np.nan], [0.5, np.inf, np.nan], [0.25, 2.0, np.nan]])
    assert summed_range_rad(q) == 0.5 + 1.0
    assert summed_range_rad(np.full((3, 2), np.nan)) == 0.0 and summed_range_rad(np.zeros((0, 7))) == 0.0
