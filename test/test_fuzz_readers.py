"""Property-based fuzz of the file readers (issue 12): whatever a file holds, reading it gives a
recording / model / effects / thresholds, or the package's own error — never another exception.

Inputs: random bytes; random text from the characters these formats are made of; and real files
(the packaged arm model and effects example, a thresholds file as `calibrate` writes it, a table
in each layout, a ``rostopic echo -p`` dump, a bagpy table, echoed messages) with one part replaced, removed or added,
written back as text. The examples are the same every run (``test/conftest.py``).
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from repo_paths import REPO
from recorded_bags import (
    BAXTER_JOINTS, echo_message, joint_states, rostopic_plot_header, rostopic_plot_row, write_bagpy_table, write_rosbag_to_csv_table,
)  # fmt: skip

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.cli.simulate import load_spec
from baxter_dynamics_ros.core.compensation import load_compensation
from baxter_dynamics_ros.core.effect_specs import load_effects
from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.errors import BaxterDynamicsError
from baxter_dynamics_ros.monitoring.thresholds import Thresholds, read_thresholds, write_thresholds
from msg_adapters.recording_files import read_recording

pytestmark = pytest.mark.filterwarnings("error")  # a warning on stderr is no more welcome than a traceback
ARM = load_arm_model("right")
FUZZ = settings(max_examples=150, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
_folder = Path(tempfile.mkdtemp(prefix="baxter-fuzz-"))  # one file rewritten per example; hypothesis reuses no fixture


def _write(name: str, data: bytes | str) -> Path:
    path = _folder / name
    path.write_bytes(data.encode("utf-8", "surrogatepass") if isinstance(data, str) else data)
    return path


def _thresholds_text() -> str:
    path = _folder / "thresholds-source.yaml"
    path.unlink(missing_ok=True)
    write_thresholds(path, Thresholds(np.full(7, 2.0), np.full(7, 0.5)))
    return path.read_text()


YAML_READERS = {
    "arm model": (lambda p: load_arm_model(p), (REPO / "config" / "baxter_right_arm.yaml").read_text()),
    "effects": (lambda p: load_effects(p), (REPO / "config" / "effects_example.yaml").read_text()),
    "compensation": (lambda p: load_compensation(ARM, p), (REPO / "config" / "effects_example.yaml").read_text()),
    "simulation spec": (lambda p: load_spec(p), (REPO / "config" / "effects_example.yaml").read_text()),
    "thresholds": (lambda p: read_thresholds(p), _thresholds_text()),
}


def _only_our_errors(read, path: Path) -> None:
    try:
        read(path)
    except BaxterDynamicsError as err:
        assert str(err), "an error without a message"
    # Anything else propagates and fails the example, with hypothesis' shrunk input.


# ----------------------------------------------------------------------------------- values
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e308, -1e308, 5e-324, "", "nan", ".inf", "right", "left", "s1", "2024-13-45"]),
    st.text(max_size=8),
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=8) | st.dictionaries(st.text(max_size=8) | st.sampled_from(["s0", "w2", "xx", "mass_kg"]), inner, max_size=5),
    max_leaves=20,
)
yaml_text = st.text(st.sampled_from(list("{}[]:,-#&*!|>'\"%@`? \n\t.0123456789eE+abcdefsxyz_")), max_size=200)


def _paths(tree, prefix=()):
    """Every (path, value) of a parsed YAML tree, the root included."""
    yield prefix, tree
    items = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    for key, child in items:
        yield from _paths(child, (*prefix, key))


@st.composite
def mutated_yaml(draw, source: str) -> str:
    """``source`` parsed, one node replaced by a random value, removed, or given a new key; dumped."""
    tree = yaml.safe_load(source)
    paths = list(_paths(tree))
    path, _ = draw(st.sampled_from(paths))
    action = draw(st.sampled_from(["replace", "remove", "add"]))
    if not path:
        return yaml.safe_dump(draw(values))
    parent = tree
    for key in path[:-1]:
        parent = parent[key]
    if action == "replace":
        parent[path[-1]] = draw(values)
    elif action == "remove":
        del parent[path[-1]]
    elif isinstance(parent, dict):
        parent[draw(st.text(max_size=8))] = draw(values)
    else:
        parent.append(draw(values))
    return yaml.safe_dump(tree, allow_unicode=True)


@pytest.mark.parametrize("reader", YAML_READERS)
@pytest.mark.parametrize("kind", ["bytes", "text"])
def test_yaml_readers_on_random_bytes_and_text(reader: str, kind: str) -> None:
    read, _ = YAML_READERS[reader]
    data = st.binary(max_size=400) if kind == "bytes" else yaml_text | st.text(max_size=100)

    @FUZZ
    @given(data)
    def check(content: bytes | str) -> None:
        _only_our_errors(read, _write("random.yaml", content))

    check()


@pytest.mark.parametrize("reader", YAML_READERS)
def test_yaml_readers_on_real_files_with_one_part_changed(reader: str) -> None:
    read, source = YAML_READERS[reader]
    read(_write("real.yaml", source))  # the file itself reads

    @FUZZ
    @given(mutated_yaml(source))
    def check(text: str) -> None:
        _only_our_errors(read, _write("mutated.yaml", text))

    check()


def test_yaml_nested_too_deep_is_our_error() -> None:
    for reader, (read, _) in YAML_READERS.items():
        with pytest.raises(BaxterDynamicsError, match="not valid YAML"):
            read(_write("deep.yaml", "[" * 100_000))


# ----------------------------------------------------------------------------------- tables
def _table(layout: str, delimiter: str) -> str:
    """A table of the right arm's joints: the Baxter export's layout, the generic one (stamp_ns), or
    the generic one with a time column of dates and times ("dated")."""
    states = joint_states(30, names=BAXTER_JOINTS)
    prefixes = ("ang_", "vel_", "torq_") if layout == "baxter export" else ("position_", "velocity_", "effort_")
    columns = {"stamp_ns": states["stamps_ns"]} if layout == "generic" else {}
    if layout == "dated":
        columns = {"time": [f"2019-05-12 10:00:{t * 1e-9 % 60:09.6f}" for t in states["stamps_ns"]]}
    for prefix, key in zip(prefixes, ("position", "velocity", "effort")):
        columns.update({f"{prefix}{name}": states[key][:, k] for k, name in enumerate(BAXTER_JOINTS) if name.startswith("right_")})
    rows = [delimiter.join(repr(float(v)) if isinstance(v, float) else str(v) for v in row) for row in zip(*columns.values())]
    return "\n".join([delimiter.join(columns), *rows]) + "\n"


def _rostopic_table() -> str:
    """Joint states as ``rostopic echo -p`` prints them (every Baxter joint, 30 messages)."""
    states = joint_states(30, names=BAXTER_JOINTS)
    rows = [rostopic_plot_row(t, t, BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort"))) for k, t in enumerate(states["stamps_ns"])]
    return "\n".join([rostopic_plot_header(BAXTER_JOINTS), *rows]) + "\n"


def _bagpy_table() -> str:
    """Joint states as bagpy writes them (every Baxter joint, 30 messages)."""
    states = joint_states(30, names=BAXTER_JOINTS)
    messages = [(t, t, BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort"))) for k, t in enumerate(states["stamps_ns"])]
    return write_bagpy_table(_folder / "bagpy-source.csv", messages).read_text()


def _rosbag_to_csv_table() -> str:
    """Joint states as the rosbag_to_csv tool writes them (every Baxter joint, 30 messages)."""
    states = joint_states(30, names=BAXTER_JOINTS)
    messages = [(t, t, BAXTER_JOINTS, *(states[f][k] for f in ("position", "velocity", "effort"))) for k, t in enumerate(states["stamps_ns"])]
    return write_rosbag_to_csv_table(_folder / "rosbag-to-csv-source.csv", messages).read_text()


def _echo_dump(ros2: bool) -> str:
    """Joint states as ``rostopic echo`` or ``ros2 topic echo`` prints them (every Baxter joint, 30 messages)."""
    states = joint_states(30, names=BAXTER_JOINTS)
    arrays = [states[f] for f in ("position", "velocity", "effort")]
    return "\n".join(echo_message(t, BAXTER_JOINTS, *(a[k] for a in arrays), ros2=ros2) for k, t in enumerate(states["stamps_ns"])) + "\n"


TABLES = [
    _table("baxter export", " "), _table("generic", ","), _table("dated", ","), _rostopic_table(), _bagpy_table(), _rosbag_to_csv_table(),
    _echo_dump(False), _echo_dump(True),
]  # fmt: skip
tokens = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["", "nan", "inf", "-inf", "1e999", "-", "0x10", "1,5", "١", "NaN", "True", "stamp_ns", "ang_s0"]),
    st.integers(-(2**70), 2**70).map(str),
    st.text(max_size=5),
)


@st.composite
def mutated_table(draw) -> str:
    """A real table with cells, whole lines or header names changed, lines dropped or added."""
    lines = draw(st.sampled_from(TABLES)).splitlines()
    delimiter = "," if "," in lines[0] else " "
    for _ in range(draw(st.integers(1, 4))):
        k = draw(st.integers(0, len(lines) - 1))
        action = draw(st.sampled_from(["cell", "line", "drop", "add", "header"]))
        cells = lines[k].split(delimiter)
        if action == "cell":
            cells[draw(st.integers(0, len(cells) - 1))] = draw(tokens)
            lines[k] = delimiter.join(cells)
        elif action == "line":
            lines[k] = delimiter.join(draw(st.lists(tokens, max_size=30)))
        elif action == "drop" and len(lines) > 1:
            del lines[k]
        elif action == "add":
            lines.insert(k, delimiter.join(draw(st.lists(tokens, max_size=30))))
        else:
            names = lines[0].split(delimiter)
            names[draw(st.integers(0, len(names) - 1))] = draw(st.sampled_from(["time_s", "stamp_ns", "ang_s0", "position_left_s0", "", "x", "time", "q1", "tau_7", "t [ms]"]) | tokens)
            lines[0] = delimiter.join(names)
    return "\n".join(lines) + draw(st.sampled_from(["\n", "", "\n\n", "\r\n"]))


def _read_any(path: Path, arm, rate_hz) -> None:
    try:
        result = read_recording(path, arm=arm, rate_hz=rate_hz, note=None)
    except BaxterDynamicsError as err:
        assert str(err)
        return
    assert isinstance(result, Recording) and len(result) >= 2
    assert all(np.isfinite(a).all() for a in (result.q, result.qd, result.effort))


options = st.tuples(st.sampled_from([None, "right", "left"]), st.sampled_from([None, 100.0, 0.0, -5.0, math.nan, math.inf]))


@pytest.mark.parametrize("suffix", [".csv", ".txt", ".parquet"])
def test_table_reader_on_random_bytes(suffix: str) -> None:
    @FUZZ
    @given(st.binary(max_size=600), options)
    def check(data: bytes, option) -> None:
        _read_any(_write(f"random{suffix}", data), *option)

    check()


def test_table_reader_on_random_text() -> None:
    @FUZZ
    @given(st.text(st.sampled_from(list(" ,\t\n-+.eE0123456789abgnrtvqsw_"))) | st.text(max_size=300), options)
    def check(text: str, option) -> None:
        _read_any(_write("random.csv", text), *option)

    check()


def test_table_reader_on_real_tables_with_parts_changed() -> None:
    for table in TABLES:
        assert read_recording(_write("real.csv", table), note=None).side == "right"

    @FUZZ
    @given(mutated_table(), options)
    def check(text: str, option) -> None:
        _read_any(_write("mutated.csv", text), *option)

    check()


@st.composite
def parquet_tables(draw) -> bytes:
    """A real Parquet file whose columns have the layouts' names and any type: numbers, text, nulls."""
    import io

    import pyarrow as pa
    import pyarrow.parquet as pq

    n = draw(st.integers(0, 12))
    joints = [name for name in BAXTER_JOINTS if name.startswith("right_")]
    names = draw(st.lists(st.sampled_from(["stamp_ns", "time_s", "time", "trial", *(f"{p}{j}" for p in ("position_", "velocity_", "effort_") for j in joints)]), unique=True, max_size=24))
    cells = {
        "float": st.floats(allow_nan=True, allow_infinity=True) | st.none(),
        "int": st.integers(-(2**63), 2**63 - 1),
        "text": st.text(max_size=4),
        "bool": st.booleans(),
        "timestamp": st.integers(-(2**63) + 1, 2**63 - 1) | st.none(),
    }
    types = {"float": pa.float64(), "int": pa.int64(), "text": pa.string(), "bool": pa.bool_(), "timestamp": pa.timestamp("ns", tz="UTC")}
    columns = {}
    for name in names:
        kind = draw(st.sampled_from(list(cells)))
        columns[name] = pa.array(draw(st.lists(cells[kind], min_size=n, max_size=n)), type=types[kind])
    buffer = io.BytesIO()
    pq.write_table(pa.table(columns) if columns else pa.table({"x": pa.array([], pa.float64())}), buffer)
    return buffer.getvalue()


