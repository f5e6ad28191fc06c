"""What a table's column names say: which columns hold a joint's position, velocity or effort, and
which the time.

Published recordings name their columns in many ways (``ang_left_s0``, ``position_s0``,
``left_s0_pos``, ``left_s0.effort``, ``q1 … q7``, ``tau_1``, ``time [s]``). A name is read as its
words (letters and digits, split at anything else, any case): one word of a quantity, the joint
(Baxter's ``s0 … w2``, after an optional side ``left``/``l``/``right``/``r``) or its index, and
nothing else but the unit and words that change no meaning (``joint``, ``state``, ``measured``,
``actual``: ``joint_states.position.left_s0``).
A name with any other word is not a joint column: ``desired_position_s0``, ``acceleration_s0``,
``gravity_left_s0`` are left alone, as are columns of other joints (``head_pan``). A name that
begins with a topic's path, as PlotJuggler's CSV export writes them
(``/robot/joint_states/left_s0/position``), is read from the path's segment that names the joint.

- quantity words: position ``position pos ang angle q qpos theta``; velocity ``velocity vel qd dq
  qdot qvel speed dtheta thetadot``, or ``dot`` or a velocity word after ``q theta ang angle``
  (``theta_dot``, ``q_vel``, ``ang_vel``); effort ``effort eff torque torq tau trq`` (plurals too);
- units: SI (``rad``, ``rad/s``, ``N·m``/``Nm``) as the package uses them, or degrees (``deg``,
  ``deg/s``, ``°``, ``°/s``) for positions and velocities, converted; any other unit word makes the
  name unknown;
- indexed joints (``q1 … q7``, ``dq_0 … dq_6``, ``tau[1]``, ``joint1_pos``, ``j1_torque``,
  ``Joint 1 Position``): Baxter's order s0, s1, e0, e1, w0, w1, w2, and only where a quantity's
  indices are exactly 1–7 or 0–6 (a table of 17 joints, as /robot/joint_states holds, does not say
  which seven are an arm's);
- time: ``time``, ``t``, ``stamp``, ``timestamp``, ``%time``, with a unit word (``s``, ``ms``,
  ``us``/``µs``, ``ns`` and their spellings) or none (:attr:`TimeColumn.scale_s` None: the reader
  infers it).

Two columns that say the same thing (``ang_left_s0`` beside ``position_left_s0``) are refused:
which of them holds the data cannot be known.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from baxter_dynamics_ros.core.joints import JOINT_SUFFIXES
from baxter_dynamics_ros.errors import RecordingFileError

__all__ = ["QUANTITIES", "JointColumn", "TimeColumn", "bare_joint_names", "block_meaning", "joint_columns", "time_columns"]

#: What a joint column holds, in the order a recording keeps them (rad, rad/s, N·m).
QUANTITIES = ("position", "velocity", "effort")
_QUANTITY_WORDS = {
    "position": ("position", "positions", "pos", "ang", "angle", "angles", "q", "qpos", "theta"),
    "velocity": ("velocity", "velocities", "vel", "qd", "dq", "qdot", "qvel", "speed", "speeds", "dtheta", "thetadot"),
    "effort": ("effort", "efforts", "eff", "torque", "torques", "torq", "tau", "trq"),
}
_QUANTITY_OF = {word: quantity for quantity, words in _QUANTITY_WORDS.items() for word in words}
#: Position words that a velocity word or ``dot`` after them makes a velocity (``theta_dot``, ``q_vel``, ``ang_vel``).
_ANGLE_WORDS = frozenset({"q", "theta", "ang", "angle"})
_SIDE_OF = {"left": "left", "l": "left", "right": "right", "r": "right"}
#: Words that, with an index after them (``joint1``, ``j1``), give the joint's index and nothing else.
_INDEX_WORDS = frozenset({"joint", "j", "jnt"})
_NEUTRAL = _INDEX_WORDS | {"joints", "angular", "state", "states", "measured", "meas", "actual"}
#: Unit words that leave SI values as they are (rad, rad/s, N·m), and the degree's.
_SI_UNITS = frozenset({"rad", "rads", "s", "sec", "nm", "n", "m"})
_DEGREE_UNITS = frozenset({"deg", "degs", "degree", "degrees", "°"})
_TIME_WORDS = frozenset({"time", "t", "stamp", "timestamp", "timestamps", "%time"})
_TIME_NEUTRAL = frozenset({"header"})  # header.stamp
#: A time column's unit word -> seconds per unit.
_TIME_UNITS = {
    "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
    "ms": 1e-3, "msec": 1e-3, "msecs": 1e-3,
    "us": 1e-6, "usec": 1e-6, "usecs": 1e-6, "µs": 1e-6, "μs": 1e-6,
    "ns": 1e-9, "nsec": 1e-9, "nsecs": 1e-9,
}  # fmt: skip
#: A word: letters and digits (µ and μ too: ``µs``), or the degree sign on its own (``[°]``, ``°/s``).
_WORD = re.compile(r"[A-Za-z0-9%µμ]+|°")
_INDEXED = re.compile(r"^([a-z]+)(\d+)$")


@dataclass(frozen=True)
class JointColumn:
    """One joint column: its name, what it holds, the joint it names (``side`` None where the name
    names no arm), the factor to the package's units (π/180 for degrees, else 1), and where in the
    name the joint's word (or index) stands."""

    name: str
    quantity: str  # one of QUANTITIES
    side: str | None  # "left", "right" or None
    joint: str  # one of JOINT_SUFFIXES
    scale: float
    joint_span: tuple[int, int]  # name[start:end] is the joint's word or index

    def renamed(self, joint: str) -> str:
        """This column's name with ``joint``'s word (or index) in place of its own: how the same
        table names that joint's column (a missing column in messages)."""
        start, end = self.joint_span
        word = self.name[start:end]
        if word.isdigit():
            word = str(int(word) + JOINT_SUFFIXES.index(joint) - JOINT_SUFFIXES.index(self.joint))
        else:
            word = joint.upper() if word.isupper() else joint
        return self.name[:start] + word + self.name[end:]


