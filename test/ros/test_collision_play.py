"""Collision detection end to end (issue 6 §5): simulated recordings played into the live node.

Every step is the user's: ``baxter-dynamics simulate`` writes a collision-free recording and one
with a push at the flange (ground truth in ``<out>.truth.json``), ``baxter-dynamics calibrate``
turns the collision-free one into a thresholds file, the node runs in its own process on
``use_sim_time`` with that ``thresholds_file``, and ``baxter-dynamics play`` (a subprocess)
publishes the recordings' joint states and /clock into it. All of it on the private local ROS graph
of test/conftest.py, which the subprocesses inherit through os.environ.

Timing is on sim time: ``~/collision`` (std_msgs/Bool) carries no stamp, so each message is stamped
here with the last /clock received before it. The player sends /clock at a sample's stamp right
before the sample, and the node answers the sample within a millisecond or so, well inside the 10 ms
to the next one: that is the stamp of the sample that changed the state (should this process lag,
a later one's, so the measured delays err long).
"""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.cli.main import main
from baxter_dynamics_ros.monitoring.observer import observe_arrays
from baxter_dynamics_ros.monitoring.thresholds import read_thresholds
from msg_adapters.recording_files import read_recording
from repo_paths import REPO

rclpy = pytest.importorskip("rclpy")
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Bool  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

NODE = "/baxter_dynamics"
ARM_JOINTS = tuple(f"right_{j}" for j in ("s0", "s1", "e0", "e1", "w0", "w1", "w2"))
#: Sensor side of the collision benchmark (bench/bench_collision.py): effort noise and q̇ noise.
#: Its s1 spring and viscous friction are left out: the node would need them as an effects_file.
SENSOR_SPEC = {
    "effects": {"acceleration_noise": {"velocity_noise_rad_s": 0.005}},
    "sensor": {"effort_noise_nm": 0.02},
}
#: A 10 N push down on the hand for 0.6 s: about 7 N·m on s1 and 3 N·m on e1 (ground truth).
PUSH = {"start_s": 1.5, "duration_s": 0.6, "profile": "push", "link": "flange", "force_n": [0.0, 0.0, -10.0]}
#: Thresholds from 20 s of collision-free motion at calibrate's defaults (6 s left s0's noise on
#: held-out seeds above them). The recordings are seeded, hence the same on every run.
CALIBRATION_S = 20.0
PLAYED_S = 3.0
RATE_HZ = 100.0
DELAY_BUDGET_S = 0.1  # the goal is a median of 50 ms
RELEASE_BUDGET_S = 1.0
TIMEOUT_S = 60.0
#: Samples at the start of a playback within which the node may still reset for the /clock jump back.
RESTART_WINDOW = 10


def _ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def simulate(folder: Path, name: str, seed: int, duration_s: float, collisions: list[dict]) -> Path:
    """``baxter-dynamics simulate`` of the random trajectory with the sensor noise and these collisions."""
    spec = folder / f"{name}.yaml"
    spec.write_text(yaml.safe_dump({**SENSOR_SPEC, "collisions": collisions}))
    out = folder / f"{name}.mcap"
    command = ["simulate", "--trajectory", "random", "--seed", str(seed), "--duration", str(duration_s), "--rate-hz", str(RATE_HZ)]
    assert main([*command, "--effects", str(spec), "--out", str(out)]) == 0
    return out


@dataclass(frozen=True)
class Recordings:
    thresholds: Path
    contact: Path
    free: Path


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> Recordings:
    """Thresholds calibrated on a collision-free recording; then one with the push, one without (other seeds)."""
    folder = tmp_path_factory.mktemp("recordings")
    calibration = simulate(folder, "calibration", 1, CALIBRATION_S, [])
    thresholds = folder / "thresholds.yaml"
    assert main(["calibrate", str(calibration), "--out", str(thresholds)]) == 0
    return Recordings(thresholds, simulate(folder, "contact", 2, PLAYED_S, [PUSH]), simulate(folder, "free", 3, PLAYED_S, []))


