"""The node's dynamics services with a real client in another process (issue 21, §2).

The node runs as ``python -m baxter_dynamics_ros.ros.node`` (test/conftest.py's harness); this
process calls its ``~/compute_*`` services. Answers are compared with the core
(:class:`~baxter_dynamics_ros.core.queries.DynamicsQueries`, to 1e-12) and with Pinocchio's
algorithms on the arm's model (reference_models, the tolerances of test/core/test_lagrange_euler.py). Requests
carry all 21 joints of a real Baxter in its alphabetical order, so the mapping by name is checked
with every answer. Every bad request is answered success false, naming the field, and the node
answers the next good one. Last, the live path: /robot/joint_states at 500 Hz gives the same
answers, none lost, at the same latency while another process floods the services.

Without the generated types (baxter_dynamics_interfaces not built: no C++ compiler where ./dev
ran) the service tests skip saying so; the node then starts without services and warns once.
"""

from __future__ import annotations

import importlib.util
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from reference_models import assert_close, pinocchio_from_arm, random_states
from repo_paths import REPO
from test_node import CONFIG, JOINTS, RIGHT, joint_state, next_start_ns

from baxter_dynamics_ros.core.compensation import load_compensation
from baxter_dynamics_ros.core.queries import DynamicsQueries
from msg_adapters.dynamics_services import MAX_STATES

rclpy = pytest.importorskip("rclpy")
from sensor_msgs.msg import JointState  # noqa: E402

BUILT = importlib.util.find_spec("baxter_dynamics_interfaces") is not None
needs_interfaces = pytest.mark.skipif(
    not BUILT, reason="baxter_dynamics_interfaces is not built (./dev builds it when cmake and a C++ compiler exist)"
)
if BUILT:
    from baxter_dynamics_interfaces.srv import FlangeKinematics, ForwardDynamics, Gravity, InverseDynamics, MassMatrix

EFFECTS = REPO / "config" / "effects_example.yaml"
PREFIX = "/services/baxter_dynamics"
N_STATES = 50
EXACT = 1e-12  # the node against the core: the same code, so equal to rounding of nothing
RTOL = 1e-12  # against Pinocchio, as test/core/test_lagrange_euler.py
RTOL_ABA = 1e-10


@pytest.fixture(scope="module")
def node(ros_client, node_processes):
    """A node in /services compensating effects_example.yaml (the rigid model is asked for by flag)."""
    process = node_processes.start(["--params-file", str(CONFIG), "-p", f"effects_file:={EFFECTS}", "-r", "__ns:=/services"])
    if BUILT:
        client = ros_client.node.create_client(Gravity, f"{PREFIX}/compute_gravity")
        deadline = time.monotonic() + 60.0
        while not client.wait_for_service(timeout_sec=0.5):
            process.check_alive()
            if time.monotonic() > deadline:
                pytest.fail(f"{PREFIX}/compute_gravity not served within 60 s:\n{process.output()}")
        ros_client.node.destroy_client(client)
    return process


@pytest.fixture(scope="module")
def states():
    """N_STATES random states within the limits, as the arm's (N, 7) arrays and as 21-joint rows."""
    q, qd, qdd = random_states(RIGHT, N_STATES, seed=21, qdd_max_rad_s2=10.0)
    tau = np.random.default_rng(22).uniform(-RIGHT.effort_limit_nm, RIGHT.effort_limit_nm, (N_STATES, 7))
    cols = [JOINTS.index(j) for j in RIGHT.joint_names]

    def wide(x):
        out = np.random.default_rng(23).uniform(-1.0, 1.0, (N_STATES, len(JOINTS)))  # the other joints: noise
        out[:, cols] = x
        return out.ravel().tolist()

    return {"q": q, "qd": qd, "qdd": qdd, "tau": tau, "wide": wide}


_clients: dict[str, object] = {}


RESEND_S = 2.0


