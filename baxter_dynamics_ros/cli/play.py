"""``baxter-dynamics play BAG``: publish a bag's joint states and /clock, paced in time.

For a node running with ``use_sim_time:=true``: no ``ros2 bag`` needed. Every JointState (and
SEAJointState, as JointState with its actual_* arrays) topic of the bag, or those named by
``--topics``, is published as sensor_msgs/msg/JointState at its recorded receive time, after a
/clock message carrying that time.

Discovery is left to the caller's environment (ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE, ...):
this command sets none of it. To keep the traffic on this machine, run it with
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and the node's ROS_DOMAIN_ID.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options."""
    parser.epilog = (
        "Discovery follows the caller's ROS 2 environment (ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE); "
        "set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST to stay on this machine."
    )
    parser.add_argument("bag", type=Path, metavar="BAG", help="bag to play: .bag, ROS 2 bag folder, .mcap or .db3")
    parser.add_argument("--speed", type=float, default=1.0, metavar="FACTOR", help="playback speed, a factor of real time: 2 plays twice as fast (default 1.0)")
    parser.add_argument("--loop", action="store_true", help="start again at the end (until Ctrl-C)")
    parser.add_argument("--topics", nargs="+", metavar="TOPIC", help="topics to play (default: every joint-state topic)")
    parser.add_argument(
        "--wait-for-subscribers", type=float, default=0.0, metavar="S",
        help="first wait up to S seconds until every topic has a subscriber (default: start at once)",
    )


def run(args: argparse.Namespace) -> int:
    """Play args.bag; returns 0 (errors raise BaxterDynamicsError)."""
    from msg_adapters.bag_io import DEFAULT_TOPIC, read_joint_state_messages
    from msg_adapters.array_files import ARRAY_FILES, split_part
    from msg_adapters.recording_files import TABLE_SUFFIXES
    from msg_adapters.text_files import kind_suffix

    from ..errors import PlaybackError

    if not (args.speed > 0):
        raise PlaybackError(f"--speed must be positive, got {args.speed}")
    file, part = split_part(args.bag)
    kind = kind_suffix(file)
    if kind in (*TABLE_SUFFIXES, *ARRAY_FILES):
        one = f"{file}:{part or 'PART'} --arm ARM" if kind in ARRAY_FILES else f"{file}"
        raise PlaybackError(
            f"{args.bag}: play takes bags (.bag, a ROS 2 bag folder, .mcap, .db3), not tables or files of arrays (.mat, .npz, HDF5); make one with "
            f"`baxter-dynamics process {one} --out BAG.mcap` and play it with --topics {DEFAULT_TOPIC}"
        )
    messages = read_joint_state_messages(args.bag, args.topics)
    from ..ros.player import play  # imports rclpy: only once the bag has been read

    return play(messages, speed=args.speed, loop=args.loop, wait_for_subscribers_s=args.wait_for_subscribers)