@dataclass(frozen=True)
class Played:
    """What came back while one recording was played: ``collisions`` as (sim time ns, state) in order
    of arrival, and the node's ``~/external_torque`` messages."""

    collisions: list[tuple[int, bool]]
    external_torque: list[JointState]

    def changes(self) -> list[tuple[int, bool]]:
        """The state changes (the node also repeats its state with every diagnostics report)."""
        out: list[tuple[int, bool]] = []
        for at, on in self.collisions:
            if (out[-1][1] if out else False) != on:
                out.append((at, on))
        return out


class SimTimeListener:
    """This process's subscriptions around the node: /clock, ~/collision stamped with it, ~/external_torque."""

    def __init__(self, client) -> None:
        self._lock = threading.Lock()
        self._clock_ns: int | None = None
        self._collisions: list[tuple[int, bool]] = []
        client.node.create_subscription(Clock, "/clock", self._on_clock, 1000)
        client.node.create_subscription(Bool, f"{NODE}/collision", self._on_collision, 100)
        self.external_torque = client.collect(JointState, f"{NODE}/external_torque")

    def _on_clock(self, msg: Clock) -> None:
        with self._lock:
            self._clock_ns = _ns(msg.clock)

    def _on_collision(self, msg: Bool) -> None:
        with self._lock:
            if self._clock_ns is not None:  # before the first /clock of a playback: not on its time
                self._collisions.append((self._clock_ns, msg.data))

    def play(self, bag: Path) -> Played:
        """``baxter-dynamics play BAG`` at real time, in a subprocess; what came back meanwhile."""
        with self._lock:
            self._clock_ns = None
            self._collisions.clear()
        self.external_torque.clear()
        command = [sys.executable, "-m", "baxter_dynamics_ros.cli", "play", str(bag), "--wait-for-subscribers", "30"]
        play = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=TIMEOUT_S)
        assert play.returncode == 0, play.stderr
        time.sleep(0.3)  # the last answers are in flight
        with self._lock:
            return Played(list(self._collisions), list(self.external_torque.messages))


@pytest.fixture(scope="module")
def listener(ros_client, node_processes, recordings: Recordings) -> SimTimeListener:
    """The node on sim time with the calibrated thresholds, and this process listening to it.

    Ready once it has answered a probe sample on ~/external_torque: every link is then matched.
    Then ~/reset forgets the probe."""
    listener = SimTimeListener(ros_client)
    node = node_processes.start(["-p", "use_sim_time:=true", "-p", f"thresholds_file:={recordings.thresholds}"])
    probe = ros_client.publisher(JointState, "/robot/joint_states")
    deadline = time.monotonic() + TIMEOUT_S
    for k in itertools.count(1):
        node.check_alive()
        if listener.external_torque.messages:
            break
        if time.monotonic() > deadline:
            pytest.fail(f"the node answered no probe within {TIMEOUT_S} s:\n{node.output()}")
        msg = JointState(name=list(ARM_JOINTS), position=[0.0] * 7, velocity=[0.0] * 7, effort=[0.0] * 7)
        msg.header.stamp.sec = k
        probe.publish(msg)
        time.sleep(0.1)
    ros_client.node.destroy_publisher(probe)
    assert ros_client.call(Trigger, f"{NODE}/reset", Trigger.Request()).success
    listener.external_torque.clear()
    return listener


def truth_of(bag: Path) -> dict:
    return json.loads(bag.with_name(bag.name + ".truth.json").read_text())


