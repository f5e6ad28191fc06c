"""The only code that knows ROS message and bag layouts; everything else sees numpy arrays.

- :mod:`msg_adapters.joint_state` — the live node's messages: serialized ``sensor_msgs/JointState``
  to one arm's arrays by joint name and back, and its DiagnosticArray;
- :mod:`msg_adapters.dynamics_services` — the dynamics services' requests (named joints, flat
  arrays) to one arm's arrays, checked field by field, and the arrays back into responses;
- :mod:`msg_adapters.serialized_joint_states` — JointState / SEAJointState bytes decoded and
  encoded in bulk;
- :mod:`msg_adapters.bag_io`, :mod:`msg_adapters.mcap_writer` — ROS 1 and ROS 2 bags in and out;
- :mod:`msg_adapters.csv_io` — recordings as tables (CSV, Parquet);
- :mod:`msg_adapters.text_files` — text tables as datasets publish them: compressed or not, with or
  without a byte-order mark, and what kind of file a path holds;
- :mod:`msg_adapters.table_columns` — what a table's column names say: each joint's position,
  velocity and effort column, and the time, however a dataset names them;
- :mod:`msg_adapters.topic_dumps` — joint states of a ROS topic dumped to text: ``rostopic echo -p``, bagpy, echoed messages;
- :mod:`msg_adapters.array_files` — files of named arrays (MATLAB, NumPy .npz, HDF5) holding
  recordings, as robot-learning datasets publish them;
- :mod:`msg_adapters.pointer_files` — the Git LFS and git-annex pointers a dataset's clone holds
  where its files were not fetched, told for what they are;
- :mod:`msg_adapters.recording_files` — which reader or writer a path calls for.

Submodules are imported on demand (``from msg_adapters.bag_io import ...``): only
:mod:`~msg_adapters.joint_state` needs rclpy's message packages (and
:func:`msg_adapters.dynamics_services.service_types` the built baxter_dynamics_interfaces).
"""

from __future__ import annotations

__all__ = [
    "array_files", "bag_io", "csv_io", "dynamics_services", "joint_state", "mcap_writer", "pointer_files", "recording_files", "topic_dumps", "serialized_joint_states",
    "table_columns", "text_files",
]  # fmt: skip