def request(ros_client, srv_type, name: str, req, timeout_s: float = 30.0):
    """The response of service ``name`` to ``req``, through one client per service kept for the
    module, as a real client keeps its client. A request unanswered after RESEND_S is sent again:
    right after discovery rmw may drop an answer to a client whose response reader the node has
    not matched yet (the node's log then says "failed to send response (timeout)"); the queries
    are idempotent."""
    client = _clients.get(name)
    if client is None:
        client = _clients[name] = ros_client.node.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=timeout_s):
            pytest.fail(f"service {name} not available after {timeout_s} s")
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        future = client.call_async(req)
        resend = time.monotonic() + RESEND_S
        while not future.done() and time.monotonic() < min(resend, deadline):
            time.sleep(0.002)
        if future.done():
            return future.result()
        client.remove_pending_request(future)
    pytest.fail(f"service {name} did not answer within {timeout_s} s")


def call(ros_client, srv_type, service: str, **fields):
    return request(ros_client, srv_type, f"{PREFIX}/{service}", srv_type.Request(name=list(JOINTS), **fields))


def ok(response):
    assert response.success, response.message
    assert list(response.name) == list(RIGHT.joint_names)
    return response


# ----------------------------------------------------------------------------- values
@needs_interfaces
@pytest.mark.parametrize("compensate", [False, True])
def test_answers_equal_the_core(node, ros_client, states, compensate: bool) -> None:
    queries = DynamicsQueries(RIGHT, load_compensation(RIGHT, EFFECTS))
    q, qd, qdd, tau, wide = states["q"], states["qd"], states["qdd"], states["tau"], states["wide"]
    n = (N_STATES, 7)
    got = ok(call(ros_client, Gravity, "compute_gravity", position=wide(q), compensate_effects=compensate))
    assert_close(np.reshape(got.effort, n), queries.gravity(q, compensate), "G", atol=EXACT)
    got = ok(call(ros_client, InverseDynamics, "compute_inverse_dynamics", position=wide(q), velocity=wide(qd), acceleration=wide(qdd), compensate_effects=compensate))
    assert_close(np.reshape(got.effort, n), queries.inverse_dynamics(q, qd, qdd, compensate), "tau", atol=EXACT)
    got = ok(call(ros_client, MassMatrix, "compute_mass_matrix", position=wide(q), compensate_effects=compensate))
    assert_close(np.reshape(got.mass_matrix, (N_STATES, 7, 7)), queries.mass_matrix(q, compensate), "M", atol=EXACT)
    got = ok(call(ros_client, ForwardDynamics, "compute_forward_dynamics", position=wide(q), velocity=wide(qd), effort=wide(tau), compensate_effects=compensate))
    assert_close(np.reshape(got.acceleration, n), queries.forward_dynamics(q, qd, tau, compensate), "qdd", atol=EXACT)
    if compensate:  # the compensated model differs from the rigid one, so the flag was heard
        assert np.abs(np.reshape(got.acceleration, n) - RIGHT.forward_dynamics(q, qd, tau)).max() > 1e-3


@needs_interfaces
def test_rigid_answers_equal_pinocchio(node, ros_client, states) -> None:
    ref = pinocchio_from_arm(RIGHT)  # Pinocchio's algorithms on the arm's DH table and inertials (no URDF needed)
    q, qd, qdd, tau, wide = states["q"], states["qd"], states["qdd"], states["tau"], states["wide"]

    def each(f, *arrays):
        return np.array([f(*row) for row in zip(*arrays)])

    n = (N_STATES, 7)
    got = ok(call(ros_client, Gravity, "compute_gravity", position=wide(q)))
    assert_close(np.reshape(got.effort, n), each(ref.gravity, q), "G vs computeGeneralizedGravity", rtol=RTOL)
    got = ok(call(ros_client, InverseDynamics, "compute_inverse_dynamics", position=wide(q), velocity=wide(qd), acceleration=wide(qdd)))
    assert_close(np.reshape(got.effort, n), each(ref.rnea, q, qd, qdd), "tau vs rnea", rtol=RTOL)
    got = ok(call(ros_client, MassMatrix, "compute_mass_matrix", position=wide(q)))
    assert_close(np.reshape(got.mass_matrix, (N_STATES, 7, 7)), each(ref.mass_matrix, q), "M vs crba", rtol=RTOL)
    got = ok(call(ros_client, ForwardDynamics, "compute_forward_dynamics", position=wide(q), velocity=wide(qd), effort=wide(tau)))
    assert_close(np.reshape(got.acceleration, n), each(ref.forward_dynamics, q, qd, tau), "qdd vs aba", rtol=RTOL_ABA)
    got = ok(call(ros_client, FlangeKinematics, "compute_flange_kinematics", position=wide(q)))
    assert_close(np.reshape(got.pose, (N_STATES, 4, 4)), each(ref.flange_pose, q), "flange pose", rtol=RTOL)
    assert_close(np.reshape(got.jacobian, (N_STATES, 6, 7)), each(ref.flange_jacobian, q), "flange Jacobian", rtol=RTOL)


