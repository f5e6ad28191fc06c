"""Issue 20 §1's goal on the real recordings: ``diagnose`` never worse than a plain fit.

For every dataset folder of ``../shared/data`` and every rotation (each recording the test once),
at every joint: diagnose ≤ 1.05 × plain + 0.005 N·m (``against="plain"``), and
diagnose ≤ 1.05 × denoised rigid + 0.01 N·m (``against="rigid"``). The comparison is
bench/versus_plain.py's, run once per dataset for the module (``diagnose`` as the CLI, two
rotations at once). Cases measured to miss the goal are ``KNOWN_MISSES``: strict xfails, so that
the test fails when one of them changes; regenerate the list with
``python -m bench.versus_plain --out docs/real_robot_versus_plain.md`` (it prints it).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from repo_paths import SHARED
from urdf_motion import URDF

from bench.plain_fit import JOINT_SUFFIXES
from bench.versus_plain import (
    PLAIN_FACTOR,
    PLAIN_SLACK_NM,
    RIGID_FACTOR,
    RIGID_SLACK_NM,
    Rotation,
    compare_dataset,
    datasets,
    diagnose_says,
    main,
    page,
    read_side,
    recordings,
    withheld,
)

DATA = SHARED / "data"
#: The datasets of ../shared/data this branch was measured on (each skipped with its reason when
#: absent), and any other folder of recordings found there: every real dataset is checked.
DATASETS = tuple(dict.fromkeys(("baxter_real", "baxter_other_unit", *(p.name for p in datasets(DATA)))))

# Printed by `python -m bench.versus_plain` (measured on this branch; re-measure after changing diagnose).
KNOWN_MISSES: dict[tuple[str, str, str, str], str] = {
    ('baxter_other_unit', 'left_circle_p-15_t105.csv', 'w0', 'plain'): 'measured: diagnose 0.126 vs plain 0.105 N·m',
    ('baxter_other_unit', 'left_circle_p90_t105.csv', 's1', 'plain'): 'measured: diagnose 0.503 vs plain 0.457 N·m',
    ('baxter_other_unit', 'left_circle_p90_t105.csv', 'e0', 'plain'): 'measured: diagnose 0.331 vs plain 0.289 N·m',
    ('baxter_other_unit', 'left_circle_p90_t105.csv', 'w0', 'plain'): 'measured: diagnose 0.148 vs plain 0.097 N·m',
}


def _cases() -> list:
    cases = []
    for dataset in DATASETS:
        folder = DATA / dataset
        files = recordings(folder) if folder.is_dir() else []
        if len(files) < 3 or not URDF.is_file():
            cases.append(pytest.param(dataset, "", "", "", id=f"{dataset}-absent", marks=pytest.mark.skip(
                reason=f"needs ≥ 3 recordings in {folder} and the URDF at {URDF} (../shared beside the checkout)")))
            continue
        for f in files:
            for joint in JOINT_SUFFIXES:
                for against in ("plain", "rigid"):
                    key = (dataset, f.name, joint, against)
                    marks = [pytest.mark.xfail(strict=True, reason=KNOWN_MISSES[key])] if key in KNOWN_MISSES else []
                    cases.append(pytest.param(*key, id=f"{dataset}-{Path(f.name).stem}-{joint}-{against}", marks=marks))
    return cases


_measured: dict[str, dict[str, Rotation]] = {}


def rotation(dataset: str, test: str) -> Rotation:
    """The comparison of ``dataset`` with ``test`` held out (every rotation of the dataset is run once, then kept)."""
    if dataset not in _measured:
        _measured[dataset] = {r.test: r for r in compare_dataset(DATA / dataset, procs=2)}
    return _measured[dataset][test]


@pytest.mark.parametrize(("dataset", "test", "joint", "against"), _cases())
def test_diagnose_is_never_worse(dataset: str, test: str, joint: str, against: str) -> None:
    r = rotation(dataset, test)
    j = JOINT_SUFFIXES.index(joint)
    if against == "plain":
        bound = PLAIN_FACTOR * r.plain[j] + PLAIN_SLACK_NM
        assert r.diagnose[j] <= bound, f"diagnose {r.diagnose[j]:.3f} N·m > {bound:.3f} (plain {r.plain[j]:.3f}); selected {r.diagnose_selected}, plain {r.plain_selected}"
    else:
        bound = RIGID_FACTOR * r.rigid[j] + RIGID_SLACK_NM
        assert r.diagnose[j] <= bound, f"diagnose {r.diagnose[j]:.3f} N·m > {bound:.3f} (denoised rigid {r.rigid[j]:.3f}); selected {r.diagnose_selected}"


def test_the_misses_table_says_what_diagnose_did_with_the_plain_fits_effects() -> None:
    """diagnose_says on a hand-built rotation: per "name@joint" the plain fit chose there, applied by
    diagnose, its not_at reason, or not selected; whole effects and other joints are not listed.
    withheld: those of them diagnose does not apply there."""
    rotation = Rotation(
        "d", "t.csv", ("a.csv", "b.csv"), np.ones(7), np.ones(7), np.ones(7),
        ("s1_spring", "armature@s1", "stribeck_friction(v_s=0.02)@s1", "delay@s1", "coulomb_friction@w0"),
        ("s1_spring", "stribeck_friction"),
        {"s1_spring": ("s1",), "stribeck_friction": ("s1", "w2")},
        {"armature": {"s1": "its fitted parameters there are at their bounds"}, "stribeck_friction": {"w0": "x"}, "delay": {}},
    )  # fmt: skip
    assert diagnose_says(rotation, "s1") == (
        "armature@s1: its fitted parameters there are at their bounds; stribeck_friction(v_s=0.02)@s1: applied by diagnose too; "
        "delay@s1: not selected by diagnose (see its reason)"
    )
    # with the plain fit's values: each label carries them, with the effect's unit (none for a gain)
    valued = replace(rotation, plain_values={"armature@s1": (-0.4734,), "stribeck_friction(v_s=0.02)@s1": (0.82, 0.1), "delay@s1": (-0.0075,),
                                             "torque_gain@s0": (-0.19,)})  # fmt: skip
    assert diagnose_says(valued, "s1") == (
        "armature@s1 (-0.473 kg·m², negative: not physical): its fitted parameters there are at their bounds; "
        "stribeck_friction(v_s=0.02)@s1 (0.82, 0.1 N·m): applied by diagnose too; delay@s1 (-0.0075 s): not selected by diagnose (see its reason)"
    )
    # Stribeck (F_c, F_s − F_c): flagged where the friction at rest F_s is negative, not for F_s below F_c;
    # a negative delay or gain is not flagged (both signs are physical)
    says = [diagnose_says(replace(valued, plain_values={"stribeck_friction(v_s=0.02)@s1": bump}), "s1") for bump in ((0.82, -0.9), (0.82, -0.7))]
    assert "(0.82, -0.9 N·m, negative: not physical)" in says[0] and "(0.82, -0.7 N·m)" in says[1], says
    assert diagnose_says(replace(valued, plain_selected=("torque_gain@s0",)), "s0") == "torque_gain@s0 (-0.19): not selected by diagnose (see its reason)"
    assert diagnose_says(rotation, "e1") == "—"
    # what the plain fit is run again without, for its figure at s1 without them: all but the applied one
    assert withheld(rotation, "s1") == {"armature@s1", "delay@s1"}
    assert withheld(rotation, "e1") == frozenset()
    # on the page: a miss at s1 against plain, with the plain fit's figures without those and at diagnose's cut-off
    missed = replace(rotation, diagnose=np.array([1, 2, 1, 1, 1, 1, 1.0]), rigid=np.full(7, 9.0), plain_without={"s1": 1.5}, plain_at_cutoff={"s1": 1.25},
                     diagnose_cutoff_hz=(6.0,) * 7)  # fmt: skip
    rows = [line for line in page([missed], 1.0, "cmd").splitlines() if line.startswith("| d | `t.csv` |")]
    assert rows == ["| d | `t.csv` | s1 | plain | diagnose 2.000 vs plain 1.000 N·m | " + diagnose_says(rotation, "s1") + " | 1.500 | 1.250 |"]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--plain-cutoff-hz", "60"], "a low-pass cut-off of 60 Hz needs a sample rate above 120 Hz, not 100"),
        (["--out", "{tmp}/a_file/page.md"], "is a file, not a folder"),
    ],
)
def test_bad_options_give_one_error_line_and_write_nothing(tmp_path, capsys, args: list[str], match: str) -> None:
    """A cut-off the recordings' rate cannot carry (baxter_real's are 100 Hz), or an output under a
    file: exit 1, one ERROR line, no page, before any diagnose runs."""
    folder = DATA / "baxter_real"
    if len(sorted(folder.glob("*.csv"))) < 3:
        pytest.skip(f"needs ≥ 3 recordings in {folder} (../shared beside the checkout)")
    data = tmp_path / "data"
    data.mkdir()
    (data / "baxter_real").symlink_to(folder)
    (tmp_path / "a_file").write_text("x")
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["--data", str(data), *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ERROR: ") and match in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "data"]


@pytest.mark.parametrize(
    ("binary", "match"),
    [
        (False, "ERROR: diagnose with r1.csv held out: "),  # they move, but are too short for diagnose
        (True, "r2.csv: not a text table"),  # the reader's refusal, naming the file
    ],
)
def test_recordings_diagnose_or_the_reader_refuses_give_one_error_line(tmp_path, capsys, binary: bool, match: str) -> None:
    """Three 1.5 s slices of a real recording (r2 binary bytes instead, in the second case):
    diagnose's own ERROR line, or the reader's with the file's path, as one line; exit 1, no page."""
    source = DATA / "baxter_real" / "Random_ang_vel_torq.csv"
    if not source.is_file():
        pytest.skip(f"needs {source} (../shared beside the checkout)")
    lines = source.read_text().splitlines()
    folder = tmp_path / "data" / "slices"
    folder.mkdir(parents=True)
    for n in (1, 2, 3):
        (folder / f"r{n}.csv").write_text("\n".join([lines[0], *lines[300 * n : 300 * n + 151]]) + "\n")
    if binary:
        (folder / "r2.csv").write_bytes(bytes(range(256)) * 8)
    assert main(["--data", str(tmp_path / "data"), "--out", str(tmp_path / "page.md")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("ERROR: ") and match in err[0], err
    assert not (tmp_path / "page.md").exists()


def _right_arm_states(duration_s: float, seed: int):
    """Simulated right-arm joint states as Baxter publishes them (both arms, by name)."""
    from baxter_dynamics_ros.simulation.plant import simulate
    from baxter_dynamics_ros.simulation.spec import SimulationSpec
    from msg_adapters.robot_joint_states import robot_joint_states

    result = simulate(SimulationSpec("random", duration_s, 100.0, seed=seed))
    return robot_joint_states(result.recording(), result.other_q, result.other_effort)


def test_a_dataset_in_other_layouts_and_of_the_right_arm_is_compared_as_the_commands_read_it(tmp_path, capsys) -> None:
    """A folder of a right-arm bag, a compressed table and a table that names no arm (the side in
    its file name): listed as the commands list recordings, read for the arm the names say, and
    every rotation compared (diagnose run with --arm right); a table naming no arm and no side in
    its name is refused, as is a dataset of both arms."""
    import gzip

    from baxter_dynamics_ros.core.joints import arm_joint_names
    from baxter_dynamics_ros.errors import RecordingFileError
    from msg_adapters.recording_files import write_joint_states

    folder = tmp_path / "data" / "lab"
    folder.mkdir(parents=True)
    states = [_right_arm_states(14.0, seed) for seed in (1, 2, 3)]
    write_joint_states(folder / "a.mcap", states[0].stamps_ns, states[0].names, states[0].position, states[0].velocity, states[0].effort)
    plain = tmp_path / "b.csv"
    write_joint_states(plain, states[1].stamps_ns, states[1].names, states[1].position, states[1].velocity, states[1].effort)
    (folder / "b.csv.gz").write_bytes(gzip.compress(plain.read_bytes()))
    right = [states[2].names.index(n) for n in arm_joint_names("right")]
    table = np.hstack([states[2].position[:, right], states[2].velocity[:, right], states[2].effort[:, right]])
    header = " ".join(f"{p}_{j}" for p in ("ang", "vel", "torq") for j in JOINT_SUFFIXES)
    np.savetxt(folder / "c_right_arm.txt", table, header=header, comments="", fmt="%.17g")
    (folder / "notes.md").write_text("no recording\n")
    assert [p.name for p in recordings(folder)] == ["a.mcap", "b.csv.gz", "c_right_arm.txt"]
    assert datasets(tmp_path / "data") == [folder]
    assert {read_side(p, None).side for p in recordings(folder)} == {"right"}
    np.testing.assert_array_equal(read_side(folder / "c_right_arm.txt", None).q, states[2].position[:, right])
    (tmp_path / "c.txt").write_text((folder / "c_right_arm.txt").read_text())
    with pytest.raises(RecordingFileError, match="name no arm"):
        read_side(tmp_path / "c.txt", None)
    assert read_side(tmp_path / "c.txt", "left").side == "left"

    assert main(["--data", str(tmp_path / "data"), "--out", str(tmp_path / "page.md")]) == 0
    page = (tmp_path / "page.md").read_text()
    assert all(f"### Test on `{name}`" in page for name in ("a.mcap", "b.csv.gz", "c_right_arm.txt")), page
    assert "--arm SIDE" in page and "## `lab`" in page
    capsys.readouterr()
    (folder / "c_right_arm.txt").rename(folder / "c_left_arm.txt")
    assert main(["--data", str(tmp_path / "data")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "recordings of both arms (left, right)" in err[0], err