def test_table_reader_on_parquet_files_of_any_column_types() -> None:
    @FUZZ
    @given(parquet_tables(), options)
    def check(data: bytes, option) -> None:
        _read_any(_write("random.parquet", data), *option)

    check()


@pytest.mark.parametrize("dump", [_rostopic_table, _bagpy_table, _rosbag_to_csv_table, lambda: _echo_dump(True)], ids=["rostopic", "bagpy", "rosbag_to_csv", "echo"])
def test_topic_dump_reader_on_random_rows_under_its_header(dump) -> None:
    """Random bytes or text never start with rostopic's or bagpy's header or an echo's first line:
    here every file does, then rows of random fields (numbers, names, lists of names, an echo's
    fields and list items, empty), random lines, or random bytes."""
    header = dump().splitlines()[0]
    names = st.sampled_from(
        [*BAXTER_JOINTS, "l_gripper_l_finger_joint", "", "base", '"[\'left_s0\', \'left_s1\']"', "[]", "['a'", "---", "name:", "- left_s0", "  sec: 1", "  nanosec: 9", "position: [1"]
    )
    row = st.tuples(st.lists(tokens | names, max_size=60), st.sampled_from([",", "\n", " "])).map(lambda r: r[1].join(r[0]))
    body = st.lists(row | st.text(max_size=40), max_size=12).map("\n".join).map(str.encode) | st.binary(max_size=300)

    @FUZZ
    @given(body, options)
    def check(data: bytes, option) -> None:
        _read_any(_write("topic.csv", header.encode() + b"\n" + data), *option)

    check()


