"""The package builds with colcon in a ROS 2 workspace and its installed copy finds its config."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from repo_paths import REPO

PACKAGE = "baxter_dynamics_ros"


def test_package_xml_is_format_3_with_runtime_dependencies() -> None:
    root = ET.parse(REPO / "package.xml").getroot()
    assert root.get("format") == "3"
    assert root.findtext("name") == PACKAGE
    exec_depends = {e.text for e in root.findall("exec_depend")}
    for key in ("rclpy", "sensor_msgs", "std_msgs", "std_srvs", "diagnostic_msgs", "python3-numpy", "pinocchio"):
        assert key in exec_depends, key
    assert root.find("export/build_type").text == "ament_python"
    assert (REPO / "resource" / PACKAGE).is_file()


@pytest.fixture(scope="module")
def colcon_install(tmp_path_factory: pytest.TempPathFactory) -> Path:
    colcon = shutil.which("colcon", path=str(Path(sys.executable).parent))
    if colcon is None:
        pytest.skip("colcon is not installed in this environment (pip install colcon-common-extensions)")
    ws = tmp_path_factory.mktemp("ws")
    (ws / "src").mkdir()
    # A copy of the sources as colcon sees them in a workspace (no venv, no caches).
    shutil.copytree(
        REPO,
        ws / "src" / PACKAGE,
        ignore=shutil.ignore_patterns(".venv", ".git", "__pycache__", "*.egg-info", ".pytest_cache", ".hypothesis", "out"),
    )
    result = subprocess.run(
        [colcon, "build", "--base-paths", "src"], cwd=ws, capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return ws / "install" / PACKAGE


def test_colcon_installs_scripts_config_and_index_marker(colcon_install: Path) -> None:
    scripts = {p.name for p in (colcon_install / "lib" / PACKAGE).iterdir()}
    assert {"baxter-dynamics", "baxter_dynamics_node"} <= scripts
    assert (colcon_install / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE).is_file()
    assert (colcon_install / "share" / PACKAGE / "package.xml").is_file()
    config = {p.name for p in (colcon_install / "share" / PACKAGE / "config").iterdir()}
    assert {"baxter_right_arm.yaml", "baxter_left_arm.yaml", "baxter_dynamics.yaml"} <= config


def test_installed_package_loads_models_from_its_share_folder(colcon_install: Path, tmp_path: Path) -> None:
    site = next((colcon_install / "lib").glob("python3*/site-packages"))
    env = dict(os.environ, PYTHONPATH=str(site), AMENT_PREFIX_PATH=str(colcon_install))
    code = (
        "import baxter_dynamics_ros as b; from baxter_dynamics_ros.core.arm_model import config_dir;"
        "import msg_adapters.recording_files, baxter_dynamics_ros.ros.node;"
        "m = b.load_arm_model('left'); print(b.__file__); print(config_dir()); print(m.joint_names[0])"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    module_file, config, first_joint = out.stdout.split()
    assert module_file.startswith(str(site))
    assert config == str(colcon_install / "share" / PACKAGE / "config")
    assert first_joint == "left_s0"
    script = colcon_install / "lib" / PACKAGE / "baxter-dynamics"
    shown = subprocess.run([sys.executable, str(script), "--help"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert shown.returncode == 0 and "diagnose" in shown.stdout, shown.stderr
