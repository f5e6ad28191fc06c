"""Tables whose columns other datasets name in their own ways (msg_adapters.table_columns), read
end to end against the simulator's own arrays."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from baxter_dynamics_ros.core.joints import JOINT_SUFFIXES
from baxter_dynamics_ros.errors import RecordingFileError
from msg_adapters.recording_files import read_recording
from msg_adapters.table_columns import bare_joint_names, joint_columns, time_columns


@pytest.fixture(scope="module")
def sim():
    from baxter_dynamics_ros.simulation.plant import simulate
    from baxter_dynamics_ros.simulation.spec import SimulationSpec

    return simulate(SimulationSpec(trajectory="random", duration_s=3.0, rate_hz=200.0, seed=11, side="left"))


def write(path: Path, columns: dict[str, np.ndarray], sep: str = ",") -> Path:
    np.savetxt(path, np.column_stack(list(columns.values())), delimiter=sep, header=sep.join(columns), comments="", fmt="%.17g")
    return path


def arm_columns(sim, name) -> dict[str, np.ndarray]:
    """name(quantity index 0..2, joint index 0..6) -> column name, for q, q̇, effort."""
    out = {}
    for k, values in enumerate((sim.q, sim.qd, sim.effort)):
        out.update({name(k, j): values[:, j] for j in range(7)})
    return out


def test_names_say_quantity_side_and_joint() -> None:
    found = joint_columns(
        ["ang_left_s0", "Left_S1.Effort", "r_e0_vel", "q3", "tau[7]", "dq_0", "position_w2 [deg]", "effort_w1 [Nm]",
         "desired_position_s0", "acceleration_left_s0", "gravity_s1", "head_pan", "field.position0", "effort_w0_deg",
         "/robot/limb/left/commanded_position/left_e1", "/robot/joint_states/head_pan/position", "joint_states.velocity.left_w0",
         "S1_speed", "dtheta_e1", "desired_state_position_w1", "position_e0 [°]", "velocity_e0 (°/s)", "effort_e0 [°]"]
    )  # fmt: skip
    said = {key: (c.name, c.scale) for key, c in found.items()}
    assert said == {
        ("position", "left", "s0"): ("ang_left_s0", 1.0),
        ("effort", "left", "s1"): ("Left_S1.Effort", 1.0),
        ("velocity", "right", "e0"): ("r_e0_vel", 1.0),
        ("position", None, "w2"): ("position_w2 [deg]", math.pi / 180.0),
        ("effort", None, "w1"): ("effort_w1 [Nm]", 1.0),
        ("velocity", "left", "w0"): ("joint_states.velocity.left_w0", 1.0),
        ("velocity", None, "s1"): ("S1_speed", 1.0),
        ("velocity", None, "e1"): ("dtheta_e1", 1.0),
        ("position", None, "e0"): ("position_e0 [°]", math.pi / 180.0),
        ("velocity", None, "e0"): ("velocity_e0 (°/s)", math.pi / 180.0),
    }  # an effort in degrees is no effort  # q3, tau[7], dq_0: one index of seven is no arm's; the rest name something else


def test_indexed_columns_are_baxters_order_only_when_seven() -> None:
    seven = joint_columns([f"q{k}" for k in range(1, 8)] + [f"tau_{k}" for k in range(7)])
    assert [seven[("position", None, j)].name for j in JOINT_SUFFIXES] == [f"q{k}" for k in range(1, 8)]
    assert [seven[("effort", None, j)].name for j in JOINT_SUFFIXES] == [f"tau_{k}" for k in range(7)]
    assert joint_columns([f"position{k}" for k in range(17)]) == {}  # /robot/joint_states' 17 joints
    assert joint_columns([f"q{k}" for k in range(2, 9)]) == {}
    for name in (lambda q, k: f"joint{k}_{q}", lambda q, k: f"j{k}_{q}", lambda q, k: f"{q}_jnt{k}", lambda q, k: f"Joint {k} {q.title()}"):
        found = joint_columns([name(q, k) for q in ("position", "velocity", "torque") for k in range(1, 8)])
        assert [found[(quantity, None, j)].name for quantity in ("position", "velocity", "effort") for j in JOINT_SUFFIXES] == [
            name(q, k) for q in ("position", "velocity", "torque") for k in range(1, 8)
        ]
    assert joint_columns(["joint1_s0_position", "joint1_sensor_position", "joint_position"]) == {}  # two joints; a word more; no joint


def test_an_angles_rate_is_a_velocity() -> None:
    found = joint_columns(["theta_dot_s0", "q_vel_s1", "ang_vel_e0", "angular_velocity_e1", "q_ddot_w0", "pos_vel_w1", "theta_dot_dot_w2"])
    assert {key: c.name for key, c in found.items()} == {
        ("velocity", None, "s0"): "theta_dot_s0",
        ("velocity", None, "s1"): "q_vel_s1",
        ("velocity", None, "e0"): "ang_vel_e0",
        ("velocity", None, "e1"): "angular_velocity_e1",
    }  # an acceleration, a position word that is no angle's, a second dot: no joint column


def test_two_columns_saying_the_same_are_refused() -> None:
    with pytest.raises(RecordingFileError, match="columns ang_left_s0 and position_left_s0 both hold the position of left_s0"):
        joint_columns(["ang_left_s0", "position_left_s0"])


def test_time_columns_nanoseconds_first_then_with_a_unit() -> None:
    got = [(c.name, c.scale_s) for c in time_columns(["time", "t [ms]", "value", "stamp_ns", "time_s_ns", "header.stamp.secs", "__time", "t [µs]", "time (μs)"])]
    assert got == [("stamp_ns", 1e-9), ("t [ms]", 1e-3), ("header.stamp.secs", 1.0), ("t [µs]", 1e-6), ("time (μs)", 1e-6), ("time", None), ("__time", None)]


@pytest.mark.parametrize(
    "name",
    [
        lambda k, j: f"{('pos', 'vel', 'eff')[k]}_left_{JOINT_SUFFIXES[j]}",
        lambda k, j: f"left_{JOINT_SUFFIXES[j]}.{('position', 'velocity', 'effort')[k]}",
        lambda k, j: f"{('Q', 'dQ', 'Tau')[k]}_L_{JOINT_SUFFIXES[j].upper()}",
        lambda k, j: f"/robot/joint_states/left_{JOINT_SUFFIXES[j]}/{('position', 'velocity', 'effort')[k]}",
        lambda k, j: f"left_joint{j + 1}_{('pos', 'vel', 'torque')[k]}",
    ],
    ids=["quantity_side_joint", "side_joint.quantity", "upper case", "PlotJuggler", "joint index"],
)
def test_named_layouts_read_the_arm_from_the_names(tmp_path: Path, sim, name) -> None:
    t = (sim.stamps_ns - sim.stamps_ns[0]) * 1e-9
    path = write(tmp_path / "named.csv", {"time [s]": t, **arm_columns(sim, name)})
    rec = read_recording(path, note=None)
    assert rec.side == "left"
    np.testing.assert_array_equal(rec.q, sim.q)
    np.testing.assert_array_equal(rec.qd, sim.qd)
    np.testing.assert_array_equal(rec.effort, sim.effort)
    np.testing.assert_array_equal(rec.stamps_ns - rec.stamps_ns[0], np.round(t * 1e9).astype(np.int64))


@pytest.mark.parametrize(("unit", "per_s", "word"), [("s", 1.0, "s"), ("ms", 1e3, "ms"), ("ns", 1e9, "ns")])
def test_a_time_column_without_a_unit_is_read_in_the_one_the_velocities_match(tmp_path: Path, sim, unit, per_s, word) -> None:
    t = (sim.stamps_ns - sim.stamps_ns[0]) * 1e-9 + 12.0
    columns = {"time": t * per_s, **arm_columns(sim, lambda k, j: f"{('q', 'dq', 'tau')[k]}{j + 1}")}
    path = write(tmp_path / "indexed.txt", columns, sep=" ")
    with pytest.raises(RecordingFileError, match="name no arm"):
        read_recording(path, note=None)
    notes: list[str] = []
    rec = read_recording(path, arm="left", note=notes.append)
    assert notes == [f"{path}: the time column time names no unit; read in {word}, in which its steps match the velocities"]
    np.testing.assert_array_equal(rec.q, sim.q)
    np.testing.assert_allclose((rec.stamps_ns - rec.stamps_ns[0]) * 1e-9, t - t[0], rtol=0, atol=2e-9)
    assert rec.rate_hz == pytest.approx(200.0, rel=1e-6)


def test_a_time_column_the_velocities_match_in_no_unit_is_refused(tmp_path: Path, sim) -> None:
    t = (sim.stamps_ns - sim.stamps_ns[0]) * 1e-9 * 60.0  # minutes written as the count of seconds: no unit matches
    path = write(tmp_path / "minutes.csv", {"t": t / 3600.0, **arm_columns(sim, lambda k, j: f"{('q', 'dq', 'tau')[k]}{j + 1}")})
    with pytest.raises(RecordingFileError, match=r"the time column t names no unit, and with none of s, ms, µs, ns do its steps match"):
        read_recording(path, arm="left", note=None)


def test_degrees_are_converted(tmp_path: Path, sim) -> None:
    columns = arm_columns(sim, lambda k, j: f"{('ang', 'vel', 'torq')[k]}_left_{JOINT_SUFFIXES[j]}{(' [deg]', ' [deg/s]', ' [Nm]')[k]}")
    for name in list(columns)[:14]:
        columns[name] = columns[name] * (180.0 / math.pi)
    rec = read_recording(write(tmp_path / "degrees.csv", columns), note=None)
    np.testing.assert_allclose(rec.q, sim.q, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(rec.qd, sim.qd, rtol=1e-14, atol=1e-14)
    np.testing.assert_array_equal(rec.effort, sim.effort)


@pytest.mark.parametrize(
    ("name", "missing"),
    [(lambda k, j: f"{('q', 'dq', 'tau')[k]}_left_{JOINT_SUFFIXES[j]}", "tau_left_w1"), (lambda k, j: f"{('Q', 'dQ', 'Tau')[k]}_L_{JOINT_SUFFIXES[j].upper()}", "Tau_L_W1")],
)
def test_a_missing_column_is_named_as_the_table_would(tmp_path: Path, sim, name, missing) -> None:
    columns = arm_columns(sim, name)
    del columns[missing]
    with pytest.raises(RecordingFileError, match=f"the left arm needs columns missing here: {missing}$"):
        read_recording(write(tmp_path / "five.csv", columns), arm="left", note=None)


def test_empty_fields_are_missing_values_and_their_rows_left_out(tmp_path: Path, sim) -> None:
    """PlotJuggler's export of two topics: rows of the other topic leave the arm's fields empty."""
    t = (sim.stamps_ns - sim.stamps_ns[0]) * 1e-9
    columns = {"__time": t, **arm_columns(sim, lambda k, j: f"/robot/joint_states/left_{JOINT_SUFFIXES[j]}/{('position', 'velocity', 'effort')[k]}")}
    columns["/robot/other/data"] = np.arange(len(t), dtype=float)
    lines = [",".join(columns)] + [",".join(f"{v[i]:.17g}" for v in columns.values()) for i in range(len(t))]
    gaps = [40, 41, 300]
    for i in gaps:  # a row of the other topic: only its own field and the time
        lines[1 + i] = ",".join(f"{v[i]:.17g}" if name in ("__time", "/robot/other/data") else "" for name, v in columns.items())
    path = tmp_path / "plotjuggler.csv"
    path.write_text("\n".join(lines) + "\n")
    notes: list[str] = []
    rec = read_recording(path, note=notes.append)
    keep = np.setdiff1d(np.arange(len(t)), gaps)
    np.testing.assert_array_equal(rec.q, sim.q[keep])
    np.testing.assert_array_equal(rec.effort, sim.effort[keep])
    assert any(f"3 of {len(t)} samples skipped as implausible (3 NaN or inf)" in n for n in notes), notes
    (tmp_path / "words.csv").write_text("__time,a\n1,\n2,x\n")
    with pytest.raises(RecordingFileError, match="not a table of numbers"):
        read_recording(tmp_path / "words.csv", note=None)


def test_positions_alone_under_bare_joint_names_are_refused_saying_so(tmp_path: Path, sim) -> None:
    """baxter_examples' joint_recorder.py: ``time,left_s0,…,left_gripper,right_s0,…`` of positions
    only; the refusal names the columns and what is missing."""
    assert bare_joint_names(["time", "left_s0", "S1 [rad]", "left_gripper", "ang_s0", "gravity_left_s0", "w2"]) == ["left_s0", "S1 [rad]", "w2"]
    names = [f"{side}_{j}" for side in ("left", "right") for j in (*JOINT_SUFFIXES, "gripper")]
    columns = {"time": np.arange(len(sim.q)) / 200.0} | {n: sim.q[:, k % 7] for k, n in enumerate(names)}
    with pytest.raises(RecordingFileError, match=r"no joint columns; .*; left_s0, left_s1, left_e0 … name a joint but not what it holds .*need each joint's effort"):
        read_recording(write(tmp_path / "joints.txt", columns), note=None)


def positions_and_efforts(sim) -> dict[str, np.ndarray]:
    """The left arm's position and effort columns of the simulated recording, no velocity column."""
    return {n: v for n, v in arm_columns(sim, lambda k, j: f"{('pos', 'vel', 'eff')[k]}_left_{JOINT_SUFFIXES[j]}").items() if not n.startswith("vel")}


