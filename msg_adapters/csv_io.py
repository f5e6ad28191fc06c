"""Recordings as tables: CSV files (and Parquet, same columns) in and out.

Joints are matched by name, columns may come in any order and extra columns are ignored, text in
them too (a date, a label). A text table's fields are separated by commas, semicolons or whitespace
(tabs too), as its header line's are, and may stand in double quotes; numbers in a table of
semicolons may have a decimal comma (``-0,90``, a spreadsheet's export where the comma is one). It
may be compressed whole (:mod:`msg_adapters.text_files`), and begin with comment lines (``#``), the
last of them the header where data rows follow it (``numpy.savetxt``'s ``# ang_s0 …``). A row of
units under the header (``s,rad,rad/s,N·m``, ``[°]``: :func:`_units_row`) is read as each column's
unit, as if its name ended with it.

Which column holds which joint's position, velocity or effort, and which the time, its name says
(:mod:`msg_adapters.table_columns`: ``ang_left_s0``, ``position_s0``, ``left_s0_pos``, ``q1 … q7``,
``time [s]`` and the like). Two layouts are this package's own:

- **Baxter export** (the layout of the real recordings in ``../shared/data/baxter_real``):
  whitespace-separated, one header line, columns ``ang_<joint>`` (rad), ``vel_<joint>`` (rad/s),
  ``torq_<joint>`` (N·m), e.g. ``ang_left_s0``; no time column.
- **Generic** (what ``process`` writes): comma-separated, one header line, a time column
  ``stamp_ns`` (integer ns; preferred when present) or ``time_s`` (s), and ``position_<joint>``
  (rad), ``velocity_<joint>`` (rad/s), ``effort_<joint>`` (N·m) columns.

``<joint>`` is a Baxter joint name such as ``right_s0``; the arm is the one whose 7 joints all have
columns (the one that moves more if both do), unless given. Tables of other datasets often name no
arm (``ang_s0``, ``q1``): they are read for the arm given (``--arm``), and refused without. A time
column whose name gives no unit is read in the one of s, ms, µs, ns in which its steps match the
velocities, and the note says which. Where it goes back (trials laid end to end, each timed from
its own start), each trial is moved to begin a gap after the one before, which cuts the recording
there, and a note says so (:func:`_laid_end_to_end`). A time column may also hold dates and times
as text (``2019-05-12 10:23:45.123456`` as pandas writes a time index, ISO 8601 with a zone,
``2019/05/12/10:23:45.123456`` as the ``rosbag_to_csv`` tool writes, or times of day alone:
:func:`~msg_adapters.datetimes.datetimes`), or in Parquet be a timestamp.

A table with no velocity column at all gives q̇ as the central difference of q over its time column
(one that names its unit) or the rate given (``--rate-hz``), said in a note
(:func:`_positions_velocity`).

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

import csv
import math
import os
import re
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.core.joints import ARM_SIDES, JOINT_SUFFIXES
from baxter_dynamics_ros.core.plausibility import package_bounds, plausible_recording, screen_samples
from baxter_dynamics_ros.core.recording import (
    JUMP_GAP_PERIODS, MAX_BACK_SHARE, OtherArm, ProcessedRecording, Recording, detect_arm, estimate_rate_hz, jumps, require_activity, summed_range_rad,
    taken_apart, velocity_from_positions,
)  # fmt: skip
from baxter_dynamics_ros.errors import RecordingFileError

from .datetimes import datetimes
from .table_columns import QUANTITIES, JointColumn, TimeColumn, bare_joint_names, joint_columns, time_columns
from .text_files import kind_suffix, read_text

__all__ = [
    "RATE_TOLERANCE", "Note", "columns_recording", "joint_state_columns", "read_table_recording", "side_in_file_name", "write_processed_table", "write_table",
]

#: Largest relative difference between a given sample rate and the estimated one that is accepted.
RATE_TOLERANCE = 0.10
#: The largest time_s that int64 nanoseconds hold (292 years), s.
MAX_TIME_S = 9.2e9
#: What a table without velocity columns must give per joint (q̇ is then its positions' difference).
_WITHOUT_VELOCITY = ("position", "effort")
#: The quote a text table's fields may stand in (``"ang_left_s0"``, ``"0.5"``), as CSV writers put it.
_QUOTE = '"'
#: A unit as a row of units writes it: letters, µ, °, %, the operators of a unit (``N·m``,
#: ``rad/s^2``, ``m*s-1``, ``s²``), in brackets or not; or nothing.
_UNIT = re.compile(r"[\[(]?[A-Za-zµμ°%/·⋅*. ^\-12²]*[\])]?")
Note = Callable[[str], None]  # takes a one-line message for the user


def side_in_file_name(path: str | os.PathLike[str]) -> str | None:
    """The arm a file's name names, for files whose contents name none (the other unit's
    ``left_circle_p90_t105.csv``): "left" or "right" when exactly one of them is a word of the name
    (words: its runs of letters), else None."""
    words = set(re.findall(r"[a-z]+", Path(path).name.lower()))
    sides = [side for side in ARM_SIDES if side in words]
    return sides[0] if len(sides) == 1 else None


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


def _numbers(rows: Sequence[str], delimiter: str | None, usecols: Sequence[int] | None = None) -> np.ndarray:
    """(rows, columns) float64 of a text table's data rows (of the columns ``usecols``, None: all), a
    field in double quotes read as the number it holds. In comma- or semicolon-separated rows an
    empty field is a missing value, NaN (exports of several topics leave one where a topic has no
    sample at that time, as PlotJuggler's do): rows with one in the arm's columns are left out. In
    semicolon-separated rows a comma in a number is its decimal mark (``-0,90``: a spreadsheet's
    export where the comma is one)."""
    try:
        return np.loadtxt(rows, delimiter=delimiter, ndmin=2, dtype=np.float64, comments=None, quotechar=_QUOTE, usecols=usecols)
    except ValueError:
        if delimiter is None:
            raise
        number = _decimal_comma_number_or_missing if delimiter == ";" else _number_or_missing
        return np.loadtxt(rows, delimiter=delimiter, ndmin=2, dtype=np.float64, comments=None, quotechar=_QUOTE, converters=number, usecols=usecols)


def _number_or_missing(field: str) -> float:
    return float(field) if field.strip() else math.nan


def _decimal_comma_number_or_missing(field: str) -> float:
    return _number_or_missing(field.replace(",", "."))


def _nanosecond_columns(names: Sequence[str]) -> list[str]:
    """The time columns in nanoseconds among a table's column names, read as integers (exact)."""
    return [c.name for c in time_columns(names) if c.scale_s == 1e-9]


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
        nanoseconds = _nanosecond_columns(table.column_names)
        wanted = _read_names(path, table.column_names)
        times = {c.name for c in time_columns(wanted)}
        columns = {}
        for name in table.column_names:
            values = table.column(name).to_numpy(zero_copy_only=False)
            if values.dtype.kind == "M" and name in times:  # a timestamp (pandas' of a time index)
                columns[name] = values
                continue
            if values.dtype.kind not in "biuf" and name not in wanted:  # text beside the joint columns (a label)
                continue
            if name in nanoseconds:
                if not (values.dtype.kind == "i" or (values.dtype.kind == "u" and (values < 2**63).all())):
                    raise RecordingFileError(f"{path}: column {name} must hold integer nanoseconds, got {values.dtype}")
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
    try:
        names = [n.strip() for n in (next(csv.reader([header], delimiter=delimiter)) if delimiter else header.split())]
    except csv.Error as err:  # a name beyond csv's field size limit
        raise RecordingFileError(f"{path}: the header line is no row of column names ({err})") from err
    if (units := _units_row(rows[0], delimiter, len(names))) is not None:  # a row of units under the names
        names, rows = [f"{name} [{unit}]" if unit else name for name, unit in zip(names, units)], rows[1:]
        if not rows:
            raise RecordingFileError(f"{path}: no data rows under the header line and its units")
    _refuse_duplicates(path, names)
    kept, times = names, {}
    try:
        try:
            values = _numbers(rows, delimiter)
        except ValueError:
            wanted = _read_names(path, names)
            if not wanted:
                raise
            _refuse_ragged(path, rows, delimiter, len(names))  # a column's place must be the header's in every row
            times = {c.name: _time_texts(path, c.name, rows, delimiter, names.index(c.name)) for c in time_columns(wanted)}
            kept = [n for n in wanted if times.get(n) is None]  # other columns may hold text, a time column dates
            values = _numbers(rows, delimiter, usecols=[names.index(n) for n in kept])
        stamps = {
            name: np.loadtxt(rows, delimiter=delimiter, ndmin=1, dtype=np.int64, usecols=names.index(name), comments=None, quotechar=_QUOTE)
            for name in _nanosecond_columns(kept)
        }
    except ValueError as err:
        raise RecordingFileError(f"{path}: not a table of numbers under a header line ({err})") from err
    if values.shape[1] != len(kept):
        raise RecordingFileError(f"{path}: the header names {len(names)} columns but rows have {values.shape[1]}")
    columns = {name: values[:, k] for k, name in enumerate(kept)}
    columns.update(stamps)
    columns.update({name: dates for name, dates in times.items() if dates is not None})
    return columns


def _units_row(row: str, delimiter: str | None, width: int) -> list[str] | None:
    """The units of a table's first data row when it is a row of units, as some exports write under
    the column names (``s,rad,rad/s,N·m`` or ``[deg]``, some left empty): a field per column, none
    a number or holding a digit but an exponent's, some not empty; None for any other row."""
    try:
        fields = [f.strip() for f in (next(csv.reader([row], delimiter=delimiter)) if delimiter else row.split())]
    except csv.Error:
        return None
    if len(fields) != width or not any(fields) or not all(_UNIT.fullmatch(f) and not _is_numbers(f) for f in fields if f):
        return None
    return [f.strip("[]()") for f in fields]


def _time_texts(path: Path, name: str, rows: Sequence[str], delimiter: str | None, column: int) -> np.ndarray | None:
    """The times (N,) datetime64[ns] of a time column ``name`` that holds dates and times as text
    (:func:`~msg_adapters.datetimes.datetimes`); None where it holds numbers (read with the other
    columns). Refuses a column of text that is no date and time in some row."""
    try:
        _numbers(rows, delimiter, usecols=[column])
        return None
    except ValueError:
        texts = np.loadtxt(rows, delimiter=delimiter, ndmin=1, dtype=str, usecols=column, comments=None, quotechar=_QUOTE)
    try:
        return datetimes(texts)
    except ValueError as err:
        raise RecordingFileError(f"{path}: the time column {name} holds neither numbers nor dates and times ({err})") from err


def _refuse_ragged(path: Path, rows: Sequence[str], delimiter: str | None, width: int) -> None:
    """Refuses rows whose fields are not as many as the header's ``width`` names (fields split as csv
    splits them, quotes kept together; by whitespace for a delimiter None)."""
    try:
        counts = [len(fields) for fields in (csv.reader(rows, delimiter=delimiter) if delimiter else (row.split() for row in rows))]
    except csv.Error as err:  # a field beyond csv's size limit
        raise RecordingFileError(f"{path}: not a table under a header line ({err})") from err
    bad = next((k for k, n in enumerate(counts) if n != width), None)
    if bad is not None:
        raise RecordingFileError(f"{path}: the header names {width} columns but data row {bad + 1} has {counts[bad]}")


def _read_names(path: Path, names: Sequence[str]) -> list[str]:
    """The names among a table's column names that it is read for, in their order: the joint
    columns (:func:`~msg_adapters.table_columns.joint_columns`) and the time columns; [] where it
    has no joint column (then its text is refused as it is)."""
    try:
        joints = {c.name for c in joint_columns(names).values()}
    except RecordingFileError as err:
        raise RecordingFileError(f"{path}: {err}") from err
    wanted = joints | {c.name for c in time_columns(names)} if joints else set()
    return [n for n in names if n in wanted]


def _quantities(found: dict[tuple[str, str | None, str], JointColumn]) -> tuple[str, ...]:
    """The quantities the table must give per joint: position, velocity and effort, or position and
    effort where it has no velocity column at all (q̇ then from q: :func:`_positions_velocity`)."""
    return QUANTITIES if any(key[0] == "velocity" for key in found) else _WITHOUT_VELOCITY


def _arm_columns(found: dict[tuple[str, str | None, str], JointColumn], side: str, *, armless: bool = True) -> list[JointColumn] | None:
    """The columns of ``side``'s 7 joints, 7 per quantity of :func:`_quantities`: those naming the
    arm when they are all there, else (``armless``) those naming none when they are; None if neither."""
    for named in (side, None) if armless else (side,):
        wanted = [found.get((quantity, named, j)) for quantity in _quantities(found) for j in JOINT_SUFFIXES]
        if all(wanted):
            return wanted
    return None


def _values(columns: dict[str, np.ndarray], chosen: Sequence[JointColumn]) -> np.ndarray:
    """(N, k) float64, the chosen joint columns' values in the package's units (rad, rad/s, N·m)."""
    return np.column_stack([columns[c.name] * c.scale for c in chosen]).astype(np.float64)


def _missing(found: dict[tuple[str, str | None, str], JointColumn], named: str | None, side: str) -> tuple[str, ...]:
    """The names, as the table would write them, of the joint columns it lacks of ``side``'s arm
    in the naming ``named`` (the arm's name, or None: no arm)."""
    out = []
    for quantity in _quantities(found):
        model = next((c for key, c in found.items() if key[:2] == (quantity, named)), None)
        out += [model.renamed(j) if model else f"the {quantity} of {side}_{j}" for j in JOINT_SUFFIXES if (quantity, named, j) not in found]
    return tuple(out)


def _other_arms(found: dict[tuple[str, str | None, str], JointColumn], columns: dict[str, np.ndarray], side: str) -> dict[str, OtherArm]:
    """What the table holds of the arms other than ``side`` (for the errors of require_activity)."""
    others = {}
    for other in ARM_SIDES:
        q = [found[key] for j in JOINT_SUFFIXES if (key := ("position", other, j)) in found]
        if other == side or not q:
            continue
        effort = [found[key] for j in JOINT_SUFFIXES if (key := ("effort", other, j)) in found]
        others[other] = OtherArm(
            _values(columns, q),
            _values(columns, effort) if effort else None,
            _missing(found, other, other),
        )
    return others


def _time_column_ns(path: Path, columns: dict[str, np.ndarray], time: TimeColumn, q: np.ndarray, qd: np.ndarray | None, note: Note | None) -> np.ndarray:
    """(N,) stamps, int64 ns, from a time column: integers in ns as they are, any other scaled by
    its unit (:mod:`msg_adapters.table_columns`) or, where its name gives none, by the unit in which
    its steps match the velocities qd (:func:`_time_unit_s`; a column of no unit needs them); where
    it goes back, trials laid end to end (:func:`_laid_end_to_end`)."""
    values = columns[time.name]
    if values.dtype.kind == "M":  # dates and times as text, or a Parquet timestamp
        if np.isnat(values).any():
            raise RecordingFileError(f"{path}: {time.name} must hold a time in every row")
        stamps = values.astype("datetime64[ns]").astype(np.int64)
    elif values.dtype.kind in "iu" and time.scale_s == 1e-9:
        stamps = values.astype(np.int64)
    else:
        t = np.asarray(values, dtype=np.float64)
        scale_s = time.scale_s if time.scale_s is not None else _time_unit_s(path, time.name, t, q, qd, note)
        if not (np.isfinite(t).all() and np.abs(t).max() * scale_s < MAX_TIME_S):
            raise RecordingFileError(f"{path}: {time.name} must hold finite times, below {MAX_TIME_S:.3g} s in size (int64 ns)")
        stamps = np.round(t * (scale_s * 1e9)).astype(np.int64)
    return _laid_end_to_end(path, time.name, stamps, note)


def _laid_end_to_end(path: Path, name: str, stamps: np.ndarray, note: Note | None) -> np.ndarray:
    """(N,) stamps ns of a time column that goes back (trials laid end to end, each timed from its
    own start): taken apart there by a gap (:func:`~baxter_dynamics_ros.core.recording.taken_apart`,
    as at a jump of the positions), said through ``note``. Refused where the time goes back at more
    than half of the steps (rows that are no time series)."""
    moved, back = taken_apart(stamps)
    if not back.size:
        return moved
    if back.size > MAX_BACK_SHARE * (len(stamps) - 1):
        raise RecordingFileError(f"{path}: the time column {name} goes back at {back.size} of {len(stamps) - 1} steps: the rows are no time series")
    if note is not None:
        note(
            f"{path}: the time column {name} goes back at {back.size} row(s) (first after sample {back[0]}): trials laid end to end, "
            f"taken apart there (gaps of unknown length, {JUMP_GAP_PERIODS} samples in the stamps)"
        )
    return moved


def _time_unit_s(path: Path, name: str, t: np.ndarray, q: np.ndarray, qd: np.ndarray, note: Note | None) -> float:
    """Seconds per unit of a time column t (N,) whose name gives no unit: the one of s, ms, µs, ns
    within :data:`RATE_TOLERANCE` of the least-squares factor s that makes the positions' steps
    match the velocities, Δq_k = s·Δt_k·(q̇_k + q̇_{k+1}) / 2 (rows with a non-finite value left
    out); said through ``note``. Refused where none is."""
    dq, dt = np.diff(q, axis=0), np.diff(t)[:, None]
    x = 0.5 * (qd[1:] + qd[:-1]) * dt
    use = np.isfinite(dq) & np.isfinite(x) & (dt > 0)  # not where the time goes back (:func:`_laid_end_to_end`)
    xx = float(x[use] @ x[use])
    factor = float(dq[use] @ x[use]) / xx if xx > 0.0 else math.nan
    units = [(u, word) for u, word in ((1.0, "s"), (1e-3, "ms"), (1e-6, "µs"), (1e-9, "ns")) if abs(factor / u - 1.0) <= RATE_TOLERANCE]
    if not units:
        raise RecordingFileError(
            f"{path}: the time column {name} names no unit, and with none of s, ms, µs, ns do its steps match the "
            f"velocities ({factor:.3g} s per unit); name the unit in the header (e.g. {name}_s or {name}_ns)"
        )
    unit, word = units[0]
    if note is not None:
        note(f"{path}: the time column {name} names no unit; read in {word}, in which its steps match the velocities")
    return unit


def _check_rate(path: Path, rate_hz: float | None) -> float | None:
    """The rate given for a table without a time column (None: none given), refused unless a
    positive number of Hz."""
    if rate_hz is not None and not (np.isfinite(rate_hz) and rate_hz > 0):
        raise RecordingFileError(f"{path}: has no time column and --rate-hz must be a positive number of Hz, got {rate_hz}")
    return rate_hz


def _sample_times_ns(
    path: Path, columns: dict[str, np.ndarray], q: np.ndarray, qd: np.ndarray, rate_hz: float | None, note: Note | None, speed_bound: np.ndarray
) -> np.ndarray:
    """(N,) stamps: the time column, or samples 1 / rate evenly apart, the rate checked against (or,
    without ``rate_hz``, taken from) :func:`~baxter_dynamics_ros.core.recording.estimate_rate_hz`,
    and a gap at each jump of the positions (:func:`~baxter_dynamics_ros.core.recording.jumps`,
    beyond ``speed_bound`` (7,) rad/s), said through ``note``."""
    times = time_columns(columns)
    if times:
        return _time_column_ns(path, columns, times[0], q, qd, note)
    _check_rate(path, rate_hz)
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
    """The recording of one arm from a CSV or Parquet file (module docstring: its columns named as :mod:`msg_adapters.table_columns` reads them).

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
    """The recording of one arm from a table's columns (name -> (N,) values, named as :mod:`msg_adapters.table_columns` reads them), as
    :func:`read_table_recording` reads it; path names the source in messages."""
    try:
        found = joint_columns(columns)
    except RecordingFileError as err:
        raise RecordingFileError(f"{path}: {err}") from err
    if not found:
        bare = bare_joint_names(columns)
        raise RecordingFileError(
            f"{path}: no joint columns; expected a position, velocity and effort column per joint, named as "
            f"ang_/vel_/torq_<joint> (Baxter export), position_/velocity_/effort_<joint> (generic), <joint>_pos, "
            f"q1 … q7 and the like (<joint>: s0 … w2, left_s0 …), found: {', '.join(columns) or 'none'}"
            + f"; {', '.join(bare[:3])}{' …' * (len(bare) > 3)} name a joint but not what it holds (as baxter_examples' "
            "joint_recorder.py names positions, the only quantity it records): the dynamics need each joint's effort too" * bool(bare)
        )
    needed = _quantities(found)
    if arm is None and all((quantity, None, j) in found for quantity in needed for j in JOINT_SUFFIXES):
        example = " ".join(found[(quantity, None, "s0")].name for quantity in needed)
        arm = side_in_file_name(path)
        if arm is None:
            raise RecordingFileError(f"{path}: the columns name no arm ({example} ...), nor does the file name; pass --arm right|left")
        if note is not None:
            note(f"{path}: the columns name no arm ({example} ...); read as the {arm} arm, which the file name names (--arm sets it)")
    if arm is None:
        named = [f"{side}_{j}" for (quantity, side, j) in found if quantity == "position" and side and all((k, side, j) in found for k in needed)]
        ranges = {
            side: summed_range_rad(_values(columns, chosen[:7]))
            for side in ARM_SIDES
            if (chosen := _arm_columns(found, side, armless=False)) is not None
        }
        arm = detect_arm(named, ranges)
    chosen = _arm_columns(found, arm)
    if chosen is None:
        named = arm if any(key[1] == arm for key in found) else None
        raise RecordingFileError(f"{path}: the {arm} arm needs columns missing here: {', '.join(_missing(found, named, arm))}")
    q, effort = _values(columns, chosen[:7]), _values(columns, chosen[-7:])
    if needed == QUANTITIES:
        qd = _values(columns, chosen[7:14])
    else:
        stamps_ns, qd = _positions_velocity(path, columns, q, rate_hz, note)
    screening = screen_samples(package_bounds(arm), q, qd, effort)
    error = screening.refusal()
    if error is not None:
        raise error
    keep = screening.keep
    require_activity(arm, q[keep], effort[keep], _other_arms(found, columns, arm))
    if needed == QUANTITIES:
        gone = np.where(keep[:, None], 0.0, np.nan)  # implausible rows left out of the rate's estimate
        stamps_ns = _sample_times_ns(path, columns, q + gone, qd + gone, rate_hz, note, package_bounds(arm)[3])
    return plausible_recording(str(path), arm, stamps_ns, q, qd, effort, note, screening)


def _positions_velocity(
    path: Path, columns: dict[str, np.ndarray], q: np.ndarray, rate_hz: float | None, note: Note | None
) -> tuple[np.ndarray, np.ndarray]:
    """(stamps (N,) int64 ns, q̇ (N, 7) rad/s) of a table without velocity columns: the times of its
    time column (one whose unit is named: with no velocities, none can be inferred) or, without
    one, samples 1 / ``rate_hz`` apart (needed: no rate can be estimated either); q̇ the central
    difference of q (N, 7) over them, one-sided at the ends of each run of evenly spaced samples
    (:func:`~baxter_dynamics_ros.core.recording.velocity_from_positions`). Said through ``note``."""
    times = time_columns(columns)
    if times:
        if times[0].scale_s is None and columns[times[0].name].dtype.kind != "M":
            raise RecordingFileError(
                f"{path}: has no velocity columns, and its time column {times[0].name} names no unit, which is read from the "
                f"velocities; name the unit in the header (e.g. {times[0].name}_s or {times[0].name}_ns)"
            )
        stamps_ns = _time_column_ns(path, columns, times[0], q, None, note)
    elif _check_rate(path, rate_hz) is None:
        raise RecordingFileError(
            f"{path}: has no time column and no velocity columns, so the sample rate can be neither read nor estimated; "
            "pass --rate-hz if the rows are consecutive samples"
        )
    else:
        stamps_ns = np.round(np.arange(len(q)) * (1e9 / rate_hz)).astype(np.int64)
    qd = velocity_from_positions(stamps_ns, q)
    if note is not None:
        note(f"{path}: no velocity columns; q̇ is the central difference of q over the {'time column' if times else 'rate given'}")
    return stamps_ns, qd


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
