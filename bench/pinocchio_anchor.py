"""Compiled Pinocchio, the anchor of ``bench_dynamics``: ``pinocchio_anchor.cpp`` built here.

The program uses Pinocchio's headers from the installed ``pin`` wheel (``cmeel.prefix/include``
in site-packages, header-only: no explicit template instantiation) and Eigen's from the
``cmeel-eigen`` wheel or the system, compiled with ``-O3 -march=native``. The binary is cached
under ``$XDG_CACHE_HOME/baxter_dynamics_ros/bench`` (``~/.cache`` by default), keyed by the
source, the compiler and its flags; nothing is written into the repository.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sysconfig
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from baxter_dynamics_ros import ArmModel

SOURCE = Path(__file__).resolve().with_name("pinocchio_anchor.cpp")
# The compile definitions Pinocchio's CMake config gives its users (boost::variant of 25 joint types).
FLAGS = (
    "-std=c++17",
    "-O3",
    "-march=native",
    "-DNDEBUG",
    "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
    "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
    "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
    "-DBOOST_FUSION_INVOKE_MAX_ARITY=12",
)


@dataclass(frozen=True)
class AnchorRun:
    """Best µs per sample of each algorithm, and its results (tau (N, 7), M (N, 7, 7), G (N, 7))."""

    rnea_us: float
    crba_us: float
    gravity_us: float
    tau: np.ndarray
    mass: np.ndarray
    grav: np.ndarray


def _include_dirs() -> tuple[list[str], str]:
    """Include folders for Pinocchio, Boost and Eigen, or ([], why not)."""
    prefixes = {Path(sysconfig.get_paths()[key]) / "cmeel.prefix" / "include" for key in ("purelib", "platlib")}
    prefix = next((p for p in prefixes if (p / "pinocchio" / "algorithm" / "rnea.hpp").is_file()), None)
    if prefix is None:
        return [], "no Pinocchio headers under site-packages/cmeel.prefix/include (is the pin wheel installed?)"
    eigen = next(
        (p for p in (prefix / "eigen3", Path("/usr/include/eigen3")) if (p / "Eigen" / "Core").is_file()), None
    )
    if eigen is None:
        return [], "no Eigen headers (cmeel-eigen wheel or /usr/include/eigen3)"
    if not (prefix / "boost" / "variant.hpp").is_file() and not Path("/usr/include/boost/variant.hpp").is_file():
        return [], "no Boost headers (cmeel-boost wheel or /usr/include/boost)"
    return [str(prefix), str(eigen)], ""


def cache_dir() -> Path:
    """Where built anchors are kept."""
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "baxter_dynamics_ros" / "bench"


def build() -> tuple[Path | None, str]:
    """(path of the anchor binary, "") — built now if it is not cached — or (None, why it is skipped)."""
    compiler = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++") or shutil.which("clang++")
    if not compiler:
        return None, "no C++ compiler (c++, g++, clang++ or $CXX) on PATH"
    includes, why = _include_dirs()
    if not includes:
        return None, why
    try:
        version = subprocess.run([compiler, "--version"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as err:
        return None, f"{compiler} --version failed: {err}"
    key = hashlib.sha1("\n".join([SOURCE.read_text(), compiler, version, *FLAGS, *includes]).encode()).hexdigest()[:16]
    binary = cache_dir() / f"pinocchio_anchor-{key}"
    if binary.is_file():
        return binary, ""
    binary.parent.mkdir(parents=True, exist_ok=True)
    print(f"  building the compiled-Pinocchio anchor (once, about a minute) into {binary}", flush=True)
    with tempfile.TemporaryDirectory(dir=binary.parent) as tmp:
        partial = Path(tmp) / binary.name
        command = [compiler, *FLAGS, *(f"-I{d}" for d in includes), str(SOURCE), "-o", str(partial)]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            first = next((line for line in done.stderr.splitlines() if "error" in line), done.stderr[-300:])
            return None, f"the anchor did not compile: {first.strip()}"
        partial.replace(binary)
    return binary, ""


def run(binary: Path, arm: ArmModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, repeats: int) -> AnchorRun:
    """Time rnea, crba and computeGeneralizedGravity on the states q, qd, qdd (N, 7) in the anchor."""
    n = len(q)
    with tempfile.TemporaryDirectory() as tmp:
        model, states, out = Path(tmp) / "model.txt", Path(tmp) / "states.bin", Path(tmp) / "out.bin"
        rows = []
        for (d, a, alpha, offset), link in zip(arm.dh, arm.links):
            inertia = link.inertia_kgm2
            numbers = [d, a, alpha, offset, link.mass_kg, *link.com_m]
            numbers += [inertia[0, 0], inertia[0, 1], inertia[0, 2], inertia[1, 1], inertia[1, 2], inertia[2, 2]]
            rows.append(" ".join(repr(float(x)) for x in numbers))
        rows.append(" ".join(repr(float(x)) for x in arm.gravity_m_s2))
        model.write_text("\n".join(rows) + "\n")
        np.concatenate([np.ascontiguousarray(x, dtype=np.float64).ravel() for x in (q, qd, qdd)]).tofile(states)
        done = subprocess.run(
            [str(binary), str(model), str(states), str(n), str(repeats), str(out)],
            capture_output=True, text=True, check=True,
        )
        raw = np.fromfile(out)
    times = dict(line.split() for line in done.stdout.splitlines())
    return AnchorRun(
        float(times["rnea"]),
        float(times["crba"]),
        float(times["gravity"]),
        raw[: 7 * n].reshape(n, 7),
        raw[7 * n : 56 * n].reshape(n, 7, 7),
        raw[56 * n :].reshape(n, 7),
    )
