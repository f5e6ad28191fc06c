"""Dates and times as text, as tables and topic dumps write them, read as UTC times to the ns:
``2019-05-12 10:23:45.123456`` (pandas' CSV of a time index), ISO 8601's ``2019-05-12T10:23:45.123Z``
or with an offset ``+02:00`` (taken off), ``2019/05/12/10:23:45.123456`` (the ``rosbag_to_csv``
tool's), or a time of day alone (``10:23:45.123``)."""

from __future__ import annotations

import datetime
import functools
import re
from collections.abc import Sequence

import numpy as np

__all__ = ["datetime_ns", "datetimes"]

#: A date and time as text: a date (``-`` or ``/`` apart), then ``T``, a space or ``/``, or no
#: date; a time of day, seconds with up to 9 decimals (after a point, or ISO 8601's comma, as
#: spreadsheets write where it is the decimal mark); a zone.
_DATETIME = re.compile(
    r"(?:(?P<date>\d{4}([-/])\d{2}\2\d{2})[T /])?(?P<h>\d{2}):(?P<m>\d{2}):(?P<s>\d{2})(?:[.,](?P<frac>\d{1,9}))?(?P<zone>Z|[+-]\d{2}:?\d{2})?"
)
_DAY_NS = 86_400 * 1_000_000_000
_SECOND_NS = 1_000_000_000
#: Days from 1970 that int64 ns hold, with a margin (1679 to 2260).
_MAX_DAYS = 106_000


@functools.lru_cache(maxsize=64)
def _days(date: str) -> int:
    """Days from 1970-01-01 to a date ``YYYY-MM-DD`` (or with ``/``); ValueError for none, or one
    int64 ns cannot hold."""
    days = datetime.date(int(date[:4]), int(date[5:7]), int(date[8:10])).toordinal() - 719_163
    if abs(days) > _MAX_DAYS:
        raise ValueError(f"{date}: a date int64 ns cannot hold (1679 to 2260)")
    return days


def _parts(text: str) -> tuple[int | None, int]:
    """(days from 1970, None without a date; ns into that day, UTC) of one date and time as text;
    ValueError for anything else."""
    m = _DATETIME.fullmatch(text.strip())
    if m is None:
        raise ValueError(f"not a date and time: {text[:40]!r}")
    h, mi, s = int(m["h"]), int(m["m"]), int(m["s"])
    if h > 23 or mi > 59 or s > 60:  # 60: a leap second
        raise ValueError(f"not a time of day: {text[:40]!r}")
    ns = (h * 3600 + mi * 60 + s - _offset_s(m["zone"])) * _SECOND_NS + int((m["frac"] or "").ljust(9, "0"))
    return (_days(m["date"]) if m["date"] else None), ns


def _offset_s(zone: str | None) -> int:
    """Seconds east of UTC of an ISO 8601 zone (``Z``, ``+02:00``, ``-0530``; none: 0)."""
    if not zone or zone == "Z":
        return 0
    digits = zone[1:].replace(":", "")
    return (1 if zone[0] == "+" else -1) * (int(digits[:2]) * 3600 + int(digits[2:]) * 60)


def datetime_ns(text: str) -> int:
    """ns since 1970 (UTC) of one date and time as text (module docstring), which must give the
    date; ValueError for anything else."""
    days, ns = _parts(text)
    if days is None:
        raise ValueError(f"no date: {text[:40]!r}")
    return days * _DAY_NS + ns


def datetimes(texts: Sequence[str]) -> np.ndarray:
    """(N,) datetime64[ns] of a column of dates and times as text (module docstring); times of day
    alone get a day added wherever they go back by more than 12 h (past midnight), from 1970-01-01.
    ValueError, naming the row, where a text is none, or some give a date and some do not."""
    parts = []
    for row, text in enumerate(texts, 1):
        try:
            parts.append(_parts(text))
        except ValueError as err:
            raise ValueError(f"row {row}: {err}") from None
    if len({days is None for days, _ in parts}) > 1:
        raise ValueError("some rows give a date and some do not")
    ns = np.array([ns for _, ns in parts], dtype=np.int64)
    if parts and parts[0][0] is None:
        ns += np.concatenate([[0], np.cumsum(np.diff(ns) < -_DAY_NS // 2)]).astype(np.int64) * _DAY_NS
    else:
        ns += np.array([days for days, _ in parts], dtype=np.int64) * _DAY_NS
    return ns.astype("datetime64[ns]")
