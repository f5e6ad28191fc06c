"""Bad input to every command, as a hostile user gives it (issues 11 §4 and 12).

Each case runs ``baxter-dynamics`` in a subprocess and checks the exit code, the one ``ERROR:``
line (no traceback) and that nothing new was written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_runs import listing, run_cli, the_error
from recorded_bags import BAXTER_JOINTS, joint_states
from test_recordings_io import write_baxter_export

N = 600


@pytest.fixture(scope="module")
def export_100_hz(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A table in the real recordings' layout (no time column) of the right arm, 6 s at 100 Hz."""
    return write_baxter_export(tmp_path_factory.mktemp("in") / "export.csv", joint_states(N, names=BAXTER_JOINTS), side="right")


def rate_in(line: str) -> float:
    """The estimated rate an error line names ("... estimated ..., 99.98 Hz ...")."""
    import re

    (rate,) = re.findall(r"estimated from position and velocity, (\d+\.\d+) Hz", line)
    return float(rate)


@pytest.mark.parametrize("command", ["process", "diagnose", "calibrate"])
def test_a_rate_that_disagrees_with_the_estimate_is_refused(export_100_hz: Path, tmp_path: Path, command: str) -> None:
    out = {"process": tmp_path / "out.csv", "diagnose": tmp_path / "diag", "calibrate": tmp_path / "thresholds.yaml"}[command]
    inputs = {"diagnose": ["--train", export_100_hz]}.get(command, [export_100_hz])
    result = run_cli(command, *inputs, "--out", out, "--rate-hz", "80")
    line = the_error(result)
    assert str(export_100_hz) in line and "--rate-hz 80 disagrees" in line
    assert rate_in(line) == pytest.approx(100.0, rel=0.01)
    assert listing(tmp_path) == []
