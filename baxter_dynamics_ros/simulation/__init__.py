"""Simulation: a Baxter arm with unmodelled effects whose ground truth is known.

The simulator (:mod:`.simulator`) and the reference trajectories it follows (:mod:`.trajectories`).
Imports only the core.
"""