def assert_every_sample_observed(played: Played, truth: dict) -> None:
    """The node answered every sample on ~/external_torque: it did see the whole recording.

    But perhaps the first: played after another recording, its stamp goes back, and unless the
    /clock jump has reset the node first, the node skips it (``stamp_backwards``, by design)."""
    stamps = (truth["start_stamp_ns"] + np.round(np.arange(truth["samples"]) * 1e9 / RATE_HZ).astype(np.int64)).tolist()
    got = sorted(_ns(m.header.stamp) for m in played.external_torque)
    assert got in (stamps, stamps[1:]), f"{len(got)} of {len(stamps)} samples answered"


def test_push_turns_collision_on_within_budget_and_off_after_it(listener: SimTimeListener, recordings: Recordings) -> None:
    truth = truth_of(recordings.contact)
    (contact,) = truth["collisions"]
    start_ns = truth["start_stamp_ns"] + round(contact["start_s"] * 1e9)
    end_ns = truth["start_stamp_ns"] + round(contact["end_s"] * 1e9)
    played = listener.play(recordings.contact)
    assert_every_sample_observed(played, truth)

    changes = played.changes()
    assert [on for _, on in changes] == [True, False], f"expected one detection, then its end: {changes}"
    (on_ns, _), (off_ns, _) = changes
    delay_s = (on_ns - start_ns) * 1e-9
    assert 0 < delay_s <= DELAY_BUDGET_S, f"~/collision true {delay_s:.3f} s (sim time) after the push began"
    release_s = (off_ns - end_ns) * 1e-9
    assert 0 < release_s <= RELEASE_BUDGET_S, f"~/collision false {release_s:.3f} s (sim time) after the push ended"

    # The node's observer saw the push's size: on s1, the most loaded joint, max |r| ≈ the true peak.
    inside = [m for m in played.external_torque if start_ns <= _ns(m.header.stamp) <= end_ns]
    r_peak = np.abs([m.effort for m in inside]).max(axis=0)
    peak = np.array(contact["peak_joint_torque_nm"])
    s1 = truth["joint_names"].index("right_s1")
    assert list(inside[0].name) == truth["joint_names"]
    assert int(np.argmax(peak)) == s1 and int(np.argmax(r_peak)) == s1
    assert r_peak[s1] == pytest.approx(peak[s1], rel=0.25)


def test_no_collision_on_a_collision_free_recording(listener: SimTimeListener, recordings: Recordings) -> None:
    played = listener.play(recordings.free)
    assert_every_sample_observed(played, truth_of(recordings.free))
    assert played.collisions, "no ~/collision message while playing (the node repeats its state every second)"
    assert not any(on for _, on in played.collisions), f"false positives: {played.changes()}"
    # The node's observer runs with the effort–state alignment calibrate estimated (half a step
    # early on simulated data) and gives the core's numbers over the recording.
    thresholds = read_thresholds(recordings.thresholds)
    assert thresholds.effort_delay_s < 0
    rec = read_recording(recordings.free)
    got = {_ns(m.header.stamp): np.array(m.effort) for m in played.external_torque}
    # The observer restarts (r = 0 exactly) where the node last reset at the start: at its first
    # sample, and once more when the /clock jump back (read on another thread than the joint states)
    # is handled after the first samples of this playback, as it may be on a loaded machine. Only
    # restarts within the first RESTART_WINDOW samples are taken as such; any later zero row fails.
    answered = [int(np.searchsorted(rec.stamps_ns, stamp)) for stamp in sorted(got)]
    restarts = [k for k in answered[:RESTART_WINDOW] if not np.any(got[int(rec.stamps_ns[k])])]
    assert restarts, f"no restart (r = 0) among the first {RESTART_WINDOW} samples answered"
    first = restarts[-1]
    part = slice(first, None)
    expected = observe_arrays(
        load_arm_model("right"), rec.stamps_ns[part], rec.q[part], rec.qd[part], rec.effort[part],
        gain_1_s=thresholds.gain_1_s, effort_delay_s=thresholds.effort_delay_s,
    )  # fmt: skip
    np.testing.assert_allclose([got[int(t)] for t in rec.stamps_ns[part]], expected, atol=1e-9)
