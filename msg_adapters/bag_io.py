"""ROS 1 and ROS 2 bags in and out, through rosbags.

Reading: a ROS 1 ``.bag`` file, a ROS 2 bag directory (sqlite3 or mcap) or a single ``.mcap`` /
``.db3`` file. Joint states are ``sensor_msgs/JointState`` or ``baxter_core_msgs/SEAJointState``
(its ``actual_*`` arrays) on any topic, default ``/robot/joint_states``. Joints are matched by name:
a message may carry any superset of the arm's joints in any order; messages lacking one of them,
or an empty velocity/effort array, are skipped and counted in one warning line per file, and so are
samples no real Baxter gives (:mod:`baxter_dynamics_ros.core.plausibility`). Sample times are the header stamps (the bag's
receive times when every header stamp is zero).

Writing: JointState topics sharing their stamps as a ROS 2 bag in one mcap file
(:mod:`msg_adapters.mcap_writer`); a processed recording as the live node's topics
(:data:`RESULT_TOPICS`: sensor_msgs/msg/JointState with the arm's 7 joints, header stamp of the
input sample, position and velocity copied from it, effort = the torque) plus the arm's input
joint states on the input topic, so that the output plays back like the input.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader

from baxter_dynamics_ros.core.joints import ARM_SIDES, arm_joint_names
from baxter_dynamics_ros.core.plausibility import plausible_recording
from baxter_dynamics_ros.core.recording import (
    JUMP_GAP_PERIODS, MAX_BACK_SHARE, OtherArm, ProcessedRecording, Recording, detect_arm, require_activity, summed_range_rad, taken_apart,
    velocity_from_positions,
)  # fmt: skip
from baxter_dynamics_ros.core.samples import SkipReason
from baxter_dynamics_ros.errors import RecordingFileError

from .mcap_writer import write_mcap
from .serialized_joint_states import (
    JOINT_ARRAYS,
    JOINT_STATE,
    JointStateBlock,
    decode_joint_states,
    encode_joint_states,
    typestore,
)

__all__ = [
    "DEFAULT_TOPIC",
    "RESULT_TOPICS",
    "TopicData",
    "joint_state_recording",
    "read_bag_recording",
    "read_joint_state_messages",
    "write_joint_state_bag",
    "write_processed_bag",
]

DEFAULT_TOPIC = "/robot/joint_states"
#: ProcessedRecording field -> output topic, as the live node publishes them.
RESULT_TOPICS = {
    "gravity": "/baxter_dynamics/gravity",
    "inverse_dynamics": "/baxter_dynamics/inverse_dynamics",
    "residual": "/baxter_dynamics/residual",
}
#: How often (in messages) reading reports progress.
PROGRESS_EVERY = 20_000
#: Messages of a topic decoded at a time while reading, so that a bag's raw bytes are never all held
#: at once (an hour of 21-joint states is 350 MB of CDR; decoded in one go it peaked at 0.96 GB).
DECODE_EVERY = 8192

Progress = Callable[[int, int], None]  # (messages done, messages in total)


@dataclass(frozen=True)
class TopicData:
    """The messages of one topic: their receive times (n,) ns, and the blocks they decode into."""

    topic: str
    log_times_ns: np.ndarray
    blocks: list[JointStateBlock]


def _is_ros1(path: Path) -> bool:
    return path.suffix == ".bag"


def _read_topics(path: Path, topics: Sequence[str] | None, progress: Progress | None, *, only_other: bool = False) -> list[TopicData]:
    """Decode every JointState-like message on ``topics`` (None: every such topic) of a bag;
    only_other: a bag without the one topic asked for is read on its only joint-state topic."""
    if not path.exists():
        raise RecordingFileError(f"{path}: no such file or directory")
    ros1 = _is_ros1(path)
    # rosbags raises many exception types on damaged files (its own errors, struct, sqlite3, zstd,
    # EOF, Unicode...): all of them mean the same thing to the user, so they are translated here.
    try:
        with AnyReader([path], default_typestore=typestore(ros1)) as reader:
            connections = _select_connections(path, reader.connections, topics, only_other)
            msgtypes = {c.topic: c.msgtype for c in connections}
            total = sum(c.msgcount for c in connections)
            deserialize = reader.typestore.deserialize_ros1 if ros1 else reader.typestore.deserialize_cdr
            decoders = {topic: _decoder(path, deserialize, msgtype) for topic, msgtype in msgtypes.items()}
            pending: dict[str, list[bytes]] = {topic: [] for topic in msgtypes}
            blocks: dict[str, list[JointStateBlock]] = {topic: [] for topic in msgtypes}
            log_times: dict[str, list[int]] = {topic: [] for topic in msgtypes}

            def flush(topic: str) -> None:
                raws = pending[topic]
                first = len(log_times[topic]) - len(raws)  # position of raws[0] among the topic's messages
                for block in decode_joint_states(raws, msgtypes[topic], ros1, decoders[topic]):
                    blocks[topic].append(replace(block, index=block.index + first))
                pending[topic] = []

            for done, (connection, log_time_ns, raw) in enumerate(reader.messages(connections=connections), 1):
                pending[connection.topic].append(raw)
                log_times[connection.topic].append(log_time_ns)
                if len(pending[connection.topic]) == DECODE_EVERY:
                    flush(connection.topic)
                if progress is not None and done % PROGRESS_EVERY == 0:
                    progress(done, total)
            for topic in msgtypes:
                flush(topic)
    except RecordingFileError:
        raise
    except Exception as err:  # noqa: BLE001 - see the comment above
        raise _corrupt(path, err) from err
    if progress is not None:
        progress(total, total)
    return [TopicData(topic, np.array(log_times[topic], dtype=np.int64), blocks[topic]) for topic in msgtypes]


def _decoder(path: Path, deserialize: Callable[[bytes, str], object], msgtype: str) -> Callable[[bytes], object]:
    """The typestore's deserializer of one message type; a damaged message is this file's error."""

    def decode(raw: bytes) -> object:
        try:
            return deserialize(raw, msgtype)
        except Exception as err:  # noqa: BLE001 - a damaged message, whatever the error type
            raise _corrupt(path, err) from err

    return decode


def _corrupt(path: Path, err: Exception) -> RecordingFileError:
    return RecordingFileError(f"{path}: cannot read the bag, it is corrupt or truncated ({type(err).__name__}: {err})")


def _select_connections(path: Path, connections: list, topics: Sequence[str] | None, only_other: bool = False) -> list:
    """The connections of the requested topics, each checked to carry a joint-state type; where
    ``only_other`` and the bag lacks the one topic asked for, those of its only joint-state topic."""
    by_topic = {c.topic: c.msgtype for c in connections}
    usable = sorted(t for t, m in by_topic.items() if m in JOINT_ARRAYS)
    if only_other and topics is not None and len(topics) == 1 and topics[0] not in by_topic and len(usable) == 1:
        topics = usable
    if topics is None:
        topics = usable
        if not topics:
            raise RecordingFileError(f"{path}: no JointState or SEAJointState topic in this bag")
    for topic in topics:
        if topic not in by_topic:
            raise RecordingFileError(
                f"{path}: no topic {topic}; joint-state topics in this bag: {', '.join(usable) or 'none'}"
            )
        if by_topic[topic] not in JOINT_ARRAYS:
            raise RecordingFileError(
                f"{path}: topic {topic} carries {by_topic[topic]}, not sensor_msgs/JointState or "
                f"baxter_core_msgs/SEAJointState; joint-state topics: {', '.join(usable) or 'none'}"
            )
    return [c for c in connections if c.topic in topics]


def read_bag_recording(
    path: str | os.PathLike[str],
    *,
    topic: str = DEFAULT_TOPIC,
    arm: str | None = None,
    progress: Progress | None = None,
    note: Callable[[str], None] | None = None,
) -> Recording:
    """The recording of one arm from the joint states on ``topic`` of a bag (the default, where
    the bag lacks it, on the bag's only joint-state topic, said through ``note``).

    arm: "right" or "left"; None detects it from the joint names (when both arms are recorded,
    the one that moves more; see :func:`~baxter_dynamics_ros.core.recording.detect_arm`). Refuses an
    arm that does not move or has no effort (:func:`~baxter_dynamics_ros.core.recording.require_activity`).
    progress: called as progress(messages read, total) while reading. Messages that are not a sample
    of the arm (one of its joints missing, an array without one entry per name) and samples no real
    Baxter can give (:func:`~baxter_dynamics_ros.core.plausibility.plausible_recording`) are left
    out, each kind counted in one line said through ``note``.
    """
    path = Path(path)
    (data,) = _read_topics(path, [topic], progress, only_other=topic == DEFAULT_TOPIC)
    if data.topic != topic and note is not None:
        note(f"{path}: no topic {topic}; its only joint-state topic, {data.topic}, read")
    return joint_state_recording(path, data, arm=arm, note=note, where=f"on {data.topic}")


def joint_state_recording(
    path: Path, data: TopicData, *, arm: str | None, note: Callable[[str], None] | None, where: str
) -> Recording:
    """The recording of one arm from the decoded joint states of one topic (``read_bag_recording``).

    Where no message gives velocities (a driver that leaves the array empty), q̇ is the central
    difference of q over the stamps (:func:`~baxter_dynamics_ros.core.recording.velocity_from_positions`);
    where the stamps go back (a clock set back, recordings laid end to end), the recording is taken
    apart there (:func:`~baxter_dynamics_ros.core.recording.taken_apart`); each said through
    ``note``. where: where the messages were, for the user ("on /robot/joint_states").
    """
    complete = [b for b in data.blocks if b.position is not None and b.velocity is not None and b.effort is not None]
    derived = not complete  # q̇ from q
    if derived:
        complete = [b for b in data.blocks if b.position is not None and b.effort is not None]
    if not complete:
        raise RecordingFileError(
            f"{path}: no message {where} has position, velocity and effort (or, where none gives velocities, position and effort), one entry per name"
            f" ({sum(len(b.index) for b in data.blocks)} messages; joint names found: {_names_found(data.blocks)})"
        )
    if arm is None:
        names = {name for b in complete for name in b.names}
        arm = detect_arm(sorted(names), {side: _q_range(complete, side) for side in ARM_SIDES})
    joints = arm_joint_names(arm)
    chosen = [b for b in complete if set(joints) <= set(b.names)]
    if not chosen:
        raise RecordingFileError(
            f"{path}: no message {where} has position, {'' if derived else 'velocity and '}effort of all 7 {arm} arm joints "
            f"({', '.join(joints)}); joint names found: {_names_found(data.blocks)}"
        )
    index = np.concatenate([b.index for b in chosen])
    order = np.argsort(index, kind="stable")
    stamps_ns = np.concatenate([b.stamps_ns for b in chosen])[order]
    if not stamps_ns.any():
        stamps_ns = data.log_times_ns[index[order]]
    stamps_ns, back = taken_apart(stamps_ns)
    if back.size > MAX_BACK_SHARE * (len(stamps_ns) - 1):
        raise RecordingFileError(f"{path}: the stamps of the messages {where} go back at {back.size} of {len(stamps_ns) - 1} steps: no time series")
    if back.size and note is not None:
        note(
            f"{path}: the stamps of the messages {where} go back at {back.size} message(s) (first after sample {back[0]}): a clock set back, "
            f"or recordings laid end to end; taken apart there (gaps of unknown length, {JUMP_GAP_PERIODS} samples in the stamps)"
        )
    q, effort = (np.concatenate([_columns(getattr(b, f), b.names, joints) for b in chosen])[order] for f in ("position", "effort"))
    if derived:
        qd = velocity_from_positions(stamps_ns, q)
        if note is not None:
            note(f"{path}: no message {where} gives velocities; q̇ is the central difference of q over the stamps")
    else:
        qd = np.concatenate([_columns(b.velocity, b.names, joints) for b in chosen])[order]
    malformed = _malformed(data.blocks, joints, where, velocity=not derived)
    if malformed is not None and note is not None:
        note(f"WARNING: {path}: {malformed}")
    recording = plausible_recording(str(path), arm, stamps_ns, q, qd, effort, note)
    others = {side: _other_arm(complete, side) for side in ARM_SIDES if side != arm}
    require_activity(arm, recording.q, recording.effort, {side: o for side, o in others.items() if o is not None})
    return recording


def _names_found(blocks: list[JointStateBlock]) -> str:
    """Every joint name the messages give, sorted, for an error message ("none" if none)."""
    return ", ".join(sorted({name for b in blocks for name in b.names})) or "none"


def _malformed(blocks: list[JointStateBlock], joints: Sequence[str], where: str, *, velocity: bool = True) -> str | None:
    """What the messages that are no sample of the arm (``joints``) were, in words; None if none.

    The causes are the node's (:class:`~baxter_dynamics_ros.core.samples.SkipReason`): one of the
    arm's joints missing from the names (or named twice), a position, velocity (where ``velocity``:
    the messages give them) or effort array not of one entry per name (an empty one included: the
    offline methods need all three)."""
    total = sum(len(b.index) for b in blocks)
    missing = sum(len(b.index) for b in blocks if not set(joints) <= set(b.names) or len(set(b.names)) != len(b.names))
    length = sum(
        len(b.index) for b in blocks
        if set(joints) <= set(b.names) and len(set(b.names)) == len(b.names)
        and (b.position is None or (velocity and b.velocity is None) or b.effort is None)
    )
    if not missing + length:
        return None
    causes = [f"{missing} {SkipReason.MISSING_JOINT.value}"] * bool(missing) + [f"{length} {SkipReason.ARRAY_LENGTH.value}"] * bool(length)
    return f"{missing + length} of {total} messages {where} skipped as malformed ({', '.join(causes)})"


def _other_arm(blocks: list[JointStateBlock], side: str) -> OtherArm | None:
    """The side's angles and efforts in the messages that carry its every joint (None if none do)."""
    joints = arm_joint_names(side)
    full = [b for b in blocks if set(joints) <= set(b.names)]
    if not full:
        return None
    return OtherArm(*(np.concatenate([_columns(getattr(b, f), b.names, joints) for b in full]) for f in ("position", "effort")))


