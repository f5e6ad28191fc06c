"""Joint states of a ROS topic dumped to text, one message after another: the CSV tables of
``rostopic echo -p``, of bagpy's ``bagreader.message_by_topic`` and of the ``rosbag_to_csv`` tool,
and the messages (YAML) that ``rostopic echo`` and ``ros2 topic echo`` print.

How many labs publish their Baxter recordings (``rostopic echo -p /robot/joint_states > run.csv``,
or ``-b run.bag`` for a bag). The layout is rostopic's plot format:

- a header line named after the *first* message: ``%time,field.header.seq,field.header.stamp,
  field.header.frame_id,field.name0,…,field.position0,…,field.velocity0,…,field.effort0,…``;
- per message: the time (ns; the bag's receive time with ``-b``, the header stamp when echoed
  live), seq, the header stamp (ns), frame_id, the m joint names, then the position, velocity and
  effort arrays, m numbers each, an empty array left out altogether. Baxter's
  ``baxter_core_msgs/SEAJointState`` (``/robot/limb/<side>/gravity_compensation_torques``) is read
  too, its ``actual_*`` arrays, as from a bag: its header names ``field.actual_position0``.

Messages of another length (a gripper's on Baxter's topic) keep their own fields, so each row is
read on its own: its names are the fields after frame_id that are not numbers. rostopic prints the
frame_id as it is: the commas of one (``base,link``) are counted on the first row, whose number of
names the header gives, and that many fields are passed over before the names of every row. Rows that are not a
sample of the arm (a joint missing, an array missing or of another length, a value that is not a
number) are skipped and counted as a bag's malformed messages are
(:func:`msg_adapters.bag_io.joint_state_recording`, which assembles the recording); rows without a
readable time, in a line of their own. Messages whose velocity array alone is empty (a driver that
gives none) are read as a bag's: where no message gives velocities, q̇ is the central difference of q.

bagpy (``bagreader(run.bag).message_by_topic("/robot/joint_states")``, how a ROS 1 bag is most often
turned into CSV in Python) writes a CSV file (quoted where a field holds a comma) whose header is
also named after the first message: ``Time,header.seq,header.stamp.secs,header.stamp.nsecs,
header.frame_id,name,position_0,…,velocity_0,…,effort_0,…``; per message: the bag's receive time (s),
the header, the joint names as one field (the list as Python prints it, ``['head_nod', 'head_pan',
…]``; ``name_0,…`` where they are split like the arrays), then the arrays. Its rows are read as
rostopic's are, each by its own names.

The ``rosbag_to_csv`` tool (AtsushiSakai/rosbag_to_csv, a ROS 1 bag's topics to CSV files) writes a
header of each field's path, ``time,.header.seq,.header.stamp.secs,.header.stamp.nsecs,
.header.frame_id,.name,.position,.velocity,.effort``, and per message the receive time as local date
and time (``2016/05/12/10:23:45.123456``), then each field as Python prints it, in double quotes where
that holds a comma: the names as bagpy's one field, each array one field too (``"(0.1, -0.2, …)"``).
It is read as bagpy's table, the receive times as :func:`~msg_adapters.datetimes.datetime_ns` reads
them (local time taken as UTC: only where every header stamp is zero are they used, and then only
their differences matter).

``ros2 topic echo --csv /robot/joint_states > run.csv`` prints each message as one line with no
header: every field in the message's order, arrays flattened, ``sec,nanosec,frame_id,name…,
position…,velocity…,effort…``, an empty array as one empty field. A file whose first line reads so
(two integers, a frame_id, then joint names and numbers) is read line by line: the header stamp as
the time, the names the fields after frame_id that are not numbers, then the arrays, m numbers each
or empty; a line whose velocity alone is empty is read as a message without velocities, any other
that fits no JointState skipped and counted as above.

``rostopic echo /robot/joint_states > run.txt`` (ROS 1) and ``ros2 topic echo`` print each message
as YAML, ``---`` after it: ``header:`` first (its ``stamp``'s ``secs``/``nsecs``, ROS 2's ``sec``/
``nanosec``), then ``name``, ``position``, ``velocity``, ``effort``, each a list in brackets
(``[head_nod, head_pan, …]``) or one ``- item`` per line (ROS 2's default). A file whose first line
is ``header:`` is read so, message by message, line by line (no YAML parser: an hour of messages is
tens of millions of lines), the header stamps as times, and messages that are no sample of the arm
skipped and counted as above.
"""

