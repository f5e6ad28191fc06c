"""Recordings for the tests, written the reference way: rosbags' own serializers and writers, message by
message (bags), numpy (the real recordings' whitespace tables); bags read back with rosbags' AnyReader.

The project reads them with its bulk decoder; writing them independently of it is what makes the
reading tests a cross-check. Nothing here is project code.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from repo_paths import SHARED

from baxter_dynamics_ros.core.joints import arm_joint_names
from msg_adapters.robot_joint_states import BAXTER_JOINT_NAMES as BAXTER_JOINTS  # the robot's names, in its order
from msg_adapters.serialized_joint_states import JOINT_STATE, SEA_JOINT_STATE, typestore

BAG_KINDS = ("ros1", "sqlite3", "mcap")
START_NS = 1_700_000_000_123_456_789
REAL_DATA = SHARED / "data" / "baxter_real"
REAL_FILES = sorted(REAL_DATA.glob("*.csv")) if REAL_DATA.is_dir() else []


def joint_states(n: int, names: Sequence[str] = BAXTER_JOINTS, rate_hz: float = 100.0, seed: int = 0) -> dict:
    """Smooth states of every joint in ``names`` at rate_hz: stamps_ns (n,), position/velocity/effort (n, m).

    Right-arm joints swing more than the others (so the right arm is the one detected), all within
    Baxter's joint limits (e1's range is −0.05 to 2.618 rad: it swings about 1.2 rad), at speeds
    and efforts a real Baxter gives.
    """
    rng = np.random.default_rng(seed)
    m = len(names)
    t = np.arange(n) / rate_hz
    freq = rng.uniform(0.2, 0.8, m)
    amp = np.where([name.startswith("right_") for name in names], 0.6, 0.05)
    phase = rng.uniform(0, 2 * np.pi, m)
    arg = 2 * np.pi * np.outer(t, freq) + phase
    return {
        "stamps_ns": START_NS + np.round(t * 1e9).astype(np.int64),
        "position": np.where([name.endswith("_e1") for name in names], 1.2, 0.0) + amp * np.sin(arg),
        "velocity": amp * 2 * np.pi * freq * np.cos(arg),
        "effort": rng.normal(0.0, 5.0, (n, m)),
    }


def message(kind: str, stamp_ns: int, names: Sequence[str], position, velocity, effort, *, sea: bool = False, frame_id: str = ""):
    """A JointState (or SEAJointState with the values in its actual_* arrays) of the kind's typestore."""
    store = typestore(ros1=kind == "ros1")
    types = store.types
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    header_fields = {"seq": 0} if kind == "ros1" else {}
    header = types["std_msgs/msg/Header"](
        **header_fields, stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
    )
    arrays = [np.asarray(a, dtype=np.float64) for a in (position, velocity, effort)]
    if not sea:
        return types[JOINT_STATE](header=header, name=list(names), position=arrays[0], velocity=arrays[1], effort=arrays[2])
    m = len(names)
    decoy = np.full(m, 99.0)  # commanded and model arrays: must not be read
    return types[SEA_JOINT_STATE](
        header=header,
        name=list(names),
        commanded_position=decoy,
        commanded_velocity=decoy,
        commanded_effort=decoy,
        actual_position=arrays[0],
        actual_velocity=arrays[1],
        actual_effort=arrays[2],
        gravity_model_effort=decoy,
        hysteresis_model_effort=decoy,
        crosstalk_model_effort=decoy,
        hystState=1.0,
    )


def bag_path(tmp_path: Path, kind: str, name: str = "recording") -> Path:
    """Where a bag of ``kind`` goes: ``name.bag`` (ROS 1) or a ROS 2 bag folder ``name``."""
    return tmp_path / (f"{name}.bag" if kind == "ros1" else name)