def _columns(values: np.ndarray, names: tuple[str, ...], joints: Sequence[str]) -> np.ndarray:
    """The columns of values (n, m) named ``joints`` (7,), in that order: (n, 7)."""
    where = {name: k for k, name in enumerate(names)}
    return values[:, [where[j] for j in joints]]


def _q_range(blocks: list[JointStateBlock], side: str) -> float:
    """Summed range (max − min) of the side's joint angles over the blocks that carry them, rad."""
    joints = arm_joint_names(side)
    q = [_columns(b.position, b.names, joints) for b in blocks if set(joints) <= set(b.names)]
    if not q:
        return 0.0
    return summed_range_rad(np.concatenate(q))


def read_joint_state_messages(
    path: str | os.PathLike[str], topics: Sequence[str] | None = None, progress: Progress | None = None
) -> list[tuple[int, str, bytes]]:
    """Every joint-state message of a bag as ROS 2 ``sensor_msgs/msg/JointState`` CDR bytes.

    Returns (receive time ns, topic, bytes) sorted by receive time, for playback. topics: None for
    every JointState / SEAJointState topic. SEAJointState becomes JointState with its actual_*
    arrays; frame_id is dropped.
    """
    messages: list[tuple[int, str, bytes]] = []
    for data in _read_topics(Path(path), topics, progress):
        for block in data.blocks:
            rows = encode_joint_states(block.stamps_ns, block.names, block.position, block.velocity, block.effort)
            times = data.log_times_ns[block.index]
            messages.extend(zip(times.tolist(), [data.topic] * len(rows), map(bytes, rows)))
    messages.sort(key=lambda m: m[0])
    return messages


