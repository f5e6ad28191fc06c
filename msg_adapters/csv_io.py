"""Recordings as tables: CSV files (and Parquet, same columns) in and out.

Two column layouts are read; joints are matched by name, columns may come in any order and extra
columns are ignored:

- **Baxter export** (the layout of the real recordings in ``../shared/data/baxter_real``):
  whitespace-separated, one header line, columns ``ang_<joint>`` (rad), ``vel_<joint>`` (rad/s),
  ``torq_<joint>`` (N·m), e.g. ``ang_left_s0``; no time column, samples ``1 / rate_hz`` apart.
- **Generic** (what ``process`` writes): comma-separated, one header line, a time column
  ``stamp_ns`` (integer ns; preferred when present) or ``time_s`` (s), and ``position_<joint>``
  (rad), ``velocity_<joint>`` (rad/s), ``effort_<joint>`` (N·m) columns. Without a time column
  samples are ``1 / rate_hz`` apart.

``<joint>`` is a Baxter joint name such as ``right_s0``; the arm is the one whose 7 joints all have
columns (the one that moves more if both do), unless given.

Written by :func:`write_processed_table`: ``stamp_ns``, ``time_s`` (s since the first sample),
``position_``, ``velocity_``, ``effort_`` (the input), ``acceleration_`` (estimated q̈, rad/s²),
``gravity_``, ``inverse_dynamics_``, ``residual_`` (N·m) for the arm's 7 joints.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.errors import RecordingFileError
from baxter_dynamics_ros.processing import ProcessedRecording
from baxter_dynamics_ros.recording import ARM_SIDES, Recording, arm_joint_names, detect_arm

__all__ = ["DEFAULT_RATE_HZ", "joint_state_columns", "read_table_recording", "write_processed_table", "write_table"]

DEFAULT_RATE_HZ = 100.0
#: Column prefixes of q, q̇, effort in each layout.
LAYOUTS = {"baxter export": ("ang_", "vel_", "torq_"), "generic": ("position_", "velocity_", "effort_")}


def _read_columns(path: Path) -> dict[str, np.ndarray]:
    """Every column of a CSV (comma or whitespace separated) or Parquet file, by header name."""
    if not path.is_file():
        raise RecordingFileError(f"{path}: no such file")
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(path)
        except Exception as err:  # noqa: BLE001 - pyarrow's errors all mean "not a readable Parquet file"
            raise RecordingFileError(f"{path}: cannot read the Parquet file ({err})") from err
        return {name: table.column(name).to_numpy() for name in table.column_names}
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as err:
        raise RecordingFileError(f"{path}: not a text table ({err})") from err
    if not lines or not lines[0].strip():
        raise RecordingFileError(f"{path}: empty file, expected a header line of column names")
    if len(lines) < 2:
        raise RecordingFileError(f"{path}: no data rows under the header line")
    delimiter = "," if "," in lines[0] else None
    names = [n.strip() for n in lines[0].split(delimiter)]
    try:
        values = np.loadtxt(lines[1:], delimiter=delimiter, ndmin=2, dtype=np.float64)
        stamps = (
            np.loadtxt(lines[1:], delimiter=delimiter, ndmin=1, dtype=np.int64, usecols=names.index("stamp_ns"))
            if "stamp_ns" in names
            else None
        )
    except ValueError as err:
        raise RecordingFileError(f"{path}: not a table of numbers under a header line ({err})") from err
    if values.shape[1] != len(names):
        raise RecordingFileError(f"{path}: the header names {len(names)} columns but rows have {values.shape[1]}")
    columns = {name: values[:, k] for k, name in enumerate(names)}
    if stamps is not None:
        columns["stamp_ns"] = stamps
    return columns


def read_table_recording(
    path: str | os.PathLike[str], *, arm: str | None = None, rate_hz: float = DEFAULT_RATE_HZ
) -> Recording:
    """The recording of one arm from a CSV or Parquet file of either layout (module docstring).

    arm: "right" or "left", None to detect it from the column names; rate_hz: the sample rate of
    files without a time column, Hz.
    """
    path = Path(path)
    columns = _read_columns(path)
    prefixes = next((p for p in LAYOUTS.values() if any(c.startswith(p[0]) for c in columns)), None)
    if prefixes is None:
        raise RecordingFileError(
            f"{path}: no joint columns; expected ang_/vel_/torq_<joint> (Baxter export) or "
            f"position_/velocity_/effort_<joint> (generic), found: {', '.join(columns) or 'none'}"
        )
    if arm is None:
        q_prefix = prefixes[0]
        joints = [c[len(q_prefix) :] for c in columns if c.startswith(q_prefix)]
        named = [j for j in joints if all(p + j in columns for p in prefixes)]
        ranges = {
            side: float(sum(np.ptp(columns[q_prefix + j]) for j in arm_joint_names(side)))
            for side in ARM_SIDES
            if set(arm_joint_names(side)) <= set(named)
        }
        arm = detect_arm(named, ranges)
    joints = arm_joint_names(arm)
    missing = [p + j for p in prefixes for j in joints if p + j not in columns]
    if missing:
        raise RecordingFileError(f"{path}: the {arm} arm needs columns missing here: {', '.join(missing)}")
    q, qd, effort = (np.stack([columns[p + j] for j in joints], axis=1).astype(np.float64) for p in prefixes)
    if "stamp_ns" in columns:
        stamps_ns = np.asarray(columns["stamp_ns"], dtype=np.int64)
    elif "time_s" in columns:
        stamps_ns = np.round(np.asarray(columns["time_s"], dtype=np.float64) * 1e9).astype(np.int64)
    else:
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise RecordingFileError(f"{path}: has no time column and the rate must be positive, got {rate_hz} Hz")
        stamps_ns = np.round(np.arange(len(q)) * (1e9 / rate_hz)).astype(np.int64)
    return Recording(arm, joints, stamps_ns, q, qd, effort)


def joint_state_columns(
    stamps_ns: np.ndarray, names: Sequence[str], position: np.ndarray, velocity: np.ndarray, effort: np.ndarray
) -> dict[str, np.ndarray]:
    """Generic-layout columns of joint states: stamp_ns, time_s (s since the first sample), then
    position_, velocity_, effort_<joint> for each of ``names`` (m,); arrays (N, m)."""
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    columns: dict[str, np.ndarray] = {"stamp_ns": stamps_ns, "time_s": (stamps_ns - stamps_ns[0]) * 1e-9}
    for prefix, values in (("position", position), ("velocity", velocity), ("effort", effort)):
        columns.update({f"{prefix}_{joint}": values[:, k] for k, joint in enumerate(names)})
    return columns


def write_table(path: str | os.PathLike[str], columns: dict[str, np.ndarray], fmt: str) -> None:
    """Write named columns (N,) at ``path``: fmt "csv" or "parquet", both through pyarrow.

    CSV numbers are written in their shortest exact form (they read back bit for bit), the header
    unquoted.
    """
    import pyarrow as pa

    table = pa.table(columns)
    if fmt == "parquet":
        import pyarrow.parquet as pq

        pq.write_table(table, path)
    else:
        import pyarrow.csv as pc

        pc.write_csv(table, path, pc.WriteOptions(quoting_header="none"))


def write_processed_table(path: str | os.PathLike[str], processed: ProcessedRecording, fmt: str) -> None:
    """Write the processed recording as a table (module docstring for the columns)."""
    rec = processed.recording
    columns = joint_state_columns(rec.stamps_ns, rec.joint_names, rec.q, rec.qd, rec.effort)
    for prefix, values in {"acceleration": processed.qdd, **processed.torques()}.items():
        columns.update({f"{prefix}_{joint}": values[:, k] for k, joint in enumerate(rec.joint_names)})
    write_table(path, columns, fmt)
