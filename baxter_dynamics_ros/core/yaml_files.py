"""The package's YAML inputs (arm models, effects specs, thresholds) read one way.

:func:`read_yaml` turns every way a file can fail to be YAML — missing or unreadable, not UTF-8
text (a binary file), not valid YAML (including values YAML itself cannot construct, such as a
date 2024-13-45, and nesting too deep to parse), empty — into the caller's error class, naming the
path. Aliases (``*name``) are refused: none of the package's files needs them, and nested aliases
(a "billion laughs" file of 600 bytes) expand to gigabytes. What the parsed document must hold is
left to the caller.
"""

from __future__ import annotations

import os
from typing import Any

import yaml

from ..errors import BaxterDynamicsError

__all__ = ["read_yaml"]


class _AliasError(yaml.YAMLError):
    """An alias met while composing the document."""


class _NoAliasLoader(yaml.SafeLoader):
    """yaml's safe loader, refusing aliases (``*name``) where it meets them, before any expansion."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            mark = self.peek_event().start_mark
            raise _AliasError(f"line {mark.line + 1}, column {mark.column + 1}")
        return super().compose_node(parent, index)


def read_yaml(path: str | os.PathLike[str], error: type[BaxterDynamicsError], what: str) -> Any:
    """The document of the YAML file ``path``, never None.

    error: the exception class raised for a file that cannot be read as YAML or holds nothing;
    what: the file's kind in the messages (e.g. "model file").
    """
    try:
        with open(path, "rb") as stream:
            data = stream.read()
    except OSError as err:
        raise error(f"{path}: cannot read the {what} ({err.strerror or err})") from err
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{path}: the {what} is not UTF-8 text (byte {err.start} is {data[err.start]:#04x}); is it a YAML file?") from err
    try:
        document = yaml.load(text, Loader=_NoAliasLoader)  # noqa: S506 - a safe loader
    except _AliasError as err:
        raise error(f"{path}: the {what} uses a YAML alias (*name) at {err}; aliases are not accepted, write the values out") from err
    except yaml.YAMLError as err:
        raise error(f"{path}: the {what} is not valid YAML ({' '.join(str(err).split())})") from err
    except (ValueError, TypeError, OverflowError, RecursionError) as err:  # a value yaml cannot construct, or too deep
        raise error(f"{path}: the {what} is not valid YAML ({type(err).__name__}: {err})") from err
    if document is None:
        raise error(f"{path}: the {what} is empty")
    return document