def _mat_file() -> bytes:
    """A MATLAB file of a forward-dynamics trajectory and an inverse-dynamics pair (msg_adapters.array_files)."""
    import io

    from scipy.io import savemat

    states = joint_states(40)
    q, qd, tau = (states[k][:, :7] for k in ("position", "velocity", "effort"))
    buffer = io.BytesIO()
    savemat(buffer, {"traj1": np.hstack([q[:-1], qd[:-1], tau[:-1], q[1:], qd[1:]]), "X_train": np.hstack([q, qd, qd]), "Y_train": tau})
    return buffer.getvalue()


@st.composite
def matrices(draw) -> dict:
    """Variables of the layouts' names and shapes (and others), of any values: numbers, NaN, ±inf, text."""
    names = draw(st.lists(st.sampled_from(["traj1", "X", "Y", "X_train", "Y_train", "sarcos", "note", "q", "dq", "tau", "t"]), unique=True, max_size=5))
    out = {}
    for name in names:
        rows = draw(st.integers(0, 6))
        cols = draw(st.sampled_from([0, 1, 7, 21, 28, 35, 3]))
        kind = draw(st.sampled_from(["float", "int", "text"]))
        if kind == "text":
            out[name] = draw(st.text(max_size=6))
        else:
            cells = st.floats(allow_nan=True, allow_infinity=True) if kind == "float" else st.integers(-(2**31), 2**31 - 1)
            out[name] = np.array(draw(st.lists(cells, min_size=rows * cols, max_size=rows * cols)), dtype=float if kind == "float" else np.int32).reshape(rows, cols)
    return out


