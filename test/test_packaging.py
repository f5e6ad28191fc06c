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
from processes import interrupt
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


def colcon_build(tmp_path_factory: pytest.TempPathFactory, *options: str) -> Path:
    """colcon's usual build of a workspace holding a copy of this repository; its install prefix."""
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
        [colcon, "build", *options], cwd=ws, capture_output=True, text=True, timeout=600
    )
    assert result.returncode == 0, result.stdout + result.stderr
    return ws / "install" / PACKAGE


def sourced(setup: Path, *command: str) -> list[str]:
    """``command`` run by bash after sourcing a colcon workspace's ``setup``, nothing quoted by hand."""
    return ["bash", "-c", 'source "$0" && exec "$@"', str(setup), *command]


@pytest.fixture(scope="module")
def colcon_install(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return colcon_build(tmp_path_factory)


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


#: The services' client, run with the colcon install's environment (its setup.bash sourced): it waits
#: for the installed node's gravity service, asks G at q = 0 of the right arm and prints where the
#: interface module came from, the node's service types and the answer.
INSTALLED_CLIENT = """
import sys, time
import rclpy
import baxter_dynamics_interfaces
from baxter_dynamics_interfaces.srv import Gravity
rclpy.init()
node = rclpy.create_node("installed_probe")
client = node.create_client(Gravity, "/installed/baxter_dynamics/compute_gravity")
if not client.wait_for_service(timeout_sec=60.0):
    sys.exit("compute_gravity not served within 60 s")
names = ["right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2"]
future = client.call_async(Gravity.Request(name=names, position=[0.0] * 7))
rclpy.spin_until_future_complete(node, future, timeout_sec=30.0)
types = sorted(t for n, ts in node.get_service_names_and_types_by_node("baxter_dynamics", "/installed") for t in ts if "compute_" in n)
print(baxter_dynamics_interfaces.__file__)
print(",".join(sorted(set(types))))
print(future.result().success, ",".join(f"{v:.9f}" for v in future.result().effort))
node.destroy_node()
rclpy.shutdown()
"""


def test_colcon_installs_the_interface_package_and_the_installed_node_serves_it(colcon_install: Path, ros_domain: int, tmp_path: Path) -> None:
    """colcon's usual ``colcon build`` installs baxter_dynamics_interfaces beside the node (its install
    step builds it: colcon does not look inside this package's folder): the ament index lists the five
    services, and with only the install's setup.bash sourced the installed node serves them and a
    client in another process gets G(0) of the right arm, equal to Pinocchio's on the URDF model."""
    if any(shutil.which(tool) is None for tool in ("cmake", "c++", "cc")):
        pytest.skip("no cmake or C/C++ compiler: the interface package is not built (the node then serves no dynamics services)")
    index = colcon_install / "share" / "ament_index" / "resource_index" / "rosidl_interfaces" / "baxter_dynamics_interfaces"
    listed = sorted(line for line in index.read_text().splitlines() if line.endswith(".srv"))
    assert listed == [f"srv/{n}.srv" for n in ("FlangeKinematics", "ForwardDynamics", "Gravity", "InverseDynamics", "MassMatrix")]
    setup = colcon_install.parent / "setup.bash"
    # The underlay (the venv's ROS wheels, as /opt/ros/jazzy would be) stays; the package comes from the install.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}

    log = tmp_path / "node.log"
    with log.open("w") as out:
        node = subprocess.Popen(
            sourced(setup, sys.executable, str(colcon_install / "lib" / PACKAGE / "baxter_dynamics_node"), "--ros-args", "-r", "__ns:=/installed"),
            cwd=tmp_path, env=env, stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        answer = subprocess.run(sourced(setup, sys.executable, "-c", INSTALLED_CLIENT), cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
        assert answer.returncode == 0, answer.stdout + answer.stderr + log.read_text()
        module_file, types, result = answer.stdout.strip().splitlines()[-3:]
    finally:
        interrupt(node)
    assert module_file.startswith(str(colcon_install)), module_file
    assert types == ",".join(f"baxter_dynamics_interfaces/srv/{n}" for n in ("FlangeKinematics", "ForwardDynamics", "Gravity", "InverseDynamics", "MassMatrix"))
    success, effort = result.split()
    assert success == "True"
    from reference_models import pinocchio_from_arm

    from baxter_dynamics_ros import load_arm_model

    expected = pinocchio_from_arm(load_arm_model("right")).rnea(np.zeros(7), np.zeros(7), np.zeros(7))
    np.testing.assert_allclose([float(v) for v in effort.split(",")], expected, rtol=1e-9, atol=1e-9)


def test_colcon_symlink_install_installs_the_interface_package_too(tmp_path_factory: pytest.TempPathFactory, tmp_path: Path) -> None:
    """``colcon build --symlink-install`` (setup.py develop) installs the interface package into the
    install prefix as well: sourced, Python imports it from there and its type support round-trips a request."""
    if any(shutil.which(tool) is None for tool in ("cmake", "c++", "cc")):
        pytest.skip("no cmake or C/C++ compiler: the interface package is not built")
    install = colcon_build(tmp_path_factory, "--symlink-install")
    assert (install / "share" / "ament_index" / "resource_index" / "rosidl_interfaces" / "baxter_dynamics_interfaces").is_file()
    code = (
        "import baxter_dynamics_interfaces; from baxter_dynamics_interfaces.srv import Gravity;"
        "from rclpy.serialization import deserialize_message, serialize_message;"
        "r = deserialize_message(serialize_message(Gravity.Request(name=['right_s0'], position=[0.5])), Gravity.Request);"
        "print(baxter_dynamics_interfaces.__file__); print(list(r.name), list(r.position))"
    )
    site = next((install / "lib").glob("python3*/site-packages"))
    assert (site / "baxter-dynamics-ros.egg-link").is_file(), "colcon did not run setup.py develop"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run(sourced(install.parent / "setup.bash", sys.executable, "-c", code), cwd=tmp_path, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    module_file, round_trip = out.stdout.strip().splitlines()[-2:]
    assert module_file.startswith(str(install)), module_file
    assert round_trip == "['right_s0'] [0.5]"


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
