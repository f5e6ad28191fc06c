"""The ``baxter_dynamics`` node: gravity, inverse-dynamics and residual torques beside a live robot.

Run it with ``baxter_dynamics_node`` or ``python -m baxter_dynamics_ros.ros.node`` (``ros2 run
baxter_dynamics_ros baxter_dynamics_node`` in a colcon workspace), with the usual
``--ros-args --params-file config/baxter_dynamics.yaml -p name:=value`` overrides. Parameters are
the fields of :class:`~baxter_dynamics_ros.ros.node_settings.NodeSettings` (arm, model_file,
effects_file, joint_states_topic, qos_depth, estimator, cutoff_hz, diagnostics_period_s,
observer_gain_1_s, thresholds_file, calibration_window_s); every
value is validated when set, and only ``estimator`` and ``cutoff_hz`` may change while running.
Numeric parameters have ranges, in their ParameterDescriptor (``ros2 param describe`` shows them;
a value outside is refused, at start-up with one ``ERROR:`` line): qos_depth 1–10000,
cutoff_hz 0.1–1000 Hz, diagnostics_period_s 0.05–3600 s, observer_gain_1_s 0.1–1000 1/s,
calibration_window_s 1–60 s. An override naming no parameter of the node (a misspelling) is
warned about at start-up, with the closest name.

Topics (sensor_msgs/JointState; outputs carry the arm's 7 joints, the input's header stamp, and
the sample's position and velocity):

- in ``joint_states_topic`` (default /robot/joint_states): any superset of the arm's joints in any
  order. QoS: the sensor-data profile (best effort, volatile, keep last ``qos_depth``): it matches
  reliable and best-effort publishers alike, and a late sample is worth less than the next one;
  the depth (100 by default, 0.1 s at 1 kHz) absorbs scheduling hiccups without loss on one host;
- out ``~/gravity`` (effort = G(q)), ``~/inverse_dynamics`` (effort = τ with the estimated q̈),
  ``~/residual`` (effort = measured effort − τ; not published when the input has no effort),
  ``~/external_torque`` (effort = r of the generalised-momentum observer, gain ``observer_gain_1_s``,
  on the same model; ≈ −τ_ext, see :mod:`baxter_dynamics_ros.monitoring.observer`; not published without effort).
  QoS: reliable, volatile, keep last ``qos_depth``, which every subscriber can match. Each is
  written only while it has a subscriber;
- out ``/diagnostics`` (diagnostic_msgs/DiagnosticArray) every ``diagnostics_period_s`` on the
  steady clock (so it reports even when a simulated clock stops): input rate, samples skipped per
  cause, processing latency (sample taken → last output written), per-joint residual RMS over the
  window; levels as in :mod:`baxter_dynamics_ros.monitoring.health`, raised to ERROR naming the joints when
  a collision was detected in the window;
- out ``~/collision`` (std_msgs/Bool, reliable, transient local: a late subscriber gets the state at
  once): published on every change and with every diagnostics report.

Collision detection (:mod:`baxter_dynamics_ros.monitoring.collision_monitor`): a hysteresis detector on the
external torque against per-joint thresholds, from ``thresholds_file`` (``baxter-dynamics
calibrate``) or from ``~/calibrate`` (std_srvs/Trigger: thresholds calibrated on the last
``calibration_window_s`` of samples, which must be collision-free motion; success false, with the
reason, on too little data). ``~/set_monitoring`` (std_srvs/SetBool) switches detection on and
off (off: no collision). Without thresholds nothing is detected.

Dynamics services (:mod:`.dynamics_services`): ``~/compute_gravity``, ``~/compute_inverse_dynamics``,
``~/compute_mass_matrix``, ``~/compute_forward_dynamics`` and ``~/compute_flange_kinematics``
(baxter_dynamics_interfaces/srv), batched and named by joint, answered by a thread of their own so
that no request delays a joint-state sample; without the built interface package the node starts
without them and warns once.

Service ``~/reset`` (std_srvs/Trigger) restarts the q̈ estimator and the observer, and forgets the
samples buffered for calibration. With ``use_sim_time`` the node
runs on /clock; a backwards jump of that clock (a recording looping) resets the estimator, as does
a header stamp going backwards. Bad samples are skipped, counted and warned about at most once per
second per cause (see :class:`~baxter_dynamics_ros.core.samples.SkipReason`); the node never stops
on input. That includes samples no real Baxter can give (``implausible_input``): a joint angle
more than 0.1 rad beyond the model's joint limits, a speed above 3 × the joint's velocity limit
(4.5 rad/s at s0–e1, 12 rad/s at the wrist), an effort above 3 × its effort limit (150, 300, 150,
150 N·m at s0–e1, 45 N·m at the wrist); the limits are the URDF's, the real recordings reach 1.34 ×
a velocity limit and 0.31 × an effort limit. Such a sample never reaches the q̈ filter or the
observer: the outputs of the next samples are those the core gives without it. Should a state
still become non-finite, it is reset and counted (``resets_total.non_finite_state``), and a
non-finite residual RMS is never reported OK.

Speed: joint states are taken as CDR bytes by a thread of their own (:class:`SubscriptionThread`),
not by the executor, whose Python bookkeeping costs ~0.2 ms per wake-up — a fifth of a core at
1 kHz, several times the dynamics. The executor serves everything else (parameters, ~/reset, the
diagnostics timer, /clock, the outputs' "matched" events, which keep their subscriber counts so that
the joint-state thread asks rmw nothing per sample); one lock keeps the two threads apart.

This module owns the ROS objects and nothing else: the work is done by
:class:`~baxter_dynamics_ros.monitoring.pipeline.ResidualPipeline` and
:class:`~baxter_dynamics_ros.monitoring.collision_monitor.CollisionMonitor`, the message layouts by
:mod:`msg_adapters.joint_state`.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.callback_groups import CallbackGroup
from rclpy.clock import Clock, ClockType, JumpThreshold, TimeJump
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks, QoSPublisherMatchedInfo, SubscriptionEventCallbacks
from rclpy.exceptions import NameValidationException, ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool
from std_srvs.srv import SetBool, Trigger

from msg_adapters.joint_state import ArmJointStateWriter, JointStateReader, diagnostic_array

from ..core.arm_model import load_arm_model
from ..core.compensation import load_compensation
from ..core.queries import DynamicsQueries
from ..core.samples import SKIP_DESCRIPTIONS, ResetCause, SkipReason
from ..errors import BaxterDynamicsError, CollisionError, SettingsError
from ..monitoring.collision_monitor import CollisionMonitor
from ..monitoring.health import HealthMonitor
from ..monitoring.observer import observe_arrays
from ..monitoring.pipeline import ResidualPipeline
from ..monitoring.thresholds import read_thresholds
from . import dynamics_services
from .node_settings import NodeSettings

__all__ = ["DynamicsNode", "SubscriptionThread", "main"]

NODE_NAME = "baxter_dynamics"
#: Settings that, when changed, rebuild the q̈ estimator.
ESTIMATOR_SETTINGS = frozenset({"estimator", "cutoff_hz"})


class OwnThreadGroup(CallbackGroup):
    """The callback group of an entity served by a thread of its own: executors never take it."""

    def can_execute(self, entity: object) -> bool:
        return False

    def beginning_execution(self, entity: object) -> bool:
        return False

    def ending_execution(self, entity: object) -> None:
        pass


class SubscriptionThread:
    """Takes every message of one subscription (in :class:`OwnThreadGroup`) in a thread of its own.

    A wait set holding just this subscription and a stop condition, as ``rclpy.wait_for_message``
    builds it; every message is taken and handed to ``callback`` in arrival order, one per wake-up
    (a second take would ask rmw once more per sample only to find the queue empty). If the
    callback raises, the thread logs the error, keeps it in :attr:`error` and shuts the context
    down, so that the program stops instead of running on deaf.
    """

    def __init__(self, subscription: Subscription, context: Context, callback: Callable[[object], None], logger) -> None:
        self._subscription, self._context, self._callback, self._logger = subscription, context, callback, logger
        self._stop = GuardCondition(None, None, context=context)
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=f"take {subscription.topic_name}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        handle, msg_type, raw = self._subscription.handle, self._subscription.msg_type, self._subscription.raw
        wait_set = _rclpy.WaitSet(1, 1, 0, 0, 0, 0, self._context.handle)
        try:
            while True:
                wait_set.clear_entities()
                wait_set.add_subscription(handle)
                wait_set.add_guard_condition(self._stop.handle)
                wait_set.wait(-1)
                if wait_set.is_ready("guard_condition", 0):
                    return
                # One message per wake-up: with more waiting, the next wait returns at once.
                taken = handle.take_message(msg_type, raw)
                if taken is not None:
                    self._callback(taken[0])
        except Exception as err:  # a defect: stop the program rather than leave it deaf
            self.error = err
            self._logger.fatal(f"stopped taking {self._subscription.topic_name}: {err!r}")
            rclpy.try_shutdown(context=self._context)

    def stop(self) -> None:
        """Wake the thread up, let it finish, and wait for it."""
        self._stop.trigger()
        self._thread.join()
        self._stop.destroy()


class DynamicsNode(Node):
    """Subscribes to joint states and publishes the arm's model torques and its health."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self._settings = NodeSettings()
        # Registered before declaring, so start-up overrides are validated like later changes.
        self.add_on_set_parameters_callback(self.on_set_parameters)
        for spec in NodeSettings.fields():
            self.declare_parameter(spec.name, spec.default, _descriptor(spec))
        settings = self._settings = NodeSettings(**{s.name: self.get_parameter(s.name).value for s in NodeSettings.fields()})
        self._warn_unknown_overrides()

        arm = load_arm_model(settings.model_file or settings.arm)
        if arm.side != settings.arm:
            raise SettingsError(
                f"model_file: {settings.model_file} models the {arm.side} arm but arm is {settings.arm!r}; "
                f"set arm:={arm.side} or choose a model of the {settings.arm} arm"
            )
        self._lock = threading.Lock()  # between the joint-state thread and the executor's callbacks
        self._reader = JointStateReader(arm.joint_names)
        self._writer = ArmJointStateWriter(arm.joint_names)
        compensation = load_compensation(arm, settings.effects_file) if settings.effects_file else None
        if compensation is not None:
            self.get_logger().info(
                f"compensating {', '.join(e.name for e in compensation.effects) or 'nothing'} from {settings.effects_file}"
                + (f"; not compensated live: {', '.join(compensation.ignored)}" if compensation.ignored else "")
            )
        thresholds = read_thresholds(settings.thresholds_file, arm) if settings.thresholds_file else None
        if thresholds is not None and not (thresholds.gain_1_s == settings.observer_gain_1_s).all():
            self.get_logger().warn(
                f"{settings.thresholds_file} was calibrated with observer gains {thresholds.gain_1_s.tolist()} 1/s, "
                f"the node runs {settings.observer_gain_1_s} 1/s: recalibrate (~/calibrate) or set observer_gain_1_s"
            )
        # The observer aligns effort and state as the thresholds were calibrated (none without them).
        effort_delay_s = 0.0 if thresholds is None else thresholds.effort_delay_s
        self._pipeline = ResidualPipeline(arm, settings.estimator, settings.cutoff_hz, compensation, settings.observer_gain_1_s, effort_delay_s)
        self._monitor = CollisionMonitor(
            arm.joint_names, settings.calibration_window_s, settings.observer_gain_1_s, thresholds, settings.thresholds_file,
            observe_window=functools.partial(
                observe_arrays, arm, gain_1_s=settings.observer_gain_1_s, compensation=compensation, effort_delay_s=effort_delay_s
            ),
            effort_delay_s=effort_delay_s,
        )
        self._skip_loggers = {reason: self.get_logger().get_child(reason.value) for reason in SkipReason}

        # No QoS-incompatibility handlers on our own topics (these profiles match every peer but a
        # transient-local subscriber). The outputs' "matched" events keep their subscriber counts in
        # _listeners, which the executor updates as subscribers come and go, so that the joint-state
        # thread asks rmw nothing per sample.
        outputs = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=settings.qos_depth,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
        )
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self._listeners = [0, 0, 0, 0]  # subscribers of gravity, inverse_dynamics, residual, external_torque
        self._output_publishers = tuple(
            self.create_publisher(
                JointState,
                f"~/{name}",
                outputs,
                event_callbacks=PublisherEventCallbacks(matched=functools.partial(self.on_matched, k), use_default_callbacks=False),
            )
            for k, name in enumerate(("gravity", "inverse_dynamics", "residual", "external_torque"))
        )
        state = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        self._collision_publisher = self.create_publisher(Bool, "~/collision", state, event_callbacks=quiet)
        self._diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        sensor_data = QoSProfile(  # qos_profile_sensor_data with a deeper queue
            history=HistoryPolicy.KEEP_LAST,
            depth=settings.qos_depth,
            reliability=ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.VOLATILE,
        )
        self._subscription = self.create_subscription(
            JointState,
            settings.joint_states_topic,
            self.on_joint_state,
            sensor_data,
            callback_group=OwnThreadGroup(),
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
            raw=True,  # CDR bytes, read by msg_adapters.joint_state
        )
        self._health = HealthMonitor(arm.joint_names, self._subscription.topic_name)
        self._status_name = f"{self.get_fully_qualified_name()}: {arm.side} arm dynamics"
        self._reset_service = self.create_service(Trigger, "~/reset", self.on_reset)
        self._calibrate_service = self.create_service(Trigger, "~/calibrate", self.on_calibrate)
        self._monitoring_service = self.create_service(SetBool, "~/set_monitoring", self.on_set_monitoring)
        # The dynamics of given states on request: their own group and thread (None if not built).
        self._dynamics_services = dynamics_services.create(self, DynamicsQueries(arm, compensation), OwnThreadGroup())

        self._steady_clock = Clock(clock_type=ClockType.STEADY_TIME)
        self._window_start_ns = self._steady_clock.now().nanoseconds
        self._diagnostics_timer = self.create_timer(
            settings.diagnostics_period_s, self.on_diagnostics_timer, clock=self._steady_clock
        )
        backwards = JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False)
        self._jump_handle = self.get_clock().create_jump_callback(backwards, post_callback=self.on_clock_jump)
        self.add_post_set_parameters_callback(self.on_parameters_set)
        self._taker = SubscriptionThread(self._subscription, self.context, self.on_joint_state, self.get_logger())
        self.get_logger().info(
            f"{arm.side} arm ({arm.source}): {self._subscription.topic_name} -> "
            + ", ".join(p.topic_name for p in self._output_publishers)
            + f"; q̈ by {settings.estimator}; collision detection "
            + (f"with {settings.thresholds_file}" if thresholds is not None else "waiting for ~/calibrate")
        )

    def _warn_unknown_overrides(self) -> None:
        """Warn about start-up overrides (-p, --params-file) naming no parameter of this node: a
        misspelt name would otherwise be ignored without a word."""
        # rclpy keeps the overrides for this node in Node._parameter_overrides (no public accessor).
        unknown = sorted(name for name in self._parameter_overrides if not self.has_parameter(name))
        if unknown:
            known = [spec.name for spec in NodeSettings.fields()]
            hints = "".join(
                f" ({name}: did you mean {close[0]}?)" for name in unknown if (close := difflib.get_close_matches(name, known, 1))
            )
            self.get_logger().warn(
                f"ignoring parameters this node does not have: {', '.join(unknown)}{hints}; its parameters: {', '.join(known)}"
            )

    @property
    def input_error(self) -> BaseException | None:
        """The defect that stopped the joint-state thread, if one did."""
        return self._taker.error

    def destroy_node(self) -> None:
        self._taker.stop()
        if self._dynamics_services is not None:
            self._dynamics_services.stop()
        super().destroy_node()

    # ------------------------------------------------------------------------------ callbacks
    def on_joint_state(self, raw: bytes) -> None:
        """One input sample (serialized JointState): read it, compute, publish, count."""
        start_ns = time.perf_counter_ns()
        with self._lock:
            result = self._reader.read(raw)
            listeners = self._listeners
            if not isinstance(result, SkipReason):
                # The observer only while something uses r: detection, or a subscriber of ~/external_torque.
                result = self._pipeline.process(result, self._monitor.active or listeners[3] > 0)
            if isinstance(result, SkipReason):
                self._log_skip(result)
            else:
                # A DDS write costs more than the dynamics: only to topics someone listens to.
                wanted = (listeners[0] > 0, listeners[1] > 0, listeners[2] > 0, listeners[3] > 0)
                for publisher, message in zip(self._output_publishers, self._writer.messages(result, wanted)):
                    if message is not None:
                        publisher.publish(message)
                if result.residual is not None:  # a sample with effort
                    changed = self._monitor.update(result.stamp_ns, result.external_torque, result.qd, result.q, result.effort)
                    if changed is not None:
                        self._collision_publisher.publish(Bool(data=changed))
            self._health.record(result, time.perf_counter_ns() - start_ns)

    def on_matched(self, output: int, info: QoSPublisherMatchedInfo) -> None:
        """A subscriber of output ``output`` (an index of _output_publishers) came or went."""
        self._listeners[output] = info.current_count

    def _log_skip(self, reason: SkipReason) -> None:
        text = f"sample skipped: {SKIP_DESCRIPTIONS[reason]}"
        if reason.is_fault:
            self._skip_loggers[reason].warn(text, throttle_duration_sec=1.0)
        else:
            self._skip_loggers[reason].debug(text)

    def on_diagnostics_timer(self) -> None:
        """Publish the health of the last window on /diagnostics."""
        with self._lock:
            now_ns = self._steady_clock.now().nanoseconds
            report = self._monitor.report(self._health.report((now_ns - self._window_start_ns) * 1e-9))
            self._window_start_ns = now_ns
            self._collision_publisher.publish(Bool(data=self._monitor.collision))
        stamp = self.get_clock().now().to_msg()
        self._diagnostics_publisher.publish(
            diagnostic_array(report, name=self._status_name, hardware_id="baxter", stamp=stamp)
        )

    def on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """~/reset: restart the estimator."""
        self._reset(ResetCause.SERVICE)
        response.success = True
        response.message = "estimator reset: the next sample starts it and the observer afresh (q̈ = 0, r = 0)"
        return response

    def on_calibrate(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """~/calibrate: thresholds from the last calibration_window_s of samples; detection starts with them."""
        with self._lock:
            try:
                thresholds, source = self._monitor.calibrate()
            except CollisionError as err:
                response.success, response.message = False, str(err)
                return response
            self._monitor.set_thresholds(thresholds, source)
        offsets = ", ".join(f"{x:.3g}" for x in thresholds.offset_nm)
        response.success = True
        response.message = f"thresholds from {source}: offsets [{offsets}] N·m; detection " + (
            "on" if self._monitor.monitoring else "off (~/set_monitoring)"
        )
        self.get_logger().info(response.message)
        return response

    def on_set_monitoring(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        """~/set_monitoring: collision detection on or off (off: no collision)."""
        with self._lock:
            if self._monitor.set_monitoring(request.data):
                self._collision_publisher.publish(Bool(data=False))
            calibrated = self._monitor.detector is not None
        response.success = True
        response.message = "collision detection " + ("on" if request.data else "off") + (
            "" if calibrated or not request.data else " once thresholds are set (~/calibrate)"
        )
        return response

    def on_clock_jump(self, jump: TimeJump) -> None:
        """The ROS clock went backwards (a recording looping under use_sim_time)."""
        self._reset(ResetCause.CLOCK_JUMP)
        self.get_logger().info(f"clock jumped back by {-jump.delta.nanoseconds * 1e-9:.3f} s: estimator reset")

    def _reset(self, cause: ResetCause) -> None:
        with self._lock:
            self._pipeline.reset()
            if self._monitor.reset():
                self._collision_publisher.publish(Bool(data=False))
            self._health.record_reset(cause)

    # ------------------------------------------------------------------------------ parameters
    @staticmethod
    def _setting_changes(parameters: Sequence[Parameter]) -> dict[str, object]:
        names = {spec.name for spec in NodeSettings.fields()}
        return {p.name: p.value for p in parameters if p.name in names}

    def on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        """Accept a change only if the settings it gives are valid."""
        try:
            self._settings.replace(**self._setting_changes(parameters))
        except SettingsError as err:
            return SetParametersResult(successful=False, reason=str(err))
        return SetParametersResult(successful=True)

    def on_parameters_set(self, parameters: list[Parameter]) -> None:
        """Apply accepted changes (only the live settings can change once running)."""
        changes = self._setting_changes(parameters)
        self._settings = self._settings.replace(**changes)
        if ESTIMATOR_SETTINGS & changes.keys():
            with self._lock:
                self._pipeline.configure(self._settings.estimator, self._settings.cutoff_hz)
                self._health.record_reset(ResetCause.SETTINGS)
            self.get_logger().info(f"q̈ by {self._settings.estimator} (cutoff {self._settings.cutoff_hz} Hz)")


def _descriptor(spec: dataclasses.Field) -> ParameterDescriptor:
    """The ROS parameter descriptor of a settings field: its help, read-only unless live, its range."""
    live, bounds = spec.metadata["live"], spec.metadata["bounds"]
    descriptor = ParameterDescriptor(description=spec.metadata["help"] + ("" if live else " (read at start-up)"), read_only=not live)
    if bounds is not None and isinstance(spec.default, int):
        descriptor.integer_range = [IntegerRange(from_value=bounds[0], to_value=bounds[1], step=1)]
    elif bounds is not None:
        descriptor.floating_point_range = [FloatingPointRange(from_value=bounds[0], to_value=bounds[1], step=0.0)]
    return descriptor


def main(args: Sequence[str] | None = None) -> int:
    """Run the node until Ctrl-C, SIGTERM or shutdown; ``args`` as for rclpy.init (default sys.argv).

    Returns 0 when stopped, also while starting; 1 (after one ``ERROR:`` line) when the parameters
    are refused or when taking joint states failed.
    """
    # One way to stop: rclpy's handlers shut the context down at Ctrl-C or SIGTERM, and spin ends
    # with ExternalShutdownException. Python's own SIGINT handler, which rclpy's calls after, would
    # raise a KeyboardInterrupt at any point of the shutdown that follows (ros-tooling/topic_tools#104;
    # an exit by SIGINT, code -2, after destroy_node in this project's CI), so it only notes the
    # signal, for a Ctrl-C while rclpy.init has not yet put rclpy's handler in.
    interrupted = threading.Event()
    signal.signal(signal.SIGINT, lambda signum, frame: interrupted.set())
    rclpy.init(args=args)
    try:
        executor = SingleThreadedExecutor()  # first: none can be made once a Ctrl-C shut the context down
        node = None if interrupted.is_set() else DynamicsNode()
    except (BaxterDynamicsError, ParameterException, NameValidationException) as err:
        print(f"ERROR: {err}", file=sys.stderr)
        rclpy.try_shutdown()
        return 1
    except Exception:
        if rclpy.ok():
            raise
        node = None  # stopped while starting: the context was shut down under the constructor
    if node is None:
        rclpy.try_shutdown()
        return 0
    try:
        executor.add_node(node)
        executor.spin()
    except ExternalShutdownException:
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    if node.input_error is not None:
        print(f"ERROR: taking joint states failed: {node.input_error!r}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
