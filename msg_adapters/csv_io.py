"""Recordings as tables: CSV files (and Parquet, same columns) in and out.

Two column layouts are read; joints are matched by name, columns may come in any order and extra
columns are ignored. A text table's fields are separated by commas, semicolons or whitespace (tabs
too), as its header line's are; it may be compressed whole (:mod:`msg_adapters.text_files`), and
begin with comment lines (``#``), the last of them the header where data rows follow it
(``numpy.savetxt``'s ``# ang_s0 …``).

- **Baxter export** (the layout of the real recordings in ``../shared/data/baxter_real``):
  whitespace-separated, one header line, columns ``ang_<joint>`` (rad), ``vel_<joint>`` (rad/s),
  ``torq_<joint>`` (N·m), e.g. ``ang_left_s0``; no time column.
- **Generic** (what ``process`` writes): comma-separated, one header line, a time column
  ``stamp_ns`` (integer ns; preferred when present) or ``time_s`` (s), and ``position_<joint>``
  (rad), ``velocity_<joint>`` (rad/s), ``effort_<joint>`` (N·m) columns.

``<joint>`` is a Baxter joint name such as ``right_s0``; the arm is the one whose 7 joints all have
columns (the one that moves more if both do), unless given. Tables of other datasets often name no
arm (``ang_s0``, ``position_s0``): they are read for the arm given (``--arm``), and refused without.

Without a time column, samples are evenly spaced at the rate given (``--rate-hz``) or estimated from
the data (:func:`~baxter_dynamics_ros.core.recording.estimate_rate_hz`: least squares of Δq on q̇ Δt);
without a given rate the estimate is used and said, and a given rate more than
:data:`RATE_TOLERANCE` away from the estimate is refused. Where the positions jump farther than a
joint can move in one sample (:func:`~baxter_dynamics_ros.core.recording.jumps`: trajectories laid
end to end in one table), the stamps get a gap, which cuts the recording there, and a note says so.

Rows no real Baxter gives (:mod:`baxter_dynamics_ros.core.plausibility`: NaN, a position beyond
the limits, a speed or effort beyond 3 × the limits) are left out and counted in one warning line;
the rate is estimated without them, and their times stay a gap in the stamps.

Written by :func:`write_processed_table`: ``stamp_ns``, ``time_s`` (s since the first sample),
``position_``, ``velocity_``, ``effort_`` (the input), ``acceleration_`` (estimated q̈, rad/s²),
``gravity_``, ``inverse_dynamics_``, ``residual_`` (N·m) for the arm's 7 joints.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.core.joints import ARM_SIDES, JOINT_SUFFIXES, arm_joint_names
from baxter_dynamics_ros.core.plausibility import package_bounds, plausible_recording, screen_samples
from baxter_dynamics_ros.core.recording import (
    JUMP_GAP_PERIODS, OtherArm, ProcessedRecording, Recording, detect_arm, estimate_rate_hz, jumps, require_activity, summed_range_rad,
)  # fmt: skip
from baxter_dynamics_ros.errors import RecordingFileError

from .text_files import kind_suffix, read_text

__all__ = ["RATE_TOLERANCE", "Note", "columns_recording", "joint_state_columns", "read_table_recording", "write_processed_table", "write_table"]

#: Largest relative difference between a given sample rate and the estimated one that is accepted.
RATE_TOLERANCE = 0.10
#: The largest time_s that int64 nanoseconds hold (292 years), s.
MAX_TIME_S = 9.2e9
Note = Callable[[str], None]  # takes a one-line message for the user
#: Column prefixes of q, q̇, effort in each layout.
LAYOUTS = {"baxter export": ("ang_", "vel_", "torq_"), "generic": ("position_", "velocity_", "effort_")}


def _refuse_duplicates(path: Path, names: Sequence[str]) -> None:
    """Refuses a header naming a column twice (which of the two holds the data cannot be known)."""
    seen: set[str] = set()
    twice = sorted({n for n in names if n in seen or seen.add(n)})
    if twice:
        raise RecordingFileError(f"{path}: column {', '.join(twice)} appears more than once in the header; keep one")


def _header_and_rows(lines: Sequence[str]) -> tuple[str, list[str]]:
    """A text table's header line and its non-blank data rows. Lines that start with ``#`` before
    any other are comments, but the last of them is the header when a row of numbers follows it:
    the header as ``numpy.savetxt`` writes it (``# ang_s0 ang_s1 …``)."""
    k = next((i for i, line in enumerate(lines) if not line.lstrip().startswith("#")), len(lines))
    if 0 < k < len(lines) and _is_numbers(lines[k]):
        header, body = lines[k - 1].lstrip()[1:], lines[k:]
    else:
        header, body = (lines[k], lines[k + 1 :]) if k < len(lines) else ("", [])
    return header, [line for line in body if line.strip()]


def _is_numbers(line: str) -> bool:
    """Whether every field of a line (separated by commas, semicolons or whitespace) is a number."""
    try:
        [float(field) for field in re.split(r"[,;\s]+", line.strip())]
    except ValueError:
        return False
    return True


def _read_columns(path: Path) -> dict[str, np.ndarray]:
    """Every column of a text table (comma, semicolon or whitespace separated; compressed or not:
    :mod:`msg_adapters.text_files`) or a Parquet file, by header name; a name given twice is refused."""
    if not path.is_file():
        raise RecordingFileError(f"{path}: no such file")
    if kind_suffix(path) == ".parquet":
        import pyarrow.parquet as pq

        try:
            table = pq.read_table(path)
        except Exception as err:  # noqa: BLE001 - pyarrow's errors all mean "not a readable Parquet file"
            raise RecordingFileError(f"{path}: cannot read the Parquet file ({err})") from err
        _refuse_duplicates(path, table.column_names)
        columns = {}
        for name in table.column_names:
            values = table.column(name).to_numpy(zero_copy_only=False)
            if name == "stamp_ns":
                if not (values.dtype.kind == "i" or (values.dtype.kind == "u" and (values < 2**63).all())):
                    raise RecordingFileError(f"{path}: column stamp_ns must hold integer nanoseconds, got {values.dtype}")
                columns[name] = values.astype(np.int64)
                continue
            try:
                columns[name] = np.asarray(values, dtype=np.float64)
            except (TypeError, ValueError) as err:
                raise RecordingFileError(f"{path}: column {name} does not hold numbers ({err})") from err
        return columns
    header, rows = _header_and_rows(read_text(path).splitlines())
    if not header.strip():
        raise RecordingFileError(f"{path}: empty file, expected a header line of column names")
    if not rows:
        raise RecordingFileError(f"{path}: no data rows under the header line")
    delimiter = next((d for d in (",", ";") if d in header), None)  # else whitespace (tabs too)
    names = [n.strip() for n in header.split(delimiter)]
    _refuse_duplicates(path, names)
    try:
        values = np.loadtxt(rows, delimiter=delimiter, ndmin=2, dtype=np.float64, comments=None)
        stamps = (
            np.loadtxt(rows, delimiter=delimiter, ndmin=1, dtype=np.int64, usecols=names.index("stamp_ns"), comments=None)
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


def _arm_columns(columns: dict[str, np.ndarray], prefixes: tuple[str, ...], side: str) -> list[str] | None:
    """The q, q̇, effort column names of ``side``'s 7 joints, 7 per prefix: ``<prefix><side>_<joint>``
    when they are all there, else the arm-less ``<prefix><joint>`` when those are; None if neither."""
    for names in (arm_joint_names(side), JOINT_SUFFIXES):
        wanted = [p + j for p in prefixes for j in names]
        if all(c in columns for c in wanted):
            return wanted
    return None


def _other_arms(columns: dict[str, np.ndarray], prefixes: tuple[str, ...], side: str) -> dict[str, OtherArm]:
    """What the table holds of the arms other than ``side`` (for the errors of require_activity)."""
    others = {}
    for other in ARM_SIDES:
        joints = arm_joint_names(other)
        q = [columns[prefixes[0] + j] for j in joints if prefixes[0] + j in columns]
        if other == side or not q:
            continue
        effort = [columns[prefixes[2] + j] for j in joints if prefixes[2] + j in columns]
        missing = tuple(p + j for p in prefixes for j in joints if p + j not in columns)
        others[other] = OtherArm(np.column_stack(q), np.column_stack(effort) if effort else None, missing)
    return others


def _sample_times_ns(
    path: Path, columns: dict[str, np.ndarray], q: np.ndarray, qd: np.ndarray, rate_hz: float | None, note: Note | None, speed_bound: np.ndarray
) -> np.ndarray:
    """(N,) stamps: the time column, or samples 1 / rate evenly apart, the rate checked against (or,
    without ``rate_hz``, taken from) :func:`~baxter_dynamics_ros.core.recording.estimate_rate_hz`,
    and a gap at each jump of the positions (:func:`~baxter_dynamics_ros.core.recording.jumps`,
    beyond ``speed_bound`` (7,) rad/s), said through ``note``."""
    if "stamp_ns" in columns:
        return np.asarray(columns["stamp_ns"], dtype=np.int64)
    if "time_s" in columns:
        time_s = np.asarray(columns["time_s"], dtype=np.float64)
        if not (np.isfinite(time_s).all() and np.abs(time_s).max() < MAX_TIME_S):
            raise RecordingFileError(f"{path}: time_s must hold finite times in s, below {MAX_TIME_S:.3g} in size (int64 ns)")
        return np.round(time_s * 1e9).astype(np.int64)
    if rate_hz is not None and not (np.isfinite(rate_hz) and rate_hz > 0):
        raise RecordingFileError(f"{path}: has no time column and --rate-hz must be a positive number of Hz, got {rate_hz}")
    estimate = estimate_rate_hz(q, qd, speed_bound)
    if estimate is None:
        if rate_hz is None:
            raise RecordingFileError(
                f"{path}: has no time column, and its sample rate cannot be estimated: the velocities do not "
                "match the positions' steps (rows out of time order, or velocities of other positions); pass --rate-hz "
                "if the rows are consecutive samples"
            )
    elif rate_hz is None:
        rate_hz = estimate
        if note is not None:
            note(f"{path}: no time column; sample rate estimated from position and velocity: {estimate:.2f} Hz (--rate-hz sets it)")
    elif abs(rate_hz / estimate - 1.0) > RATE_TOLERANCE:
        raise RecordingFileError(
            f"{path}: --rate-hz {rate_hz:g} disagrees with the sample rate estimated from position and velocity, "
            f"{estimate:.2f} Hz (by more than {RATE_TOLERANCE:.0%}); check the rate, or leave --rate-hz out to use the estimate"
        )
    steps = np.ones(len(q))
    steps[0] = 0.0
    cut = jumps(q, qd, 1.0 / rate_hz, speed_bound)
    if cut.size > 0.5 * (len(q) - 1):
        raise RecordingFileError(
            f"{path}: the positions jump at {cut.size} of {len(q) - 1} steps farther than the joints can move in a sample "
            f"at {rate_hz:.4g} Hz: the rows are not consecutive samples (a table of shuffled samples?), and dynamics need them"
        )
    steps[cut + 1] = JUMP_GAP_PERIODS
    if cut.size and note is not None:
        note(
            f"{path}: the positions jump at {cut.size} step(s) (first after sample {cut[0]}) farther than the joints "
            f"can move in a sample: trajectories laid end to end, taken apart there (gaps of unknown length, {JUMP_GAP_PERIODS} samples in the stamps)"
        )
    return np.round(np.cumsum(steps) * (1e9 / rate_hz)).astype(np.int64)


def read_table_recording(
    path: str | os.PathLike[str], *, arm: str | None = None, rate_hz: float | None = None, note: Note | None = None
) -> Recording:
    """The recording of one arm from a CSV or Parquet file of either layout (module docstring).

    arm: "right" or "left", None to detect it from the column names (a table whose columns name no
    arm needs it); rate_hz: the sample rate of a table without a time column, Hz, None to estimate
    it (said through ``note``, a one-line message). Refuses an arm that does not move or has no
    effort (:func:`~baxter_dynamics_ros.core.recording.require_activity`).
    """
    path = Path(path)
    return columns_recording(path, _read_columns(path), arm=arm, rate_hz=rate_hz, note=note)


def columns_recording(
    path: str | os.PathLike[str], columns: dict[str, np.ndarray], *, arm: str | None = None, rate_hz: float | None = None, note: Note | None = None
) -> Recording:
    """The recording of one arm from a table's columns (name -> (N,) values; either layout), as
    :func:`read_table_recording` reads it; path names the source in messages."""
    prefixes = next((p for p in LAYOUTS.values() if any(c.startswith(p[0]) for c in columns)), None)
    if prefixes is None:
        raise RecordingFileError(
            f"{path}: no joint columns; expected ang_/vel_/torq_<joint> (Baxter export) or "
            f"position_/velocity_/effort_<joint> (generic), found: {', '.join(columns) or 'none'}"
        )
    armless = all(p + j in columns for p in prefixes for j in JOINT_SUFFIXES)
    if arm is None and armless:
        example = " ".join(p + "s0" for p in prefixes)
        raise RecordingFileError(f"{path}: the columns name no arm ({example} ...); pass --arm right|left")
    if arm is None:
        q_prefix = prefixes[0]
        joints = [c[len(q_prefix) :] for c in columns if c.startswith(q_prefix)]
        named = [j for j in joints if all(p + j in columns for p in prefixes)]
        ranges = {
            side: summed_range_rad(np.column_stack([columns[q_prefix + j] for j in arm_joint_names(side)]))
            for side in ARM_SIDES
            if set(arm_joint_names(side)) <= set(named)
        }
        arm = detect_arm(named, ranges)
    joints = arm_joint_names(arm)
    names = _arm_columns(columns, prefixes, arm)
    if names is None:
        missing = [p + j for p in prefixes for j in joints if p + j not in columns]
        raise RecordingFileError(f"{path}: the {arm} arm needs columns missing here: {', '.join(missing)}")
    q, qd, effort = (np.column_stack([columns[c] for c in names[7 * k : 7 * k + 7]]).astype(np.float64) for k in range(3))
    screening = screen_samples(package_bounds(arm), q, qd, effort)
    error = screening.refusal()
    if error is not None:
        raise error
    keep = screening.keep
    require_activity(arm, q[keep], effort[keep], _other_arms(columns, prefixes, arm))
    gone = np.where(keep[:, None], 0.0, np.nan)  # implausible rows left out of the rate's estimate
    stamps_ns = _sample_times_ns(path, columns, q + gone, qd + gone, rate_hz, note, package_bounds(arm)[3])
    return plausible_recording(str(path), arm, stamps_ns, q, qd, effort, note, screening)


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
