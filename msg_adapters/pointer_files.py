"""Files that stand in for a recording without holding it: the pointers Git LFS and git-annex leave
in a clone of a dataset's repository whose contents were not fetched.

- Git LFS (its pointer specification, in the git-lfs repository): a text file of at most a few hundred bytes, its first
  line ``version https://git-lfs.github.com/spec/v1`` (``https://hawser.github.com/spec/v1`` in
  early versions), then ``oid sha256:…`` and ``size <bytes>``;
- git-annex: a symbolic link into ``.git/annex/objects/…`` that leads nowhere until ``git annex
  get``, or (an unlocked file) a text file whose one line is ``/annex/objects/…``.

Read as a table, a bag or a MATLAB file, such a pointer is refused as a damaged file; said for what
it is, the fix is one command.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

__all__ = ["pointer_file"]

#: The first line of a Git LFS pointer, in every version of the spec.
LFS_VERSIONS = (b"version https://git-lfs.github.com/spec/v1\n", b"version https://hawser.github.com/spec/v1\n")
#: A pointer is smaller than this (Git LFS writes at most ~200 bytes); larger files are never read here.
MAX_POINTER_BYTES = 1024
ANNEX_OBJECTS = "annex/objects/"
_LFS_SIZE = re.compile(rb"^size (\d+)$", re.MULTILINE)


def pointer_file(path: str | os.PathLike[str]) -> str | None:
    """What stands at ``path`` in place of its contents, with the command that fetches them; None
    where the path holds its contents (or is no pointer: a missing file, a folder)."""
    path = Path(path)
    if path.is_symlink() and not path.exists():
        target = os.readlink(path)
        return f"a git-annex link whose content is not in this clone ({target}): fetch it with `git annex get`" if ANNEX_OBJECTS in target else None
    if not path.is_file() or path.stat().st_size >= MAX_POINTER_BYTES:
        return None
    head = path.read_bytes()
    if head.startswith(LFS_VERSIONS):
        size = _LFS_SIZE.search(head)
        stored = f" of {int(size.group(1)):,} bytes" if size else ""
        return f"a Git LFS pointer to a file{stored}, not the file itself: fetch it with `git lfs pull` (or download the file)"
    if head.startswith(b"/" + ANNEX_OBJECTS.encode()):
        return "a git-annex pointer, not the file itself: fetch it with `git annex get`"
    return None
