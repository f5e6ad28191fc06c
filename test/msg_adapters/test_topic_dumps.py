"""Joint states dumped by ``rostopic echo -p``, by bagpy and by ``rostopic echo`` / ``ros2 topic echo``:
written here the way rostopic prints them (``recorded_bags.rostopic_plot_row``), bagpy writes them
(``recorded_bags.write_bagpy_table``) and echo prints them (``recorded_bags.echo_message``), read
back exactly through ``read_recording``."""

from __future__ import annotations

import datetime
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from recorded_bags import (
    BAXTER_JOINTS, columns, echo_csv_line, echo_message, joint_states, rostopic_plot_header, rostopic_plot_row, write_bagpy_table, write_rosbag_to_csv_table, write_rostopic_table,
)
from repo_paths import REPO

from baxter_dynamics_ros.core.joints import arm_joint_names
from baxter_dynamics_ros.core.samples import SkipReason
from baxter_dynamics_ros.errors import RecordingFileError
from msg_adapters.recording_files import read_recording
from msg_adapters import topic_dumps
from msg_adapters.topic_dumps import is_topic_dump

N = 300


def assert_arm(rec, states: dict, side: str, stamps_ns: np.ndarray | None = None) -> None:
    assert rec.side == side
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"] if stamps_ns is None else stamps_ns)
    for got, want in zip((rec.q, rec.qd, rec.effort), columns(states, arm_joint_names(side))):
        np.testing.assert_array_equal(got, want)


def test_a_rostopic_table_reads_back_exactly_with_the_moving_arm_detected(tmp_path: Path) -> None:
    states = joint_states(N)
    path = write_rostopic_table(tmp_path / "joint_states.csv", states, receive_delay_ns=2_500_000)
    assert is_topic_dump(path)
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert_arm(read_recording(path, arm="left", note=notes.append), states, "left")
    assert notes == []