def write_joint_state_bag(
    path: str | os.PathLike[str],
    stamps_ns: np.ndarray,
    topics: dict[str, tuple[Sequence[str], np.ndarray | None, np.ndarray | None, np.ndarray | None]],
) -> None:
    """Write sensor_msgs/msg/JointState topics as a ROS 2 bag in one mcap file at ``path`` (new).

    stamps_ns (N,) strictly increasing: header stamp and log time of sample k on every topic;
    topics: {topic: (names (m,), position, velocity, effort)}, arrays (N, m) or None for empty.
    """
    definition, _ = typestore(ros1=False).generate_msgdef(JOINT_STATE, ros_version=2)
    write_mcap(
        path,
        [(topic, JOINT_STATE, definition) for topic in topics],
        stamps_ns,
        [encode_joint_states(stamps_ns, *arrays) for arrays in topics.values()],
    )


def write_processed_bag(path: str | os.PathLike[str], processed: ProcessedRecording, input_topic: str = DEFAULT_TOPIC) -> None:
    """Write a ROS 2 bag as one mcap file at ``path`` (which must not exist).

    Topics: ``input_topic`` (the arm's joint states as read) and :data:`RESULT_TOPICS`; every
    message is stamped and logged at its input sample's stamp.
    """
    rec = processed.recording
    efforts = {input_topic: rec.effort, **{RESULT_TOPICS[k]: v for k, v in processed.torques().items()}}
    write_joint_state_bag(
        path, rec.stamps_ns, {topic: (rec.joint_names, rec.q, rec.qd, effort) for topic, effort in efforts.items()}
    )