@needs_interfaces
def test_one_state_and_the_limit_are_answered(node, ros_client) -> None:
    q = np.zeros((MAX_STATES, 7))
    got = ok(request(ros_client, Gravity, f"{PREFIX}/compute_gravity", Gravity.Request(name=list(RIGHT.joint_names[::-1]), position=q[:1].ravel().tolist())))
    np.testing.assert_array_equal(got.effort, RIGHT.gravity(q[0]))
    assert got.message == "1 state"
    got = ok(request(ros_client, Gravity, f"{PREFIX}/compute_gravity", Gravity.Request(name=list(RIGHT.joint_names), position=q.ravel().tolist())))
    assert len(got.effort) == MAX_STATES * 7


# ----------------------------------------------------------------------------- bad requests
def _bad_cases():
    arm = list(RIGHT.joint_names)
    q7 = [0.1] * 7
    return {
        "empty names": (Gravity, dict(name=[], position=[]), "name: empty"),
        "missing joint": (Gravity, dict(name=arm[:6], position=q7[:6]), "name: missing right_w2"),
        "unknown joint": (Gravity, dict(name=arm[:6] + ["right_w9"], position=q7), "name: missing right_w2 (unknown to this arm: 'right_w9')"),
        "name twice": (Gravity, dict(name=arm + ["right_s0"], position=q7 + [0.1]), "name: 'right_s0' appears more than once"),
        "no state": (Gravity, dict(name=arm, position=[]), "position: 0 values for 7 names"),
        "partial state": (Gravity, dict(name=arm, position=q7 + [0.1]), "position: 8 values for 7 names"),
        "short velocity": (InverseDynamics, dict(name=arm, position=q7, velocity=q7[:6], acceleration=q7), "velocity: 6 values, expected 7"),
        "long acceleration": (InverseDynamics, dict(name=arm, position=q7, velocity=q7, acceleration=q7 * 2), "acceleration: 14 values, expected 7"),
        "short effort": (ForwardDynamics, dict(name=arm, position=q7, velocity=q7, effort=[]), "effort: 0 values, expected 7"),
        "nan position": (MassMatrix, dict(name=arm, position=q7[:3] + [float("nan")] + q7[4:]), "position: nan at state 0, joint right_e1"),
        "inf velocity": (InverseDynamics, dict(name=arm, position=q7 * 2, velocity=q7 + [0.1] * 6 + [float("inf")], acceleration=q7 * 2), "velocity: inf at state 1, joint right_w2"),
        "-inf effort": (ForwardDynamics, dict(name=arm, position=q7, velocity=q7, effort=[-float("inf")] + q7[1:]), "effort: -inf at state 0, joint right_s0"),
        "nan pose": (FlangeKinematics, dict(name=arm, position=[float("nan")] * 7), "position: nan at state 0, joint right_s0"),
        "too many states": (Gravity, dict(name=arm, position=[0.0] * 7 * (MAX_STATES + 1)), f"position: {MAX_STATES + 1} states, more than the limit of {MAX_STATES}"),
    }


@needs_interfaces
@pytest.mark.parametrize("case", list(_bad_cases()) if BUILT else ["built"])
def test_a_bad_request_is_refused_naming_the_field_and_the_node_answers_on(node, ros_client, case: str) -> None:
    srv_type, fields, message = _bad_cases()[case]
    service = {Gravity: "compute_gravity", InverseDynamics: "compute_inverse_dynamics", MassMatrix: "compute_mass_matrix",
               ForwardDynamics: "compute_forward_dynamics", FlangeKinematics: "compute_flange_kinematics"}[srv_type]  # fmt: skip
    response = request(ros_client, srv_type, f"{PREFIX}/{service}", srv_type.Request(**fields))
    assert not response.success
    assert response.message.startswith(message), response.message
    assert "\n" not in response.message
    node.check_alive()
    ok(request(ros_client, Gravity, f"{PREFIX}/compute_gravity", Gravity.Request(name=list(RIGHT.joint_names), position=[0.0] * 7)))