@pytest.mark.parametrize("chunk_rows", [None, 5])
def test_rows_of_other_layouts_are_matched_by_name_and_the_rest_skipped_and_counted(
    tmp_path: Path, chunk_rows: int | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Shuffled names, a frame_id, gripper rows, rows without efforts, a corrupt value and a
    truncated last line (a dump cut short): the arm's samples read exactly, the rest counted; the
    same when the reader decodes a few rows at a time."""
    if chunk_rows is not None:
        monkeypatch.setattr(topic_dumps, "CHUNK_ROWS", chunk_rows)
    states = joint_states(N)
    rng = np.random.default_rng(3)
    lines = [rostopic_plot_header(BAXTER_JOINTS)]
    missing = length = 0
    for k, stamp in enumerate(states["stamps_ns"]):
        order = rng.permutation(len(BAXTER_JOINTS)) if k % 7 == 3 else np.arange(len(BAXTER_JOINTS))
        names = [BAXTER_JOINTS[i] for i in order]
        arrays = [states[f][k][order] for f in ("position", "velocity", "effort")]
        if k % 19 == 9:  # the previous message's names and one more
            names, arrays = names + ["torso_t0_extra"], [np.append(a, 0.0) for a in arrays]
        lines.append(rostopic_plot_row(int(stamp) + 1000, int(stamp), names, *arrays, frame_id="base" * (k % 5 == 1), seq=k))
        if k % 11 == 5:  # the gripper's joint states on the same topic
            lines.append(rostopic_plot_row(int(stamp) + 2000, int(stamp) + 1, ["l_gripper_l_finger_joint", "l_gripper_r_finger_joint"], [0.01, 0.01], [0.0, 0.0], [0.0, 0.0]))
            missing += 1
        if k % 13 == 6:  # a message with an empty effort array
            lines.append(rostopic_plot_row(int(stamp) + 3000, int(stamp) + 2, names, arrays[0], arrays[1], []))
            length += 1
        if k % 17 == 8:  # a value that is not a number
            bad = rostopic_plot_row(int(stamp) + 4000, int(stamp) + 3, names, *arrays).split(",")
            bad[-3] = "0.1x"
            lines.append(",".join(bad))
            length += 1
    lines.append(rostopic_plot_row(int(states["stamps_ns"][-1]) + 10**7, int(states["stamps_ns"][-1]) + 10**7, BAXTER_JOINTS, *(states[f][0] for f in ("position", "velocity", "effort")))[:-40])
    length += 1
    path = tmp_path / "dump.txt"
    path.write_text("\r\n".join(lines) + "\r\n")
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert notes == [
        f"WARNING: {path}: {missing + length} of {len(lines) - 1} messages in this file skipped as malformed "
        f"({missing} {SkipReason.MISSING_JOINT.value}, {length} {SkipReason.ARRAY_LENGTH.value})"
    ]
    assert missing and length


@pytest.mark.parametrize("frame_id", ["base,link", "a,b,c"])
def test_a_frame_id_with_commas_is_passed_over(tmp_path: Path, frame_id: str) -> None:
    """rostopic prints a frame_id as it is, commas and all: its pieces are not joint names, on the
    rows of the arm as on a gripper's rows between them (still skipped as missing the arm's joints)."""
    states = joint_states(40)
    lines = [rostopic_plot_header(BAXTER_JOINTS)]
    for k, stamp in enumerate(states["stamps_ns"]):
        lines.append(rostopic_plot_row(int(stamp), int(stamp), BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort")), frame_id=frame_id))
        if k % 9 == 4:
            lines.append(rostopic_plot_row(int(stamp) + 1, int(stamp) + 1, ["l_gripper_l_finger_joint"], [0.01], [0.0], [0.0], frame_id=frame_id))
    path = tmp_path / "frame.csv"
    path.write_text("\n".join(lines) + "\n")
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert notes == [f"WARNING: {path}: 4 of 44 messages in this file skipped as malformed (4 {SkipReason.MISSING_JOINT.value})"]


def test_without_header_stamps_the_time_column_is_used(tmp_path: Path) -> None:
    states = joint_states(40)
    lines = [rostopic_plot_header(BAXTER_JOINTS)]
    receive = states["stamps_ns"] + 1234
    for k, t in enumerate(receive):
        lines.append(rostopic_plot_row(int(t), 0, BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort"))))
    path = tmp_path / "unstamped.csv"
    path.write_text("\n".join(lines) + "\n")
    assert_arm(read_recording(path, note=None), states, "right", stamps_ns=receive)


def test_bad_rostopic_tables_are_refused_in_one_line(tmp_path: Path) -> None:
    header = rostopic_plot_header(BAXTER_JOINTS)
    only_header = tmp_path / "header.csv"
    only_header.write_text(header + "\n")
    with pytest.raises(RecordingFileError, match="no messages in this file$"):
        read_recording(only_header, note=None)
    only_header.write_text(header + "\nsoon,0,0\nlater,0,0\n")
    with pytest.raises(RecordingFileError, match=r"no messages in this file \(2 rows without a readable time\)$"):
        read_recording(only_header, note=None)
    (tmp_path / "echo.txt").write_text("header:\n  stamp:\n    sec: 1\n")
    with pytest.raises(RecordingFileError, match=r"no messages in this file \(1 message without a readable time\)$"):
        read_recording(tmp_path / "echo.txt", note=None)
    binary = tmp_path / "binary.csv"
    binary.write_bytes(header.encode() + b"\n\xff\xfe\x00garbage\n")
    assert is_topic_dump(binary)
    with pytest.raises(RecordingFileError, match="not a text table"):
        read_recording(binary, note=None)
    gripper_only = tmp_path / "gripper.csv"
    gripper = ["l_gripper_l_finger_joint"]
    gripper_only.write_text(rostopic_plot_header(gripper) + "\n" + rostopic_plot_row(1, 1, gripper, [0.0], [0.0], [0.0]) + "\n")
    with pytest.raises(RecordingFileError, match=r"no arm has all 7 joints .*found: l_gripper_l_finger_joint$"):
        read_recording(gripper_only, note=None)
    with pytest.raises(RecordingFileError, match=r"no message in this file has position, velocity and effort of all 7 left .*found: l_gripper_l_finger_joint$"):
        read_recording(gripper_only, arm="left", note=None)


@pytest.mark.parametrize("dump", ["rostopic", "bagpy"])
def test_process_reads_a_dump_from_the_command_line(tmp_path: Path, dump: str) -> None:
    states = joint_states(N)
    if dump == "rostopic":
        path = write_rostopic_table(tmp_path / "run.csv", states)
    else:
        path = write_bagpy_table(tmp_path / "robot-joint_states.csv", bagpy_messages(states, 1_000_000))
    out = tmp_path / "out.csv"
    done = subprocess.run(
        [str(Path(sys.executable).with_name("baxter-dynamics")), "process", str(path), "--out", str(out)],
        capture_output=True, text=True, cwd=REPO,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    assert header[0] == "stamp_ns" and "residual_right_s0" in header and len(lines) == N + 1


def test_rows_without_a_time_are_skipped_and_counted_on_their_own(tmp_path: Path) -> None:
    states = joint_states(40)
    lines = [rostopic_plot_header(BAXTER_JOINTS)]
    for k, t in enumerate(states["stamps_ns"]):
        lines.append(rostopic_plot_row(int(t), int(t), BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort"))))
    bad = [f"{2**70}" + lines[5][lines[5].index(","):], "nan" + lines[9][lines[9].index(","):], "12,0"]
    path = tmp_path / "times.csv"
    path.write_text("\n".join(lines[:5] + bad[:1] + lines[6:9] + bad[1:2] + lines[10:] + bad[2:]) + "\n")
    keep = np.array([k for k in range(40) if k not in (4, 8)])
    notes: list[str] = []
    rec = read_recording(path, note=notes.append)
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"][keep])
    np.testing.assert_array_equal(rec.q, columns(states, arm_joint_names("right"))[0][keep])
    assert notes == [f"WARNING: {path}: 3 of 41 rows skipped: no time, header stamp and joint names could be read from them"]


#: baxter_core_msgs/SEAJointState's arrays: baxter_common's definition, and a later one with 11.
SEA_ARRAYS = {
    9: ("commanded_position", "commanded_velocity", "commanded_effort", "actual_position", "actual_velocity", "actual_effort",
        "gravity_model_effort", "hysteresis_model_effort", "crosstalk_model_effort"),
    11: ("commanded_position", "commanded_velocity", "commanded_acceleration", "commanded_effort", "actual_position", "actual_velocity",
         "actual_effort", "gravity_model_effort", "gravity_only", "hysteresis_model_effort", "crosstalk_model_effort"),
}  # fmt: skip


@pytest.mark.parametrize("version", sorted(SEA_ARRAYS))
def test_sea_joint_states_are_read_from_their_actual_arrays(tmp_path: Path, version: int) -> None:
    """Baxter's /robot/limb/left/gravity_compensation_torques (baxter_core_msgs/SEAJointState): the
    left arm's 7 joints, its arrays and hystState; q, q̇, effort are the actual_* arrays, found by
    the header's names in either version of the message."""
    joints = arm_joint_names("left")
    states = joint_states(60, names=joints)
    rng = np.random.default_rng(5)
    names = SEA_ARRAYS[version]
    at = [names.index(f"actual_{f}") for f in ("position", "velocity", "effort")]
    lines = [rostopic_plot_header(joints, names, ("hystState",))]
    for k, t in enumerate(states["stamps_ns"]):
        arrays = [rng.normal(size=7) for _ in names]
        for i, f in zip(at, ("position", "velocity", "effort")):
            arrays[i] = states[f][k]
        lines.append(rostopic_plot_row(int(t), int(t), joints, *arrays, [float(k % 2)]))
    path = tmp_path / "gravity_compensation_torques.csv"
    path.write_text("\n".join(lines) + "\n")
    rec = read_recording(path, note=None)
    assert rec.side == "left"
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])
    for got, want in zip((rec.q, rec.qd, rec.effort), (states["position"], states["velocity"], states["effort"])):
        np.testing.assert_array_equal(got, want)