def central_differences(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(q[k+1] − q[k−1]) / (t[k+1] − t[k−1]) inside, one-sided steps at the two ends."""
    out = np.empty_like(q)
    out[1:-1] = (q[2:] - q[:-2]) / (t[2:] - t[:-2])[:, None]
    out[0], out[-1] = (q[1] - q[0]) / (t[1] - t[0]), (q[-1] - q[-2]) / (t[-1] - t[-2])
    return out


def test_without_velocity_columns_the_velocity_is_the_positions_difference(tmp_path: Path, sim) -> None:
    """Positions and efforts only, over a time column (with a gap: each run differenced on its own)
    or at a given rate: q and τ as written, q̇ the central difference of q, near the simulator's own
    q̇; said in a note."""
    t = (sim.stamps_ns - sim.stamps_ns[0]) * 1e-9
    t[300:] += 0.5  # a gap of half a second
    columns = positions_and_efforts(sim)
    notes: list[str] = []
    path = write(tmp_path / "timed.csv", {"time_s": t, **columns})
    rec = read_recording(path, note=notes.append)
    assert rec.side == "left" and rec.segments == ((0, 300), (300, len(t)))
    np.testing.assert_array_equal(rec.q, sim.q)
    np.testing.assert_array_equal(rec.effort, sim.effort)
    want = np.vstack([central_differences(sim.q[:300], t[:300]), central_differences(sim.q[300:], t[300:])])
    np.testing.assert_allclose(rec.qd, want, rtol=1e-9, atol=1e-12)
    inside = np.r_[1:299, 301 : len(t) - 1]  # (the simulator's q holds its sensor noise, which differencing amplifies)
    assert np.sqrt(np.mean((rec.qd - sim.qd)[inside] ** 2)) < 0.15 * np.sqrt(np.mean(sim.qd**2))
    assert notes == [f"{path}: no velocity columns; q̇ is the central difference of q over the time column"]
    untimed = write(tmp_path / "untimed.csv", columns)
    rec = read_recording(untimed, rate_hz=200.0, note=None)
    np.testing.assert_allclose(rec.qd, central_differences(sim.q, np.arange(len(t)) / 200.0), rtol=1e-9, atol=1e-12)
    with pytest.raises(RecordingFileError, match="no time column and no velocity columns, so the sample rate can be neither read nor estimated; pass --rate-hz"):
        read_recording(untimed, note=None)
    with pytest.raises(RecordingFileError, match="has no time column and --rate-hz must be a positive number of Hz, got -5.0"):
        read_recording(untimed, rate_hz=-5.0, note=None)
    with pytest.raises(RecordingFileError, match=r"no velocity columns, and its time column t names no unit, which is read from the velocities; name the unit in the header \(e.g. t_s"):
        read_recording(write(tmp_path / "t.csv", {"t": t, **columns}), note=None)
    some = arm_columns(sim, lambda k, j: f"{('pos', 'vel', 'eff')[k]}_left_{JOINT_SUFFIXES[j]}")
    del some["vel_left_w2"]  # velocity columns, one missing: not a table without them
    with pytest.raises(RecordingFileError, match="the left arm needs columns missing here: vel_left_w2$"):
        read_recording(write(tmp_path / "six.csv", {"time_s": t, **some}), arm="left", note=None)
