"""Monitoring: the live node's work on each sample, without ROS.

The per-sample pipeline of model torques and residuals and its health report
(:mod:`.residuals`), the generalised-momentum observer, collision thresholds, their calibration
and the detector (:mod:`.collision`), and the node's collision monitoring (:mod:`.collision_monitor`).
Imports only the core.
"""