from __future__ import annotations

import ast
import csv
import itertools
import os
import re
from collections.abc import Callable, Collection, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.errors import RecordingFileError

from .bag_io import TopicData, joint_state_recording
from .datetimes import datetime_ns
from .serialized_joint_states import JointStateBlock
from .text_files import first_line, open_text, reading

__all__ = ["is_topic_dump", "read_topic_dump_recording"]

#: How the header line of ``rostopic echo -p`` starts, and the field of the first joint name.
HEADER_START = "%time,"
NAMES_FIELD = "field.name0"
STAMP_FIELD = "field.header.stamp"
#: Bytes read to recognise the layout (a header of a few hundred joints fits).
SNIFF_BYTES = 65536
#: Rows decoded at a time.
CHUNK_ROWS = 8192
#: bagpy's header: its first field, the fields of the joint names (one, or one per name), the header stamp's.
BAGPY_TIME = "Time"
BAGPY_NAMES = ("name", "name_0")
BAGPY_STAMP = ("header.stamp.secs", "header.stamp.nsecs")
#: rosbag_to_csv's header: its first field, and the field of the joint names.
ROSBAG_TO_CSV_TIME = "time"
ROSBAG_TO_CSV_NAMES = ".name"
#: The first line of messages as ``rostopic echo`` and ``ros2 topic echo`` print them; the line after each.
ECHO_START = "header:"
ECHO_END = "---"
#: Their stamp's fields of seconds and nanoseconds (ROS 1's, ROS 2's).
_ECHO_SECONDS = frozenset({"secs", "sec"})
_ECHO_NANOSECONDS = frozenset({"nsecs", "nanosec"})
#: The arrays read as q, q̇, effort of every layout: a JointState's, or a SEAJointState's actual_*
#: arrays, where the message has them (:func:`_state_arrays`).
_STATE_ARRAYS = (("position", "velocity", "effort"), ("actual_position", "actual_velocity", "actual_effort"))
#: YAML's spellings of floats that Python's float() does not read (ROS 2 prints NaN as .nan).
_YAML_FLOATS = {".nan": "nan", ".inf": "inf", "+.inf": "inf", "-.inf": "-inf"}
#: A header field of an array's element (``field.position3``, bagpy's ``position_3``): its array is
#: the name without the index.
_ARRAY_FIELD = re.compile(r"_?\d+$")


