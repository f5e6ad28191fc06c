"""JointState and SEAJointState messages in serialized form, decoded and encoded in bulk.

Bags hold messages as bytes: ROS 1 serialization in ``.bag`` files, CDR in ROS 2 bags. Decoding
hundreds of thousands of them one by one through a typestore costs ~30 µs each, so messages that
share a layout (same size, joint names and array lengths: the normal case, one publisher) are
stacked into an (n, size) byte matrix and their fields read as numpy columns. Messages of any other
layout go through the typestore, one by one. Both paths give the same numbers (tested).

Both message types start alike — ``Header header``, ``string[] name``, then float64 arrays — so one
layout parser serves them; :data:`JOINT_ARRAYS` says which arrays hold q, q̇ and effort.

``baxter_core_msgs/SEAJointState`` (Baxter's ROS 1 message) is registered in the typestores from
its definition text below, so bags carrying it read with no baxter_core_msgs installed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

__all__ = [
    "JOINT_ARRAYS",
    "JOINT_STATE",
    "SEA_JOINT_STATE",
    "SEA_JOINT_STATE_MSG",
    "JointStateBlock",
    "MessageLayout",
    "decode_joint_states",
    "encode_joint_states",
    "parse_layout",
    "true_runs",
    "typestore",
]

JOINT_STATE = "sensor_msgs/msg/JointState"
SEA_JOINT_STATE = "baxter_core_msgs/msg/SEAJointState"

#: Definition of baxter_core_msgs/SEAJointState, copied from baxter_common (baxter_core_msgs/msg).
SEA_JOINT_STATE_MSG = """\
# This is a message that holds data to describe the state of a set of torque controlled joints.
Header header