@needs_interfaces
def test_compensation_asked_of_a_node_without_effects_is_refused(ros_client, node_processes) -> None:
    process = node_processes.start(["-r", "__ns:=/rigid"])
    name = "/rigid/baxter_dynamics/compute_gravity"
    req = Gravity.Request(name=list(RIGHT.joint_names), position=[0.0] * 7, compensate_effects=True)
    response = request(ros_client, Gravity, name, req, timeout_s=60.0)
    assert not response.success and response.message.startswith("compensate_effects: this node has no effects loaded")
    req.compensate_effects = False
    ok(request(ros_client, Gravity, name, req))
    assert process.stop() == 0


# ----------------------------------------------------------------------------- without the interfaces
def test_without_the_interfaces_the_node_runs_and_warns_once(ros_domain, tmp_path: Path) -> None:
    """The generated package hidden from the node's interpreter, as on a machine without a compiler."""
    code = "import sys; sys.modules['baxter_dynamics_interfaces'] = None; from baxter_dynamics_ros.ros.node import main; sys.exit(main())"
    log = tmp_path / "node.log"
    with log.open("w") as out:
        process = subprocess.Popen([sys.executable, "-c", code, "--ros-args", "-r", "__ns:=/bare"], cwd=REPO, stdout=out, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 60.0
        while "right arm (" not in log.read_text() and time.monotonic() < deadline:
            assert process.poll() is None, log.read_text()
            time.sleep(0.2)
        text = log.read_text()
        assert "right arm (" in text, text
        warnings = [line for line in text.splitlines() if "not served" in line]
        assert len(warnings) == 1 and "[WARN]" in warnings[0] and "baxter_dynamics_interfaces is not built" in warnings[0], text
    finally:
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=15) == 0, log.read_text()


# ----------------------------------------------------------------------------- the live path under a flood
RATE_500_HZ = 500.0
N_LIVE = 1000  # 2 s at 500 Hz


