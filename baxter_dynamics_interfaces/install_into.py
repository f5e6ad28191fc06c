"""Build baxter_dynamics_interfaces with cmake and install it into a prefix: the one way both builds do it.

- ``./dev`` installs it into its venv, where ROS 2 Jazzy's PyPI wheels are (``python
  baxter_dynamics_interfaces/install_into.py PREFIX BUILD_DIR LOG``);
- ``colcon build`` in a ROS 2 workspace installs it into baxter_dynamics_ros's own install prefix:
  colcon stops looking for packages inside a package's folder, so it never sees this one, and
  ``setup.py``'s install step (the step colcon runs for this ament_python package) calls
  :func:`install_into`. Its ament index, type support libraries, Python module and CMake config then
  sit beside the node's, on the paths colcon's setup scripts export for baxter_dynamics_ros.

Without cmake or a C/C++ compiler, or where cmake cannot find ament_cmake and rosidl, nothing is
installed and the reason is returned: the node then starts without its dynamics services (one warning).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

SOURCE = Path(__file__).resolve().parent


def install_into(prefix: str | os.PathLike[str], build_dir: str | os.PathLike[str], log: str | os.PathLike[str]) -> str | None:
    """Configure, build and install the interface package into ``prefix`` (cmake's output in ``log``).

    The packages it needs are searched in ``prefix`` and on AMENT_PREFIX_PATH (a sourced ROS 2
    install or workspace). Returns None once installed, else one line saying why it was not.
    """
    missing = [tool for tool in ("cmake", os.environ.get("CXX", "c++"), os.environ.get("CC", "cc")) if shutil.which(tool) is None]
    if missing:
        return f"no {', '.join(missing)} on PATH"
    search = [str(prefix), *filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep))]
    build = Path(build_dir)  # kept between calls: cmake rebuilds only what changed
    build.mkdir(parents=True, exist_ok=True)
    jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
    steps = [
        ["cmake", "-S", str(SOURCE), "-B", str(build), f"-DCMAKE_PREFIX_PATH={';'.join(search)}", f"-DCMAKE_INSTALL_PREFIX={prefix}",
         f"-DPython3_EXECUTABLE={sys.executable}", "-DBUILD_TESTING=OFF"],
        ["cmake", "--build", str(build), f"-j{jobs}"],
        ["cmake", "--install", str(build)],
    ]  # fmt: skip
    with open(log, "w", encoding="utf-8") as out:
        for step in steps:
            if subprocess.run(step, stdout=out, stderr=subprocess.STDOUT, check=False).returncode:
                return f"`{' '.join(step[:2])}` failed (see {log})"
    return None


def main() -> int:
    """``install_into.py PREFIX BUILD_DIR LOG``: exit 0 once installed; else 1 and the reason on stderr."""
    if len(sys.argv) != 4:
        print("usage: install_into.py PREFIX BUILD_DIR LOG", file=sys.stderr)
        return 2
    why = install_into(*sys.argv[1:])
    if why is not None:
        print(f"baxter_dynamics_interfaces not built: {why}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