string[] name
float64[] commanded_position
float64[] commanded_velocity
float64[] commanded_effort
float64[] actual_position
float64[] actual_velocity
float64[] actual_effort
float64[] gravity_model_effort
float64[] hysteresis_model_effort
float64[] crosstalk_model_effort
float64   hystState
"""


@dataclass(frozen=True)
class _Arrays:
    """Where a message type keeps q, q̇, effort: field names and their index among its float64[]."""

    fields: tuple[str, str, str]
    index: tuple[int, int, int]
    count: int


#: Message type -> the float64[] fields read as position (rad), velocity (rad/s), effort (N·m).
JOINT_ARRAYS = {
    JOINT_STATE: _Arrays(("position", "velocity", "effort"), (0, 1, 2), 3),
    SEA_JOINT_STATE: _Arrays(("actual_position", "actual_velocity", "actual_effort"), (3, 4, 5), 9),
}


@cache
def typestore(ros1: bool) -> Typestore:
    """ROS 1 Noetic (``ros1=True``) or ROS 2 Jazzy types, with baxter_core_msgs/SEAJointState added."""
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(SEA_JOINT_STATE_MSG, SEA_JOINT_STATE))
    return store


@dataclass(frozen=True)
class JointStateBlock:
    """Messages of one topic that name the same joints, one row per message.

    index (n,): positions of these messages in the decoded sequence; names (m,); stamps_ns (n,)
    int64 header stamps; position (n, m) rad, velocity (n, m) rad/s, effort (n, m) N·m, each None
    when the messages leave that array empty (or give it a length other than m).
    """

    index: np.ndarray
    names: tuple[str, ...]
    stamps_ns: np.ndarray
    position: np.ndarray | None
    velocity: np.ndarray | None
    effort: np.ndarray | None


@dataclass(frozen=True)
class MessageLayout:
    """Byte layout of one serialized message: where the stamp, names and float64 arrays lie."""

    size: int
    names: tuple[str, ...]
    endian: str  # "<" or ">"
    sec_dtype: str  # "i4" (CDR) or "u4" (ROS 1)
    stamp_offset: int  # sec, then nanosec (both 4 bytes)
    arrays: tuple[tuple[int, int], ...]  # (data offset, length) of each float64[]
    structure: np.ndarray  # (size,) bool: bytes every message of this layout has in common


def parse_layout(raw: bytes, ros1: bool, n_arrays: int) -> MessageLayout:
    """The layout of one message (Header, string[] name, n_arrays float64[], anything after).

    ROS 1: no alignment, Header = seq, secs, nsecs, frame_id. CDR: a 4-byte encapsulation header,
    then fields aligned to their size relative to its end; float64 data aligned to 8 only when the
    array is not empty. Raises ValueError on anything else.
    """
    size = len(raw)
    structure = np.ones(size, dtype=bool)
    if ros1:
        endian, base, sec_dtype = "<", 0, "u4"
        structure[0:4] = False  # seq
    else:
        if size < 4 or raw[0] != 0 or raw[1] not in (0, 1):
            raise ValueError("not plain CDR (encapsulation header)")
        endian, base, sec_dtype = ("<" if raw[1] == 1 else ">"), 4, "i4"
    stamp_offset = base + (4 if ros1 else 0)
    structure[stamp_offset : stamp_offset + 8] = False
    pos = stamp_offset + 8
    u32 = np.dtype(endian + "u4")

    def align(pos: int, n: int) -> int:
        return pos if ros1 else base + -(-(pos - base) // n) * n

    def read_u32(pos: int) -> tuple[int, int]:
        pos = align(pos, 4)
        if pos + 4 > size:
            raise ValueError("message ends early")
        return int(np.frombuffer(raw, u32, 1, pos)[0]), pos + 4

    def read_string(pos: int) -> tuple[str, int]:
        length, pos = read_u32(pos)
        text = raw[pos : pos + length]
        if len(text) != length:
            raise ValueError("message ends early")
        return text.rstrip(b"\0").decode("utf-8"), pos + length

    _, pos = read_string(pos)  # frame_id
    n_names, pos = read_u32(pos)
    names = []
    for _ in range(n_names):
        name, pos = read_string(pos)
        names.append(name)
    arrays = []
    for _ in range(n_arrays):
        length, pos = read_u32(pos)
        if length:
            pos = align(pos, 8)
        arrays.append((pos, length))
        structure[pos : pos + 8 * length] = False
        pos += 8 * length
    if pos > size:
        raise ValueError("message ends early")
    structure[pos:] = False  # fields after the arrays (SEAJointState.hystState)
    return MessageLayout(size, tuple(names), endian, sec_dtype, stamp_offset, tuple(arrays), structure)


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of every run of True in a 1-D bool mask (slices compare faster than indices)."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def _column(rows: np.ndarray, offset: int, dtype: str, count: int = 1) -> np.ndarray:
    """(n, count) values of ``dtype`` starting at byte ``offset`` of every row of (n, size) bytes."""
    item = np.dtype(dtype).itemsize
    return rows[:, offset : offset + item * count].copy().view(dtype)


def _decode_rows(rows: np.ndarray, layout: MessageLayout, arrays: _Arrays) -> tuple[np.ndarray, list]:
    """Stamps (n,) ns and the three arrays (n, m) or None of messages of one layout."""
    sec = _column(rows, layout.stamp_offset, layout.endian + layout.sec_dtype)[:, 0]
    nanosec = _column(rows, layout.stamp_offset + 4, layout.endian + "u4")[:, 0]
    stamps_ns = sec.astype(np.int64) * 1_000_000_000 + nanosec.astype(np.int64)
    m = len(layout.names)
    values = []
    for k in arrays.index:
        offset, length = layout.arrays[k]
        values.append(_column(rows, offset, layout.endian + "f8", m).astype(np.float64) if length == m else None)
    return stamps_ns, values


def decode_joint_states(
    raws: Sequence[bytes], msgtype: str, ros1: bool, deserialize: Callable[[bytes], object]
) -> list[JointStateBlock]:
    """Decode serialized messages of ``msgtype`` (a key of :data:`JOINT_ARRAYS`) into blocks.

    raws: the messages of one topic, in bag order; ros1: ROS 1 serialization, else CDR;
    deserialize: the typestore's deserializer for messages whose layout is not shared (slow path).
    Every message lands in exactly one block; ``block.index`` gives its position in ``raws``.
    """
    arrays = JOINT_ARRAYS[msgtype]
    sizes = np.fromiter(map(len, raws), dtype=np.int64, count=len(raws))
    blocks: list[JointStateBlock] = []
    irregular: list[int] = []
    for size in np.unique(sizes):
        index = np.flatnonzero(sizes == size)
        try:
            layout = parse_layout(raws[index[0]], ros1, arrays.count)
        except (ValueError, UnicodeDecodeError):
            irregular.extend(index.tolist())
            continue
        rows = np.frombuffer(b"".join([raws[i] for i in index]), dtype=np.uint8).reshape(len(index), size)
        shared = np.ones(len(index), dtype=bool)
        for start, stop in true_runs(layout.structure):
            shared &= (rows[:, start:stop] == rows[0, start:stop]).all(axis=1)
        if not shared.all():
            irregular.extend(index[~shared].tolist())
            rows, index = rows[shared], index[shared]
        stamps_ns, (position, velocity, effort) = _decode_rows(rows, layout, arrays)
        blocks.append(JointStateBlock(index, layout.names, stamps_ns, position, velocity, effort))
    blocks.extend(_decode_one_by_one(raws, sorted(irregular), arrays, deserialize))
    return blocks


def _decode_one_by_one(
    raws: Sequence[bytes], index: list[int], arrays: _Arrays, deserialize: Callable[[bytes], object]
) -> list[JointStateBlock]:
    """The slow path: typestore-deserialize each message, then group them by joint names."""
    groups: dict[tuple, list] = {}
    for i in index:
        msg = deserialize(raws[i])
        names = tuple(msg.name)
        stamp = msg.header.stamp
        values = [np.asarray(getattr(msg, f), dtype=np.float64) for f in arrays.fields]
        present = tuple(len(v) == len(names) for v in values)
        groups.setdefault((names, present), []).append((i, stamp.sec * 1_000_000_000 + stamp.nanosec, values))
    blocks = []
    for (names, present), items in groups.items():
        stacked = [
            np.array([item[2][k] for item in items]).reshape(len(items), len(names)) if present[k] else None
            for k in range(3)
        ]
        blocks.append(
            JointStateBlock(
                np.array([item[0] for item in items], dtype=np.int64),
                names,
                np.array([item[1] for item in items], dtype=np.int64),
                *stacked,
            )
        )
    return blocks


def encode_joint_states(
    stamps_ns: np.ndarray,
    names: Sequence[str],
    position: np.ndarray | None,
    velocity: np.ndarray | None,
    effort: np.ndarray | None,
) -> np.ndarray:
    """CDR bytes of sensor_msgs/msg/JointState messages, (n, size) uint8, one row per message.

    stamps_ns (n,) header stamps in ns; names (m,); position, velocity, effort (n, m) or None for an
    empty array. frame_id is empty. Rows are what a ROS 2 publisher or bag carries.
    """
    store = typestore(ros1=False)
    types = store.types
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    n, m = len(stamps_ns), len(names)
    columns = [None if a is None else np.asarray(a, dtype="<f8").reshape(n, m) for a in (position, velocity, effort)]
    template_msg = types[JOINT_STATE](
        header=types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=""),
        name=list(names),
        **{f: np.zeros(0 if c is None else m) for f, c in zip(JOINT_ARRAYS[JOINT_STATE].fields, columns)},
    )
    template = np.frombuffer(bytes(store.serialize_cdr(template_msg, JOINT_STATE)), dtype=np.uint8)
    layout = parse_layout(template.tobytes(), ros1=False, n_arrays=3)
    rows = np.empty((n, layout.size), dtype=np.uint8)
    rows[:] = template
    sec, nanosec = np.divmod(stamps_ns, 1_000_000_000)
    rows[:, layout.stamp_offset : layout.stamp_offset + 4] = sec.astype("<i4").view(np.uint8).reshape(n, 4)
    rows[:, layout.stamp_offset + 4 : layout.stamp_offset + 8] = nanosec.astype("<u4").view(np.uint8).reshape(n, 4)
    for (offset, _), column in zip(layout.arrays, columns):
        if column is not None:
            rows[:, offset : offset + 8 * m] = np.ascontiguousarray(column).view(np.uint8).reshape(n, 8 * m)
    return rows
