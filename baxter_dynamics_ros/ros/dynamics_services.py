"""The node's dynamics services, answered by a thread of their own beside the live path.

``~/compute_gravity``, ``~/compute_inverse_dynamics``, ``~/compute_mass_matrix``,
``~/compute_forward_dynamics`` and ``~/compute_flange_kinematics`` (the types of
``baxter_dynamics_interfaces/srv``, :mod:`msg_adapters.dynamics_services`) are created in a callback
group that no executor takes (:class:`~baxter_dynamics_ros.ros.node.OwnThreadGroup`) and served by
:class:`ServiceThread`: a wait set of these services and a stop condition, one request taken,
answered and sent back at a time. So a burst of requests neither queues in front of the node's
executor (parameters, ~/reset, the diagnostics timer) nor touches the joint-state thread or its
lock: the queries read only the immutable arm models. A request the adapter or the model refuses
gets success false with the reason; an unexpected error is logged and answered the same way; the
thread never stops on a request.

When the interface package is not built (no C++ compiler where ``./dev`` ran), :func:`create`
logs one warning saying so and returns None: the node runs without these services.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence

from rclpy.context import Context
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.service import Service

from msg_adapters.dynamics_services import MAX_STATES, SERVICES, RequestReader, refuse, service_types, write_response

from ..core.queries import DynamicsQueries
from ..errors import BaxterDynamicsError

__all__ = ["DynamicsServices", "ServiceThread", "create"]


class ServiceThread:
    """Serves ``services`` (in a group no executor takes) from a thread of its own, until :meth:`stop`."""

    def __init__(self, services: Sequence[Service], context: Context, logger, name: str = "dynamics services") -> None:
        self._services, self._context, self._logger = tuple(services), context, logger
        self._stop = GuardCondition(None, None, context=context)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        wait_set = _rclpy.WaitSet(0, 1, 0, 0, len(self._services), 0, self._context.handle)
        while True:
            wait_set.clear_entities()
            for service in self._services:
                wait_set.add_service(service.handle)
            wait_set.add_guard_condition(self._stop.handle)
            try:
                wait_set.wait(-1)
            except Exception as err:  # the context was shut down under us
                self._logger.debug(f"service thread: {err!r}")
                return
            if wait_set.is_ready("guard_condition", 0):
                return
            ready = wait_set.get_ready_entities("service")
            for service in self._services:
                if service.handle.pointer in ready:
                    try:
                        self._serve(service)
                    except Exception as err:  # rmw could not take or answer (the client left): serve on
                        self._logger.warn(f"{service.service_name}: request not answered: {err!r}", throttle_duration_sec=1.0)

    def _serve(self, service: Service) -> None:
        request, header = service.handle.service_take_request(service.srv_type.Request)
        if header is None:
            return
        response = service.srv_type.Response()
        try:
            response = service.callback(request, response)
        except Exception as err:  # a defect: answer, say so, and serve the next request
            self._logger.error(f"{service.service_name}: {err!r}")
            response = service.srv_type.Response(success=False, message=f"internal error: {err!r}")
        service.send_response(response, header)

    def stop(self) -> None:
        """Wake the thread up, let it finish, and wait for it."""
        self._stop.trigger()
        self._thread.join()
        self._stop.destroy()


class DynamicsServices:
    """The dynamics services of ``node`` for one arm, and the thread answering them."""

    def __init__(self, node: Node, types: dict[str, type], queries: DynamicsQueries, group) -> None:
        self._queries = queries
        self._reader = RequestReader(queries.arm.joint_names)
        self.services = tuple(
            node.create_service(types[key], f"~/compute_{key}", self._handler(key), callback_group=group) for key in SERVICES
        )
        self._thread = ServiceThread(self.services, node.context, node.get_logger().get_child("services"))

    def _handler(self, key: str) -> Callable[[object, object], object]:
        layout, query = SERVICES[key], getattr(self._queries, key)
        can_compensate = self._queries.compensation is not None
        names = self._queries.arm.joint_names

        def handle(request, response):
            try:
                results = query(**self._reader.read(request, layout, can_compensate))
            except BaxterDynamicsError as err:
                return refuse(response, str(err))
            return write_response(response, layout, names, results if isinstance(results, tuple) else (results,))

        return handle

    def stop(self) -> None:
        self._thread.stop()


def create(node: Node, queries: DynamicsQueries, group) -> DynamicsServices | None:
    """The services on ``node``, or None with one warning when their types are not built."""
    try:
        types = service_types()
    except ImportError as err:
        node.get_logger().warn(
            f"dynamics services (~/compute_*) not served: baxter_dynamics_interfaces is not built ({err}); "
            "build it with `./dev` (needs cmake and a C++ compiler) or colcon"
        )
        return None
    services = DynamicsServices(node, types, queries, group)
    node.get_logger().info(
        f"serving {', '.join(s.service_name for s in services.services)} (up to {MAX_STATES} states a request)"
    )
    return services
