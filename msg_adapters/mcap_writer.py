"""A bulk writer of MCAP files holding a ROS 2 bag (profile ``ros2``, CDR messages).

Why not rosbags' Writer: it spends ~5 µs of Python per message, 7 s for the 1.44 million messages
(4 topics × 360,000 samples) of a one-hour recording processed at 100 Hz. Here every sample's
messages are laid out as one row of a byte matrix (numpy), a chunk is a block of rows, and its
message indexes are computed in bulk: the same file in well under a second of Python.

The file follows the MCAP specification (https://mcap.dev/spec): header, schemas and channels,
uncompressed chunks each followed by one message index per channel, data end, then a summary
(schemas, channels, chunk indexes, statistics) and the footer. It reads with rosbags,
``ros2 bag`` (rosbag2_storage_mcap) and Foxglove.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Sequence

import numpy as np

__all__ = ["write_mcap"]

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
OP_CHUNK, OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_STATISTICS, OP_DATA_END = 0x06, 0x07, 0x08, 0x0B, 0x0F
MESSAGE_HEADER_BYTES = 1 + 8 + 2 + 4 + 8 + 8  # opcode, length, channel, sequence, log and publish time
CHUNK_BYTES = 4 << 20  # target uncompressed chunk size


def _string(text: str) -> bytes:
    data = text.encode("utf-8")
    return struct.pack("<I", len(data)) + data


def _record(op: int, body: bytes) -> bytes:
    return struct.pack("<BQ", op, len(body)) + body


def _map(entries: bytes) -> bytes:
    return struct.pack("<I", len(entries)) + entries


def write_mcap(
    path: str | os.PathLike[str],
    channels: Sequence[tuple[str, str, str]],
    stamps_ns: np.ndarray,
    payloads: Sequence[np.ndarray],
    chunk_bytes: int = CHUNK_BYTES,
) -> None:
    """Write an MCAP file at ``path`` (which must not exist).

    channels: (topic, message type, ros2msg definition) per channel; stamps_ns (N,) strictly
    increasing log and publish times in ns; payloads: one (N, size_c) uint8 matrix of CDR messages
    per channel. Messages are written sample by sample, the channels of one sample in order, in
    chunks of about ``chunk_bytes``.
    """
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    n = len(stamps_ns)
    schema_ids = {msgtype: k + 1 for k, msgtype in enumerate(dict.fromkeys(c[1] for c in channels))}
    definitions = {msgtype: definition for _, msgtype, definition in channels}
    schemas = b"".join(
        _record(OP_SCHEMA, struct.pack("<H", sid) + _string(t) + _string("ros2msg") + _string(definitions[t]))
        for t, sid in schema_ids.items()
    )
    channel_records = b"".join(
        _record(OP_CHANNEL, struct.pack("<HH", cid, schema_ids[t]) + _string(topic) + _string("cdr") + _map(b""))
        for cid, (topic, t, _) in enumerate(channels, 1)
    )
    # One sample = one row: for each channel, a message record header then the CDR payload.
    sizes = [p.shape[1] for p in payloads]
    starts = np.cumsum([0] + [MESSAGE_HEADER_BYTES + s for s in sizes])
    row_bytes = int(starts[-1])
    rows_per_chunk = max(1, chunk_bytes // row_bytes)
    chunk_indexes, counts = [], np.zeros(len(channels), dtype=np.int64)
    with open(path, "xb") as out:
        out.write(MAGIC)
        out.write(_record(OP_HEADER, _string("ros2") + _string("baxter_dynamics_ros")))
        out.write(schemas + channel_records)
        for first in range(0, n, rows_per_chunk):
            stamps = stamps_ns[first : first + rows_per_chunk]
            m = len(stamps)
            rows = np.empty((m, row_bytes), dtype=np.uint8)
            times = stamps.astype("<u8").view(np.uint8).reshape(m, 8)
            for c, (payload, size) in enumerate(zip(payloads, sizes)):
                at = int(starts[c])
                rows[:, at : at + 15] = np.frombuffer(struct.pack("<BQHI", OP_MESSAGE, 22 + size, c + 1, 0), np.uint8)
                rows[:, at + 15 : at + 23] = times
                rows[:, at + 23 : at + 31] = times
                rows[:, at + 31 : at + 31 + size] = payload[first : first + m]
            data = rows.tobytes()
            start_ns, end_ns = int(stamps[0]), int(stamps[-1])
            body = struct.pack("<QQQI", start_ns, end_ns, len(data), zlib.crc32(data)) + _string("")
            body += struct.pack("<Q", len(data))
            chunk_start = out.tell()
            out.write(struct.pack("<BQ", OP_CHUNK, len(body) + len(data)) + body)
            out.write(data)
            chunk_end = out.tell()
            index_offsets = b""
            for c in range(len(channels)):
                entries = np.empty((m, 2), dtype="<u8")
                entries[:, 0] = stamps
                entries[:, 1] = int(starts[c]) + row_bytes * np.arange(m)
                index_offsets += struct.pack("<HQ", c + 1, out.tell())
                out.write(_record(OP_MESSAGE_INDEX, struct.pack("<H", c + 1) + _map(entries.tobytes())))
            counts += m
            chunk_indexes.append(
                _record(
                    OP_CHUNK_INDEX,
                    struct.pack("<QQQQ", start_ns, end_ns, chunk_start, chunk_end - chunk_start)
                    + _map(index_offsets)
                    + struct.pack("<Q", out.tell() - chunk_end)
                    + _string("")
                    + struct.pack("<QQ", len(data), len(data)),
                )
            )
        out.write(_record(OP_DATA_END, struct.pack("<I", 0)))
        summary_start = out.tell()
        out.write(schemas + channel_records + b"".join(chunk_indexes))
        channel_counts = b"".join(struct.pack("<HQ", c + 1, int(k)) for c, k in enumerate(counts))
        first_ns, last_ns = (int(stamps_ns[0]), int(stamps_ns[-1])) if n else (0, 0)
        statistics = struct.pack(
            "<QHIIIIQQ", int(counts.sum()), len(schema_ids), len(channels), 0, 0, len(chunk_indexes), first_ns, last_ns
        )
        out.write(_record(OP_STATISTICS, statistics + _map(channel_counts)))
        out.write(_record(OP_FOOTER, struct.pack("<QQI", summary_start, 0, 0)))
        out.write(MAGIC)