def test_a_table_of_another_message_type_is_refused_naming_its_fields(tmp_path: Path) -> None:
    path = tmp_path / "other.csv"
    path.write_text(rostopic_plot_header(["a"], ("data",), ("count",)) + "\n1,0,1,,a,0.5,3\n")
    with pytest.raises(RecordingFileError, match=r"not JointState or SEAJointState messages: after the joint names the header names arrays data and fields field.count;"):
        read_recording(path, note=None)


#: A dump as rostopic (Python 2) prints it, typed out: the first message a gripper's (the header
#: names two joints), Python 2's str() of a float (12 significant digits), a BOM and a trailing
#: comma from a spreadsheet's re-save, Windows line ends.
TYPED_DUMP = (
    "\ufeff%time,field.header.seq,field.header.stamp,field.header.frame_id,field.name0,field.name1,field.position0,field.position1,"
    "field.velocity0,field.velocity1,field.effort0,field.effort1,\r\n"
    "1400000000000000000,1,1400000000000000000,,l_gripper_l_finger_joint,l_gripper_r_finger_joint,0.0208333333333,-0.0208333333333,"
    "0.0,0.0,0.0,0.0,\r\n"
    "1400000000011000000,2,1400000000010000000,,head_pan,left_e0,left_e1,left_s0,left_s1,left_w0,left_w1,left_w2,"
    "0.0113,0.0460194236,1.98881314,-0.150721358811,-0.999534,0.01,0.9,-0.0141,0.0,0.1,0.2,0.3,0.4,0.5,0.6,0.7,"
    "0.0,0.1,1.2,-1.1,-20.2658,0.0,0.3,-0.0125,\r\n"
    "1400000000021000000,3,1400000000020000000,,head_pan,left_e0,left_e1,left_s0,left_s1,left_w0,left_w1,left_w2,"
    "0.0113,0.0470194236,1.99881314,-0.149721358811,-0.989534,0.02,0.91,-0.0131,0.0,0.1,0.2,0.3,0.4,0.5,0.6,0.7,"
    "0.0,0.2,1.3,-1.2,-20.3658,0.1,0.4,-0.0135,\r\n"
)