def write_bag(path: Path, kind: str, topics: dict[str, list[tuple[int, object]]]) -> Path:
    """Write {topic: [(receive time ns, message), ...]} as a bag of ``kind`` at path; returns path."""
    store = typestore(ros1=kind == "ros1")
    if kind == "ros1":
        writer = Writer1(path)
        serialize = store.serialize_ros1
    else:
        plugin = StoragePlugin.SQLITE3 if kind == "sqlite3" else StoragePlugin.MCAP
        writer = Writer2(path, version=9, storage_plugin=plugin)
        serialize = store.serialize_cdr
    with writer:
        for topic, items in topics.items():
            msgtype = items[0][1].__msgtype__
            connection = writer.add_connection(topic, msgtype, typestore=store)
            for receive_ns, msg in items:
                writer.write(connection, receive_ns, bytes(serialize(msg, msgtype)))
    return path


def write_reference_bag(path: Path, kind: str, states: dict, topic: str = "/robot/joint_states", **options) -> Path:
    """A bag with the ``states`` of :func:`joint_states` on one topic, received at their stamps."""
    names = options.pop("names", BAXTER_JOINTS)
    msgs = [
        (int(stamp), message(kind, stamp, names, p, v, e, **options))
        for stamp, p, v, e in zip(states["stamps_ns"], states["position"], states["velocity"], states["effort"])
    ]
    return write_bag(path, kind, {topic: msgs})


def bag_storage_file(path: Path) -> Path:
    """The file holding a bag's messages: the .bag itself or the storage file in a ROS 2 folder."""
    if path.is_file():
        return path
    (storage,) = [p for p in path.iterdir() if p.suffix in (".db3", ".mcap")]
    return storage


def columns(states: dict, joints: tuple[str, ...], names: tuple[str, ...] = BAXTER_JOINTS) -> list[np.ndarray]:
    """position, velocity, effort (n, 7) of ``joints`` from states over ``names``."""
    where = [names.index(j) for j in joints]
    return [states[k][:, where] for k in ("position", "velocity", "effort")]


def write_baxter_export(path: Path, states: dict, side: str = "left") -> Path:
    """The whitespace layout of the real recordings: ang_/vel_/torq_ columns, no time."""
    joints = arm_joint_names(side)
    q, qd, tau = columns(states, joints)
    header = " ".join(f"{p}_{j}" for p in ("ang", "vel", "torq") for j in joints)
    np.savetxt(path, np.hstack([q, qd, tau]), header=header, comments="", fmt="%.17g")
    return path


