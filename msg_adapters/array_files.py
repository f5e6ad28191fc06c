"""Recordings in files of named arrays, as robot-learning datasets publish them: MATLAB files
(``.mat``), and NumPy's (``.npz``) and HDF5 files (``.h5``, ``.hdf5``) holding the same arrays,
each array a variable (an HDF5 file's top-level datasets; its groups are no recording), stored as
numpy writes them (samples in rows, or transposed).

A MATLAB file holds several recordings (trajectories), each a *part* named after its variables:
``BaxterDirectDynamics.mat:baxtertraj3`` (:func:`split_part`). A file of one part is read as it is;
of several, the commands take each as one recording (:func:`array_parts`), or the one named.

Layouts, told apart by the variables' shapes (rows are samples; each block of 7 columns is the arm's
joints s0, s1, e0, e1, w0, w1, w2; rad, rad/s, N·m; no time column: the sample rate is estimated
from q and q̇ or given, as for a table without one, :mod:`msg_adapters.csv_io`):

- **forward dynamics**, a matrix of 35 columns ``[q, q̇, τ, q⁺, q̇⁺]`` (a sample, the torque, the
  next sample; e.g. ``baxtertraj1`` … ``baxtertraj10`` of BaxterDirectDynamics.mat): one part per
  variable, accepted only where the next state is the following row's (the layout's own check);
- **inverse dynamics**, ``X<s>`` of 21 columns ``[q, q̇, q̈]`` beside ``Y<s>`` of 7 ``[τ]`` (e.g.
  ``X_train``/``Y_train`` and ``X_test``/``Y_test`` of BaxterRand.mat): one part per pair, named by
  ``<s>`` without its leading underscore (``train``), ``XY`` for a bare ``X``/``Y``, the X
  variable's name where another part or variable has that name already;
- a matrix of 28 columns ``[q, q̇, q̈, τ]`` (the SARCOS layout): one part per variable;
- **one variable per quantity**, each of 7 columns: ``q``, ``dq``, ``tau`` and a time vector ``t``
  (optional), named as :func:`msg_adapters.table_columns.block_meaning` reads them (``pos``,
  ``qd``, ``torque``, ``time_s``, degrees converted, …): one part per label, the words their names
  share beside the quantity (``q_train``, ``dq_train``, ``tau_train``: part ``train``; none: the
  part is named after its variables, ``q_dq_tau``). A time whose name gives no unit is read in the
  one in which its steps match the velocities.

Matrices stored transposed are read too (a layout with samples in rows is taken first). Parts come
in the file's order, but a part named ``test`` (a dataset's own held-out split) last, the one
``diagnose`` holds out when given the file alone. The given q̈ is not used (the package estimates
its own from q̇). A file names no arm: ``--arm`` is needed. Only matrices of doubles or singles
are read: other variables (integers, logicals, text, structs, other shapes) are ignored, and a file
with no recording names what it holds. Refused: complex numbers; a variable name given twice.

MATLAB's v7.3 files (HDF5, what ``save -v7.3`` writes and files over 2 GB need) are read with h5py:
each top-level dataset is a variable, its MATLAB class in the attribute ``MATLAB_class``, stored
column-major (an N×35 matrix as a dataset of shape (35, N)); groups (structs), references and empty
variables are not recordings. Variables come in the order the file lists them (by name where it
keeps no creation order).
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from baxter_dynamics_ros.core.joints import JOINT_SUFFIXES
from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.errors import RecordingFileError

from .csv_io import Note, columns_recording, side_in_file_name
from .table_columns import QUANTITIES, block_meaning, time_columns
from .text_files import kind_suffix

__all__ = ["ARRAY_FILES", "array_parts", "read_array_recording", "split_part"]

#: The kinds of files of named arrays read (suffix -> what messages call them): MATLAB's, and
#: NumPy's and HDF5's holding arrays as MATLAB's variables.
ARRAY_FILES = {".mat": "MATLAB file", ".npz": "NumPy .npz file", ".h5": "HDF5 file", ".hdf5": "HDF5 file"}
#: An input naming one part of such a file: ``<file>.mat:<part>``.
_PART_ADDRESS = re.compile(r"^(?P<file>.+\.(?:mat|npz|h5|hdf5)):(?P<part>[^:/\\]+)$", re.IGNORECASE)
_JOINTS = len(JOINT_SUFFIXES)
#: columns of a matrix layout -> (what its blocks of 7 columns hold, the index of q̇'s and τ's blocks)
_MATRIX_LAYOUTS = {5 * _JOINTS: ("[q, q̇, τ, q⁺, q̇⁺]", 1, 2), 4 * _JOINTS: ("[q, q̇, q̈, τ]", 1, 3)}
#: The MATLAB classes of the matrices read (integers, logicals, text and the rest are not recordings).
_NUMBER_CLASSES = ("double", "single")
#: The part a dataset holds out as its test data, put last (what ``diagnose`` holds out by default).
_TEST_PART = "test"
#: The class given an HDF5 variable whose name is no UTF-8 text (h5py gives it as bytes): listed by
#: a spelling of its bytes, never read (no part can name it).
_NAME_NOT_TEXT = "name not UTF-8"


def split_part(path: str | os.PathLike[str]) -> tuple[Path, str | None]:
    """The file on disk and the part an input names: ``x.mat:traj1`` -> (x.mat, "traj1"); any other
    path (one that exists as given included) -> (path, None)."""
    path = Path(path)
    match = None if path.exists() else _PART_ADDRESS.match(str(path))
    return (path, None) if match is None else (Path(match["file"]), match["part"])


def _hdf5_variables(path: Path) -> Iterator[tuple[str, tuple[int, ...], str, Any]]:
    """(name, MATLAB shape, MATLAB class, h5py object) of each variable of the v7.3 file at path,
    inside an open file (a generator used within one ``with``)."""
    import h5py

    with h5py.File(path, "r") as f:
        for name, item in f.items():
            if isinstance(name, bytes):
                yield repr(name), (), _NAME_NOT_TEXT, item
                continue
            if name.startswith("#"):  # "#refs#", "#subsystem#": MATLAB's own storage, no variable
                continue
            cls = item.attrs.get("MATLAB_class", b"")
            cls = cls.decode(errors="replace") if isinstance(cls, bytes) else str(cls)
            if not isinstance(item, h5py.Dataset):  # a struct (a group)
                yield name, (), cls, item
            elif item.attrs.get("MATLAB_empty", 0):  # its data are the dimensions, not values
                yield name, (), "empty", item
            else:
                yield name, tuple(item.shape[::-1]), cls, item


def _numpy_class(dtype: np.dtype) -> str:
    """The MATLAB class of an array of ``dtype`` ("double", "single"; else numpy's name of it)."""
    return {"float64": "double", "float32": "single"}.get(np.dtype(dtype).name, np.dtype(dtype).name)


@contextmanager
def _plain_arrays(path: Path) -> Iterator[Any]:
    """The arrays of a NumPy .npz or HDF5 file by name (an HDF5 group among them), open while the
    block runs; any error of the file's, there or in the block, a RecordingFileError naming its kind."""
    try:
        with ExitStack() as stack:
            if kind_suffix(path) == ".npz":
                stream = stack.enter_context(open(path, "rb"))  # numpy leaves a path it opened open on errors
                yield stack.enter_context(np.load(stream, allow_pickle=False))
            else:
                import h5py

                yield stack.enter_context(h5py.File(path, "r"))
    except Exception as err:  # noqa: BLE001 - numpy's and h5py's errors all mean "not a readable file of this kind"
        raise RecordingFileError(f"{path}: not a readable {ARRAY_FILES[kind_suffix(path)]} ({err})") from err


def _plain_contents(path: Path) -> list[tuple[str, tuple[int, ...], str]]:
    """(name, shape, class) of each array of a NumPy .npz or HDF5 file (top level; an HDF5 group is
    class "group"), shapes as stored (samples in rows or, transposed, in columns)."""
    with _plain_arrays(path) as arrays:
        items = [(name, arrays[name]) for name in arrays]  # an .npz array read once
        return [
            (repr(name), (), _NAME_NOT_TEXT) if isinstance(name, bytes)
            else (name, item.shape, _numpy_class(item.dtype)) if hasattr(item, "dtype")
            else (name, (), "group")
            for name, item in items
        ]


def _contents(path: Path) -> list[tuple[str, tuple[int, ...], str]]:
    """The variables of the file of arrays at path: (name, shape, MATLAB class), without their data."""
    from scipy.io import whosmat

    if not path.is_file():
        raise RecordingFileError(f"{path}: no such file")
    if kind_suffix(path) != ".mat":
        return _plain_contents(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy's notes on odd files; what matters is refused below
            contents = [(name, tuple(shape), cls) for name, shape, cls in whosmat(str(path))]
    except NotImplementedError:  # scipy's answer to v7.3: HDF5
        try:
            contents = [(name, shape, cls) for name, shape, cls, _ in _hdf5_variables(path)]
        except Exception as err:  # noqa: BLE001 - h5py's errors all mean "not a readable HDF5 file"
            raise RecordingFileError(f"{path}: a MATLAB v7.3 file whose HDF5 cannot be read ({err})") from err
    except Exception as err:  # noqa: BLE001 - scipy's errors all mean "not a readable MATLAB file"
        raise RecordingFileError(f"{path}: not a readable MATLAB file ({err})") from err
    names = [name for name, _, _ in contents]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise RecordingFileError(f"{path}: variable {', '.join(twice)} appears more than once in this {ARRAY_FILES[kind_suffix(path)]}; which one holds the data cannot be known")
    return contents


def _rows_first(shape: tuple[int, ...], columns: int) -> bool | None:
    """Whether a matrix of ``shape`` holds samples in rows (True), in columns (False: stored
    transposed), or is not a matrix of ``columns`` columns (None)."""
    if len(shape) != 2:
        return None
    if shape[1] == columns:
        return True
    return False if shape[0] == columns else None


def _matrix_layout(shape: tuple[int, ...]) -> int | None:
    """The columns of the matrix layout a variable of ``shape`` is in: one of samples in rows first,
    then one stored transposed; None for neither."""
    for rows_first in (True, False):
        for columns in _MATRIX_LAYOUTS:
            if _rows_first(shape, columns) is rows_first:
                return columns
    return None


def _recordings(path: Path, contents: list[tuple[str, tuple[int, ...], str]]) -> dict[str, tuple[str, ...]]:
    """part name -> its variables (one matrix, the X and Y of a pair, or the q, q̇, τ blocks and a time) of a file's
    :func:`_contents`, in the file's order but a part named ``test`` last; {} for none."""
    numbers = {name: shape for name, shape, cls in contents if cls in _NUMBER_CLASSES}
    parts: dict[str, tuple[str, ...]] = {}
    for name, shape in numbers.items():
        y = "Y" + name[1:]
        if name.startswith("X") and _rows_first(shape, 3 * _JOINTS) is not None and _rows_first(numbers.get(y, ()), _JOINTS) is not None:
            short = name[1:].lstrip("_") or "XY"
            parts[name if short in numbers or short in parts else short] = (name, y)
        elif _matrix_layout(shape) is not None:
            parts[name] = (name,)
    blocks: dict[str, dict[str, str]] = {}  # label -> quantity or "time" -> variable
    for name, shape in numbers.items():
        said = block_meaning(name)
        if said is not None and (len(shape) == 2 and 1 in shape if said[0] == "time" else _rows_first(shape, _JOINTS) is not None):
            held = blocks.setdefault(said[1], {})
            if said[0] in held:
                raise RecordingFileError(
                    f"{path}: variables {held[said[0]]} and {name} both hold the {said[0]} of recording {said[1] or 'of no label'}; "
                    "which one holds the data cannot be known"
                )
            held[said[0]] = name
    for label, held in blocks.items():
        if all(quantity in held for quantity in QUANTITIES):
            names = tuple(held[k] for k in (*QUANTITIES, "time") if k in held)
            short = label or "_".join(names[:3])
            parts[names[0] if short in numbers or short in parts else short] = names
    return dict(sorted(parts.items(), key=lambda item: item[0] == _TEST_PART))


def _parts(path: Path) -> dict[str, tuple[str, ...]]:
    """:func:`_recordings`, refusing a file that holds none by what it holds."""
    contents = _contents(path)
    parts = _recordings(path, contents)
    if not parts:
        held = ", ".join(" ".join(filter(None, (n, "×".join(map(str, s)), c))) for n, s, c in contents) or "no variables"
        raise RecordingFileError(
            f"{path}: no recording in this {ARRAY_FILES[kind_suffix(path)]} (holds {held}); expected matrices of {' / '.join(_NUMBER_CLASSES)} "
            "of 35 columns [q, q̇, τ, q⁺, q̇⁺] or 28 [q, q̇, q̈, τ], X<s> of 21 columns [q, q̇, q̈] with Y<s> of 7 [τ], "
            "or q, dq, tau of 7 columns each (and a time t), named as msg_adapters.table_columns reads them"
        )
    return parts


def array_parts(path: str | os.PathLike[str]) -> list[str]:
    """The names of the recordings (parts) in the MATLAB file at path (module docstring); [] for a
    readable file that holds none (RecordingFileError for one that cannot be read)."""
    return list(_recordings(Path(path), _contents(Path(path))))


def _matrix(path: Path, data: dict, name: str, columns: int) -> np.ndarray:
    """Variable ``name`` of loaded ``data`` as an (N, columns) float64 array, samples in rows."""
    values = np.asarray(data[name])
    if np.iscomplexobj(values):
        raise RecordingFileError(f"{path}: variable {name} holds complex numbers; angles, velocities and torques are real")
    values = values.astype(np.float64)
    return values if _rows_first(values.shape, columns) else values.T


def _layout_arrays(path: Path, part: str, names: tuple[str, ...], data: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, τ (N, 7) of one part from its loaded variables."""
    n = _JOINTS
    if len(names) >= 3:  # q, q̇, τ blocks (and the time)
        q, qd, tau = (_matrix(path, data, name, n) * block_meaning(name)[2] for name in names[:3])
        if not len(q) == len(qd) == len(tau):
            raise RecordingFileError(f"{path}:{part}: {names[0]}, {names[1]} and {names[2]} have {len(q)}, {len(qd)} and {len(tau)} samples")
        return q, qd, tau
    if len(names) == 2:
        x, y = _matrix(path, data, names[0], 3 * n), _matrix(path, data, names[1], n)
        if len(x) != len(y):
            raise RecordingFileError(f"{path}:{part}: {names[0]} has {len(x)} samples but {names[1]} {len(y)}")
        return x[:, :n], x[:, n : 2 * n], y
    columns = _matrix_layout(np.shape(data[names[0]]))
    what, velocity, torque = _MATRIX_LAYOUTS[columns]
    values = _matrix(path, data, names[0], columns)
    if columns == 5 * n and len(values) > 1:
        state, following = values[:-1, 3 * n :], values[1:, : 2 * n]
        # equal as stored, to single precision's rounding; a few rows may differ (a sample lost);
        # values beyond any robot's (±1e308) compare unequal, not with a warning
        with np.errstate(over="ignore", invalid="ignore"):
            next_state = np.mean(np.isclose(state, following, rtol=1e-6, atol=1e-9).all(axis=1)) > 0.5
        if not next_state:
            raise RecordingFileError(
                f"{path}:{part}: 35 columns, but columns 22-35 are not the next row's q and q̇ in most rows, "
                f"so they are not the layout {what}; no other layout of 35 columns is known"
            )
    return values[:, :n], values[:, velocity * n : (velocity + 1) * n], values[:, torque * n : (torque + 1) * n]


def _load(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Variables ``names`` of the file of arrays at path, each as MATLAB holds it (rows, columns)."""
    from scipy.io import loadmat

    if kind_suffix(path) != ".mat":
        with _plain_arrays(path) as arrays:
            return {name: arrays[name][()] for name in names}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return loadmat(str(path), variable_names=list(names))
    except NotImplementedError:  # v7.3
        pass
    except Exception as err:  # noqa: BLE001 - as in _contents
        raise RecordingFileError(f"{path}: not a readable MATLAB file ({err})") from err
    data = {}
    try:
        for name, _, _, item in _hdf5_variables(path):
            if name in names:
                values = item[()]
                if values.dtype.names is not None and {"real", "imag"} <= set(values.dtype.names):
                    values = values["real"] + 1j * values["imag"]  # MATLAB's complex: a compound of two
                data[name] = np.asarray(values).T
    except Exception as err:  # noqa: BLE001 - as in _contents
        raise RecordingFileError(f"{path}: a MATLAB v7.3 file whose HDF5 cannot be read ({err})") from err
    return data


def read_array_recording(
    path: str | os.PathLike[str],
    part: str | None = None,
    *,
    arm: str | None = None,
    rate_hz: float | None = None,
    note: Note | None = None,
) -> Recording:
    """One part of the MATLAB file at path as the recording of ``arm`` (module docstring); part None
    for a file of one part. rate_hz: the sample rate, Hz, None to estimate it (said through note).
    Raises RecordingFileError naming the file and part."""
    path = Path(path)
    parts = _parts(path)
    if part is None:
        if len(parts) > 1:
            raise RecordingFileError(
                f"{path}: holds {len(parts)} recordings ({', '.join(parts)}); name one as {path}:PART, "
                "or give the file to diagnose or calibrate, which take each as one recording"
            )
        part = next(iter(parts))
    if part not in parts:
        raise RecordingFileError(f"{path}: no recording {part!r} in this {ARRAY_FILES[kind_suffix(path)]}; it holds {', '.join(parts)}")
    label = f"{path}:{part}" if len(parts) > 1 else str(path)
    if arm is None:
        arm = side_in_file_name(path)
        if arm is None:
            raise RecordingFileError(f"{label}: a {ARRAY_FILES[kind_suffix(path)]} names no arm, nor does the file name; pass --arm right|left")
        if note is not None:
            note(f"{label}: a {ARRAY_FILES[kind_suffix(path)]} names no arm; read as the {arm} arm, which the file name names (--arm sets it)")
    data = _load(path, parts[part])
    q, qd, effort = _layout_arrays(path, part, parts[part], data)
    columns = {
        f"{prefix}_{joint}": values[:, k]
        for prefix, values in (("position", q), ("velocity", qd), ("effort", effort))
        for k, joint in enumerate(JOINT_SUFFIXES)
    }
    if len(parts[part]) == 4:  # with its time
        columns.update(_time_column(path, part, parts[part][3], data, len(q)))
    return columns_recording(Path(label), columns, arm=arm, rate_hz=rate_hz, note=note)


def _time_column(path: Path, part: str, name: str, data: dict, samples: int) -> dict[str, np.ndarray]:
    """A part's time variable as a table's time column: ``time_s`` where its name gives the unit,
    else one named as the variable (``time`` where it has a label: ``t_train``), its unit inferred
    from the velocities (:mod:`msg_adapters.csv_io`)."""
    if np.iscomplexobj(data[name]):
        raise RecordingFileError(f"{path}: variable {name} holds complex numbers; times are real")
    t = np.asarray(data[name], dtype=np.float64).reshape(-1)
    if len(t) != samples:
        raise RecordingFileError(f"{path}:{part}: {name} has {len(t)} samples but the joints' {samples}")
    scale_s = block_meaning(name)[2]
    if scale_s is not None:
        return {"time_s": t * scale_s}
    return {name if time_columns([name]) else "time": t}  # named as the file does where a table's column could be
