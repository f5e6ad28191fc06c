"""Live ``sensor_msgs/JointState`` messages, serialized (CDR bytes), ↔ one arm's arrays; diagnostics.

The node subscribes and publishes serialized messages (``raw=True``, ``publish(bytes)``): turning
a 21-joint JointState into a Python message and three 7-joint answers back into C costs more than
all of the dynamics, so the bytes are read and written here directly, with the byte layouts of
:mod:`msg_adapters.serialized_joint_states`.

Input (:class:`JointStateReader`): any superset of the arm's joints in any order (a real Baxter
sends both arms, the head and the grippers, alphabetically), mapped by name. A publisher's
messages all share one layout (names, array lengths, frame_id); it is parsed when it changes, and
the name → index map rebuilt only when the names change. ``position`` must have one entry per
name; ``velocity`` and ``effort`` one per name or none (the sample then has no q̇ / no effort).
Each message is checked against the layout, and its stamp and the arm's values read, in one
compiled call (:func:`_read_sample`): live, each step of the node costs several µs as it starts on
cold caches, so fewer steps cost less.

Output (:class:`ArmJointStateWriter`): CDR bytes of JointState messages with the arm's 7 joint
names, the input's header stamp (frame_id empty: joint-space torques have no frame), position and
velocity of the sample, effort = a torque. :func:`diagnostic_array`: the /diagnostics message of
a :class:`~baxter_dynamics_ros.core.samples.HealthReport`.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
from numba import njit
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from baxter_dynamics_ros.core.samples import ArmSample, HealthReport, ModelTorques, SkipReason

from .serialized_joint_states import MessageLayout, parse_layout, true_runs

__all__ = ["ArmJointStateWriter", "JointStateReader", "diagnostic_array"]

N_ARRAYS = 3  # position, velocity, effort


@njit(cache=True, inline="always")
def _unsigned(raw: np.ndarray, offset: int, size: int, big_endian: bool) -> np.uint64:
    """The unsigned integer of ``size`` bytes at ``offset`` of raw (uint8), in the message's byte order."""
    bits = np.uint64(0)
    for b in range(size):
        byte = np.uint64(raw[offset + (size - 1 - b if big_endian else b)])
        bits |= byte << np.uint64(8 * b)
    return bits


@njit(cache=True)
def _read_sample(raw, template, shared, stamp_offset, big_endian, first, rows, values) -> tuple[bool, int]:
    """Whether raw (uint8) has the layout of template (its size and the bytes of every (start, stop)
    row of ``shared``), and if so the header stamp, ns, with values[k, j] = the float64 at
    first + 8 · rows[k, j] (rows (k, 7); k = 0 reads nothing). One compiled call per message."""
    if raw.size != template.size:
        return False, 0
    for r in range(shared.shape[0]):
        for i in range(shared[r, 0], shared[r, 1]):
            if raw[i] != template[i]:
                return False, 0
    sec = np.int64(np.int32(np.uint32(_unsigned(raw, stamp_offset, 4, big_endian))))
    nanosec = np.int64(_unsigned(raw, stamp_offset + 4, 4, big_endian))
    word = np.empty(1, dtype=np.uint64)
    as_float = word.view(np.float64)
    for k in range(rows.shape[0]):
        for j in range(rows.shape[1]):
            word[0] = _unsigned(raw, first + 8 * rows[k, j], 8, big_endian)
            values[k, j] = as_float[0]
    return True, sec * 1_000_000_000 + nanosec


