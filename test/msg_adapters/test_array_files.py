"""MATLAB files of recordings, written here with scipy.io.savemat (v5) and as MATLAB's v7.3 (HDF5,
:func:`savemat_v73`) in the layouts robot-learning datasets publish (BaxterDirectDynamics' 35
columns per trajectory, BaxterRand's X/Y pairs, the SARCOS 28 columns), read back through
``read_recording`` and the commands."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from cli_runs import listing, run_cli, the_error
from recorded_bags import columns, joint_states, savemat_v73
from reference_models import pinocchio_from_arm
from scipy.io import savemat

from baxter_dynamics_ros.core.arm_model import load_arm_model
from baxter_dynamics_ros.core.joints import arm_joint_names
from baxter_dynamics_ros.core.recording import JUMP_GAP_PERIODS, jumps
from baxter_dynamics_ros.errors import RecordingFileError
from baxter_dynamics_ros.cli.inputs import expand_inputs
from msg_adapters.recording_files import read_recording, recordings_in

N = 400
RATE_HZ = 100.0


def arm_states(seed: int = 0, n: int = N) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, τ (n, 7) of a moving arm at RATE_HZ (the right arm of recorded_bags.joint_states)."""
    return tuple(columns(joint_states(n, rate_hz=RATE_HZ, seed=seed), arm_joint_names("right")))


