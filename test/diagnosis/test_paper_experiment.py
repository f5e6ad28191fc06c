"""The paper's experiment: L-E against Pinocchio's RNEA on simulated recordings, Table V and figures."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from baxter_dynamics_ros import load_arm_model
from baxter_dynamics_ros.cli.main import main
from baxter_dynamics_ros.core.pinocchio_model import pinocchio_from_arm, rnea
from baxter_dynamics_ros.diagnosis.paper_experiment import SETS, SetResult, run_experiment

DURATION_S = 6.0


@pytest.fixture(scope="module")
def sets() -> list[SetResult]:
    return run_experiment(DURATION_S, seed=1)


def test_pinocchio_rnea_matches_the_core() -> None:
    arm = load_arm_model("left")
    rng = np.random.default_rng(5)
    q = rng.uniform(arm.lower_rad, arm.upper_rad, (50, 7))
    qd, qdd = rng.normal(size=(2, 50, 7))
    np.testing.assert_allclose(rnea(pinocchio_from_arm(arm), q, qd, qdd), arm.inverse_dynamics(q, qd, qdd), atol=1e-10)


def test_three_sets_at_50_hz(sets: list[SetResult]) -> None:
    assert [(s.trajectory, s.figure) for s in sets] == list(SETS)
    for s in sets:
        assert s.simulation.spec.rate_hz == 50.0 and len(s.recorded) == int(DURATION_S * 50)
        assert np.all(np.diff(s.simulation.stamps_ns) == 20_000_000)


def test_errors_are_noise_without_bias(sets: list[SetResult]) -> None:
    for s in sets:
        st = s.statistics()
        assert max(st["max_abs_le_minus_rne"]) < 1e-9, "L-E and RN-E agree: same parameters"
        assert max(st["abs_mean_error_le"]) < 0.15, "no bias once the spring is compensated"
        assert st["rms_error_le"][1] > 0.5, "first-difference q̈ of noisy q̇ is noisy"
        assert st["rms_error_le_filtered"][1] < 0.5 * st["rms_error_le"][1], "filtering q̇ first removes most of it"


def test_the_spring_compensation_is_what_removes_the_s1_bias(sets: list[SetResult]) -> None:
    s = sets[0]
    raw_bias = (s.simulation.effort - s.tau_le).mean(axis=0)
    assert raw_bias[1] > 5.0, "without adding the spring back, s1 is off by its share"
    np.testing.assert_allclose(np.delete(raw_bias, 1), np.delete((s.recorded - s.tau_le).mean(axis=0), 1))


def test_command_writes_tables_figures_and_page(tmp_path: Path) -> None:
    out, page = tmp_path / "run", tmp_path / "docs" / "paper.md"
    assert main(["paper-experiment", "--out", str(out), "--page", str(page), "--duration", "3"]) == 0
    figures = ["fig3_trajectories.png", "fig5_set1.png", "fig6_set2.png", "fig7_set3.png"]
    for name in figures:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = (out / "table_v.md").read_text()
    assert len(re.findall(r"^\| \\\|ē_\d\\\| \|", table, flags=re.M)) == 14  # measured and the paper's
    results = json.loads((out / "results.json").read_text())
    assert set(results) == {"set1_paper_xyz", "set2_paper_y", "set3_paper_z"}
    assert len(results["set2_paper_y"]["abs_mean_error_le"]) == 7
    text = page.read_text()
    assert f"--out {out.as_posix()} --page {page.as_posix()} --duration 3" in text
    for link in re.findall(r"!\[[^]]*\]\(([^)]+)\)", text):
        assert (page.parent / link).is_file(), link
    assert "What differs from the paper" in text
    for k in (1, 2, 3):
        assert (out / f"set{k}_{SETS[k - 1][0]}.truth.json").is_file()
