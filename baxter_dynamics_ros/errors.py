"""The package's error classes: one per layer, each message naming the field or path and the fix."""

from __future__ import annotations

__all__ = ["BaxterDynamicsError", "ModelFileError", "InputShapeError", "RecordingError", "RecordingFileError", "EffectSpecError", "SimulationError", "PlaybackError", "SettingsError", "DiagnosisError", "CollisionError", "OutputError", "WorkerError", "QueryError"]


class BaxterDynamicsError(Exception):
    """Base class of every error this package raises on purpose."""


class ModelFileError(BaxterDynamicsError):
    """An arm model file is missing, unreadable or holds an invalid field."""


class InputShapeError(BaxterDynamicsError, ValueError):
    """An array handed to the dynamics has the wrong shape."""


class RecordingError(BaxterDynamicsError, ValueError):
    """A recording's arrays are inconsistent (shapes, time order, non-finite values, unknown arm)."""


class RecordingFileError(BaxterDynamicsError):
    """A bag or table file cannot be read or written: missing, corrupt, lacking the arm's joints."""


class EffectSpecError(BaxterDynamicsError, ValueError):
    """An unmodelled-effect specification (YAML/JSON or constructor arguments) is invalid."""


class SimulationError(BaxterDynamicsError):
    """A simulation cannot run as asked: a trajectory leaves the joint limits, the integration would be unstable."""


class PlaybackError(BaxterDynamicsError):
    """Playback into ROS cannot go on (no subscriber came, nothing to play)."""


class SettingsError(BaxterDynamicsError, ValueError):
    """A setting of the dynamics node (a ROS parameter) has an invalid value."""


class DiagnosisError(BaxterDynamicsError):
    """A gap diagnosis cannot run on the data given (no test data, mixed arms, too little data)."""


class CollisionError(BaxterDynamicsError, ValueError):
    """Collision monitoring cannot run as asked: bad thresholds file, gains or calibration data."""


class OutputError(BaxterDynamicsError):
    """An output cannot be written: a folder or file in the way, no permission, no space."""


class WorkerError(BaxterDynamicsError):
    """Per-file work cannot run in worker processes or on a cluster (scheduler unreachable, a worker died)."""


class QueryError(BaxterDynamicsError, ValueError):
    """A dynamics query (a service request) cannot be answered: joint names, lengths, non-finite
    values, too many states, effects asked for but not loaded."""
