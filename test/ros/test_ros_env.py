"""Domain-id leases: concurrent holders never share an id, and an id comes back when released."""

from __future__ import annotations

import os
import subprocess
import sys

from baxter_dynamics_ros.ros.ros_env import DOMAIN_IDS, isolated_ros_env, lease_domain_id


def test_concurrent_leases_get_distinct_ids_and_released_ids_return(tmp_path) -> None:
    with lease_domain_id() as a, lease_domain_id() as b:
        assert a != b and a in DOMAIN_IDS and b in DOMAIN_IDS
    with lease_domain_id() as again:
        assert again == a


def test_a_lease_held_by_another_process_is_skipped() -> None:
    code = "from baxter_dynamics_ros.ros.ros_env import lease_domain_id\nwith lease_domain_id() as d:\n print(d, flush=True)\n input()"
    other = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        held = int(other.stdout.readline())
        with lease_domain_id(first=held) as domain_id:
            assert domain_id != held
        assert held != int(os.environ["ROS_DOMAIN_ID"])  # nor does it hold this session's lease
        with lease_domain_id(first=int(os.environ["ROS_DOMAIN_ID"])) as domain_id:
            assert domain_id != int(os.environ["ROS_DOMAIN_ID"])
    finally:
        other.communicate("\n", timeout=30)


def test_isolated_env_keeps_discovery_local(tmp_path) -> None:
    with isolated_ros_env(tmp_path) as env:
        assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
        assert int(env["ROS_DOMAIN_ID"]) in DOMAIN_IDS and env["ROS_LOG_DIR"] == str(tmp_path)
    # and the session's own environment, set by conftest, is the same kind
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
