"""Text tables as datasets publish them: plain or compressed whole, UTF-8 with or without a byte-order mark.

A text table's kind is its suffix (``.csv``, ``.txt``, ``.tsv``, ``.dat``, in any case); a
compression's suffix after it (``run.csv.gz``, ``run.txt.bz2``, ``run.tsv.xz``) means the file is
that table compressed, and it is decompressed as it is read. :func:`kind_suffix` says what any
input holds, so that the readers, the folder listing and the output names agree on it.
"""

from __future__ import annotations

import bz2
import gzip
import lzma
import os
from pathlib import Path
from typing import TextIO

from baxter_dynamics_ros.errors import RecordingFileError

__all__ = ["COMPRESSION_SUFFIXES", "TEXT_SUFFIXES", "UNREADABLE", "first_line", "kind_suffix", "open_text", "read_text", "stem", "unreadable_reason"]

#: Suffixes of text tables.
TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")
#: Compression suffix -> the function that opens such a file as a text stream.
_OPENERS = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}
COMPRESSION_SUFFIXES = tuple(_OPENERS)
#: What opening or reading a text table may raise besides UnicodeDecodeError: the file's own errors,
#: and a compressed stream's when it is not of its format (gzip, bz2: OSError) or is cut short.
UNREADABLE = (OSError, EOFError, lzma.LZMAError)


def _split(path: str | os.PathLike[str]) -> tuple[str, str, str]:
    """(name without the kind and compression suffixes, kind suffix lower-case, compression suffix or "")."""
    name = Path(path).name
    outer = Path(name).suffix
    if outer.lower() in _OPENERS and Path(name[: -len(outer)]).suffix.lower() in TEXT_SUFFIXES:
        inner = Path(name[: -len(outer)]).suffix
        return name[: -len(outer) - len(inner)], inner.lower(), outer.lower()
    return (name[: -len(outer)] if outer else name), outer.lower(), ""


def kind_suffix(path: str | os.PathLike[str]) -> str:
    """What a file holds, as its suffix in lower case: ``.csv`` for ``run.csv``, ``run.CSV`` and
    ``run.csv.gz``; "" without one (a ROS 2 bag folder). A compression suffix counts only after a
    text table's (``run.mat.gz`` is ``.gz``, no kind this package reads)."""
    return _split(path)[1]


def stem(path: str | os.PathLike[str]) -> str:
    """The name without what :func:`kind_suffix` reads: ``run`` for ``run.csv.gz``."""
    return _split(path)[0]


def open_text(path: str | os.PathLike[str]) -> TextIO:
    """``path`` opened to read text: UTF-8, a byte-order mark dropped, decompressed when it is a
    compressed text table. Opening or reading it raises one of :data:`UNREADABLE` where the file
    cannot be read or decompressed (corrupt, cut short), UnicodeDecodeError where it is no UTF-8 text."""
    compression = _split(path)[2]
    if not compression:
        return open(path, encoding="utf-8-sig")
    return _OPENERS[compression](path, "rt", encoding="utf-8-sig")


def first_line(path: str | os.PathLike[str], limit: int) -> str | None:
    """The first line of a text table (within its first ``limit`` bytes, decompressed; line end
    dropped), None where the file cannot be read or that line is no UTF-8 text: what comes after it
    is not looked at."""
    compression = _split(path)[2]
    try:
        with (_OPENERS[compression](path, "rb") if compression else open(path, "rb")) as f:
            return f.read(limit).split(b"\n", 1)[0].rstrip(b"\r").decode("utf-8-sig")
    except (*UNREADABLE, UnicodeDecodeError):
        return None


def read_text(path: str | os.PathLike[str]) -> str:
    """The whole text of a text table (as :func:`open_text`); RecordingFileError naming the path
    when it cannot be read or decompressed, or is no UTF-8 text."""
    try:
        with open_text(path) as f:
            return f.read()
    except UNREADABLE as err:
        raise RecordingFileError(f"{path}: cannot read the file ({unreadable_reason(err)})") from err
    except UnicodeDecodeError as err:
        raise RecordingFileError(f"{path}: not a text table ({err})") from err


def unreadable_reason(err: BaseException) -> str:
    """Why a file could not be read, in words (a truncated compressed file's EOFError has none)."""
    if isinstance(err, EOFError):
        return f"it is cut short: {err}" if str(err) else "it is cut short"
    if isinstance(err, OSError) and err.strerror:
        return err.strerror
    return str(err) or type(err).__name__
