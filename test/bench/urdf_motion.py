"""Rethink's URDF arm and smooth joint motion for the bench tests (the plain fit's and the
inertial-scale analysis' synthetic recordings)."""

from __future__ import annotations

import numpy as np
from repo_paths import SHARED

from bench.plain_fit import UrdfArm

URDF = SHARED / "reference" / "baxter.urdf"
RATE_HZ = 100.0


def motion(arm: UrdfArm, seed: int, seconds: float = 20.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, q̇, q̈), each (n, 7) at RATE_HZ: per joint two sinusoids of 0.1–0.5 Hz about mid-range, in closed form."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * RATE_HZ)) / RATE_HZ
    lo, hi = arm.model.lowerPositionLimit, arm.model.upperPositionLimit
    q = np.tile(0.5 * (lo + hi), (len(t), 1))
    qd, qdd = np.zeros_like(q), np.zeros_like(q)
    for _ in range(2):
        w = 2 * np.pi * rng.uniform(0.1, 0.5, 7)
        a = 0.12 * (hi - lo) * rng.uniform(0.6, 1.0, 7)
        arg = np.outer(t, w) + rng.uniform(0, 2 * np.pi, 7)
        q += a * np.sin(arg)
        qd += a * w * np.cos(arg)
        qdd -= a * w**2 * np.sin(arg)
    return q, qd, qdd