class GravityProbe:
    """This process's publisher of /robot/joint_states and subscriber of ~/gravity, timing each sample
    from its publication to the arrival of its answer (steady clock, ns)."""

    def __init__(self, ros_client) -> None:
        self.publisher = ros_client.publisher(JointState, "/robot/joint_states", 1000)
        self.sent: dict[int, int] = {}
        self.received: dict[int, tuple[int, np.ndarray]] = {}
        self._changed = threading.Condition()
        ros_client.node.create_subscription(JointState, f"{PREFIX}/gravity", self.on_gravity, 1000)

    def on_gravity(self, msg: JointState) -> None:
        now = time.monotonic_ns()
        with self._changed:
            self.received[msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec] = (now, np.array(msg.effort))
            self._changed.notify_all()

    def wait(self, stamps, timeout_s: float) -> int:
        """How many of ``stamps`` were answered, waiting up to timeout_s for them all."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                count = sum(s in self.received for s in stamps)
                if count == len(stamps) or time.monotonic() > deadline:
                    return count
                self._changed.wait(0.1)

    def run(self, q: np.ndarray) -> dict[str, object]:
        """Publish one 21-joint sample per row of q (the arm's (N, 7)) at 500 Hz; latencies in ms and answers."""
        cols = [JOINTS.index(j) for j in RIGHT.joint_names]
        start, period_ns = next_start_ns(), int(1e9 / RATE_500_HZ)
        stamps = [start + k * period_ns for k in range(len(q))]
        messages = []
        for k, row in enumerate(q):
            position = np.zeros(len(JOINTS))
            position[cols] = row
            messages.append(joint_state(JOINTS, stamps[k], position, np.zeros(len(JOINTS)), np.zeros(len(JOINTS))))
        t0 = time.monotonic()
        for k, msg in enumerate(messages):
            delay = t0 + k / RATE_500_HZ - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            self.sent[stamps[k]] = time.monotonic_ns()
            self.publisher.publish(msg)
        answered = self.wait(stamps, 10.0)
        got = [s for s in stamps if s in self.received]
        latency_ms = np.array([(self.received[s][0] - self.sent[s]) * 1e-6 for s in got])
        effort = np.array([self.received[s][1] for s in stamps]) if answered == len(stamps) else None
        return {"answered": answered, "latency_ms": latency_ms, "effort": effort}

    def warm_up(self, node) -> None:
        """Samples until the node answers one: the topics are matched both ways."""
        deadline = time.monotonic() + 60.0
        while not self.received:
            node.check_alive()
            assert time.monotonic() < deadline, "the node gave no ~/gravity within 60 s"
            self.run(np.zeros((1, 7)))


def _percentiles(latency_ms: np.ndarray) -> str:
    p50, p99 = np.percentile(latency_ms, [50, 99])
    return f"p50 {p50:.3f} ms, p99 {p99:.3f} ms, max {latency_ms.max():.3f} ms"


@needs_interfaces
def test_a_service_flood_neither_delays_nor_drops_joint_states(node, ros_client, capsys) -> None:
    """The topic at 500 Hz alone, then while another process keeps four requests in flight (1- and
    1,000-state gravity, 1,000-state mass matrix): every sample answered, the same answers, and the
    latency from publication to answer no worse than alone, within the scheduling noise of a
    shared 2-core machine (where the flood's two busy processes also compete for the cores): 2 × + 1
    ms at the median, 2 × + 5 ms at p99 (alone, p99 ranged from 4.6 to 56 ms between runs at a load
    average of 7; flooded, from 2.3 to 21 ms; in a full-suite run the median went from 0.75 ms alone
    to 1.80 ms flooded)."""
    probe = GravityProbe(ros_client)
    probe.warm_up(node)
    q, _, _ = random_states(RIGHT, N_LIVE, seed=24, qdd_max_rad_s2=1.0)
    # The machine is shared: a latency bound missed once, or a sample lost once (the input is best
    # effort, as Baxter publishes it: a saturated host may drop a datagram, flood or not; a full-suite
    # run lost 67 of 1,000), is measured again, both runs, once.
    for _attempt in (1, 2):
        quiet, flooded, calls = _alone_and_flooded(probe, q, capsys)
        quiet_p50, quiet_p99 = np.percentile(quiet["latency_ms"], [50, 99])
        flood_p50, flood_p99 = np.percentile(flooded["latency_ms"], [50, 99])
        whole = all(run["answered"] == N_LIVE for run in (quiet, flooded))
        if whole and flood_p50 <= 2.0 * quiet_p50 + 1.0 and flood_p99 <= 2.0 * quiet_p99 + 5.0:
            break
    for run in (quiet, flooded):
        assert run["answered"] == N_LIVE, f"{N_LIVE - run['answered']} of {N_LIVE} samples unanswered"
        assert_close(run["effort"], RIGHT.gravity(q), "~/gravity", atol=1e-9)
    np.testing.assert_array_equal(flooded["effort"], quiet["effort"])  # the same answers, bit for bit
    assert flood_p50 <= 2.0 * quiet_p50 + 1.0 and flood_p99 <= 2.0 * quiet_p99 + 5.0, (
        f"alone {_percentiles(quiet['latency_ms'])}; flooded {_percentiles(flooded['latency_ms'])}"
    )
    node.check_alive()


def _alone_and_flooded(probe: GravityProbe, q: np.ndarray, capsys):
    """The topic run alone, then under a flood: both runs' results and the calls answered meanwhile."""
    quiet = probe.run(q)
    flood = subprocess.Popen([sys.executable, str(Path(__file__).with_name("service_flood.py")), PREFIX],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)  # fmt: skip
    try:
        first = flood.stdout.readline()
        assert first.strip() == "ready", first + flood.stdout.read()
        flooded = probe.run(q)
        flood.stdin.close()
        out = flood.stdout.read()
        flood.wait(timeout=30)
    finally:
        if flood.poll() is None:
            flood.kill()
            flood.wait()
    calls, failed = (int(x) for x in out.split()[1::2])
    duration_s = N_LIVE / RATE_500_HZ
    with capsys.disabled():
        print(f"\n500 Hz alone:        {_percentiles(quiet['latency_ms'])}")
        print(f"500 Hz with a flood: {_percentiles(flooded['latency_ms'])}; {calls} service calls answered meanwhile (~{calls / duration_s:.0f}/s)")
    assert failed == 0 and calls >= 20, out
    return quiet, flooded, calls
