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
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, TextIO

from baxter_dynamics_ros.errors import RecordingFileError

__all__ = ["COMPRESSION_SUFFIXES", "TEXT_SUFFIXES", "first_line", "kind_suffix", "open_text", "read_text", "reading", "stem"]

#: Suffixes of text tables.
TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")
#: Compression suffix -> the function that opens such a file as a text stream.
_OPENERS = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}
COMPRESSION_SUFFIXES = tuple(_OPENERS)
#: What opening or reading a text table may raise besides UnicodeDecodeError: the file's own errors,
#: and a compressed stream's when it is not of its format (gzip, bz2: OSError) or is cut short.
_UNREADABLE = (OSError, EOFError, lzma.LZMAError)


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


def _opener(path: str | os.PathLike[str]) -> Callable[..., IO]:
    """The function that opens ``path``: its compression's, or the built-in ``open``."""
    return _OPENERS.get(_split(path)[2], open)


def open_text(path: str | os.PathLike[str]) -> TextIO:
    """``path`` opened to read text: UTF-8, a byte-order mark dropped, decompressed when it is a
    compressed text table; read it inside :func:`reading`, which says in words what goes wrong."""
    return _opener(path)(path, "rt", encoding="utf-8-sig")


def first_line(path: str | os.PathLike[str], limit: int) -> str | None:
    """The first line of a text table (within its first ``limit`` bytes, decompressed; line end
    dropped), None where the file cannot be read or that line is no UTF-8 text: what comes after it
    is not looked at."""
    try:
        with _opener(path)(path, "rb") as f:
            return f.read(limit).split(b"\n", 1)[0].rstrip(b"\r").decode("utf-8-sig")
    except (*_UNREADABLE, UnicodeDecodeError):
        return None


@contextmanager
def reading(path: str | os.PathLike[str]) -> Iterator[None]:
    """A block that reads the text table at ``path``: the file's errors, a compressed stream's that
    is not of its format or cut short, and bytes that are no UTF-8 text become RecordingFileError
    naming the path."""
    try:
        yield
    except EOFError as err:  # a compressed file cut short
        raise RecordingFileError(f"{path}: cannot read the file (it is cut short{': ' + str(err) if str(err) else ''})") from err
    except _UNREADABLE as err:
        raise RecordingFileError(f"{path}: cannot read the file ({getattr(err, 'strerror', None) or str(err) or type(err).__name__})") from err
    except UnicodeDecodeError as err:
        raise RecordingFileError(f"{path}: not a text table ({err})") from err


def read_text(path: str | os.PathLike[str]) -> str:
    """The whole text of a text table (as :func:`open_text`, errors as :func:`reading` says them)."""
    with reading(path), open_text(path) as f:
        return f.read()
