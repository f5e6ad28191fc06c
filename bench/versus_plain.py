"""``diagnose`` against the plain reference fit on every real dataset, every rotation (issue 20 §1).

For each folder of real recordings (default: every folder of recordings under ``../shared/data``, in
any layout the package reads: :func:`recordings`) and each rotation — each recording the test once, the others training — this runs

- the plain fit of :mod:`bench.plain_fit` (recordings read by the package's reader, the sample rate
  of a table without a time column estimated from position and velocity, as ``diagnose`` does), and
- ``baxter-dynamics diagnose --train … --test … --out DIR --arm SIDE --force --no-progress --jobs 1``
  in a subprocess (several rotations at once: ``--procs``; one BLAS thread each), reading ``final.test_rms`` and
  ``denoised.test_rms`` from DIR/diagnosis.json,

and writes per dataset, rotation and joint the held-out RMS of the plain fit, of the denoised rigid
model and of ``diagnose``, the ratio diagnose/plain, the worst ratio per dataset, and every case that
misses the goal (:func:`misses`), also printed as the ``KNOWN_MISSES`` literal of
``test/bench/test_versus_plain.py``. For each miss against the plain fit it also runs the plain fit
again without the effects it applied at that joint which ``diagnose`` does not apply there: how much
of the plain fit's lead rests on them.

Run: ``python -m bench.versus_plain --out docs/real_robot_versus_plain.md`` (``--plain-cutoff-hz`` sets
the plain fit's low-pass of q̇, 4 Hz by default).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from baxter_dynamics_ros.cli.inputs import expand_inputs
from baxter_dynamics_ros.core.output_files import check_outputs, staged_outputs
from baxter_dynamics_ros.core.recording import Recording
from baxter_dynamics_ros.errors import BaxterDynamicsError, DiagnosisError, OutputError, RecordingFileError
from bench.plain_fit import CUTOFF_HZ, JOINT_SUFFIXES, RecordingStats, UrdfArm, effect_name, physical_levels, plain_diagnosis, recording_stats
from msg_adapters.recording_files import read_recording

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"
#: The goal (issue 20 §1): diagnose ≤ PLAIN_FACTOR·plain + PLAIN_SLACK_NM at every joint, and
#: ≤ RIGID_FACTOR·denoised rigid + RIGID_SLACK_NM.
PLAIN_FACTOR, PLAIN_SLACK_NM = 1.05, 0.005
RIGID_FACTOR, RIGID_SLACK_NM = 1.05, 0.01


@dataclass(frozen=True)
class Rotation:
    """One split of a dataset and its held-out RMS per joint, (7,) N·m each."""

    dataset: str
    test: str
    train: tuple[str, ...]
    plain: np.ndarray
    rigid: np.ndarray  # diagnose's denoised rigid model
    diagnose: np.ndarray
    plain_selected: tuple[str, ...]
    diagnose_selected: tuple[str, ...]
    #: diagnose's selected effects → the joints (suffixes) they act on
    diagnose_joints: dict[str, tuple[str, ...]]
    #: diagnose's per-joint effects → {joint suffix → why it is not applied there} (its ``not_at``)
    diagnose_not_at: dict[str, dict[str, str]]
    #: joint suffix of a miss against plain → the plain fit's held-out RMS there, N·m, when it may not
    #: take the effects at that joint that diagnose does not apply there (:func:`withheld`)
    plain_without: dict[str, float] = field(default_factory=dict)
    #: joint suffix of a miss against plain → the plain fit's held-out RMS there, N·m, with its q̇
    #: low-passed at the cut-off diagnose chose for that joint instead of its own
    plain_at_cutoff: dict[str, float] = field(default_factory=dict)
    #: (7,) Hz, diagnose's q̇ low-pass per joint (its ``q_ddot_cutoff_hz``)
    diagnose_cutoff_hz: tuple[float, ...] = ()
    #: the plain fit's per-joint selections "name@joint" → their fitted values (:meth:`PlainResult.joint_values`)
    plain_values: dict[str, tuple[float, ...]] = field(default_factory=dict)
    #: (7,) N·m, the plain fit never taking a move that leaves values no physical effect has
    plain_physical: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: (7,) the share of the test samples outside the range of the training data (diagnose's ``coverage``)
    test_outside: np.ndarray = field(default_factory=lambda: np.zeros(0))


def recordings(folder: Path) -> list[Path]:
    """A dataset folder's recordings as the commands list them (:func:`~baxter_dynamics_ros.cli.inputs.expand_inputs`:
    tables, compressed or not, bags, each part of a MATLAB file), [] for a folder that holds none."""
    try:
        return expand_inputs([folder])
    except RecordingFileError:
        return []


def datasets(root: Path = DATA) -> list[Path]:
    """The folders under ``root`` that hold recordings, sorted."""
    return sorted(p for p in root.iterdir() if p.is_dir() and recordings(p)) if root.is_dir() else []


def read_side(path: Path, arm: str | None) -> Recording:
    """One recording of a dataset: of ``arm`` when given; else of the arm its joint names say, or,
    where they name none (as the other unit's ``ang_s0 …``), of the side its file name says, as the
    commands read it; RecordingFileError when neither does."""
    return read_recording(path, arm=arm, note=None)


def run_diagnose(train: Sequence[Path], test: Path, out: Path, arm: str) -> dict:
    """``baxter-dynamics diagnose`` on one split in a subprocess (one worker); its diagnosis.json.
    Raises DiagnosisError with diagnose's own ERROR line when it fails."""
    exe = Path(sys.executable).with_name("baxter-dynamics")
    command = [str(exe), "diagnose", "--train", *map(str, train), "--test", str(test), "--out", str(out),
               "--arm", arm, "--force", "--no-progress", "--jobs", "1"]
    # One BLAS thread per diagnose, as its own workers have: --procs of them share the cores.
    env = {**os.environ, **{k: "1" for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}}
    done = subprocess.run(command, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        said = [line.removeprefix("ERROR: ") for line in done.stderr.splitlines() if line.startswith("ERROR: ")]
        raise DiagnosisError(f"diagnose with {test.name} held out: {said[-1] if said else f'exit {done.returncode}'}")
    return json.loads((out / "diagnosis.json").read_text())


def compare_dataset(folder: Path, *, arm: str | None = None, procs: int = 2, plain_cutoff_hz: float = CUTOFF_HZ) -> list[Rotation]:
    """Every rotation of the recordings in ``folder`` (:func:`recordings`; of ``arm``, or as
    :func:`read_side` finds it): plain fit here (q̇ low-passed at plain_cutoff_hz), diagnose in ≤
    procs subprocesses at once."""
    files = recordings(folder)
    if len(files) < 3:
        raise ValueError(f"{folder}: a rotation needs at least 3 recordings (2 to train, 1 to test), found {len(files)}")
    # The plain fit's statistics first: a recording it cannot read, or a cut-off it cannot apply,
    # stops the comparison before any diagnose runs.
    recs = [read_side(f, arm) for f in files]  # as diagnose reads them; errors name the file
    sides = {rec.side for rec in recs}
    if len(sides) != 1:
        raise ValueError(f"{folder}: recordings of both arms ({', '.join(sorted(sides))}); a dataset's rotations need one arm")
    (side,) = sides
    urdf_arm = UrdfArm.from_urdf(side)
    by_cutoff: dict[float, list[RecordingStats]] = {}

    def stats_at(cutoff_hz: float) -> list[RecordingStats]:
        """Every recording's statistics with q̇ low-passed at cutoff_hz, computed once."""
        if cutoff_hz not in by_cutoff:
            with threadpool_limits(1):
                by_cutoff[cutoff_hz] = [
                    recording_stats(urdf_arm, f.name, rec.q, rec.qd, rec.effort, rec.rate_hz, cutoff_hz=cutoff_hz) for f, rec in zip(files, recs)
                ]
        return by_cutoff[cutoff_hz]

    stats = stats_at(plain_cutoff_hz)
    with tempfile.TemporaryDirectory(prefix="versus_plain-") as scratch, ThreadPoolExecutor(procs) as pool:
        jobs: list[Future] = [
            pool.submit(run_diagnose, [f for f in files if f != test], test, Path(scratch) / str(k), side) for k, test in enumerate(files)
        ]
        out = []
        for k, test in enumerate(files):
            train = [s for i, s in enumerate(stats) if i != k]
            plain = plain_diagnosis(train, [stats[k]])
            report = jobs[k].result()
            rotation = Rotation(
                folder.name, test.name, tuple(f.name for f in files if f != test), plain.test_rms,
                np.array(report["denoised"]["test_rms"], dtype=float), np.array(report["final"]["test_rms"], dtype=float),
                plain.selected, tuple(e["name"] for e in report["effects"] if e["selected"]),
                {e["name"]: tuple(j.split("_", 1)[-1] for j in e["joints"]) for e in report["effects"] if e["selected"]},
                {e["name"]: {j.split("_", 1)[-1]: why for j, why in e["not_at"].items()} for e in report["effects"]},
                diagnose_cutoff_hz=tuple(float(c) for c in report["q_ddot_cutoff_hz"].values()),
                plain_values={label: plain.joint_values(label) for label in plain.selected if "@" in label},
                plain_physical=plain_diagnosis(train, [stats[k]], physical=True).test_rms,
                test_outside=np.array(list(report["coverage"]["test_outside_share"].values()), dtype=float),
            )
            without, at_cutoff = {}, {}
            for _, _, joint, against in misses([rotation]):
                if against != "plain":
                    continue
                j = JOINT_SUFFIXES.index(joint)
                barred = withheld(rotation, joint)
                if barred:
                    without[joint] = float(plain_diagnosis(train, [stats[k]], exclude=barred).test_rms[j])
                cut = stats_at(rotation.diagnose_cutoff_hz[j])
                at_cutoff[joint] = float(plain_diagnosis([s for i, s in enumerate(cut) if i != k], [cut[k]]).test_rms[j])
            out.append(replace(rotation, plain_without=without, plain_at_cutoff=at_cutoff))
        return out


def misses(rotations: Sequence[Rotation]) -> dict[tuple[str, str, str, str], str]:
    """Cases missing the goal: (dataset, test file, joint, "plain" | "rigid") → "measured: …"."""
    out = {}
    for r in rotations:
        for j, joint in enumerate(JOINT_SUFFIXES):
            if r.diagnose[j] > PLAIN_FACTOR * r.plain[j] + PLAIN_SLACK_NM:
                out[(r.dataset, r.test, joint, "plain")] = f"measured: diagnose {r.diagnose[j]:.3f} vs plain {r.plain[j]:.3f} N·m"
            if r.diagnose[j] > RIGID_FACTOR * r.rigid[j] + RIGID_SLACK_NM:
                out[(r.dataset, r.test, joint, "rigid")] = f"measured: diagnose {r.diagnose[j]:.3f} vs denoised rigid {r.rigid[j]:.3f} N·m"
    return out


def _plain_at(rotation: Rotation, joint: str) -> list[tuple[str, str]]:
    """Each per-joint effect the plain fit applied at ``joint`` (its "name@joint" selections), with
    "" where ``diagnose`` applies it there too, else why it does not (its ``not_at``, or that it did
    not select it, with no reason per joint)."""
    out = []
    for chosen in rotation.plain_selected:
        if chosen.partition("@")[2] != joint:
            continue
        name = effect_name(chosen)
        if joint in rotation.diagnose_joints.get(name, ()):
            out.append((chosen, ""))
        else:
            out.append((chosen, rotation.diagnose_not_at.get(name, {}).get(joint) or "not selected by diagnose (see its reason)"))
    return out


#: Units of the plain fit's per-joint effects' values (:meth:`PlainResult.joint_values`).
UNITS = {"torque_offset": "N·m", "viscous_friction": "N·m·s/rad", "coulomb_friction": "N·m", "stribeck_friction": "N·m",
         "armature": "kg·m²", "delay": "s", "torque_gain": ""}


def _valued(rotation: Rotation, chosen: str) -> str:
    """ "name@joint (its fitted values and unit[, negative: not physical])", or the label alone when
    the rotation has no values."""
    values = rotation.plain_values.get(chosen)
    if values is None:
        return chosen
    name = effect_name(chosen)
    flag = ", negative: not physical" if min(physical_levels(chosen, values), default=0.0) < 0 else ""
    return f"{chosen} ({', '.join(f'{v:.3g}' for v in values)}{' ' + UNITS[name] if UNITS[name] else ''}{flag})"


def diagnose_says(rotation: Rotation, joint: str) -> str:
    """:func:`_plain_at` in words: "name@joint (the plain fit's values): applied by diagnose too" or
    ": why not"; "—" if none."""
    return "; ".join(f"{_valued(rotation, chosen)}: {why or 'applied by diagnose too'}" for chosen, why in _plain_at(rotation, joint)) or "—"


def withheld(rotation: Rotation, joint: str) -> frozenset[str]:
    """The plain fit's "name@joint" selections at ``joint`` that ``diagnose`` does not apply there."""
    return frozenset(chosen for chosen, why in _plain_at(rotation, joint) if why)


def _row(label: str, values: np.ndarray) -> str:
    return f"| {label} | " + " | ".join(f"{v:.3f}" for v in values) + " |"


def page(rotations: Sequence[Rotation], elapsed_s: float, command: str, plain_cutoff_hz: float = CUTOFF_HZ) -> str:
    """The Markdown page: a table per dataset and rotation, the worst ratios, the misses; ``command``
    the one that made it."""
    lines = [
        "# `diagnose` against a plain fit on the real recordings",
        "",
        f"Generated by `{command}` ({elapsed_s:.0f} s). For every folder of real recordings under `../shared/data` "
        "and every rotation (each recording the test once, the others training): held-out RMS per joint, N·m, of",
        "",
        "- **plain**: the plain reference fit of `bench/plain_fit.py`, which shares none of the package's fitting code: "
        "the rigid residual of Rethink's URDF (Pinocchio, joint-torque regressor) with q̈ the central difference of q̇ "
        f"low-passed by a zero-phase 4th-order Butterworth at {plain_cutoff_hz:g} Hz; linear least squares of torque_offset (per recording), "
        "viscous, Coulomb and Stribeck friction (v_s 0.02–0.2 rad/s), the s1 spring [1, q_s1, cos q_s1, sin q_s1], payload "
        "(last link's 10 inertial parameters), inertial_error (all 70), armature, delay (−τ̇_rigid) and torque_gain "
        "(τ_rigid per joint); acceleration_noise is not linear and is omitted (the filtering is always applied); greedy "
        "forward selection by leave-one-recording-out error, per joint for per-joint effects, 5 % to add (the larger of "
        "nested alternatives only if it pays 5 % more than the smaller); offsets on the test recording: the training "
        "recordings' mean, as `diagnose` writes out;",
        "- **plain, physical values only**: the same, never taking a move after which a per-joint effect's values (fitted "
        "on all training recordings) are ones no physical effect has — a negative armature, viscous or Coulomb coefficient, "
        "or friction at rest (Stribeck's F_s), which `diagnose`'s bounds refuse; for comparison only, not the goal's yardstick;",
        "- **rigid (denoised)**: `diagnose`'s rigid-body model with its filtered q̈ (`denoised.test_rms`; q̇ low-passed "
        "at each joint's own cut-off, chosen on the training data, the table's last row);",
        "- **diagnose**: `baxter-dynamics diagnose --train … --test … --arm SIDE --jobs 1` (`final.test_rms`; SIDE the "
        "recordings' arm, as their joint names or else their file names say).",
        "",
        "The tables' last row: the share of the test recording's samples whose joint angle lies outside the range of the "
        "training recordings (`diagnose`'s `coverage.test_outside_share`); there every fit extrapolates (at s0, whose axis "
        "is vertical, the angle changes no torque).",
        "",
        "The plain fit is a yardstick of held-out error only, not of attribution: fitted freely, `inertial_error` can "
        "stand in for the s1 spring (../shared/DIAGNOSIS-NOTES.md), and its selections below are what paid on "
        "leave-one-recording-out error, nothing more.",
        "",
        f"Goal (issue 20 §1): diagnose ≤ {PLAIN_FACTOR:g} × plain + {PLAIN_SLACK_NM:g} N·m and "
        f"≤ {RIGID_FACTOR:g} × rigid + {RIGID_SLACK_NM:g} N·m at every joint; checked by `test/bench/test_versus_plain.py`.",
        "",
    ]
    by_dataset: dict[str, list[Rotation]] = {}
    for r in rotations:
        by_dataset.setdefault(r.dataset, []).append(r)
    header = "| held-out RMS [N·m] | " + " | ".join(JOINT_SUFFIXES) + " |"
    rule = "|---|" + "---:|" * len(JOINT_SUFFIXES)
    for name, rots in by_dataset.items():
        ratios = np.array([r.diagnose / r.plain for r in rots])
        k, j = np.unravel_index(int(np.argmax(ratios)), ratios.shape)
        lines += [f"## `{name}`", "",
                  f"Worst ratio diagnose/plain: **{ratios[k, j]:.2f}** (test `{rots[k].test}`, {JOINT_SUFFIXES[j]}).", ""]
        for r in rots:
            lines += [f"### Test on `{r.test}`", "", header, rule,
                      _row("plain", r.plain), _row("plain, physical values only", r.plain_physical), _row("rigid (denoised)", r.rigid),
                      _row("diagnose", r.diagnose),
                      _row("ratio diagnose/plain", r.diagnose / r.plain),
                      "| diagnose's q̇ cut-off [Hz] | " + " | ".join(f"{c:g}" for c in r.diagnose_cutoff_hz) + " |",
                      "| test samples outside the training data's range | " + " | ".join(f"{v:.0%}" for v in r.test_outside) + " |", "",
                      f"Plain fit selected: {', '.join(r.plain_selected) or 'nothing'}.", "",
                      f"`diagnose` selected: {', '.join(r.diagnose_selected) or 'nothing'}.", ""]
    found = misses(rotations)
    lines += ["## Cases that miss the goal", ""]
    if found:
        by_test = {(r.dataset, r.test): r for r in rotations}
        lines += ["The last columns: each per-joint effect the plain fit applied at that joint, with its fitted values there "
                  "(Stribeck: Coulomb friction F_c, then the bump F_s − F_c at rest; an offset: the one applied to the test recording; "
                  "\"not physical\" where an armature, a viscous or Coulomb coefficient or the friction at rest F_s is negative, which "
                  "`diagnose`'s bounds refuse), and why `diagnose` does not "
                  "apply it there (its report's `not_at`); the plain fit's held-out RMS at the joint when it is run again "
                  "without those it applied there and `diagnose` does not (— where there are none); and when it is run again with "
                  "its q̇ low-passed at the cut-off `diagnose` chose for that joint (the tables' row above) instead of "
                  f"{plain_cutoff_hz:g} Hz: how much of the difference is the filter's.", "",
                  "| dataset | test | joint | against | measured | the plain fit's effects at the joint in `diagnose` | plain without them [N·m] "
                  "| plain at diagnose's cut-off [N·m] |",
                  "|---|---|---|---|---|---|---:|---:|"]
        for (d, t, j, c), m in found.items():
            r = by_test[d, t]
            without, at_cutoff = (r.plain_without.get(j), r.plain_at_cutoff.get(j)) if c == "plain" else (None, None)
            lines.append(f"| {d} | `{t}` | {j} | {c} | {m[len('measured: '):]} | {diagnose_says(r, j)} | "
                         f"{'—' if without is None else f'{without:.3f}'} | {'—' if at_cutoff is None else f'{at_cutoff:.3f}'} |")
    else:
        lines.append("None.")
    return "\n".join(lines) + "\n"


def known_misses_literal(rotations: Sequence[Rotation]) -> str:
    """The ``KNOWN_MISSES`` dict of the test, as Python source."""
    body = "".join(f"    {key!r}: {reason!r},\n" for key, reason in misses(rotations).items())
    return "KNOWN_MISSES = {\n" + body + "}\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.versus_plain", description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA, help="folder of dataset folders (default ../shared/data)")
    parser.add_argument("--out", type=Path, help="Markdown page to write (default: print only the summary)")
    parser.add_argument("--procs", type=int, default=2, help="diagnose subprocesses at once (default 2)")
    parser.add_argument("--arm", choices=("left", "right"), help="the recordings' arm (default: as their joint names, else their file names, say)")
    parser.add_argument("--plain-cutoff-hz", type=float, default=CUTOFF_HZ,
                        help=f"the plain fit's low-pass of q̇, Hz (default {CUTOFF_HZ:g}; diagnose chooses its own)")
    args = parser.parse_args(argv)
    command = " ".join(["python -m bench.versus_plain", *(sys.argv[1:] if argv is None else argv)])
    folders = datasets(args.data)
    if not folders:
        print(f"ERROR: no folders of recordings under {args.data}", file=sys.stderr)
        return 1
    start = time.perf_counter()
    try:
        if args.out:
            check_outputs([args.out], replace=True)  # before the comparison: fail fast
        rotations = [r for folder in folders for r in compare_dataset(folder, arm=args.arm, procs=args.procs, plain_cutoff_hz=args.plain_cutoff_hz)]
    except (ValueError, BaxterDynamicsError) as exc:
        print(f"ERROR: {exc}", file=sys.stderr)
        return 1
    elapsed = time.perf_counter() - start
    for r in rotations:
        print(f"{r.dataset} / {r.test}: worst ratio diagnose/plain {np.max(r.diagnose / r.plain):.2f}")
    if args.out:
        try:
            with staged_outputs([args.out]) as (staged,):
                staged.write_text(page(rotations, elapsed, command, args.plain_cutoff_hz))
        except OutputError as exc:
            print(f"ERROR: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {args.out}")
    print(f"{elapsed:.0f} s; cases missing the goal, for test/bench/test_versus_plain.py:")
    print(known_misses_literal(rotations))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