def read_output_bag(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """{topic: {stamps_ns, names, position, velocity, effort}} read with rosbags message by message."""
    from rosbags.highlevel import AnyReader

    out: dict[str, dict[str, list]] = {}
    with AnyReader([path]) as reader:
        assert {c.msgtype for c in reader.connections} == {JOINT_STATE}
        for connection, log_ns, raw in reader.messages():
            msg = reader.deserialize(raw, connection.msgtype)
            stamp_ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            assert log_ns == stamp_ns
            entry = out.setdefault(connection.topic, {k: [] for k in ("stamps_ns", "names", "position", "velocity", "effort")})
            entry["stamps_ns"].append(stamp_ns)
            entry["names"].append(tuple(msg.name))
            for field in ("position", "velocity", "effort"):
                entry[field].append(getattr(msg, field))
    return {topic: {k: np.array(v) for k, v in entry.items()} for topic, entry in out.items()}


def listing_of(folder: Path) -> list[str]:
    """The names in ``folder``, sorted."""
    return sorted(p.name for p in folder.iterdir())


def rostopic_plot_row(time_ns: int, stamp_ns: int, names: Sequence[str], *arrays, frame_id: str = "", seq: int = 0) -> str:
    """One JointState as ``rostopic echo -p`` prints it: time, seq, stamp (ns), frame_id, the names,
    then each non-empty array's values as Python's str() (an empty array prints nothing)."""
    fields = [str(int(time_ns)), str(seq), str(int(stamp_ns)), frame_id, *names]
    for values in arrays:
        fields += [str(float(v)) for v in values]
    return ",".join(fields)


def rostopic_plot_header(names: Sequence[str], arrays: Sequence[str] = ("position", "velocity", "effort"), scalars: Sequence[str] = ()) -> str:
    """The header line ``rostopic echo -p`` prints, named after a first message of ``names``, its
    non-empty float64[] ``arrays`` and its float64 ``scalars``, in the message's field order."""
    fields = ["%time", "field.header.seq", "field.header.stamp", "field.header.frame_id"]
    fields += [f"field.name{k}" for k in range(len(names))]
    for array in arrays:
        fields += [f"field.{array}{k}" for k in range(len(names))]
    return ",".join(fields + [f"field.{s}" for s in scalars])


def write_rostopic_table(path: Path, states: dict, names: Sequence[str] = BAXTER_JOINTS, receive_delay_ns: int = 0) -> Path:
    """``rostopic echo -p -b`` of a bag of ``states``: receive time = stamp + receive_delay_ns."""
    rows = [rostopic_plot_header(names)]
    for k, stamp in enumerate(states["stamps_ns"]):
        arrays = (states[f][k] for f in ("position", "velocity", "effort"))
        rows.append(rostopic_plot_row(int(stamp) + receive_delay_ns, int(stamp), names, *arrays, seq=k))
    path.write_text("\n".join(rows) + "\n")
    return path


def write_bagpy_table(path: Path, messages: Sequence[tuple], names_split: bool = False) -> Path:
    """A topic's JointStates as bagpy's ``bagreader.message_by_topic`` writes them (bagpy/bagreader.py:
    a csv.writer file; the header from the first message's fields, each tuple (a float64[] as genpy
    decodes it) spread over ``<field>_<k>`` columns; the names, a list, in one field as Python prints
    it, or spread like the arrays where ``names_split``). messages: (receive_ns, stamp_ns, names,
    position, velocity, effort[, frame_id]) each."""
    import csv

    def fields(message: tuple) -> list[tuple[str, object]]:
        receive_ns, stamp_ns, names, *arrays = message[:6]
        frame_id = message[6] if len(message) > 6 else ""
        secs, nsecs = divmod(int(stamp_ns), 1_000_000_000)
        out = [("Time", int(receive_ns) // 1_000_000_000 + int(receive_ns) % 1_000_000_000 * 1e-9), ("header.seq", 0),
               ("header.stamp.secs", secs), ("header.stamp.nsecs", nsecs), ("header.frame_id", frame_id)]
        out += [(f"name_{k}", n) for k, n in enumerate(names)] if names_split else [("name", list(names))]
        for field, values in zip(("position", "velocity", "effort"), arrays):
            out += [(f"{field}_{k}", float(v)) for k, v in enumerate(values)]
        return out

    with open(path, "w", newline="") as f:
        writer = csv.writer(f, delimiter=",")
        writer.writerow([name for name, _ in fields(messages[0])])
        for message in messages:
            writer.writerow([value for _, value in fields(message)])
    return path


def write_rosbag_to_csv_table(path: Path, messages: Sequence[tuple]) -> Path:
    """A topic's JointStates as the rosbag_to_csv tool (AtsushiSakai/rosbag_to_csv, rosbag_to_csv.py)
    writes them with its header: ``time`` then each field's path (``.header.seq``, …, ``.name``,
    ``.position``), from the first message; per message the receive time as local time
    (``datetime.fromtimestamp(t).strftime("%Y/%m/%d/%H:%M:%S.%f")``), then every field as Python's
    str() prints it, in double quotes where that holds a comma (a list of names, a tuple of floats as
    genpy decodes a float64[]). messages: (receive_ns, stamp_ns, names, position, velocity,
    effort[, frame_id]) each."""
    import datetime

    def text(value: object) -> str:
        printed = str(value)
        return f'"{printed}"' if "," in printed else printed

    with open(path, "w") as f:
        f.write("time,.header.seq,.header.stamp.secs,.header.stamp.nsecs,.header.frame_id,.name,.position,.velocity,.effort\n")
        for seq, (receive_ns, stamp_ns, names, *rest) in enumerate(messages):
            secs, nsecs = divmod(int(stamp_ns), 1_000_000_000)
            frame_id = rest[3] if len(rest) > 3 else ""
            values = [seq, secs, nsecs, frame_id, list(names), *(tuple(float(v) for v in a) for a in rest[:3])]
            when = datetime.datetime.fromtimestamp(receive_ns / 1e9).strftime("%Y/%m/%d/%H:%M:%S.%f")
            f.write(when + "".join("," + text(v) for v in values) + "\n")
    return path


def savemat_v73(path: Path, variables: dict, track_order: bool = False) -> Path:
    """A MATLAB v7.3 file as MATLAB writes one: a 512-byte user block holding the MAT header (text,
    version 0x0200, "IM"), then HDF5 with one dataset per variable, column-major (a MATLAB N×M matrix
    is a dataset of shape (M, N)), its class in the attribute MATLAB_class; complex numbers as a
    compound of real and imag; text as uint16 characters; a struct as a group. track_order: keep the
    variables' creation order in the file (HDF5 lists them by name otherwise)."""
    import h5py

    with h5py.File(path, "w", userblock_size=512, track_order=track_order) as f:
        for name, value in variables.items():
            if isinstance(value, dict):
                group = f.create_group(name)
                group.attrs["MATLAB_class"] = np.bytes_("struct")
                for key, inner in value.items():
                    group.create_dataset(key, data=np.atleast_2d(inner).T).attrs["MATLAB_class"] = np.bytes_("double")
                continue
            if isinstance(value, str):
                data, cls = np.array([[ord(c)] for c in value], dtype=np.uint16), "char"
            elif np.iscomplexobj(value):
                value = np.atleast_2d(value).T
                data = np.empty(value.shape, dtype=[("real", "<f8"), ("imag", "<f8")])
                data["real"], data["imag"] = value.real, value.imag
                cls = "double"
            else:
                data, cls = np.atleast_2d(value).T, {np.dtype(np.float32): "single", np.dtype(np.int32): "int32"}.get(np.asarray(value).dtype, "double")
            f.create_dataset(name, data=data).attrs["MATLAB_class"] = np.bytes_(cls)
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sun Dec  6 12:00:00 2026 HDF5 schema 1.00 .".ljust(116) + bytes(8) + b"\x00\x02IM"
    with open(path, "r+b") as f:
        f.write(header)
    return path


def echo_csv_line(stamp_ns: int, names: Sequence[str], *arrays, frame_id: str = "") -> str:
    """One JointState as ``ros2 topic echo --csv`` prints it (rosidl_runtime_py's message_to_csv:
    every field in the message's order joined by commas, arrays flattened, str() of each value, an
    empty array an empty field); arrays: position, velocity, effort."""
    secs, nsecs = divmod(int(stamp_ns), 1_000_000_000)
    return ",".join([str(secs), str(nsecs), frame_id, ",".join(names), *(",".join(str(float(v)) for v in a) for a in arrays)])


def echo_message(stamp_ns: int, names: Sequence[str], *arrays, ros2: bool = False, frame_id: str = "") -> str:
    """One JointState as ``rostopic echo`` (ROS 1: lists in brackets, ``secs``/``nsecs``) or ``ros2
    topic echo`` (one ``- item`` per line, ``sec``/``nanosec``, NaN as YAML's ``.nan``) prints it, its
    ``---`` line after it; arrays: position, velocity, effort (each may be empty: ``[]``)."""
    secs, nsecs = divmod(int(stamp_ns), 1_000_000_000)
    if ros2:
        lines = ["header:", "  stamp:", f"    sec: {secs}", f"    nanosec: {nsecs}", f"  frame_id: '{frame_id}'"]
    else:
        lines = ["header: ", "  seq: 0", "  stamp: ", f"    secs: {secs}", f"    nsecs: {nsecs}", f"  frame_id: '{frame_id}'"]
    fields = {"name": list(names)}
    fields |= {f: [".nan" if ros2 and np.isnan(v) else repr(float(v)) for v in values] for f, values in zip(("position", "velocity", "effort"), arrays)}
    for field, items in fields.items():
        if ros2 and items:
            lines += [f"{field}:", *(f"- {item}" for item in items)]
        else:
            lines += [f"{field}: [{', '.join(items)}]"]
    return "\n".join(lines + ["---"])
