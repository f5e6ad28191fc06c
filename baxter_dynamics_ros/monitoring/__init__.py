"""Monitoring: the live node's work on each sample, and collision monitoring, without ROS.

The per-sample pipeline of model torques and residuals (:mod:`.pipeline`) and its health report
(:mod:`.health`); the generalised-momentum observer (:mod:`.observer`), per-joint collision
thresholds and their file (:mod:`.thresholds`), their calibration from collision-free data
(:mod:`.calibration`) and the detector (:mod:`.detector`); the node's collision monitoring
(:mod:`.collision_monitor`). Imports only the core.
"""
