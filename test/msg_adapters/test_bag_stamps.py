"""A recording's sample times are its messages' header stamps, not the bag's receive times.

The bags are written with rosbags' own writers (``recorded_bags.write_bag``), each message received
3–8 ms after its header stamp (a jitter the header does not have), so that reading the wrong clock
gives other numbers; the reference is the stamps the messages were built with.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from recorded_bags import BAG_KINDS, BAXTER_JOINTS, bag_path, joint_states, message, write_bag

from msg_adapters.bag_io import read_bag_recording
from msg_adapters.recording_files import read_recording

TOPIC = "/robot/joint_states"


def _bag_with_late_receipt(tmp_path: Path, kind: str, n: int = 300) -> tuple[Path, np.ndarray, np.ndarray]:
    """A bag whose messages arrive 3–8 ms after their header stamp: (path, header stamps, receive times)."""
    states = joint_states(n, seed=3)
    stamps = states["stamps_ns"]
    rng = np.random.default_rng(7)
    receive = stamps + np.sort(rng.integers(3_000_000, 8_000_000, n))  # still increasing
    receive = np.maximum.accumulate(receive + np.arange(n))
    msgs = [
        (int(r), message(kind, int(s), BAXTER_JOINTS, p, v, e))
        for s, r, p, v, e in zip(stamps, receive, states["position"], states["velocity"], states["effort"])
    ]
    return write_bag(bag_path(tmp_path, kind), kind, {TOPIC: msgs}), stamps, receive


@pytest.mark.parametrize("kind", BAG_KINDS)
def test_sample_times_are_header_stamps(tmp_path: Path, kind: str) -> None:
    """read_bag_recording and read_recording return the header stamps exactly, which differ from
    every receive time in the bag."""
    path, stamps, receive = _bag_with_late_receipt(tmp_path, kind)
    assert np.all(receive != stamps)  # the check below can tell the two clocks apart
    for rec in (read_bag_recording(path, topic=TOPIC), read_recording(path)):
        np.testing.assert_array_equal(rec.stamps_ns, stamps)