def forward_dynamics(q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """The 35 columns [q, q̇, τ, q⁺, q̇⁺] of one trajectory (its last sample has no next one)."""
    return np.hstack([q[:-1], qd[:-1], tau[:-1], q[1:], qd[1:]])


def assert_read(rec, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> None:
    np.testing.assert_array_equal(rec.q, q)
    np.testing.assert_array_equal(rec.qd, qd)
    np.testing.assert_array_equal(rec.effort, tau)
    assert rec.side == "left" and rec.joint_names == arm_joint_names("left")
    assert rec.rate_hz == pytest.approx(RATE_HZ, rel=2e-3)  # estimated from q and q̇
    assert rec.segments == ((0, len(q)),)


def test_each_trajectory_of_a_forward_dynamics_file_is_a_recording(tmp_path: Path) -> None:
    trajectories = [arm_states(seed) for seed in range(3)]
    path = tmp_path / "BaxterDirectDynamics.mat"
    savemat(path, {f"baxtertraj{k + 1}": forward_dynamics(*t) for k, t in enumerate(trajectories)} | {"note": "pick and place"})
    parts = recordings_in(path)
    assert [str(p) for p in parts] == [f"{path}:baxtertraj{k}" for k in (1, 2, 3)]
    notes: list[str] = []
    for part, (q, qd, tau) in zip(parts, trajectories):
        assert_read(read_recording(part, arm="left", note=notes.append), q[:-1], qd[:-1], tau[:-1])
    assert len(notes) == 3 and all("sample rate estimated" in n for n in notes)
    with pytest.raises(RecordingFileError, match=r"holds 3 recordings \(baxtertraj1, baxtertraj2, baxtertraj3\); name one as"):
        read_recording(path, arm="left")
    with pytest.raises(RecordingFileError, match=r"no recording 'baxtertraj9'.*holds baxtertraj1, baxtertraj2, baxtertraj3"):
        read_recording(f"{path}:baxtertraj9", arm="left")
    with pytest.raises(RecordingFileError, match=r"baxtertraj2: a MATLAB file names no arm, nor does the file name; pass --arm"):
        read_recording(parts[1])


def test_inverse_dynamics_pairs_and_sarcos_matrices_read_their_torque_columns(tmp_path: Path) -> None:
    (q, qd, tau), (q2, qd2, tau2) = arm_states(0), arm_states(1)
    qdd = np.gradient(qd, axis=0) * RATE_HZ  # given, and not used
    path = tmp_path / "BaxterRand.mat"
    savemat(path, {"X_train": np.hstack([q, qd, qdd]), "Y_train": tau, "X_test": np.hstack([q2, qd2, qdd]).T, "Y_test": tau2.T})
    assert [str(p) for p in recordings_in(path)] == [f"{path}:train", f"{path}:test"]
    assert_read(read_recording(f"{path}:train", arm="left", note=None), q, qd, tau)
    assert_read(read_recording(f"{path}:test", arm="left", note=None), q2, qd2, tau2)  # stored transposed
    sarcos = tmp_path / "sarcos_inv.mat"
    savemat(sarcos, {"sarcos_inv": np.hstack([q, qd, qdd, tau])})
    assert recordings_in(sarcos) == [sarcos]
    assert_read(read_recording(sarcos, arm="left", note=None), q, qd, tau)


def test_35_columns_whose_next_state_is_not_the_next_row_are_refused(tmp_path: Path) -> None:
    matrix = forward_dynamics(*arm_states())
    matrix[:, 21:] = matrix[::-1, 21:]  # the next-state block of other rows
    path = tmp_path / "shuffled.mat"
    savemat(path, {"traj": matrix})
    with pytest.raises(RecordingFileError, match=r"shuffled.mat:traj: 35 columns, but columns 22-35 are not the next row's q and q̇"):
        read_recording(path, arm="left")


def test_files_that_hold_no_recording_are_refused_saying_what_they_hold(tmp_path: Path) -> None:
    path = tmp_path / "other.mat"
    savemat(path, {"X_train": np.zeros((10, 21)), "torques": np.zeros((10, 6)), "label": "ur10"})
    with pytest.raises(RecordingFileError, match=r"no recording in this MATLAB file \(holds X_train 10×21 double, torques 10×6 double, label 1 char\)"):
        read_recording(path, arm="left")
    v73 = tmp_path / "v73.mat"  # MATLAB's v7.3 header, then HDF5 cut short
    v73.write_bytes(b"MATLAB 7.3 MAT-file, HDF5 schema 1.00 .".ljust(116) + bytes(8) + b"\x00\x02IM" + b"\x89HDF\r\n\x1a\n" + bytes(400))
    with pytest.raises(RecordingFileError, match=r"v73.mat: a MATLAB v7.3 file whose HDF5 cannot be read \("):
        read_recording(v73, arm="left")
    savemat_v73(v73, {"X_train": np.zeros((10, 21)), "torques": np.zeros((10, 6)), "label": "ur10", "meta": {"rate": 100.0}})
    with pytest.raises(RecordingFileError, match=r"no recording in this MATLAB file \(holds X_train 10×21 double, label 1×4 char, meta struct, torques 10×6 double\)"):
        read_recording(v73, arm="left")
    text = tmp_path / "text.mat"
    text.write_text("q qd tau\n1 2 3\n")
    with pytest.raises(RecordingFileError, match=r"text.mat: not a readable MATLAB file"):
        read_recording(text, arm="left")


def test_trajectories_laid_end_to_end_are_cut_where_the_positions_jump(tmp_path: Path) -> None:
    """One X/Y pair of two trajectories, the second 0.8 rad away at s1 and e0: the join's step is left
    out of the rate's estimate (with it, the estimate is 3 % off), the join is a gap,
    each side a segment of its own."""
    (q, qd, tau), (q2, qd2, tau2) = arm_states(0), arm_states(1)
    q2 = q2 + np.array([0.0, -0.8, 0.8, 0.0, 0.0, 0.0, 0.0])
    path = tmp_path / "joined.mat"
    savemat(path, {"X": np.hstack([np.vstack([q, q2]), np.vstack([qd, qd2]), np.zeros((2 * N, 7))]), "Y": np.vstack([tau, tau2])})
    notes: list[str] = []
    rec = read_recording(path, arm="left", note=notes.append)
    assert rec.segments == ((0, N), (N, 2 * N))
    steps = np.diff(rec.stamps_ns)
    assert steps[N - 1] == pytest.approx(JUMP_GAP_PERIODS * np.median(steps), rel=1e-6)
    assert rec.rate_hz == pytest.approx(RATE_HZ, rel=2e-3)
    assert any(f"jump at 1 step(s) (first after sample {N - 1})" in n for n in notes), notes


def test_shuffled_samples_are_refused_not_cut_into_pieces(tmp_path: Path) -> None:
    """Machine-learning datasets may shuffle their rows (samples of X/Y pairs): no rate can be
    estimated, and with a rate given, nearly every step jumps; either way the error says the rows are
    not consecutive samples, and nothing is written."""
    q, qd, tau = arm_states()
    order = np.random.default_rng(4).permutation(N)
    path = tmp_path / "shuffled.mat"
    savemat(path, {"X": np.hstack([q, qd, np.zeros_like(q)])[order], "Y": tau[order]})
    with pytest.raises(RecordingFileError, match=r"shuffled.mat: has no time column, and its sample rate cannot be estimated: .*rows out of time order"):
        read_recording(path, arm="left")
    with pytest.raises(RecordingFileError, match=rf"shuffled.mat: the positions jump at \d+ of {N - 1} steps .* the rows are not consecutive samples"):
        read_recording(path, arm="left", rate_hz=RATE_HZ)
    done = run_cli("process", path, "--arm", "left", "--rate-hz", "100", "--out", tmp_path / "out.csv")
    assert "the rows are not consecutive samples" in the_error(done)
    assert listing(tmp_path) == ["shuffled.mat"]


def test_jumps_are_steps_beyond_what_the_top_speed_covers() -> None:
    period = 0.01
    q = np.zeros((6, 2))
    qd = np.zeros((6, 2))
    q[3:, 1] = 0.05  # 0.05 rad in one step at rest: 5 rad/s
    assert jumps(q, qd, period, np.array([1.0, 6.0])).tolist() == []
    assert jumps(q, qd, period, np.array([1.0, 4.0])).tolist() == [2]
    qd[2:4, 1] = 5.0  # the same step, moving at 5 rad/s: explained
    assert jumps(q, qd, period, np.array([1.0, 4.0])).tolist() == []
    q[4, 0] = np.nan
    assert jumps(q, qd, period, np.array([1.0, 4.0])).tolist() == []


def test_the_commands_take_each_recording_of_a_matlab_file(tmp_path: Path) -> None:
    rnea = pinocchio_from_arm(load_arm_model("left")).rnea  # an effort that follows the model, as a real arm's

    def followed(q, qd, tau):
        qdd = np.gradient(qd, axis=0) * RATE_HZ
        return q, qd, 0.05 * tau + np.array([rnea(*x) for x in zip(q, qd, qdd)])

    trajectories = [followed(*arm_states(seed, n=2000)) for seed in range(3)]
    path = tmp_path / "data" / "traj.mat"
    path.parent.mkdir()
    savemat(path, {f"t{k}": forward_dynamics(*t) for k, t in enumerate(trajectories)})
    out = tmp_path / "processed"
    done = run_cli("process", path.parent, "--arm", "left", "--out", out, "--format", "csv")
    assert done.returncode == 0, done.stderr
    assert listing(out) == ["traj_t0.csv", "traj_t1.csv", "traj_t2.csv"]
    assert "traj.mat:t1: no time column" in done.stderr
    diagnosed = run_cli("diagnose", "--train", path, "--arm", "left", "--out", tmp_path / "diagnosis", "--jobs", "1")
    assert diagnosed.returncode == 0, diagnosed.stderr  # t0, t1 trained on, t2 held out: parts told apart
    assert (tmp_path / "diagnosis" / "report.html").is_file()
    before = listing(tmp_path)
    repeated = run_cli("diagnose", "--train", f"{path}:t0", f"{path}:t1", "--test", f"{path}:t1", "--arm", "left", "--out", tmp_path / "d")
    assert the_error(repeated) == f"ERROR: {path}:t1 (in --test) is the same file as {path}:t1 (in --train): held-out data must not have been fitted on; give each recording once"
    assert the_error(run_cli("process", f"{path}:t7", "--arm", "left", "--out", tmp_path / "x.csv")).startswith(f"ERROR: {path}: no recording 't7'")
    assert the_error(run_cli("play", f"{path}:t0")).startswith(f"ERROR: {path}:t0: play takes bags")
    one_file = the_error(run_cli("process", path, "--arm", "left", "--out", tmp_path / "all.csv"))
    assert one_file.startswith(f"ERROR: {tmp_path / 'all.csv'}: names a file, but the input stands for 3 recordings ({path}:t0, {path}:t1, {path}:t2)")
    assert listing(tmp_path) == before


def test_a_part_too_short_is_passed_over_when_found_and_refused_when_named(tmp_path: Path) -> None:
    rnea = pinocchio_from_arm(load_arm_model("left")).rnea

    def followed(q, qd, tau):
        qdd = np.gradient(qd, axis=0) * RATE_HZ
        return q, qd, 0.05 * tau + np.array([rnea(*x) for x in zip(q, qd, qdd)])

    long = [forward_dynamics(*followed(*arm_states(seed, n=1500))) for seed in range(3)]
    short = forward_dynamics(*followed(*arm_states(7, n=151)))  # 150 samples, 1.5 s: too short to diagnose
    path = tmp_path / "picks.mat"
    savemat(path, {"t0": long[0], "t1": short, "t2": long[1], "t3": long[2]})
    out = tmp_path / "diagnosis"
    done = run_cli("diagnose", "--train", path, "--arm", "left", "--out", out, "--jobs", "1")
    assert done.returncode == 0, done.stderr
    assert re.search(rf"{re.escape(str(path))}:t1: passed over, too short: 150 samples, 1\.[45]\d s; a recording needs at least 200 samples and 2 s\n", done.stderr)
    report = json.loads((out / "diagnosis.json").read_text())
    assert (report["train_files"], report["test_files"]) == ([f"{path}:t0", f"{path}:t2"], [f"{path}:t3"])
    assert list(report["passed_over"]) == [f"{path}:t1"] and report["passed_over"][f"{path}:t1"].startswith("150 samples")
    assert f"Passed over, too short: {path}:t1 (150 samples" in (out / "report.html").read_text()
    calibrated = run_cli("calibrate", path, "--arm", "left", "--out", tmp_path / "thresholds.yaml")
    assert calibrated.returncode == 0 and f"{path}:t1: passed over, too short" in calibrated.stderr, calibrated.stderr
    before = listing(tmp_path)
    named = run_cli("diagnose", "--train", f"{path}:t0", f"{path}:t1", "--test", f"{path}:t3", "--arm", "left", "--out", tmp_path / "d")
    assert re.fullmatch(rf"ERROR: {re.escape(str(path))}:t1: 150 samples, 1\.[45]\d s; a training recording needs at least 200 samples and 2 s", the_error(named))
    only_short = tmp_path / "short" / "one.mat"
    only_short.parent.mkdir()
    savemat(only_short, {"a": short, "b": forward_dynamics(*followed(*arm_states(8, n=151)))})
    refused = run_cli("diagnose", "--train", path, "--test", only_short, "--arm", "left", "--out", tmp_path / "d")
    assert the_error(refused) == "ERROR: --test: every recording in it is too short for the diagnosis (passed over above)"
    refused = run_cli("calibrate", only_short.parent, "--arm", "left", "--out", tmp_path / "t.yaml")
    assert the_error(refused) == "ERROR: every recording given is too short for a calibration (passed over above)"
    assert listing(tmp_path) == sorted(before + ["short", "short/one.mat"])


def test_the_parts_of_a_file_are_named_and_ordered_without_clashes(tmp_path: Path) -> None:
    """Pairs whose short names clash keep the X variable's name; a dataset's ``test`` part comes last
    (MATLAB saves variables in alphabetical order); names of any characters are addressed; a layout
    with samples in rows wins over a transposed one (35 samples of 28 columns)."""
    (q, qd, tau), (q2, qd2, tau2) = arm_states(0), arm_states(1)
    qdd = np.zeros_like(q)
    path = tmp_path / "pairs.mat"
    savemat(path, {"X_test": np.hstack([q2, qd2, qdd]), "X_train": np.hstack([q, qd, qdd]), "Xtrain": np.hstack([q2, qd2, qdd]),
                   "Y_test": tau2, "Y_train": tau, "Ytrain": tau2})  # fmt: skip
    assert [p.name for p in recordings_in(path)] == ["pairs.mat:train", "pairs.mat:Xtrain", "pairs.mat:test"]
    assert_read(read_recording(f"{path}:train", arm="left", note=None), q, qd, tau)
    assert_read(read_recording(f"{path}:Xtrain", arm="left", note=None), q2, qd2, tau2)
    dashes = tmp_path / "dashes.mat"
    savemat(dashes, {"traj-1": forward_dynamics(q, qd, tau), "traj-2": forward_dynamics(q2, qd2, tau2)})
    assert [p.name for p in recordings_in(dashes)] == ["dashes.mat:traj-1", "dashes.mat:traj-2"]
    assert_read(read_recording(f"{dashes}:traj-2", arm="left", note=None), q2[:-1], qd2[:-1], tau2[:-1])
    square = tmp_path / "square.mat"
    savemat(square, {"s": np.hstack([q, qd, qdd, tau])[:35]})
    rec = read_recording(square, arm="left", rate_hz=RATE_HZ, note=None)
    np.testing.assert_array_equal(rec.effort, tau[:35])
    (tmp_path / "pairs.mat:test").write_text("a file named like a part")
    with pytest.raises(RecordingFileError, match=r"pairs.mat:test: a file of this name hides the recording test of .*pairs.mat; rename it"):
        recordings_in(path)


def test_complex_numbers_and_a_name_given_twice_are_refused(tmp_path: Path) -> None:
    q, qd, tau = arm_states()
    path = tmp_path / "complex.mat"
    savemat(path, {"traj": forward_dynamics(q + 1e-3j, qd, tau)})
    with pytest.raises(RecordingFileError, match=r"complex.mat: variable traj holds complex numbers"):
        read_recording(path, arm="left")
    twice = tmp_path / "twice.mat"  # a second file's variables (after its 128-byte header) appended
    savemat(twice, {"traj": np.zeros((5, 3))})
    second = tmp_path / "second.mat"
    savemat(second, {"traj": forward_dynamics(q, qd, tau)})
    twice.write_bytes(twice.read_bytes() + second.read_bytes()[128:])
    with pytest.raises(RecordingFileError, match=r"twice.mat: variable traj appears more than once in this MATLAB file"):
        read_recording(twice, arm="left")


def test_v73_files_read_as_the_same_variables_saved_by_scipy(tmp_path: Path) -> None:
    """Every layout, and a matrix stored transposed, saved as v7.3 (HDF5, h5py) and as v5 (scipy's
    writer and reader, another implementation of MATLAB's format): the same parts, bit for bit;
    single precision, text, a struct and integers beside them as MATLAB would keep them."""
    (q, qd, tau), (q2, qd2, tau2) = arm_states(0), arm_states(1)
    variables = {
        "baxtertraj1": forward_dynamics(q, qd, tau),
        "baxtertraj2": forward_dynamics(q2, qd2, tau2).T.copy(),
        "X_test": np.hstack([q, qd, qd]),
        "Y_test": tau,
        "sarcos": np.hstack([q2, qd2, qd2, tau2]).astype(np.float32),
        "square": np.hstack([q, qd, qd, tau])[:28],  # 28 samples of 28 columns: which way round is the storage's to say
        "note": "pick and place",
        "counts": np.arange(6, dtype=np.int32).reshape(2, 3),
    }
    v5, v73 = tmp_path / "v5.mat", savemat_v73(tmp_path / "v73.mat", variables)
    savemat(v5, variables)
    parts = [p.split(":", 1)[1] for p in map(str, recordings_in(v73))]
    assert parts == ["baxtertraj1", "baxtertraj2", "sarcos", "square", "test"]  # by name (no creation order kept); test last
    assert sorted(parts) == sorted(p.split(":", 1)[1] for p in map(str, recordings_in(v5)))
    ordered = savemat_v73(tmp_path / "ordered.mat", {"trajB": variables["baxtertraj1"], "trajA": variables["sarcos"]}, track_order=True)
    assert [str(p).rsplit(":", 1)[1] for p in recordings_in(ordered)] == ["trajB", "trajA"]  # saving order, where the file keeps it
    for part in parts:
        a, b = (read_recording(f"{path}:{part}", arm="left", note=None) for path in (v5, v73))
        for got, want in zip((b.q, b.qd, b.effort, b.stamps_ns), (a.q, a.qd, a.effort, a.stamps_ns)):
            np.testing.assert_array_equal(got, want)
    assert_read(read_recording(f"{v73}:test", arm="left", note=None), q, qd, tau)
    savemat_v73(tmp_path / "complex.mat", {"traj": forward_dynamics(q + 1e-3j, qd, tau)})
    with pytest.raises(RecordingFileError, match=r"complex.mat: variable traj holds complex numbers"):
        read_recording(tmp_path / "complex.mat", arm="left")


def test_a_folder_passes_over_a_matlab_file_of_no_recording(tmp_path: Path) -> None:
    """A calibration file beside the data is not an input; named on its own, it is refused."""
    folder = tmp_path / "runs"
    folder.mkdir()
    savemat(folder / "calibration.mat", {"offsets": np.zeros(7), "note": "not a recording"})
    savemat(folder / "run.mat", {"traj": forward_dynamics(*arm_states())})
    assert expand_inputs([folder]) == [folder / "run.mat"]
    assert expand_inputs([folder / "*.mat"]) == [folder / "run.mat"]
    assert expand_inputs([folder / "calibration.mat"]) == [folder / "calibration.mat"]
    with pytest.raises(RecordingFileError, match=r"calibration.mat: no recording in this MATLAB file \(holds offsets 1×7 double, note 1 char\)"):
        read_recording(folder / "calibration.mat", arm="left")


def test_one_variable_per_quantity_with_or_without_a_time(tmp_path: Path) -> None:
    """q, dq, tau of 7 columns (and t): one recording per label; a time without a unit read in the
    one its steps match (here ms), degrees converted; v7.3 alike."""
    (q1, qd1, tau1), (q2, qd2, tau2) = arm_states(1), arm_states(2)
    t_ms = 1e3 * np.arange(N) / RATE_HZ + 500.0
    path = tmp_path / "identification.mat"
    contents = {
        "q_test": q2, "dq_test": qd2.T, "tau_test": tau2,  # stored transposed too
        "q_deg_train": np.degrees(q1), "qd_deg_train": np.degrees(qd1), "torque_train": tau1, "t_train": t_ms[:, None],
        "qdd_train": np.zeros((N, 7)), "q_des_train": np.zeros((N, 7)),
    }  # fmt: skip
    for write in (savemat, savemat_v73):
        write(path, contents)
        parts = recordings_in(path)
        assert [str(p) for p in parts] == [f"{path}:train", f"{path}:test"]
        notes: list[str] = []
        train = read_recording(parts[0], arm="left", note=notes.append)
        np.testing.assert_allclose(train.q, q1, rtol=1e-15, atol=1e-15)
        np.testing.assert_allclose(train.qd, qd1, rtol=1e-15, atol=1e-15)
        np.testing.assert_array_equal(train.effort, tau1)
        np.testing.assert_array_equal(train.stamps_ns - train.stamps_ns[0], np.round((t_ms - t_ms[0]) * 1e6).astype(np.int64))
        assert notes == [f"{path}:train: the time column time names no unit; read in ms, in which its steps match the velocities"]
        assert_read(read_recording(parts[1], arm="left", note=None), q2, qd2, tau2)
    savemat(path, {"theta": q1, "theta_dot": qd1, "tau": tau1})  # an angle's rate, as a column name says it
    assert_read(read_recording(path, arm="left", note=None), q1, qd1, tau1)
    savemat(path, {"q": q1, "qd": qd1, "tau": tau1[:-1]})
    with pytest.raises(RecordingFileError, match=r"identification.mat:q_qd_tau: q, qd and tau have 400, 400 and 399 samples"):
        read_recording(path, arm="left")
    savemat(path, {"q": q1, "qd": qd1, "tau": tau1, "torque_measured": tau1})
    with pytest.raises(RecordingFileError, match=r"variables tau and torque_measured both hold the effort of recording of no label"):
        read_recording(path, arm="left")
    savemat(path, {"q": q1, "qd": qd1, "tau_cmd": tau1})
    with pytest.raises(RecordingFileError, match=r"no recording in this MATLAB file \(holds q 400×7 double, qd 400×7 double, tau_cmd 400×7 double\)"):
        read_recording(path, arm="left")


def test_numpy_and_hdf5_files_of_arrays_read_as_matlab_files(tmp_path: Path) -> None:
    """The arrays of a MATLAB file saved by numpy (.npz) and h5py (.h5, rows as numpy writes them):
    the same parts and recordings; unreadable ones refused by kind."""
    import h5py

    (q1, qd1, tau1), (q2, qd2, tau2) = arm_states(1), arm_states(2)
    contents = {"X_train": np.hstack([q1, qd1, np.zeros_like(q1)]), "Y_train": tau1, "q_test": q2, "dq_test": qd2, "tau_test": tau2.T, "rate": np.array([100])}
    mat = tmp_path / "set.mat"
    savemat(mat, contents)
    npz, h5 = tmp_path / "set.npz", tmp_path / "set.H5"
    np.savez(npz, **contents)
    with h5py.File(h5, "w") as f:
        for name, values in contents.items():
            f[name] = values
        f.create_group("meta")
    for path in (npz, h5):
        parts = recordings_in(path)
        assert [p.name for p in parts] == [f"{path.name}:train", f"{path.name}:test"]
        for part, (q, qd, tau) in zip(parts, ((q1, qd1, tau1), (q2, qd2, tau2))):
            assert_read(read_recording(part, arm="left", note=None), q, qd, tau)
            mine = read_recording(Path(f"{mat}:{part.name.split(':')[1]}"), arm="left", note=None)
            np.testing.assert_array_equal(read_recording(part, arm="left", note=None).q, mine.q)
    with pytest.raises(RecordingFileError, match=r"set.npz:train: a NumPy .npz file names no arm, nor does the file name; pass --arm"):
        read_recording(f"{npz}:train")
    np.savez(npz, torques=np.zeros((10, 6)))
    with pytest.raises(RecordingFileError, match=r"no recording in this NumPy .npz file \(holds torques 10×6 double\)"):
        read_recording(npz, arm="left")
    np.savez(npz, q=np.array([{"a": 1}], dtype=object))
    with pytest.raises(RecordingFileError, match=r"set.npz: not a readable NumPy .npz file \("):
        read_recording(npz, arm="left")
    for path, kind in ((npz, "NumPy .npz file"), (h5, "HDF5 file")):
        path.write_bytes(b"PK\x03\x04" + bytes(100) if path == npz else b"\x89HDF\r\n\x1a\n" + bytes(100))
        with pytest.raises(RecordingFileError, match=rf"{path.name}: not a readable {kind} \("):
            read_recording(path, arm="left")


def test_an_hdf5_variable_whose_name_is_no_text_is_listed_and_never_read(tmp_path: Path) -> None:
    """HDF5 names are bytes; h5py gives one that is no UTF-8 as bytes (a fuzz run found the reader
    failing on it): beside a recording it is passed over, alone it is named in the refusal."""
    import h5py

    q, qd, tau = arm_states()
    h5, v73 = tmp_path / "odd.h5", tmp_path / "odd.mat"
    with h5py.File(h5, "w") as f:
        f["q"], f["dq"], f["tau"], f[b"q\xff"] = q, qd, tau, q
    savemat_v73(v73, {"traj": forward_dynamics(q, qd, tau)})
    with h5py.File(v73, "r+") as f:
        f[b"\xfe"] = forward_dynamics(q, qd, tau).T
    assert_read(read_recording(h5, arm="left", note=None), q, qd, tau)
    assert_read(read_recording(v73, arm="left", note=None), q[:-1], qd[:-1], tau[:-1])
    for path in (h5, v73):
        with h5py.File(path, "r+") as f:
            for name in [n for n in f if isinstance(n, str)]:
                del f[name]
        with pytest.raises(RecordingFileError, match=r"no recording in this (HDF5|MATLAB) file \(holds b'(q\\xff|\\xfe)' name not UTF-8\)"):
            read_recording(path, arm="left")
