"""Memory and time of ``baxter-dynamics diagnose`` on an archive of hour-long files (issue 14 §2).

Simulated recordings of the right arm (random joint-space excitation, the s1 spring and viscous
friction, 0.1 N·m effort noise; 100 Hz, one hour each, written by the project's writer as mcap
bags of Baxter's 21-joint /robot/joint_states, the other arm at rest). Measured for 4 h (3
training files + 1 test file) and 12 h (9 + 3): the command as a subprocess, its wall time and
its peak memory — the resident set of its whole process tree (the command and its worker
processes, summed; /proc polled every 50 ms), the tree's summed proportional set (shared pages
counted once) and, from ``getrusage(RUSAGE_CHILDREN)``, the largest single process. Goals for
12 h: ≤ 1.5 GB peak RSS (the tree, summed) and ≤ 90 s. Memory should not
grow with the hours: each file is read, reduced to statistics and let go.

Simulating 12 hours takes a while, so the files are cached under
``$XDG_CACHE_HOME/baxter_dynamics_ros/bench/scale-<key>`` (``~/.cache`` by default), keyed by the
simulator spec, the package version of the writer and this module's spec constants; delete the
folder to make them anew.

Run: ``./dev bench scale`` (or ``python -m bench.bench_scale --hours 4 --jobs 1`` for one size and one
process).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.pinocchio_anchor import cache_dir

REPO = Path(__file__).resolve().parents[1]
HOUR_S = 3600.0
RATE_HZ = 100.0
EFFECTS = {"s1_spring": {}, "viscous_friction": {"damping_nm_s_rad": [1.0, 1.5, 0.6, 0.6, 0.15, 0.15, 0.05]}}
SENSOR = {"effort_noise_nm": 0.1}
SEEDS = tuple(300 + k for k in range(12))  # files 0-8 train the 12 h run, 9-11 test it
SIZES = {4: ([0, 1, 2], [9]), 12: (list(range(9)), [9, 10, 11])}
GOAL_RSS_GB = 1.5
GOAL_S = 90.0
POLL_S = 0.05


def _key(duration_s: float) -> str:
    spec = {"trajectory": "random", "duration_s": duration_s, "rate_hz": RATE_HZ, "seeds": SEEDS, "effects": EFFECTS, "sensor": SENSOR, "format": "mcap", "writer": 1}
    return hashlib.sha1(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]


def recordings(duration_s: float) -> list[Path]:
    """The 12 files (made now if not cached): one per seed, duration_s each."""
    folder = cache_dir() / f"scale-{_key(duration_s)}"
    paths = [folder / f"random-{seed}.mcap" for seed in SEEDS]
    missing = [(seed, p) for seed, p in zip(SEEDS, paths) if not p.exists()]
    if missing:
        from baxter_dynamics_ros import load_arm_model
        from baxter_dynamics_ros.core.effect_specs import effects_from_dict
        from baxter_dynamics_ros.simulation.plant import simulate
        from baxter_dynamics_ros.simulation.spec import SensorModel, SimulationSpec
        from msg_adapters.recording_files import write_joint_states
        from msg_adapters.robot_joint_states import robot_joint_states

        folder.mkdir(parents=True, exist_ok=True)
        arm = load_arm_model("right")
        for seed, path in missing:
            start = time.perf_counter()
            spec = SimulationSpec(
                trajectory="random", duration_s=duration_s, rate_hz=RATE_HZ, seed=seed, side="right",
                effects=effects_from_dict(EFFECTS), sensor=SensorModel(**SENSOR),
            )  # fmt: skip
            result = simulate(spec, arm)
            states = robot_joint_states(result.recording(), result.other_q, result.other_effort)
            partial = path.with_suffix(".partial.mcap")
            write_joint_states(partial, states.stamps_ns, states.names, states.position, states.velocity, states.effort, replace=True)
            partial.rename(path)
            print(f"  simulated {path.name} ({duration_s:g} s) in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return paths


def _tree(pid: int) -> tuple[int, int]:
    """(summed resident set, summed proportional set) of pid and its descendants, bytes (0 once gone).

    The resident sets count the pages the processes share (the libraries' code) once per process;
    the proportional sets (``Pss`` of /proc/PID/smaps_rollup) share them out, so their sum is the
    memory the tree holds."""
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        children.setdefault(int(fields[1]), []).append(int(entry))
        rss[int(entry)] = int(fields[21]) * os.sysconf("SC_PAGE_SIZE")
    total, proportional, todo = 0, 0, [pid]
    while todo:
        p = todo.pop()
        total += rss.get(p, 0)
        proportional += _pss(p)
        todo += children.get(p, [])
    return total, proportional


def _pss(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/smaps_rollup") as f:
            return next((int(line.split()[1]) * 1024 for line in f if line.startswith("Pss:")), 0)
    except OSError:
        return 0


def measure(train: list[Path], test: list[Path], jobs: int | None) -> tuple[float, int, int, int, str]:
    """(wall s, peak tree RSS bytes, peak tree PSS bytes, largest process' peak RSS bytes, stdout) of one diagnose run."""
    with tempfile.TemporaryDirectory(prefix="bench_scale-") as tmp:
        command = [sys.executable, "-m", "baxter_dynamics_ros.cli", "diagnose", "--train", *map(str, train), "--test", *map(str, test), "--out", f"{tmp}/out", "--no-progress"]
        if jobs is not None:
            command += ["--jobs", str(jobs)]
        start = time.perf_counter()
        process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        peak = peak_pss = 0
        while process.poll() is None:
            rss, pss = _tree(process.pid)
            peak, peak_pss = max(peak, rss), max(peak_pss, pss)
            time.sleep(POLL_S)
        wall = time.perf_counter() - start
        out, err = process.communicate()
        if process.returncode != 0:
            raise SystemExit(f"diagnose failed ({process.returncode}):\n{err}")
        largest = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
        return wall, peak, peak_pss, largest, out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.bench_scale")
    parser.add_argument("--hours", type=int, nargs="+", choices=sorted(SIZES), default=sorted(SIZES), help="sizes to run (default 4 12)")
    parser.add_argument("--jobs", type=int, help="diagnose --jobs (default: the command's, every core)")
    parser.add_argument("--file-s", type=float, default=HOUR_S, help="length of each file, s (default 3600; shorter for a quick look)")
    args = parser.parse_args(argv)
    paths = recordings(args.file_s)
    print(f"scale: diagnose on {args.file_s:g}-s files of 100 Hz, 21-joint mcap bags (cached in {paths[0].parent}); --jobs {args.jobs or 'default'}, {os.cpu_count()} cores")
    for hours in args.hours:
        train, test = ([paths[k] for k in ks] for ks in SIZES[hours])
        load = os.getloadavg()
        wall, peak, peak_pss, largest, out = measure(train, test, args.jobs)
        total_h = (len(train) + len(test)) * args.file_s / HOUR_S
        print(
            f"  {total_h:5.2f} h ({len(train)} train + {len(test)} test files): {wall:6.1f} s, peak RSS {peak / 1e9:.2f} GB "
            f"(process tree summed; PSS summed {peak_pss / 1e9:.2f} GB; largest single process {largest / 1e9:.2f} GB); "
            f"load before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}"
        )
        print("    selected: " + next((line.split(": ", 1)[1] for line in out.splitlines() if line.startswith("selected effects")), "?"))
        if hours == 12 and args.file_s == HOUR_S:
            ok = peak <= GOAL_RSS_GB * 1e9 and wall <= GOAL_S
            print(f"  goal 12 h: <= {GOAL_RSS_GB:g} GB and <= {GOAL_S:g} s: {'met' if ok else 'NOT met'}")
    print(f"  load after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