def test_mat_reader_on_random_bytes_changed_files_and_any_variables() -> None:
    """Random bytes; a real MATLAB file, v5 or v7.3 (HDF5), with bytes changed or cut; files of
    variables of any value, each read whole and part by part."""
    import io

    from recorded_bags import savemat_v73
    from scipy.io import loadmat, savemat

    source = _mat_file()
    assert read_recording(f"{_write('real.mat', source)}:traj1", arm="left", note=None).side == "left"
    scratch = Path(tempfile.mkdtemp(prefix="baxter-fuzz-v73-"))
    v73 = savemat_v73(scratch / "v73.mat", loadmat(_write("real.mat", source), variable_names=["traj1", "X_train", "Y_train"])).read_bytes()
    assert read_recording(f"{_write('v73.mat', v73)}:traj1", arm="left", note=None).side == "left"
    sources = st.sampled_from([source, v73])
    changed = st.tuples(sources, st.floats(0, 1, exclude_max=True), st.binary(min_size=1, max_size=8)).map(
        lambda c: c[0][: int(c[1] * len(c[0]))] + c[2] + c[0][int(c[1] * len(c[0])) + len(c[2]) :]
    )
    cut = st.tuples(sources, st.floats(0, 1, exclude_max=True)).map(lambda c: c[0][: int(c[1] * len(c[0]))])

    def saved(variables: dict) -> bytes:
        buffer = io.BytesIO()
        savemat(buffer, variables)
        return buffer.getvalue()

    @FUZZ
    @given(st.binary(max_size=600) | changed | cut | matrices().map(saved), options)
    def check(data: bytes, option) -> None:
        path = _write("fuzzed.mat", data)
        for part in ("", ":traj1", ":train", ":XY", ":sarcos"):
            _read_any(Path(f"{path}{part}"), *option)

    check()


