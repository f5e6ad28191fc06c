"""The package's error classes: one per layer, each message naming the field or path and the fix."""

from __future__ import annotations

__all__ = ["BaxterDynamicsError", "ModelFileError", "InputShapeError"]


class BaxterDynamicsError(Exception):
    """Base class of every error this package raises on purpose."""


class ModelFileError(BaxterDynamicsError):
    """An arm model file is missing, unreadable or holds an invalid field."""


class InputShapeError(BaxterDynamicsError, ValueError):
    """An array handed to the dynamics has the wrong shape."""
