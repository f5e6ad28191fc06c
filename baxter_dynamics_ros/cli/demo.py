"""The main job on a built-in default (``./dev demo``): model, live node, recording, diagnosis.

1. The Lagrange-Euler model along the paper's first trajectory: G, the diagonal of M and τ.
2. A simulated Baxter with unmodelled effects the model does not know (the s1 gravity-assist
   spring, viscous friction, q̇ noise like the real robot), recorded as ``/robot/joint_states``
   bags: three to learn from, one to test on.
3. The node in its own process on simulated time, the test bag played into it, and what it
   publishes on ``~/residual``.
4. ``process`` of the same bag (zero-phase q̈) and a plot of measured and modelled torques.
5. ``diagnose``: where the gap lies, which effects cause it, how far it shrinks on the test bag.
6. The node again, now with the diagnosis' ``effects.yaml``: the residual it publishes shrinks.

Every ROS process runs on a private, local ROS graph (:mod:`baxter_dynamics_ros.ros.ros_env`). Outputs
go to ``out/demo`` (or ``--out``), replaced on each run; nothing else is written.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..core.arm_model import load_arm_model
from ..core.joints import JOINT_SUFFIXES
from ..core.joints import JOINTS as N
from ..ros.ros_env import isolated_ros_env

EFFECTS = {
    "s1_spring": {},
    "viscous_friction": {"damping_nm_s_rad": [1.0, 1.5, 0.6, 0.6, 0.15, 0.15, 0.05]},
    "acceleration_noise": {"velocity_noise_rad_s": 0.015},
}
RECORDINGS = (("train-1", "random", 1), ("train-2", "random", 2), ("train-3", "paper_y", 3), ("test", "paper_xyz", 4))
DURATION_S = 20.0


def _say(text: str) -> None:
    print(text, flush=True)


def model_table() -> None:
    """Step 1: G, diag M and τ at a few instants of the paper's first trajectory (right arm)."""
    from ..simulation.trajectories import make_reference

    arm = load_arm_model("right")
    ref = make_reference(arm, "paper_xyz", 10.0)
    t = np.arange(len(ref.q)) * ref.dt_s
    qdd = np.gradient(ref.qd, ref.dt_s, axis=0)
    picks = [int(np.argmin(np.abs(t - s))) for s in (0.0, 2.5, 5.0, 7.5, 10.0)]
    q, qd, qdd = ref.q[picks], ref.qd[picks], qdd[picks]
    gravity, mass, tau = arm.gravity(q), arm.mass_matrix(q), arm.inverse_dynamics(q, qd, qdd)
    joints = " ".join(f"{n.split('_')[1]:>7}" for n in arm.joint_names)
    _say("1. The L-E model along the paper's trajectory 1 (x = 0.6 + 0.1 sin t, y = −0.2 + 0.1 cos t, z = 0.1 + 0.1 cos 0.2t)")
    _say(f"   {'t [s]':>6} {'':18} {joints}")
    for k, i in enumerate(picks):
        for label, row in (("G [N·m]", gravity[k]), ("diag M [kg·m²]", np.diag(mass[k])), ("τ [N·m]", tau[k])):
            stamp = f"{t[i]:6.1f}" if label.startswith("G") else " " * 6
            _say(f"   {stamp} {label:18} " + " ".join(f"{v:7.3f}" for v in row))


def simulate_recordings(out: Path) -> dict[str, Path]:
    """Step 2: the simulated recordings (mcap bags with Baxter's joint names)."""
    from msg_adapters.recording_files import write_joint_states
    from msg_adapters.robot_joint_states import robot_joint_states

    from ..core.effect_specs import effects_from_dict
    from ..simulation.plant import simulate
    from ..simulation.sensor import write_ground_truth
    from ..simulation.spec import SensorModel, SimulationSpec

    _say(f"\n2. Simulating {len(RECORDINGS)} recordings of {DURATION_S:g} s with effects the model lacks: {', '.join(EFFECTS)}")
    arm = load_arm_model("right")
    paths = {}
    for name, trajectory, seed in RECORDINGS:
        spec = SimulationSpec(
            trajectory=trajectory, duration_s=DURATION_S, rate_hz=100.0, seed=seed, side="right",
            effects=effects_from_dict(EFFECTS), sensor=SensorModel(effort_noise_nm=0.1),
        )
        result = simulate(spec, arm)
        states = robot_joint_states(result.recording(), result.other_q, result.other_effort)
        path = out / f"{name}.mcap"
        write_joint_states(path, states.stamps_ns, states.names, states.position, states.velocity, states.effort, replace=True)
        write_ground_truth(out / f"{name}.mcap.truth.json", result)
        paths[name] = path
        _say(f"   {path} ({trajectory}, {len(states.stamps_ns)} messages of {len(states.names)} joints)")
    return paths