@pytest.mark.parametrize("suffix", [".npz", ".h5"])
def test_array_file_readers_on_random_bytes_changed_files_and_any_arrays(suffix: str) -> None:
    """NumPy and HDF5 files of arrays: random bytes; a real one with bytes changed or cut; files of
    arrays of any value, each read whole and part by part."""
    import io

    import h5py
    from scipy.io import loadmat

    def saved(arrays: dict) -> bytes:
        buffer = io.BytesIO()
        if suffix == ".npz":
            np.savez(buffer, **{k: np.asarray(v) for k, v in arrays.items()})
        else:
            with h5py.File(buffer, "w") as f:
                for name, values in arrays.items():
                    f[name] = np.asarray(values) if not isinstance(values, str) else np.bytes_(values.encode())  # h5py's variable-length text holds no NUL
        return buffer.getvalue()

    real = {k: v for k, v in loadmat(_write("real.mat", _mat_file())).items() if not k.startswith("__")}
    source = saved(real)
    assert read_recording(f"{_write('real' + suffix, source)}:traj1", arm="left", note=None).side == "left"
    changed = st.tuples(st.floats(0, 1, exclude_max=True), st.binary(min_size=1, max_size=8)).map(
        lambda c: source[: int(c[0] * len(source))] + c[1] + source[int(c[0] * len(source)) + len(c[1]) :]
    )
    cut = st.floats(0, 1, exclude_max=True).map(lambda c: source[: int(c * len(source))])

    @FUZZ
    @given(st.binary(max_size=600) | changed | cut | matrices().map(saved), options)
    def check(data: bytes, option) -> None:
        path = _write("fuzzed" + suffix, data)
        for part in ("", ":traj1", ":train", ":XY", ":q_dq_tau"):
            _read_any(Path(f"{path}{part}"), *option)

    check()