def is_topic_dump(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a file whose first line is the header of joint states dumped by ``rostopic
    echo -p``, bagpy or rosbag_to_csv, the first line of messages echoed, or a message as ``ros2 topic
    echo --csv`` prints it (module docstring)."""
    first = first_line(path, SNIFF_BYTES)
    return first is not None and (
        _header_fields(first) is not None or _bagpy_fields(first) is not None or _is_echo(first) or _echo_csv_row(first) is not None
    )


def _is_echo(line: str) -> bool:
    """Whether a file's first line is that of echoed messages."""
    return line.rstrip() == ECHO_START


def _header_fields(line: str) -> list[str] | None:
    """The header's fields (a trailing comma or line end dropped), None if the line is no rostopic header."""
    fields = line.rstrip("\r\n,").split(",")
    return fields if line.startswith(HEADER_START) and NAMES_FIELD in fields else None


def _bagpy_fields(line: str) -> list[str] | None:
    """The fields of bagpy's header (trailing empty ones dropped), or of rosbag_to_csv's (its
    fields' leading dots dropped); None if the line is neither."""
    try:
        fields = next(csv.reader([line.rstrip("\r\n")]), [])
    except csv.Error:  # a carriage return or a quote no CSV writer puts in a header
        return None
    while fields and not fields[-1]:
        fields.pop()
    if fields[:1] == [ROSBAG_TO_CSV_TIME] and ROSBAG_TO_CSV_NAMES in fields:
        return [ROSBAG_TO_CSV_TIME] + [f.removeprefix(".") for f in fields[1:]]
    return fields if fields[:1] == [BAGPY_TIME] and any(name in fields for name in BAGPY_NAMES) else None


def _nanoseconds(text: str) -> int:
    """A time field, ns: rostopic writes integers; a float (a re-saved table) is rounded. ValueError
    for anything else, or a time int64 nanoseconds cannot hold."""
    try:
        value: float = int(text)
    except ValueError:
        value = float(text)
    if not abs(value) < 2.0**63:  # NaN too
        raise ValueError(f"not a time in ns: {text!r}")
    return round(value)


def _seconds_ns(text: str) -> int:
    """A time in s (bagpy's), in ns; ValueError for anything but a finite time int64 ns can hold."""
    value = float(text) * 1e9
    if not abs(value) < 2.0**63:  # NaN too
        raise ValueError(f"not a time in s: {text!r}")
    return round(value)


def _stamp_ns(seconds: str, nanoseconds: str) -> int:
    """A header stamp of two integer fields (secs and nsecs), in ns; ValueError for anything else,
    or a time int64 nanoseconds cannot hold."""
    value = int(seconds) * 1_000_000_000 + int(nanoseconds)
    if not abs(value) < 2**63:
        raise ValueError(f"not a stamp: {seconds!r} s {nanoseconds!r} ns")
    return value


def _listed_names(text: str) -> tuple[str, ...]:
    """The joint names of bagpy's one field (a Python list or tuple of text); () for anything else."""
    try:
        names = ast.literal_eval(text)
    except (ValueError, SyntaxError, MemoryError, RecursionError):
        return ()
    ok = isinstance(names, (list, tuple)) and all(isinstance(n, str) for n in names)
    return tuple(names) if ok else ()


def _is_number(text: str) -> bool:
    """Whether float() reads the text (as rostopic's str() of a float, nan and inf included)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _values(texts: list[str]) -> list[np.ndarray | None]:
    """Each row's numbers (the comma-separated text after its names), None where one is not a number."""
    if texts and all(texts):
        try:
            table = np.loadtxt(texts, delimiter=",", dtype=np.float64, ndmin=2, comments=None)
        except ValueError:
            pass  # ragged rows or a bad value: row by row
        else:
            if len(table) == len(texts):
                return list(table)
    out: list[np.ndarray | None] = []
    for text in texts:
        try:
            out.append(np.array([float(x) for x in text.split(",")]) if text else np.zeros(0))
        except ValueError:
            out.append(None)
    return out


@dataclass(frozen=True)
class _Layout:
    """What follows a row's m names: ``count`` arrays of m numbers, then ``trailing`` single numbers;
    q, q̇ and effort are the arrays at ``index`` (q̇'s None: the messages give no velocities)."""

    index: tuple[int, int | None, int]
    count: int
    trailing: int

    @classmethod
    def of_header(cls, path: Path, fields: list[str]) -> tuple[_Layout, ...]:
        """The layouts of the rows under a header, the header's own first: its arrays in their order
        after the joint names (a JointState's position, velocity, effort; a SEAJointState's, whichever
        version, with actual_*), then its single numbers. The header is named after the first
        message: where that left an array empty, its rows are read in the full layout too, and
        where the array is velocity (a driver that gives none), without it first."""
        arrays = [f.removeprefix("field.") for f in dict.fromkeys(_ARRAY_FIELD.sub("", f) for f in fields if _ARRAY_FIELD.search(f))]
        scalars = [f for f in fields if not _ARRAY_FIELD.search(f)]
        wanted = _state_arrays(arrays)
        if all(w in arrays for w in wanted):
            return (cls(tuple(arrays.index(w) for w in wanted), len(arrays), len(scalars)),)
        if wanted[0] == "position" and not scalars and set(arrays) <= set(wanted):
            return JOINT_STATE_LAYOUTS if arrays == ["position", "effort"] else JOINT_STATE_LAYOUTS[:1]
        raise _not_joint_states(path, arrays, scalars)

    @staticmethod
    def whole_fields(path: Path, fields: list[str]) -> tuple[int, int, int]:
        """Where q, q̇ and effort are among the fields after the joint names of a header that gives
        each array one field (rosbag_to_csv's): a JointState's position, velocity, effort, or a
        SEAJointState's actual_* (every one of them there)."""
        wanted = _state_arrays(fields)
        if not all(w in fields for w in wanted):
            raise _not_joint_states(path, fields, [])
        return (fields.index(wanted[0]), fields.index(wanted[1]), fields.index(wanted[2]))

    def width(self, m: int) -> int:
        """How many numbers follow m names."""
        return self.count * m + self.trailing

    def arrays(self, values: np.ndarray, m: int) -> list[np.ndarray | None]:
        """q, q̇, effort (n, m) of rows of numbers (n, count·m + trailing); q̇ None without velocities."""
        return [None if i is None else values[:, i * m : (i + 1) * m] for i in self.index]


#: A JointState's rows: position, velocity, effort; or, where it leaves velocity empty, position and effort.
JOINT_STATE_LAYOUTS = (_Layout((0, 1, 2), 3, 0), _Layout((0, None, 1), 2, 0))


def _state_numbers(position: list[str], velocity: list[str], effort: list[str]) -> list[str]:
    """The numbers of a message whose arrays are named (echoed, rosbag_to_csv's) in one of
    JOINT_STATE_LAYOUTS: all three, or position and effort where velocity alone is empty; none
    (a row that fits no layout) where position or effort is."""
    if not (position and effort):
        return []
    return position + velocity + effort


def _state_arrays(names: Collection[str]) -> tuple[str, str, str]:
    """The arrays read as q, q̇ and effort among a message's ``names``: a SEAJointState's actual_*
    where it has them, else a JointState's position, velocity, effort."""
    return _STATE_ARRAYS[1] if _STATE_ARRAYS[1][0] in names else _STATE_ARRAYS[0]


def _not_joint_states(path: Path, arrays: list[str], scalars: list[str]) -> RecordingFileError:
    """The error of a header whose fields after the joint names are no JointState's or SEAJointState's."""
    return RecordingFileError(
        f"{path}: not JointState or SEAJointState messages: after the joint names the header names arrays "
        f"{', '.join(arrays) or 'none'} and fields {', '.join(scalars) or 'none'}; expected position, velocity, effort "
        "(JointState) or actual_position, actual_velocity, actual_effort (SEAJointState)"
    )


class _Rows:
    """Rows read so far: their times, and blocks of rows naming the same joints (one per chunk)."""

    def __init__(self, layouts: tuple[_Layout, ...]) -> None:
        self.layouts = layouts
        self.times_ns: list[int] = []
        self.stamps_ns: list[int] = []
        self.blocks: list[JointStateBlock] = []
        self.pending: dict[tuple[str, ...], tuple[list[int], list[str]]] = {}

    def add(self, time_ns: int, stamp_ns: int, names: tuple[str, ...], numbers: str) -> None:
        """One row: its times (ns), names and the text of its numbers (decoded at the next flush,
        every CHUNK_ROWS rows)."""
        index, texts = self.pending.setdefault(names, ([], []))
        index.append(len(self.times_ns))
        texts.append(numbers)
        self.times_ns.append(time_ns)
        self.stamps_ns.append(stamp_ns)
        if len(self.times_ns) % CHUNK_ROWS == 0:
            self.flush()

    def flush(self) -> None:
        """Decode the pending rows into blocks of one name list and layout each (the first whose
        width their numbers have), apart from those that fit none (an array left out, a value not a
        number)."""
        for names, (index, texts) in self.pending.items():
            m = len(names)
            widths = {layout.width(m): layout for layout in reversed(self.layouts)} if m else {}
            fit: dict[_Layout | None, list[tuple[int, np.ndarray | None]]] = {}
            for k, values in zip(index, _values(texts)):
                fit.setdefault(None if values is None else widths.get(len(values)), []).append((k, values))
            for layout, rows in fit.items():
                rows_index = np.array([k for k, _ in rows], dtype=np.int64)
                stamps = np.array([self.stamps_ns[k] for k in rows_index], dtype=np.int64)
                arrays = [None, None, None] if layout is None else layout.arrays(np.array([v for _, v in rows], dtype=np.float64), m)
                self.blocks.append(JointStateBlock(rows_index, names, stamps, *arrays))
        self.pending = {}


def _leading_texts(fields: list[str]) -> int:
    """How many of a row's fields, from the first on, are not numbers (names, a frame_id's pieces)."""
    k = 0
    while k < len(fields) and not _is_number(fields[k]):
        k += 1
    return k


def _split_names(rest: str, previous: tuple[str, ...]) -> tuple[tuple[str, ...], str]:
    """(names, the text of the numbers after them) of a row's fields from field.name0 on; the
    previous row's names are tried first (the common case: every message names the same joints)."""
    prefix = ",".join(previous) + ","
    if previous and rest.startswith(prefix) and _is_number(rest[len(prefix) :].split(",", 1)[0]):
        return previous, rest[len(prefix) :]
    fields = rest.split(",")
    m = _leading_texts(fields)
    return tuple(fields[:m]), ",".join(fields[m:])


def _frame_id_commas(rest: str, m: int, layout: _Layout) -> int:
    """How many commas the frame_id of a row holds, from the first row, whose m names the header
    gives: rostopic prints the frame_id as it is, so each comma in it puts one more field that is
    not a number before the names. 0 when the row's numbers do not fit m names in the layout."""
    fields = rest.split(",")
    k = _leading_texts(fields)
    return k - m if k > m and len(fields) - k == layout.width(m) else 0


def _rostopic_rows(path: Path, header: list[str], lines: Iterable[str]) -> tuple[_Rows, int]:
    """The rows of a ``rostopic echo -p`` table under its ``header``, and how many had no readable time."""
    unreadable = 0
    names: tuple[str, ...] = ()
    names_at = header.index(NAMES_FIELD)
    header_names = sum(1 for h in header if h.startswith("field.name"))
    commas: int | None = None  # in the frame_id, from the first row
    stamp_at = header.index(STAMP_FIELD) if STAMP_FIELD in header[:names_at] else None
    rows = _Rows(_Layout.of_header(path, [h for h in header[names_at:] if not h.startswith("field.name")]))
    for line in lines:
        line = line.rstrip("\r\n,")  # a spreadsheet's re-save may end rows with a comma
        if not line.strip():
            continue
        fields = line.split(",", names_at)
        try:
            if len(fields) <= names_at:
                raise ValueError("too few fields")
            time_ns = _nanoseconds(fields[0])
            stamp_ns = _nanoseconds(fields[stamp_at]) if stamp_at is not None else 0
        except ValueError:
            unreadable += 1
            continue
        rest = fields[names_at]
        if commas is None:
            commas = _frame_id_commas(rest, header_names, rows.layouts[0])
        if commas:
            rest = rest.split(",", commas)[-1] if rest.count(",") >= commas else ""
        names, numbers = _split_names(rest, names)
        rows.add(time_ns, stamp_ns, names, numbers)
    return rows, unreadable


def _csv_rows(lines: Iterable[str]) -> Iterator[list[str] | None]:
    """The fields of each line, as csv reads them; None for a line csv cannot read (a field over
    its size limit), and the lines after it read on."""
    reader = csv.reader(lines)
    while True:
        try:
            yield next(reader)
        except StopIteration:
            return
        except csv.Error:
            yield None


def _bagpy_rows(path: Path, header: list[str], lines: Iterable[str]) -> tuple[_Rows, int]:
    """The rows of a bagpy table under its ``header``, and how many had no readable time."""
    unreadable = 0
    names: tuple[str, ...] = ()
    names_at = min(header.index(name) for name in BAGPY_NAMES if name in header)
    listed = header[names_at] == BAGPY_NAMES[0]  # the names in one field
    stamp_at = [header.index(h) for h in BAGPY_STAMP if h in header[:names_at]]
    listing = None  # the last row's field of names, read once while it repeats
    time_ns = datetime_ns if header[0] == ROSBAG_TO_CSV_TIME else _seconds_ns
    after = header[names_at + 1 :]
    if listed and not any(_ARRAY_FIELD.search(h) for h in after):  # rosbag_to_csv's: each array in one field
        whole = [names_at + 1 + k for k in _Layout.whole_fields(path, after)]
        rows = _Rows(JOINT_STATE_LAYOUTS)
    else:
        whole = []
        rows = _Rows(_Layout.of_header(path, [h for h in header[names_at:] if _ARRAY_FIELD.sub("", h) != "name"]))
    for fields in _csv_rows(lines):
        while fields and not fields[-1]:  # a spreadsheet's re-save may end rows with a comma
            fields.pop()
        if fields == []:
            continue
        try:
            if fields is None or len(fields) <= names_at:
                raise ValueError("too few fields")
            receive_ns = time_ns(fields[0])
            stamp_ns = _stamp_ns(fields[stamp_at[0]], fields[stamp_at[1]]) if len(stamp_at) == 2 else 0
        except ValueError:
            unreadable += 1
            continue
        if listed:
            if fields[names_at] != listing:
                listing, names = fields[names_at], _listed_names(fields[names_at])
            numbers = _state_numbers(*(_tuple_items(fields[k]) if k < len(fields) else [] for k in whole)) if whole else fields[names_at + 1 :]
        else:
            m = _leading_texts(fields[names_at:])
            names, numbers = tuple(fields[names_at : names_at + m]), fields[names_at + m :]
        rows.add(receive_ns, stamp_ns, names, ",".join(numbers))
    return rows, unreadable


def _tuple_items(field: str) -> list[str]:
    """The numbers of a tuple or list as Python prints it (``(0.1, -0.2)``, rosbag_to_csv's arrays)."""
    return [x for x in field.strip(" ()[]").replace(" ", "").split(",") if x]


def _unquoted(text: str) -> str:
    """A YAML scalar as printed, without the quotes echo puts around some (``'left_s0'``)."""
    text = text.strip()
    return text[1:-1] if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"" else text


def _echo_items(value: str) -> list[str] | None:
    """The items of a list echo prints in brackets (``[a, b]``), None for a value that is none."""
    if not (value.startswith("[") and value.endswith("]")):
        return None
    inner = value[1:-1].strip()
    return [_unquoted(item) for item in inner.split(",")] if inner else []


class _EchoMessage:
    """The fields of one echoed message read so far: its stamp's, and its lists by name."""

    def __init__(self) -> None:
        self.lines = 0
        self.seconds: str | None = None
        self.nanoseconds: str | None = None
        self.lists: dict[str, list[str]] = {}
        self.block: list[str] | None = None  # the list whose ``- item`` lines follow

    def line(self, line: str) -> None:
        """Take one line of the message."""
        self.lines += 1
        text = line.strip()
        if text.startswith("-") and text[1:2] in ("", " "):  # an item of a list in block style
            if self.block is not None:
                self.block.append(_unquoted(text[1:]))
            return
        field, _, value = text.partition(":")
        value = value.strip()
        if line[:1] not in (" ", "\t"):  # a field of the message's own
            self.block = self.lists.setdefault(field, []) if not value else None
            items = _echo_items(value)
            if items is not None:
                self.lists[field] = items
        elif field in _ECHO_SECONDS:
            self.seconds = value
        elif field in _ECHO_NANOSECONDS:
            self.nanoseconds = value

    def row(self) -> tuple[int, tuple[str, ...], str]:
        """(stamp ns, names, the text of its q, q̇ and effort numbers, comma-separated); ValueError
        where the stamp is no time."""
        stamp_ns = _stamp_ns(self.seconds or "", self.nanoseconds or "")
        arrays = _state_arrays(self.lists)
        numbers = _state_numbers(*([_YAML_FLOATS.get(x.lower(), x) for x in self.lists.get(array, [])] for array in arrays))
        return stamp_ns, tuple(self.lists.get("name", ())), ",".join(numbers)


def _echo_rows(lines: Iterable[str]) -> tuple[_Rows, int]:
    """The messages of an echo after its first line (module docstring), and how many had no
    readable stamp. A last message without its ``---`` (a dump cut short) is read as it is."""
    rows = _Rows(JOINT_STATE_LAYOUTS)
    unreadable = 0

    def take(message: _EchoMessage) -> None:
        nonlocal unreadable
        try:
            stamp_ns, names, numbers = message.row()
        except ValueError:
            unreadable += 1
            return
        rows.add(stamp_ns, stamp_ns, names, numbers)

    message = _EchoMessage()
    for line in lines:
        line = line.rstrip("\r\n")
        if line.startswith(ECHO_END):
            if message.lines:  # (two --- in a row hold no message)
                take(message)
            message = _EchoMessage()
        elif line.strip():
            message.line(line)
    if message.lines:
        take(message)
    return rows, unreadable


def _echo_csv_row(line: str) -> tuple[int, tuple[str, ...], str] | None:
    """(stamp ns, names, the text of its q, q̇ and effort numbers) of a line of ``ros2 topic echo
    --csv`` (module docstring); None for a line that is none: no stamp of two integers, no name, or
    a field after the names that is neither a number nor empty. Numbers fit no layout (and the row
    is skipped) unless position and effort hold one per name, and velocity as many or none."""
    fields = line.rstrip("\r\n").split(",")
    if len(fields) < 5 or not (fields[0].isdigit() and fields[1].isdigit()):
        return None
    m = 0
    while 3 + m < len(fields) and fields[3 + m] and not _is_number(fields[3 + m]):
        m += 1
    rest = fields[3 + m :]
    if not m or not all(x == "" or _is_number(x) for x in rest):
        return None
    arrays: list[list[str]] = []
    while rest and len(arrays) < 3:  # each array: m numbers, or one empty field
        take = 1 if rest[0] == "" else m
        arrays.append([x for x in rest[:take] if x])
        rest = rest[take:]
    try:
        stamp_ns = _stamp_ns(fields[0], fields[1])
    except ValueError:  # digits int() does not read, or a time int64 ns cannot hold
        return None
    numbers = _state_numbers(*arrays) if len(arrays) == 3 and not rest else []
    return stamp_ns, tuple(fields[3 : 3 + m]), ",".join(numbers)


def _echo_csv_rows(first: str, lines: Iterable[str]) -> tuple[_Rows, int]:
    """The messages of ``ros2 topic echo --csv`` from its first line on, and how many lines are none."""
    rows = _Rows(JOINT_STATE_LAYOUTS)
    unreadable = 0
    for line in itertools.chain([first], lines):
        if not line.strip():
            continue
        row = _echo_csv_row(line)
        if row is None:
            unreadable += 1
            continue
        stamp_ns, names, numbers = row
        rows.add(stamp_ns, stamp_ns, names, numbers)
    return rows, unreadable


def _topic_data(path: str | os.PathLike[str], note: Callable[[str], None] | None = None) -> TopicData:
    """The joint-state messages of a dump (module docstring), as a bag topic's decoded messages.

    Read in chunks of CHUNK_ROWS messages (an hour at 100 Hz is 0.5 GB of text). Messages whose
    time or header stamp is not a time (or rows that end before the names, or that csv cannot read)
    are left out and counted in one warning line said through ``note``.
    """
    path = Path(path)
    entries = "rows"
    with reading(path), open_text(path) as f:
        first = f.readline()
        if (header := _header_fields(first)) is not None:
            rows, unreadable = _rostopic_rows(path, header, f)
        elif (header := _bagpy_fields(first)) is not None:
            rows, unreadable = _bagpy_rows(path, header, f)
        elif _is_echo(first):
            rows, unreadable = _echo_rows(f)
            entries = "messages"
        elif _echo_csv_row(first) is not None:
            rows, unreadable = _echo_csv_rows(first, f)
            entries = "lines"
        else:
            raise RecordingFileError(
                f"{path}: not a table of rostopic echo -p joint states (its header must start {HEADER_START!r} and name {NAMES_FIELD}), "
                f"of bagpy's (its header must start {BAGPY_TIME!r} and name {' or '.join(BAGPY_NAMES)}), of rosbag_to_csv's "
                f"(start {ROSBAG_TO_CSV_TIME!r}, name {ROSBAG_TO_CSV_NAMES}), or messages echoed (first line {ECHO_START!r}, "
                "or with --csv sec,nanosec,frame_id,names,position,velocity,effort)"
            )
    rows.flush()
    if not rows.times_ns:
        some = f" ({unreadable} {entries.removesuffix('s') if unreadable == 1 else entries} without a readable time)" if unreadable else ""
        raise RecordingFileError(f"{path}: no messages in this file{some}")
    if unreadable and note is not None:
        note(
            f"WARNING: {path}: {unreadable} of {unreadable + len(rows.times_ns)} {entries} skipped: no time, header stamp "
            "and joint names could be read from them"
        )
    return TopicData("topic dump", np.array(rows.times_ns, dtype=np.int64), rows.blocks)


def read_topic_dump_recording(
    path: str | os.PathLike[str], *, arm: str | None = None, note: Callable[[str], None] | None = None
) -> Recording:
    """One arm's recording from joint states dumped to text (module docstring).

    Stamps are the header stamps (the time column when every header stamp is zero); arm: "right"
    or "left", None to detect it as for a bag.
    """
    path = Path(path)
    return joint_state_recording(path, _topic_data(path, note), arm=arm, note=note, where="in this file")
