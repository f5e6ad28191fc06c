"""The bench tests' arm: Rethink's URDF (left), skipped with the reason where ../shared is absent."""

from __future__ import annotations

import pytest
from urdf_motion import URDF

from bench.plain_fit import UrdfArm


@pytest.fixture(scope="module")
def arm() -> UrdfArm:
    if not URDF.is_file():
        pytest.skip(f"Baxter's URDF is not at {URDF} (../shared/reference beside the checkout)")
    return UrdfArm.from_urdf("left", URDF)
