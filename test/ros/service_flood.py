"""A client process flooding a node's dynamics services, for the tests' live-path check (issue 21).

``python service_flood.py <node prefix>``: calls ``<prefix>/compute_gravity`` with 1 and 1,000
states and ``<prefix>/compute_mass_matrix`` with 1,000 states, four requests in flight at a time,
as fast as the node answers; prints ``ready`` after the first answers and, when its stdin closes,
``calls <n> failed <k>`` and exits. The ROS environment is inherited (the test's own domain).
"""

from __future__ import annotations

import sys
import threading

import numpy as np
import rclpy
from baxter_dynamics_interfaces.srv import Gravity, MassMatrix
from rclpy.executors import SingleThreadedExecutor

JOINTS = ["right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"]


def main(prefix: str) -> int:
    rclpy.init()
    node = rclpy.create_node("service_flood")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    gravity = node.create_client(Gravity, f"{prefix}/compute_gravity")
    mass = node.create_client(MassMatrix, f"{prefix}/compute_mass_matrix")
    for client in (gravity, mass):
        if not client.wait_for_service(timeout_sec=30.0):
            print(f"no service {client.srv_name}", flush=True)
            return 1
    q1 = np.random.default_rng(0).uniform(-1.0, 1.0, (1, 7))
    q1000 = np.random.default_rng(1).uniform(-1.0, 1.0, (1000, 7))
    requests = [
        (gravity, Gravity.Request(name=JOINTS, position=q1.ravel().tolist())),
        (gravity, Gravity.Request(name=JOINTS, position=q1000.ravel().tolist())),
        (mass, MassMatrix.Request(name=JOINTS, position=q1000.ravel().tolist())),
        (gravity, Gravity.Request(name=JOINTS, position=q1.ravel().tolist())),
    ]
    for client, request in requests:  # answered once each: a first answer may be lost while discovery completes
        while True:
            future = client.call_async(request)
            executor.spin_until_future_complete(future, timeout_sec=2.0)
            if future.done():
                break
            client.remove_pending_request(future)
    done = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), done.set()), daemon=True).start()
    calls = failed = 0
    while not done.is_set():
        futures = [client.call_async(request) for client, request in requests]
        for future in futures:
            executor.spin_until_future_complete(future, timeout_sec=10.0)
            calls += 1
            failed += not (future.done() and future.result().success)
        if calls == len(requests):
            print("ready", flush=True)
    print(f"calls {calls} failed {failed}", flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
