"""The package builds with colcon in a ROS 2 workspace, its installed copy finds its config and its
launch file, and a plain ``pip install`` (no extras) into a fresh venv gives working ROS-free parts."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from repo_paths import REPO

PACKAGE = "baxter_dynamics_ros"
LAUNCH_FILE = "baxter_dynamics.launch.xml"
LAUNCH_ARGS = {"arm", "params_file", "namespace", "use_sim_time"}
#: The elements and attributes of a ROS 2 XML launch file this one may use (launch_xml, launch_ros).
LAUNCH_SCHEMA = {
    "launch": set(),
    "arg": {"name", "default", "description"},
    "node": {"pkg", "exec", "name", "namespace", "output"},
    "param": {"name", "value", "from"},
}
SUBSTITUTION = re.compile(r"\$\((\S+) ([^)]*)\)")

PACKAGE = "baxter_dynamics_ros"


def test_package_xml_is_format_3_with_runtime_dependencies() -> None:
    root = ET.parse(REPO / "package.xml").getroot()
    assert root.get("format") == "3"
    assert root.findtext("name") == PACKAGE
    exec_depends = {e.text for e in root.findall("exec_depend")}
    for key in ("rclpy", "sensor_msgs", "std_msgs", "std_srvs", "diagnostic_msgs", "python3-numpy", "pinocchio", "ros2launch"):
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


def console_scripts() -> set[str]:
    """The console-script names setup.py declares (read from its text: no setuptools run)."""
    text = (REPO / "setup.py").read_text(encoding="utf-8")
    block = text[text.index('"console_scripts"') :]
    return set(re.findall(r'"([\w-]+) = [\w.]+:\w+"', block[: block.index("]")]))


def check_launch_file(path: Path, share: Path, scripts: Path) -> None:
    """A well-formed ROS 2 XML launch file: only launch_xml's elements and attributes, the four
    arguments declared with defaults, every $(var) declared, $(find-pkg-share) naming this package
    and a file installed under ``share``, the node's pkg this package and its exec a console script
    installed in ``scripts``, its parameters (and the default params file's) the node's."""
    import yaml

    from baxter_dynamics_ros.ros.node_settings import NodeSettings

    node_parameters = {spec.name for spec in NodeSettings.fields()}
    root = ET.parse(path).getroot()
    assert root.tag == "launch"
    for element in root.iter():
        assert element.tag in LAUNCH_SCHEMA, f"<{element.tag}> is not a launch_xml element this file may use"
        assert set(element.attrib) <= LAUNCH_SCHEMA[element.tag], (element.tag, element.attrib)
    args = {a.get("name"): a for a in root.findall("arg")}
    assert set(args) == LAUNCH_ARGS and all(a.get("default") is not None and a.get("description") for a in args.values())
    for element in root.iter():
        for value in element.attrib.values():
            for kind, argument in SUBSTITUTION.findall(value):
                assert kind in ("var", "find-pkg-share"), value
                if kind == "var":
                    assert argument in args, f"$(var {argument}) is not declared"
                else:
                    assert argument == PACKAGE, value
                    installed = value.replace(f"$(find-pkg-share {PACKAGE})", str(share))
                    assert "$(" in installed or Path(installed).is_file(), f"{value} -> {installed} is not installed"
    (node,) = root.findall("node")
    assert node.get("pkg") == PACKAGE and node.get("exec") in console_scripts()
    assert (scripts / node.get("exec")).is_file()
    assert node.get("namespace") == "$(var namespace)"
    params = node.findall("param")
    assert [p.get("from") for p in params if p.get("from")] == ["$(var params_file)"]
    named = {p.get("name"): p.get("value") for p in params if p.get("name")}
    assert named == {"arm": "$(var arm)", "use_sim_time": "$(var use_sim_time)"}
    assert "arm" in node_parameters
    default_params = Path(args["params_file"].get("default").replace(f"$(find-pkg-share {PACKAGE})", str(share)))
    assert set(yaml.safe_load(default_params.read_text(encoding="utf-8"))["/**"]["ros__parameters"]) <= node_parameters


def test_colcon_installs_a_well_formed_launch_file(colcon_install: Path) -> None:
    share = colcon_install / "share" / PACKAGE
    installed = share / "launch" / LAUNCH_FILE
    assert installed.is_file()
    assert installed.read_bytes() == (REPO / "launch" / LAUNCH_FILE).read_bytes()
    check_launch_file(installed, share, colcon_install / "lib" / PACKAGE)


def test_readme_shows_ros2_launch_and_says_it_needs_ros() -> None:
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    assert f"ros2 launch {PACKAGE} {LAUNCH_FILE} arm:=right" in readme
    assert "`ros2 launch` is not on PyPI" in readme


def test_pip_install_without_extras_gives_working_ros_free_parts(tmp_path: Path) -> None:
    """``pip install <copy of the checkout>`` in a fresh venv, from the machine's package index, no
    extras: the install requirements suffice for the core, simulation, diagnosis, msg_adapters'
    files and the ``baxter-dynamics`` script, and rclpy is neither installed nor needed."""
    src = tmp_path / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(".venv", ".git", "__pycache__", "*.egg-info", "build", ".pytest_cache", ".hypothesis", "out"))
    subprocess.run([sys.executable, "-m", "venv", str(tmp_path / "venv")], check=True, timeout=120)
    python = tmp_path / "venv" / "bin" / "python"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "AMENT_PREFIX_PATH")}
    install = subprocess.run([str(python), "-m", "pip", "install", "--quiet", str(src)], capture_output=True, text=True, timeout=900, env=env, cwd=tmp_path)
    assert install.returncode == 0, install.stdout[-3000:] + install.stderr[-3000:]
    code = (
        "import sys, importlib.util, numpy as np\n"
        "from baxter_dynamics_ros import load_arm_model\n"
        "import baxter_dynamics_ros.diagnosis.procedure, baxter_dynamics_ros.simulation.plant\n"
        "import baxter_dynamics_ros.monitoring.pipeline, msg_adapters.recording_files, baxter_dynamics_ros.cli.main\n"
        "arm = load_arm_model('right')\n"
        "print(' '.join(repr(float(x)) for x in arm.gravity(np.zeros(7))))\n"
        "print(importlib.util.find_spec('rclpy') is None, 'rclpy' in sys.modules)\n"
    )
    run = subprocess.run([str(python), "-c", code], capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    gravity, ros = run.stdout.strip().splitlines()
    from baxter_dynamics_ros import load_arm_model

    np.testing.assert_allclose([float(x) for x in gravity.split()], load_arm_model("right").gravity(np.zeros(7)), rtol=1e-12)
    assert ros == "True False"  # no rclpy in that venv, and nothing asked for it
    script = tmp_path / "venv" / "bin" / "baxter-dynamics"
    shown = subprocess.run([str(script), "--help"], capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert shown.returncode == 0 and "process" in shown.stdout, shown.stderr