def live_node(bag: Path, effects_file: Path | None = None) -> np.ndarray:
    """The node on simulated time, the bag played into it; returns ~/residual (N, 7) as received."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState

    extra = [] if effects_file is None else ["-p", f"effects_file:={effects_file}"]
    node_proc = subprocess.Popen(
        [sys.executable, "-m", "baxter_dynamics_ros.ros.node", "--ros-args", "-p", "arm:=right", "-p", "use_sim_time:=true", *extra],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    received: list[JointState] = []
    node = rclpy.create_node("baxter_dynamics_demo", context=context)
    node.create_subscription(JointState, "/baxter_dynamics/residual", received.append, 100)
    executor.add_node(node)
    player = None
    try:
        deadline = time.monotonic() + 20.0
        while node.count_publishers("/baxter_dynamics/residual") == 0 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        player = subprocess.Popen(
            [sys.executable, "-m", "baxter_dynamics_ros.cli", "play", str(bag), "--speed", "2", "--wait-for-subscribers", "10"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        )
        while player.poll() is None:
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        if player is not None and player.poll() is None:
            player.terminate()
        node_proc.terminate()
        try:
            node_proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            node_proc.kill()
    if player is not None and player.returncode != 0:
        _say(f"   play failed: {(player.stderr.read() or '').strip().splitlines()[-1:]}")
    return np.array([m.effort for m in received]).reshape(-1, N), [m.header.stamp for m in received]


def show_live_residual(bag: Path) -> np.ndarray:
    """Step 3: the rigid-body node on the test bag; a few of its ~/residual messages."""
    _say("\n3. The node (python -m baxter_dynamics_ros.ros.node, use_sim_time) with the test bag played into it")
    residual, stamps = live_node(bag)
    _say(f"   received {len(residual)} messages on /baxter_dynamics/residual (measured effort − model τ, N·m); every 400th:")
    first = stamps[0].sec + stamps[0].nanosec * 1e-9 if stamps else 0.0
    for effort, stamp in list(zip(residual, stamps))[::400]:
        _say(f"   t = {stamp.sec + stamp.nanosec * 1e-9 - first:6.2f} s  " + " ".join(f"{v:7.3f}" for v in effort))
    rms = np.sqrt(np.mean(residual**2, axis=0)) if len(residual) else np.full(N, np.nan)
    _say("   RMS per joint  " + " ".join(f"{v:7.3f}" for v in rms) + "  (s1: the spring the model lacks)")
    return rms


def process_and_plot(bag: Path, out: Path) -> Path:
    """Step 4: ``process`` the bag and plot measured against modelled torques."""
    from msg_adapters.recording_files import read_recording, write_processed

    from ..core.processing import process_recording

    _say("\n4. Offline: baxter-dynamics process (zero-phase q̈) and a plot")
    recording = read_recording(bag)
    processed = process_recording(load_arm_model(recording.side), recording)
    write_processed(out / "test-processed.csv", processed, replace=True)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = recording.stamps_s
    fig, axes = plt.subplots(N, 1, figsize=(10, 12), sharex=True)
    for j, ax in enumerate(axes):
        ax.plot(t, recording.effort[:, j], lw=0.7, color="0.4", label="measured effort")
        ax.plot(t, processed.inverse_dynamics[:, j], lw=0.9, color="tab:blue", label="L-E model τ")
        ax.set_ylabel(f"{recording.joint_names[j].split('_')[1]}\nN·m")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", ncol=2, fontsize=8)
    axes[0].set_title("Simulated Baxter (spring, friction, noise) against the rigid-body model")
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    plot = out / "torques.png"
    fig.savefig(plot, dpi=80)
    plt.close(fig)
    _say(f"   {out / 'test-processed.csv'}\n   plot: {plot}")
    return plot


def diagnosis(paths: dict[str, Path], out: Path) -> Path:
    """Step 5: the diagnosis, trained on the three training bags, measured on the test bag."""
    from .main import main as cli

    _say("\n5. baxter-dynamics diagnose --train train-*.mcap --test test.mcap")
    target = out / "diagnosis"
    train = [str(p) for name, p in paths.items() if name != "test"]
    status = cli(["diagnose", "--train", *train, "--test", str(paths["test"]), "--out", str(target), "--force", "--no-progress"])
    if status != 0:
        raise SystemExit(status)
    return target / "report.html"


def compensated_node(bag: Path, effects_file: Path, rigid_rms: np.ndarray) -> None:
    """Step 6: the node with the identified effects compensated, on the same test bag."""
    _say(f"\n6. The node again with -p effects_file:={effects_file}")
    residual, _ = live_node(bag, effects_file)
    rms = np.sqrt(np.mean(residual**2, axis=0)) if len(residual) else np.full(N, np.nan)
    _say("   ~/residual RMS per joint [N·m]   " + " ".join(f"{n:>7}" for n in JOINT_SUFFIXES))
    _say("   rigid-body model                 " + " ".join(f"{v:7.3f}" for v in rigid_rms))
    _say("   with the identified effects      " + " ".join(f"{v:7.3f}" for v in rms))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m baxter_dynamics_ros.cli.demo", description=__doc__.split("\n", 1)[0])
    parser.add_argument("--out", type=Path, default=Path("out/demo"), help="output folder (default out/demo)")
    args = parser.parse_args(argv)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    log_dir = tempfile.mkdtemp(prefix="baxter_dynamics_demo-roslog-")
    try:
        with isolated_ros_env(log_dir) as env:
            os.environ.update(env)
            model_table()
            paths = simulate_recordings(out)
            rigid_rms = show_live_residual(paths["test"])
            plot = process_and_plot(paths["test"], out)
            report = diagnosis(paths, out)
            compensated_node(paths["test"], report.parent / "effects.yaml", rigid_rms)
    finally:
        shutil.rmtree(log_dir, ignore_errors=True)
    _say(f"\nDone. Look at {plot} and open {report} in a browser (it works offline).")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
