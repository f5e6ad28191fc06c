"""Simulation: a Baxter arm with unmodelled effects whose ground truth is known.

What a run is (:mod:`.spec`), the plant and its controller (:mod:`.plant`: ``simulate``), what the
robot records of it and the ground truth (:mod:`.sensor`), and the reference trajectories
(:mod:`.trajectories`). Imports only the core.
"""
