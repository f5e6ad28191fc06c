"""The ROS 2 program behind ``baxter-dynamics play``: recorded joint states and /clock, in time.

A thin shell: messages come from :func:`msg_adapters.bag_io.read_joint_state_messages` already
serialized as sensor_msgs/msg/JointState, and are published as they are (rclpy accepts bytes),
each after a /clock message carrying its recorded receive time, so that nodes with
``use_sim_time`` run on the bag's time. Paced by wall time at ``speed`` × real time.

The ROS 2 environment of the caller is used as it is (ROS_DOMAIN_ID,
ROS_AUTOMATIC_DISCOVERY_RANGE, RMW_IMPLEMENTATION...): nothing here changes discovery.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Sequence

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from ..errors import PlaybackError

__all__ = ["BagPlayer", "play"]

#: Publisher queue depth: deep enough for bursts when playing faster than real time.
QUEUE_DEPTH = 100
#: After every topic has a subscriber, time for the subscribers to match the publishers too (their
#: side of discovery is not visible from here; a best-effort reader drops data until it has).
SETTLE_S = 1.0


#: How long the publishers stay up after the last message, s.
LINGER_S = 0.5


class BagPlayer(Node):
    """Publishes JointState bytes on their recorded topics and the recorded time on /clock."""

    def __init__(self, topics: Sequence[str]) -> None:
        super().__init__("baxter_dynamics_player")
        reliable = QoSProfile(depth=QUEUE_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        self.clock_publisher = self.create_publisher(Clock, "/clock", reliable)
        self.joint_state_publishers = {topic: self.create_publisher(JointState, topic, reliable) for topic in topics}

    def wait_for_subscribers(self, timeout_s: float) -> bool:
        """Wait until every joint-state topic has a subscriber (at most timeout_s s); True if so."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if all(p.get_subscription_count() > 0 for p in self.joint_state_publishers.values()):
                time.sleep(SETTLE_S)
                return True
            time.sleep(0.05)
        return False

    def publish(self, topic: str, receive_time_ns: int, raw: bytes) -> None:
        """/clock at the recorded receive time, then the message (CDR bytes) on its topic."""
        sec, nanosec = divmod(receive_time_ns, 1_000_000_000)
        clock = Clock()
        clock.clock.sec, clock.clock.nanosec = sec, nanosec
        self.clock_publisher.publish(clock)
        self.joint_state_publishers[topic].publish(raw)


def play(
    messages: Sequence[tuple[int, str, bytes]],
    *,
    speed: float = 1.0,
    loop: bool = False,
    wait_for_subscribers_s: float = 0.0,
) -> int:
    """Publish (receive time ns, topic, bytes) messages, sorted by time, at ``speed`` × real time.

    loop: start again from the first message after the last (the clock jumps back).
    wait_for_subscribers_s: first wait up to this long for a subscriber on every topic (raises
    PlaybackError if they do not come). Returns 0 when done or stopped by Ctrl-C (SIGINT) or SIGTERM.
    """
    if not messages:
        raise PlaybackError("nothing to play: no joint-state message on the chosen topics")
    # No rclpy signal handlers: they invalidate the context at Ctrl-C while this loop may still be
    # publishing (an RCLError instead of a clean stop). SIGINT and SIGTERM raise KeyboardInterrupt
    # here instead, set explicitly: a caller may have left SIGINT ignored (a shell's background job).
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = BagPlayer(sorted({topic for _, topic, _ in messages}))
    previous = {sig: signal.signal(sig, signal.default_int_handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        if wait_for_subscribers_s > 0 and not node.wait_for_subscribers(wait_for_subscribers_s):
            raise PlaybackError(
                f"no subscriber on every topic ({', '.join(node.joint_state_publishers)}) after "
                f"{wait_for_subscribers_s} s; is the node running with the same ROS_DOMAIN_ID?"
            )
        first_ns = messages[0][0]
        while True:
            start_s = time.monotonic()
            for receive_ns, topic, raw in messages:
                delay_s = start_s + (receive_ns - first_ns) * 1e-9 / speed - time.monotonic()
                if delay_s > 0:
                    time.sleep(delay_s)
                node.publish(topic, receive_ns, raw)
            if not loop:
                # Keep the writers up a moment: the node reads best effort, and the last samples
                # still in flight would be dropped with the publishers.
                time.sleep(LINGER_S)
                return 0
    except KeyboardInterrupt:
        return 0
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        node.destroy_node()
        rclpy.try_shutdown()