class JointStateReader:
    """Reads one arm's sample out of serialized JointState messages, by joint name."""

    def __init__(self, joint_names: Sequence[str]) -> None:
        self.joint_names = tuple(joint_names)
        self._layout: MessageLayout | None = None
        self._template = np.zeros(0, dtype=np.uint8)  # the message the layout was parsed from
        self._shared = np.zeros((0, 2), dtype=np.intp)  # (start, stop) byte ranges every message of the layout shares
        self._big_endian = False
        self._index: np.ndarray | SkipReason = SkipReason.MISSING_JOINT
        self._gather: tuple[int, np.ndarray, bool, bool] | SkipReason = SkipReason.MISSING_JOINT
        self._no_rows = np.zeros((0, len(self.joint_names)), dtype=np.intp)
        self._first, self._rows = 0, self._no_rows  # what _read_sample gathers (nothing from a refused layout)

    def _learn_layout(self, raw: bytes) -> bool:
        """Parse a new layout; rebuild the index map if its names differ. False if unreadable."""
        try:
            layout = parse_layout(raw, ros1=False, n_arrays=N_ARRAYS)
        except (ValueError, UnicodeDecodeError):
            return False
        if self._layout is None or layout.names != self._layout.names:
            self._index = self.index_map(list(layout.names))
        self._layout, self._template = layout, np.frombuffer(raw, dtype=np.uint8)
        self._shared = np.array(true_runs(layout.structure), dtype=np.intp).reshape(-1, 2)
        self._big_endian = layout.endian == ">"
        gather = self._gather = self._gather_map(layout)
        self._first, self._rows = (0, self._no_rows) if isinstance(gather, SkipReason) else gather[:2]
        return True

    def _gather_map(self, layout: MessageLayout) -> tuple[int, np.ndarray, bool, bool] | SkipReason:
        """How :meth:`read` takes the arm's values of this layout in one step: (offset of the first
        float64 read, (k, 7) positions of the arm's q, then q̇ and effort if present, on the float64
        grid from there; q̇ present; effort present), or why no sample can be read."""
        index = self._index
        if isinstance(index, SkipReason):
            return index
        n = len(layout.names)
        (p, n_position), (v, n_velocity), (e, n_effort) = layout.arrays
        if n_position != n or n_velocity not in (0, n) or n_effort not in (0, n):
            return SkipReason.ARRAY_LENGTH
        # Every float64[]'s data is 8-aligned from the same base, so all lie on one float64 grid from p.
        offsets = [p] + [offset for offset, length in ((v, n_velocity), (e, n_effort)) if length]
        rows = np.array([(offset - p) // 8 for offset in offsets], dtype=np.intp)
        return p, np.ascontiguousarray(rows[:, None] + index[None, :]), n_velocity > 0, n_effort > 0

    def index_map(self, names: list[str]) -> np.ndarray | SkipReason:
        """(7,) positions of the arm's joints in ``names``; MISSING_JOINT if one is absent or repeated."""
        if any(names.count(joint) != 1 for joint in self.joint_names):
            return SkipReason.MISSING_JOINT
        return np.array([names.index(joint) for joint in self.joint_names], dtype=np.intp)

    def read(self, raw: bytes) -> ArmSample | SkipReason:
        """The arm's (7,) q, q̇ (None if velocity is empty), effort (None if empty) and stamp."""
        message = np.frombuffer(raw, dtype=np.uint8)
        values = np.empty((N_ARRAYS, len(self.joint_names)))
        same, stamp_ns = (False, 0) if self._layout is None else self._read(message, values)
        if not same:
            if not self._learn_layout(raw):
                return SkipReason.UNREADABLE
            _, stamp_ns = self._read(message, values)
        gather = self._gather
        if isinstance(gather, SkipReason):
            return gather
        _, _, velocity, effort = gather
        return ArmSample(stamp_ns, values[0], values[1] if velocity else None, values[1 + velocity] if effort else None)

    def _read(self, message: np.ndarray, values: np.ndarray) -> tuple[bool, int]:
        return _read_sample(
            message, self._template, self._shared, self._layout.stamp_offset, self._big_endian, self._first, self._rows, values
        )


class ArmJointStateWriter:
    """Serialized output JointStates of one arm: its 7 names, stamp, q, q̇ and one torque each."""

    def __init__(self, joint_names: Sequence[str]) -> None:
        zeros = [0.0] * len(joint_names)
        template = JointState(name=list(joint_names), position=zeros, velocity=zeros, effort=zeros)
        self._buffer = bytearray(serialize_message(template))  # the message being written
        layout = parse_layout(bytes(self._buffer), ros1=False, n_arrays=N_ARRAYS)
        self._stamp = struct.Struct(layout.endian + "iI")
        self._stamp_offset = layout.stamp_offset
        # Writable float64 views of the buffer's position, velocity and effort arrays, (7,) each.
        self._position, self._velocity, self._effort = (
            np.frombuffer(self._buffer, layout.endian + "f8", n, offset) for offset, n in layout.arrays
        )

    def messages(
        self, torques: ModelTorques, wanted: tuple[bool, bool, bool, bool] = (True, True, True, True)
    ) -> tuple[bytes | None, bytes | None, bytes | None, bytes | None]:
        """CDR bytes of the gravity, inverse-dynamics, residual and external-torque messages; None for
        one not ``wanted`` and, without effort, for the last two."""
        self._stamp.pack_into(self._buffer, self._stamp_offset, *divmod(torques.stamp_ns, 1_000_000_000))
        self._position[:] = torques.q
        self._velocity[:] = torques.qd
        out = []
        for torque, want in zip((torques.gravity, torques.tau, torques.residual, torques.external_torque), wanted):
            if torque is None or not want:
                out.append(None)
                continue
            self._effort[:] = torque
            out.append(bytes(self._buffer))
        return out[0], out[1], out[2], out[3]


def diagnostic_array(report: HealthReport, *, name: str, hardware_id: str, stamp: Time) -> DiagnosticArray:
    """/diagnostics message holding one status built from ``report``."""
    status = DiagnosticStatus(
        level=bytes([report.level.value]),
        name=name,
        message=report.message,
        hardware_id=hardware_id,
        values=[KeyValue(key=key, value=value) for key, value in report.values],
    )
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp
    return msg
