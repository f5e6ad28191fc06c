"""The ROS shell: the live node, its settings, the bag player and the ROS environment helper.

:mod:`.node` (``baxter_dynamics_node``) and :mod:`.player` own the rclpy objects and no maths;
:mod:`.dynamics_services` serves the node's dynamics services; :mod:`.node_settings` holds the node's parameters; :mod:`.ros_env` gives every ROS process a
private local graph. The only layer that imports rclpy (with ``msg_adapters``).
"""