@dataclass(frozen=True)
class TimeColumn:
    """A time column: its name and seconds per unit (None where the name gives no unit)."""

    name: str
    scale_s: float | None


def _words(name: str) -> list[tuple[str, tuple[int, int]]]:
    """A name's words, lower case, with their spans in the name."""
    return [(w.group().lower(), w.span()) for w in _WORD.finditer(name)]


def _rates(words: list[tuple[str, tuple[int, int]]]) -> list[tuple[str, tuple[int, int]]]:
    """The words, an angle's word and ``dot`` or a velocity word after it (``theta_dot``, ``q_vel``)
    taken as one word of velocity, ``qdot``."""
    out: list[tuple[str, tuple[int, int]]] = []
    for word, where in words:
        if out and out[-1][0] in _ANGLE_WORDS and (word == "dot" or _QUANTITY_OF.get(word) == "velocity"):
            out[-1] = ("qdot", (out[-1][1][0], where[1]))
        else:
            out.append((word, where))
    return out


def _joint_word(words: Sequence[tuple[str, tuple[int, int]]]) -> tuple[str | None, str | None, tuple[int, int], list[tuple[str, tuple[int, int]]]]:
    """(side, joint, the joint word's span, the other words) of a name's words; joint None where no
    word is a joint of Baxter's, side None where none names an arm."""
    side = joint = None
    span = (0, 0)
    rest = []
    for word, where in words:
        if word in JOINT_SUFFIXES and joint is None:
            joint, span = word, where
        elif word in _SIDE_OF and side is None:
            side = _SIDE_OF[word]
        else:
            rest.append((word, where))
    return side, joint, span, rest


def _meaning(name: str) -> tuple[str, str | None, str | None, int | None, tuple[int, int], float] | None:
    """(quantity, side, joint, index, the joint word's span, scale) that a column name says, or
    None where it is not a joint column (module docstring)."""
    words = _words(name)
    if name.startswith("/"):  # a topic's path first (PlotJuggler's /robot/joint_states/left_s0/position)
        joint_at = next((start for word, (start, _) in words if word in JOINT_SUFFIXES), len(name))
        segment = name.rfind("/", 0, joint_at)
        words = [(word, where) for word, where in words if where[0] > segment]
    side, joint, span, rest = _joint_word(words)
    rest = _rates(rest)
    quantity = index = None
    scale = 1.0
    for word, (start, end) in rest:
        indexed = _INDEXED.match(word)
        if word in _QUANTITY_OF and quantity is None:
            quantity = _QUANTITY_OF[word]
        elif indexed and indexed.group(1) in _QUANTITY_OF and quantity is None and index is None:
            quantity, index = _QUANTITY_OF[indexed.group(1)], int(indexed.group(2))
            span = (start + len(indexed.group(1)), end)
        elif indexed and indexed.group(1) in _INDEX_WORDS and index is None:
            index, span = int(indexed.group(2)), (start + len(indexed.group(1)), end)
        elif word.isdigit() and index is None:
            index, span = int(word), (start, end)
        elif word in _DEGREE_UNITS:
            scale = math.pi / 180.0
        elif word not in _NEUTRAL and word not in _SI_UNITS:
            return None
    if quantity is None or (joint is None) == (index is None) or (scale != 1.0 and quantity == "effort"):
        return None
    return quantity, side, joint, index, span, scale


