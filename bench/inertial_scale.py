"""How much of the rigid model's inertial torque each real recording shows, per joint.

For every CSV recording of every dataset folder under ``../shared/data`` and every joint j: the
least-squares coefficient s_j of the model's inertial torque

    τ_inertial,j = τ_rigid,j(q, q̇_f, q̈_f) − τ_rigid,j(q, q̇_f, 0)

(Pinocchio's RNEA on Rethink's URDF, :class:`bench.plain_fit.UrdfArm`; q̇ low-passed at 4 Hz and
q̈ its central difference, :func:`bench.plain_fit.denoise`) in the residual effort_j − τ_rigid,j,
fitted beside an offset and Coulomb friction sign(q̇_f,j), at s1 also beside the spring's
[q_s1, cos q_s1, sin q_s1]. s_j = 0: the recording carries the model's inertial torque as it is;
s_j = −0.2: a fifth less of it. At the wrists the model's inertial torque is small against the
effort's noise and the coefficient says little (w2's swings by several units between recordings).
At s0 (a vertical axis: no gravity) a torque gain and an error of the
inertia about s0 are this same column, which is why ``diagnose`` reports them as not
distinguishable where its training data cannot tell them apart (``selection.LOOKALIKES``).

    python -m bench.inertial_scale [--data DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from baxter_dynamics_ros.errors import BaxterDynamicsError
from bench.plain_fit import JOINT_SUFFIXES, UrdfArm, denoise
from msg_adapters.recording_files import read_recording

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
S1 = JOINT_SUFFIXES.index("s1")


def inertial_scale(arm: UrdfArm, q: np.ndarray, qd: np.ndarray, effort: np.ndarray, rate_hz: float) -> np.ndarray:
    """(7,) per joint the least-squares coefficient of the model's inertial torque in the rigid
    residual (module docstring); q, qd, effort (n, 7) in rad, rad/s, N·m at rate_hz (Hz)."""
    qd_f, qdd_f = denoise(qd, rate_hz)
    tau = arm.torque(q, qd_f, qdd_f)
    inertial = tau - arm.torque(q, qd_f, np.zeros_like(qdd_f))
    residual = effort - tau
    out = np.empty(len(JOINT_SUFFIXES))
    for j in range(len(JOINT_SUFFIXES)):
        columns = [inertial[:, j], np.ones(len(q)), np.sign(qd_f[:, j])]
        if j == S1:
            columns += [q[:, S1], np.cos(q[:, S1]), np.sin(q[:, S1])]
        out[j] = np.linalg.lstsq(np.column_stack(columns), residual[:, j], rcond=None)[0][0]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.inertial_scale", description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DATA, help="folder of dataset folders (default ../shared/data)")
    parser.add_argument("--arm", default="left", choices=("left", "right"), help="the arm of the recordings (default left)")
    args = parser.parse_args(argv)
    folders = sorted(p for p in args.data.iterdir() if p.is_dir() and any(p.glob("*.csv"))) if args.data.is_dir() else []
    if not folders:
        print(f"ERROR: {args.data}: no folder of CSV recordings there", file=sys.stderr)
        return 1
    urdf_arm = UrdfArm.from_urdf(args.arm)
    print("least-squares scale of the model's inertial torque in the rigid residual (0: as modelled)")
    print(f"{'dataset / recording':60s}" + "".join(f"{j:>8s}" for j in JOINT_SUFFIXES))
    try:
        for folder in folders:
            for path in sorted(folder.glob("*.csv")):
                rec = read_recording(path, arm=args.arm, note=None)
                scale = inertial_scale(urdf_arm, rec.q, rec.qd, rec.effort, rec.rate_hz)
                print(f"{folder.name + ' / ' + path.name:60.60s}" + "".join(f"{s:8.3f}" for s in scale))
    except BaxterDynamicsError as err:
        print(f"ERROR: {err}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