def test_a_dump_typed_out_as_rostopic_prints_it(tmp_path: Path) -> None:
    path = tmp_path / "typed.csv"
    path.write_bytes(TYPED_DUMP.encode("utf-8"))
    assert is_topic_dump(path)
    notes: list[str] = []
    rec = read_recording(path, note=notes.append)
    assert rec.side == "left" and rec.joint_names == tuple(f"left_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
    np.testing.assert_array_equal(rec.stamps_ns, [1400000000010000000, 1400000000020000000])
    np.testing.assert_array_equal(rec.q, [[-0.150721358811, -0.999534, 0.0460194236, 1.98881314, 0.01, 0.9, -0.0141],
                                          [-0.149721358811, -0.989534, 0.0470194236, 1.99881314, 0.02, 0.91, -0.0131]])  # fmt: skip
    np.testing.assert_array_equal(rec.qd, [[0.3, 0.4, 0.1, 0.2, 0.5, 0.6, 0.7]] * 2)
    np.testing.assert_array_equal(rec.effort, [[-1.1, -20.2658, 0.1, 1.2, 0.0, 0.3, -0.0125], [-1.2, -20.3658, 0.2, 1.3, 0.1, 0.4, -0.0135]])
    assert notes == [f"WARNING: {path}: 1 of 3 messages in this file skipped as malformed (1 {SkipReason.MISSING_JOINT.value})"]


def test_a_nan_does_not_decide_which_arm_moves(tmp_path: Path) -> None:
    """One NaN in the moving (right) arm's angles made its range NaN, and the left arm was taken."""
    states = joint_states(N)
    states["position"][17, BAXTER_JOINTS.index("right_s1")] = np.nan
    rec = read_recording(write_rostopic_table(tmp_path / "nan.csv", states), note=None)
    assert rec.side == "right" and len(rec) == N - 1


def test_when_no_row_is_a_whole_sample_the_error_says_so(tmp_path: Path) -> None:
    states = joint_states(20)
    lines = [rostopic_plot_header(BAXTER_JOINTS, ("position", "velocity"))]
    for k, t in enumerate(states["stamps_ns"]):
        lines.append(rostopic_plot_row(int(t), int(t), BAXTER_JOINTS, states["position"][k], states["velocity"][k]))
    path = tmp_path / "no_effort.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingFileError, match=r"no message in this file has position, velocity and effort \(or, where none gives velocities, position and effort\), one entry per name \(20 messages; joint names found: head_nod"):
        read_recording(path, note=None)


def bagpy_messages(states: dict, receive_delay_ns: int = 0) -> list[tuple]:
    """One message of every Baxter joint per sample of ``states``, received receive_delay_ns late."""
    arrays = [states[f] for f in ("position", "velocity", "effort")]
    return [(int(t) + receive_delay_ns, int(t), BAXTER_JOINTS, *(a[k] for a in arrays)) for k, t in enumerate(states["stamps_ns"])]


@pytest.mark.parametrize("names_split", [False, True])
def test_a_bagpy_table_reads_back_exactly_by_its_header_stamps(tmp_path: Path, names_split: bool) -> None:
    """bagpy's CSV of /robot/joint_states: the arm found by name, stamps from header.stamp.secs and
    .nsecs (the Time column is the receive time, here 2.5 ms later), values to the last bit."""
    states = joint_states(N)
    path = write_bagpy_table(tmp_path / "robot-joint_states.csv", bagpy_messages(states, 2_500_000), names_split=names_split)
    assert is_topic_dump(path) and path.read_text().startswith("Time,header.seq,header.stamp.secs,header.stamp.nsecs,header.frame_id,name")
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert_arm(read_recording(path, arm="left", note=notes.append), states, "left")
    assert notes == []


def test_a_bagpy_table_of_gripper_messages_frame_ids_and_bad_rows(tmp_path: Path) -> None:
    """The topic's first message a gripper's (the header names 2 joints), frame_ids with commas
    (quoted), rows in shuffled order of names, a row without efforts, a names field that is no list,
    rows without a time: the arm's samples read exactly, the rest skipped and counted."""
    states = joint_states(60)
    gripper = ("l_gripper_l_finger_joint", "l_gripper_r_finger_joint")
    messages: list[tuple] = [(int(states["stamps_ns"][0]) - 1, int(states["stamps_ns"][0]) - 1, gripper, [0.01, 0.01], [0.0, 0.0], [0.0, 0.0])]
    order = np.arange(len(BAXTER_JOINTS))[::-1]
    for k, message in enumerate(bagpy_messages(states)):
        if k % 4 == 1:  # the names in another order
            message = (*message[:2], tuple(BAXTER_JOINTS[i] for i in order), *(a[order] for a in message[3:6]))
        messages.append((*message, "base, link" if k % 3 == 0 else ""))
        if k % 10 == 5:
            messages.append((message[0] + 1, message[1] + 1, gripper, [0.02, 0.02], [0.0, 0.0], [0.0, 0.0]))
    path = write_bagpy_table(tmp_path / "joint_states.csv", messages)
    lines = path.read_text().splitlines()
    assert lines[0].endswith("effort_0,effort_1") and '"base, link"' in lines[2]
    last = lines[-1].split(",")
    lines += [",".join(["1.5e9", *last[1:5], "not a list", *last[-3 * len(BAXTER_JOINTS):]])]  # a names field no list
    lines += [",".join([*lines[3].split(",")[:-len(BAXTER_JOINTS)], *lines[3].split(",")[-len(BAXTER_JOINTS):][:0]])]  # no efforts
    lines += ["nan" + lines[3][lines[3].index(","):], "", "12"]  # no time; an empty line; a row that ends before the names
    stamp = lines[3].split(",")
    lines += [",".join([*stamp[:2], "1" + "0" * 25, *stamp[3:]]), '"' + "x" * 200_000 + '"']  # a stamp beyond int64 ns; a field beyond csv's limit
    path.write_text("\n".join(lines) + "\n")
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert notes == [
        f"WARNING: {path}: 4 of {len(messages) + 6} rows skipped: no time, header stamp and joint names could be read from them",
        f"WARNING: {path}: {len(messages) - 60 + 2} of {len(messages) + 2} messages in this file skipped as malformed "
        f"({len(messages) - 60 + 1} {SkipReason.MISSING_JOINT.value}, 1 {SkipReason.ARRAY_LENGTH.value})",
    ]


def test_a_rosbag_to_csv_table_reads_back_exactly_by_its_header_stamps(tmp_path: Path) -> None:
    """rosbag_to_csv's CSV of /robot/joint_states (each array one quoted field, the receive time as
    local date and time): read as bagpy's, stamps from the header, values to the last bit; the
    receive times where every header stamp is zero; a gripper's message, an empty effort array and
    a row whose time is no date skipped and counted."""
    states = joint_states(N)
    messages = bagpy_messages(states, 2_500_000)
    path = write_rosbag_to_csv_table(tmp_path / "robot-joint_states.csv", messages)
    lines = path.read_text().splitlines()
    assert is_topic_dump(path) and lines[0].startswith("time,.header.seq,.header.stamp.secs,.header.stamp.nsecs,.header.frame_id,.name,")
    assert lines[1].split(",")[5].startswith('"[\'head_nod\'')
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert_arm(read_recording(path, arm="left", note=notes.append), states, "left")
    assert notes == []
    unstamped = write_rosbag_to_csv_table(tmp_path / "unstamped.csv", [(m[0], 0, *m[2:]) for m in messages])
    local = [datetime.datetime.fromtimestamp(m[0] / 1e9) - datetime.datetime(1970, 1, 1) for m in messages]  # as written: local, µs
    assert_arm(read_recording(unstamped, note=None), states, "right", stamps_ns=np.array([t // datetime.timedelta(microseconds=1) * 1000 for t in local]))
    gripper = ("l_gripper_l_finger_joint",)
    late = (messages[10][0] + 1, messages[10][1] + 1)
    odd = [*messages[:11], (*late, gripper, [0.01], [0.0], [0.0]), (*late, *messages[10][2:5], []), *messages[11:]]
    path = write_rosbag_to_csv_table(tmp_path / "odd.csv", odd)
    lines = path.read_text().splitlines()
    assert lines[12].endswith(',[\'l_gripper_l_finger_joint\'],"(0.01,)","(0.0,)","(0.0,)"') and lines[13].endswith(",()")
    lines.insert(14, lines[13].removesuffix(",()"))  # a row that ends before its effort field
    lines.insert(5, "yesterday" + lines[5][lines[5].index(",") :])
    path.write_text("\n".join(lines) + "\n")
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert notes == [
        f"WARNING: {path}: 1 of {len(odd) + 2} rows skipped: no time, header stamp and joint names could be read from them",
        f"WARNING: {path}: 3 of {len(odd) + 1} messages in this file skipped as malformed (1 {SkipReason.MISSING_JOINT.value}, 2 {SkipReason.ARRAY_LENGTH.value})",
    ]


def echo_text(states: dict, ros2: bool) -> list[str]:
    """Every Baxter joint's states echoed, one message per sample."""
    arrays = [states[f] for f in ("position", "velocity", "effort")]
    return [echo_message(int(t), BAXTER_JOINTS, *(a[k] for a in arrays), ros2=ros2) for k, t in enumerate(states["stamps_ns"])]


@pytest.mark.parametrize("ros2", [False, True])
def test_echoed_messages_read_back_exactly(tmp_path: Path, ros2: bool) -> None:
    """``rostopic echo /robot/joint_states > run.txt`` and ROS 2's echo: the arm found by name, the
    header stamps as times, values to the last bit."""
    states = joint_states(N)
    path = tmp_path / "run.txt"
    path.write_text("\n".join(echo_text(states, ros2)) + "\n")
    assert is_topic_dump(path)
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert_arm(read_recording(path, arm="left", note=notes.append), states, "left")
    assert notes == []


def mixed_messages(states: dict, message: Callable[..., str]) -> list[str]:
    """The samples of ``states`` as ``message(stamp_ns, names, position, velocity, effort, frame_id=…)``
    writes them, frame_id "base", every 5th from the 3rd with its joints in reverse order, and a
    gripper's message after every 9th from the 5th (k % 9 == 4)."""
    order = np.arange(len(BAXTER_JOINTS))[::-1]
    gripper = ("l_gripper_l_finger_joint", "l_gripper_r_finger_joint")
    out = []
    for k, t in enumerate(states["stamps_ns"]):
        names, arrays = BAXTER_JOINTS, [states[f][k] for f in ("position", "velocity", "effort")]
        if k % 5 == 2:
            names, arrays = [BAXTER_JOINTS[i] for i in order], [a[order] for a in arrays]
        out.append(message(int(t), names, *arrays, frame_id="base"))
        if k % 9 == 4:
            out.append(message(int(t) + 1, gripper, [0.01, 0.01], [0.0, 0.0], [0.0, 0.0]))
    return out


@pytest.mark.parametrize("ros2", [False, True])
def test_echoed_messages_of_other_layouts_are_matched_by_name_and_the_rest_skipped_and_counted(tmp_path: Path, ros2: bool) -> None:
    """Names in another order, gripper messages, a message without efforts, one without a stamp, a
    NaN (ROS 2's ``.nan``), an empty message (``---`` twice), Windows line ends, and the last message
    cut short: the arm's samples read exactly, the rest counted."""
    states = joint_states(80)
    messages = mixed_messages(states, lambda *a, **k: echo_message(*a, **k, ros2=ros2))
    no_effort = echo_message(int(states["stamps_ns"][-1]) + 5, BAXTER_JOINTS, states["position"][0], states["velocity"][0], [], ros2=ros2)
    no_stamp = echo_message(int(states["stamps_ns"][-1]) + 6, BAXTER_JOINTS, *(states[f][0] for f in ("position", "velocity", "effort")), ros2=ros2)
    no_stamp = no_stamp.replace("sec", "when")
    nan = states["position"][1].copy()
    nan[BAXTER_JOINTS.index("right_e0")] = np.nan
    with_nan = echo_message(int(states["stamps_ns"][-1]) + 7, BAXTER_JOINTS, nan, states["velocity"][1], states["effort"][1], ros2=ros2)
    cut = echo_message(int(states["stamps_ns"][-1]) + 8, BAXTER_JOINTS, *(states[f][0] for f in ("position", "velocity", "effort")), ros2=ros2)
    cut = cut[: cut.index("effort")] + "effort: [1.0]"
    text = "\n".join([*messages, no_effort, no_stamp, "---", with_nan, cut])
    path = tmp_path / "echo.txt"
    path.write_bytes(text.replace("\n", "\r\n").encode())
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    grippers = sum(1 for k in range(80) if k % 9 == 4)
    assert notes == [
        f"WARNING: {path}: 1 of {len(messages) + 4} messages skipped: no time, header stamp and joint names could be read from them",
        f"WARNING: {path}: {grippers + 2} of {len(messages) + 3} messages in this file skipped as malformed "
        f"({grippers} {SkipReason.MISSING_JOINT.value}, 2 {SkipReason.ARRAY_LENGTH.value})",
        f"WARNING: {path}: 1 of {80 + 1} samples skipped as implausible (1 NaN or inf); the recording is split into pieces at them",
    ]


def test_messages_echoed_as_csv_read_back_exactly(tmp_path: Path) -> None:
    """``ros2 topic echo --csv /robot/joint_states > run.csv``, no header: the arm found by name, the
    header stamps as times, values to the last bit."""
    states = joint_states(N)
    path = tmp_path / "run.csv"
    path.write_text("\n".join(echo_csv_line(int(t), BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort")))
                              for k, t in enumerate(states["stamps_ns"])) + "\n")
    assert is_topic_dump(path)
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert_arm(read_recording(path, arm="left", note=notes.append), states, "left")
    assert notes == []


def test_messages_echoed_as_csv_of_other_layouts_are_matched_by_name_and_the_rest_skipped_and_counted(tmp_path: Path) -> None:
    """Names in another order, a frame_id, gripper messages, a message without efforts (an empty
    field), a line that is no message, a NaN, Windows line ends: the arm's samples read exactly, the
    rest counted. Without velocities in every message, q̇ is the central difference of q."""
    states = joint_states(80)
    lines = mixed_messages(states, echo_csv_line)
    last = int(states["stamps_ns"][-1])
    no_effort = echo_csv_line(last + 5, BAXTER_JOINTS, states["position"][0], states["velocity"][0], [])
    nan = states["position"][1].copy()
    nan[BAXTER_JOINTS.index("right_e0")] = np.nan
    with_nan = echo_csv_line(last + 7, BAXTER_JOINTS, nan, states["velocity"][1], states["effort"][1])
    path = tmp_path / "echo.csv"
    path.write_bytes("\r\n".join([*lines, no_effort, "sec,nanosec,frame_id,left_s0,0.1", with_nan]).encode())
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    grippers = sum(1 for k in range(80) if k % 9 == 4)
    assert notes == [
        f"WARNING: {path}: 1 of {len(lines) + 3} lines skipped: no time, header stamp and joint names could be read from them",
        f"WARNING: {path}: {grippers + 1} of {len(lines) + 2} messages in this file skipped as malformed "
        f"({grippers} {SkipReason.MISSING_JOINT.value}, 1 {SkipReason.ARRAY_LENGTH.value})",
        f"WARNING: {path}: 1 of {80 + 1} samples skipped as implausible (1 NaN or inf); the recording is split into pieces at them",
    ]
    no_velocity = tmp_path / "no_velocity.csv"
    no_velocity.write_text("\n".join(echo_csv_line(int(t), BAXTER_JOINTS, states["position"][k], [], states["effort"][k])
                                     for k, t in enumerate(states["stamps_ns"])) + "\n")
    rec = read_recording(no_velocity, note=None)
    q, _, effort = columns(states, arm_joint_names("right"))
    np.testing.assert_array_equal(rec.q, q)
    np.testing.assert_array_equal(rec.effort, effort)
    np.testing.assert_allclose(rec.qd, np.gradient(q, (states["stamps_ns"] - states["stamps_ns"][0]) * 1e-9, axis=0), rtol=1e-12, atol=1e-12)


def test_echoed_sea_joint_states_are_read_from_their_actual_arrays(tmp_path: Path) -> None:
    """``rostopic echo /robot/limb/left/gravity_compensation_torques``: q, q̇, effort are the
    actual_* arrays of each SEAJointState."""
    joints = arm_joint_names("left")
    states = joint_states(60, names=joints)
    rng = np.random.default_rng(2)
    messages = []
    for k, t in enumerate(states["stamps_ns"]):
        text = echo_message(int(t), joints, *(rng.normal(size=7) for _ in range(3)))  # the commanded_* arrays
        for f in ("position", "velocity", "effort"):
            text = text.replace(f"\n{f}: ", f"\ncommanded_{f}: ")
        actual = "\n".join(f"actual_{f}: [{', '.join(repr(float(v)) for v in states[f][k])}]" for f in ("position", "velocity", "effort"))
        messages.append(text.replace("\n---", f"\n{actual}\ngravity_model_effort: [{', '.join(['0.5'] * 7)}]\nhystState: 0\n---"))
    path = tmp_path / "sea.txt"
    path.write_text("\n".join(messages) + "\n")
    rec = read_recording(path, note=None)
    assert rec.side == "left"
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])
    for got, want in zip((rec.q, rec.qd, rec.effort), (states["position"], states["velocity"], states["effort"])):
        np.testing.assert_array_equal(got, want)


DUMPS_WITHOUT_VELOCITIES = ("rostopic", "bagpy", "rosbag_to_csv", "echo", "ros2 echo")


def write_without_velocities(path: Path, states: dict, dump: str) -> Path:
    """A dump of ``states`` as a driver that leaves every message's velocity array empty gives it."""
    stamps, position, effort = states["stamps_ns"], states["position"], states["effort"]
    messages = [(int(t), int(t), BAXTER_JOINTS, position[k], [], effort[k]) for k, t in enumerate(stamps)]
    if dump == "rostopic":
        rows = [rostopic_plot_row(int(t), int(t), BAXTER_JOINTS, position[k], effort[k]) for k, t in enumerate(stamps)]
        path.write_text("\n".join([rostopic_plot_header(BAXTER_JOINTS, ("position", "effort")), *rows]) + "\n")
    elif dump == "bagpy":
        write_bagpy_table(path, messages)
    elif dump == "rosbag_to_csv":
        write_rosbag_to_csv_table(path, messages)
    else:
        path.write_text("\n".join(echo_message(*m[1:], ros2=dump == "ros2 echo") for m in messages) + "\n")
    return path


@pytest.mark.parametrize("dump", DUMPS_WITHOUT_VELOCITIES)
def test_without_velocities_q_dot_is_the_central_difference_of_q(tmp_path: Path, dump: str) -> None:
    """Every message's velocity empty, in each dump's way (rostopic's and bagpy's headers without
    velocity fields, rosbag_to_csv's ``()``, echo's ``[]``): q and effort to the last bit, q̇ numpy's
    central difference of q over the stamps, said in a note; as a bag's are read."""
    states = joint_states(N)
    path = write_without_velocities(tmp_path / "run.csv", states, dump)
    notes: list[str] = []
    rec = read_recording(path, note=notes.append)
    assert rec.side == "right" and notes == [f"{path}: no message in this file gives velocities; q̇ is the central difference of q over the stamps"]
    q, _, effort = columns(states, arm_joint_names("right"))
    np.testing.assert_array_equal(rec.stamps_ns, states["stamps_ns"])
    np.testing.assert_array_equal(rec.q, q)
    np.testing.assert_array_equal(rec.effort, effort)
    np.testing.assert_allclose(rec.qd, np.gradient(q, (states["stamps_ns"] - states["stamps_ns"][0]) * 1e-9, axis=0), rtol=1e-12, atol=1e-12)


def test_where_some_messages_give_velocities_those_are_read_and_the_rest_counted(tmp_path: Path) -> None:
    """A rostopic table whose first message (which names the header) gave no velocities, the others
    all three: the messages with velocities read exactly, the first skipped as malformed. And an echoed
    message without efforts but with velocities is never read as position and effort."""
    states = joint_states(N)
    head = rostopic_plot_header(BAXTER_JOINTS, ("position", "effort"))
    first = rostopic_plot_row(int(states["stamps_ns"][0]) - 10**7, int(states["stamps_ns"][0]) - 10**7, BAXTER_JOINTS, states["position"][0], states["effort"][0])
    full = write_rostopic_table(tmp_path / "full.csv", states).read_text().splitlines()[1:]
    path = tmp_path / "run.csv"
    path.write_text("\n".join([head, first, *full]) + "\n")
    notes: list[str] = []
    assert_arm(read_recording(path, note=notes.append), states, "right")
    assert notes == [f"WARNING: {path}: 1 of {N + 1} messages in this file skipped as malformed (1 {SkipReason.ARRAY_LENGTH.value})"]
    no_effort = tmp_path / "no_effort.txt"
    no_effort.write_text("\n".join(echo_message(int(t), BAXTER_JOINTS, states["position"][k], states["velocity"][k], []) for k, t in enumerate(states["stamps_ns"])) + "\n")
    with pytest.raises(RecordingFileError, match=r"no message in this file has position, velocity and effort \(or, where none gives velocities, position and effort\)"):
        read_recording(no_effort, note=None)