def joint_columns(names: Iterable[str]) -> dict[tuple[str, str | None, str], JointColumn]:
    """The joint columns among a table's column names, by (quantity, side, joint); raises
    RecordingFileError where two names say the same (module docstring)."""
    said = [(name, m) for name in names if (m := _meaning(name)) is not None]
    # Indexed columns: per (quantity, side), indices exactly 1..7 or 0..6, Baxter's joint order.
    indices: dict[tuple[str, str | None], set[int]] = {}
    for _, (quantity, side, _, index, _, _) in said:
        if index is not None:
            indices.setdefault((quantity, side), set()).add(index)
    base = {key: min(seen) for key, seen in indices.items() if seen in ({*range(1, 8)}, {*range(7)})}
    out: dict[tuple[str, str | None, str], JointColumn] = {}
    for name, (quantity, side, joint, index, span, scale) in said:
        if index is not None:
            if (quantity, side) not in base:
                continue
            joint = JOINT_SUFFIXES[index - base[(quantity, side)]]
        key = (quantity, side, joint)
        if key in out:
            where = f"{side}_{joint}" if side else joint
            raise RecordingFileError(f"columns {out[key].name} and {name} both hold the {quantity} of {where}; keep one")
        out[key] = JointColumn(name, quantity, side, joint, scale, span)
    return out


def bare_joint_names(names: Iterable[str]) -> list[str]:
    """The column names that name one of Baxter's joints and nothing it holds (``left_s0``,
    ``s0 [rad]``): read as no quantity, as baxter_examples' joint_recorder.py names its positions."""
    out = []
    for name in names:
        side, joint, _, rest = _joint_word(_words(name))
        if joint is not None and all(word in _NEUTRAL or word in _SI_UNITS or word in _DEGREE_UNITS for word, _ in rest):
            out.append(name)
    return out


def time_columns(names: Iterable[str]) -> list[TimeColumn]:
    """The time columns among a table's column names, the one to use first: one in nanoseconds
    (integers, exact), then any other with a unit, then one without, each in the table's order."""
    found = []
    for name in names:
        words = [word for word, _ in _words(name)]
        units = [_TIME_UNITS[w] for w in words if w in _TIME_UNITS]
        if any(w in _TIME_WORDS for w in words) and all(w in _TIME_WORDS or w in _TIME_UNITS or w in _TIME_NEUTRAL for w in words) and len(units) <= 1:
            found.append(TimeColumn(name, units[0] if units else None))
    return sorted(found, key=lambda c: (c.scale_s != 1e-9, c.scale_s is None))


def block_meaning(name: str) -> tuple[str, str, float | None] | None:
    """What the name of a variable holding one quantity of all 7 joints (a matrix, columns s0 … w2)
    or the time (a vector) says, as MATLAB files name them (``q``, ``dq_train``, ``tau``, ``t``):
    (the quantity, or "time"; the label of the recording it belongs to, its other words joined by
    "_", "" for none; the factor to the package's units — π/180 for degrees, else 1 — or for a time
    its unit in s, None where the name gives none). None unless exactly one word is a quantity's
    or the time's, or where a word names a joint."""
    words = [word for word, _ in _rates(_words(name))]
    quantities = [_QUANTITY_OF[w] for w in words if w in _QUANTITY_OF]
    if len(quantities) + sum(w in _TIME_WORDS for w in words) != 1 or any(w in JOINT_SUFFIXES for w in words):
        return None
    if not quantities:
        units = [_TIME_UNITS[w] for w in words if w in _TIME_UNITS]
        label = [w for w in words if w not in _TIME_WORDS and w not in _TIME_UNITS and w not in _TIME_NEUTRAL]
        return ("time", "_".join(label), units[0]) if len(units) == 1 else ("time", "_".join(label), None) if not units else None
    degrees = any(w in _DEGREE_UNITS for w in words)
    if degrees and quantities[0] == "effort":
        return None
    label = [w for w in words if w not in _QUANTITY_OF and w not in _NEUTRAL and w not in _SI_UNITS and w not in _DEGREE_UNITS]
    return quantities[0], "_".join(label), math.pi / 180.0 if degrees else 1.0
