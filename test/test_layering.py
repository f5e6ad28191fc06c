"""The layers of the package (issue 13): each imports only the layers below it.

| layer | may import of this project | and of the others |
|---|---|---|
| core | errors | numpy, numba, scipy, yaml (pinocchio in pinocchio_model) |
| monitoring, simulation | core | numpy, numba, scipy, yaml |
| diagnosis | core, simulation | numpy, numba, scipy, yaml, matplotlib |
| ros | everything above, msg_adapters | rclpy and ROS messages |
| cli | everything | everything |
| msg_adapters | core's records (recording, samples, joints), plausibility, output_files, errors | rosbags, pyarrow, scipy.io and h5py (MATLAB files), rclpy messages |

Two checks: every import statement in a layer's source, wherever it stands (a function's lazy
import too), names only what the table allows; and importing each module of core, monitoring,
simulation and diagnosis in a fresh interpreter loads neither rclpy nor msg_adapters nor a higher
layer, and importing msg_adapters loads no layer above the core's records (nor numba).
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest
from repo_paths import REPO

PACKAGE = REPO / "baxter_dynamics_ros"
STDLIB = set(sys.stdlib_module_names) | {"__future__"}

#: The project's modules a layer may import (its own are always allowed).
OWN = {
    "core": {"baxter_dynamics_ros.errors"},
    "monitoring": {"baxter_dynamics_ros.errors", "baxter_dynamics_ros.core"},
    "simulation": {"baxter_dynamics_ros.errors", "baxter_dynamics_ros.core"},
    "diagnosis": {"baxter_dynamics_ros.errors", "baxter_dynamics_ros.core", "baxter_dynamics_ros.simulation"},
    "ros": {
        "baxter_dynamics_ros.errors", "baxter_dynamics_ros.core", "baxter_dynamics_ros.monitoring",
        "baxter_dynamics_ros.simulation", "baxter_dynamics_ros.diagnosis", "msg_adapters",
    },
    "msg_adapters": {
        "baxter_dynamics_ros.errors", "baxter_dynamics_ros.core.recording", "baxter_dynamics_ros.core.samples",
        "baxter_dynamics_ros.core.joints", "baxter_dynamics_ros.core.output_files", "baxter_dynamics_ros.core.plausibility",
    },
}  # fmt: skip
ROS_MESSAGES = {"rclpy", "rcl_interfaces", "builtin_interfaces", "sensor_msgs", "std_msgs", "std_srvs", "diagnostic_msgs", "rosgraph_msgs", "baxter_dynamics_interfaces"}
#: Other distributions' top-level modules a layer may import.
OTHERS = {
    "core": {"numpy", "numba", "scipy", "yaml", "pinocchio"},
    "monitoring": {"numpy", "numba", "scipy", "yaml"},
    "simulation": {"numpy", "numba", "scipy", "yaml"},
    "diagnosis": {"numpy", "numba", "scipy", "yaml", "matplotlib"},
    "ros": {"numpy", "yaml"} | ROS_MESSAGES,
    "msg_adapters": {"numpy", "numba", "rosbags", "pyarrow", "scipy", "h5py"} | ROS_MESSAGES,  # numba: the live reader of CDR bytes; scipy.io and h5py: MATLAB files
}
#: What importing a module of these layers must not load.
FORBIDDEN_AT_IMPORT = ("rclpy", "msg_adapters", *ROS_MESSAGES)
LOWER_LAYERS = ("core", "monitoring", "simulation", "diagnosis")


def modules_of(layer: str) -> list[tuple[str, Path]]:
    """(dotted name, file) of every module of a layer (a subpackage, or msg_adapters)."""
    folder = REPO / "msg_adapters" if layer == "msg_adapters" else PACKAGE / layer
    out = []
    for path in sorted(folder.rglob("*.py")):
        parts = path.relative_to(REPO).with_suffix("").parts
        out.append((".".join(parts[:-1] if parts[-1] == "__init__" else parts), path))
    return out


def imported_names(name: str, path: Path) -> list[tuple[int, str]]:
    """(line, absolute dotted name) of everything ``path``'s source imports, anywhere in it."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module
            found += [(node.lineno, module if node.module else f"{module}.{alias.name}") for alias in node.names]
    return found


def allowed(layer: str, imported: str) -> bool:
    top = imported.split(".")[0]
    own_prefix = "msg_adapters" if layer == "msg_adapters" else f"baxter_dynamics_ros.{layer}"
    if top in STDLIB or imported == own_prefix or imported.startswith(own_prefix + "."):
        return True
    if top in ("baxter_dynamics_ros", "msg_adapters"):
        return any(imported == ok or imported.startswith(ok + ".") for ok in OWN[layer])
    return top in OTHERS[layer]


@pytest.mark.parametrize("layer", [*OWN])
def test_every_import_statement_stays_within_the_layers_below(layer: str) -> None:
    offending = [
        f"{path.relative_to(REPO)}:{line}: {imported}"
        for name, path in modules_of(layer)
        for line, imported in imported_names(name, path)
        if not allowed(layer, imported)
    ]
    assert not offending, f"{layer} may import only {sorted(OWN[layer] | OTHERS[layer])}:\n" + "\n".join(offending)


def test_the_front_and_errors_import_no_layer_but_the_arm_model_on_demand() -> None:
    names = [n for _, n in imported_names("baxter_dynamics_ros", PACKAGE / "__init__.py")]
    names += [n for _, n in imported_names("baxter_dynamics_ros.errors", PACKAGE / "errors.py")]
    assert {n for n in names if n.startswith("baxter_dynamics_ros")} <= {"baxter_dynamics_ros.errors", "baxter_dynamics_ros.core.arm_model", "baxter_dynamics_ros.core"}
    assert sorted(p.name for p in PACKAGE.iterdir() if p.suffix == ".py") == ["__init__.py", "errors.py"]


def loaded_after_import(module: str) -> list[str]:
    """The modules in sys.modules after ``import module`` in a fresh interpreter."""
    code = f"import json, sys; import {module}; print(json.dumps(sorted(sys.modules)))"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("module", [name for layer in LOWER_LAYERS for name, _ in modules_of(layer)])
def test_importing_a_lower_layer_loads_neither_rclpy_nor_msg_adapters_nor_a_higher_layer(module: str) -> None:
    layer = module.split(".")[1]
    higher = [f"baxter_dynamics_ros.{name}" for name in ("monitoring", "simulation", "diagnosis", "ros", "cli") if f"baxter_dynamics_ros.{name}" not in OWN[layer] and name != layer]
    loaded = loaded_after_import(module)
    bad = [m for m in loaded if m.split(".")[0] in FORBIDDEN_AT_IMPORT or any(m == h or m.startswith(h + ".") for h in higher)]
    assert not bad, f"import {module} loaded {bad}"


@pytest.mark.parametrize("module", [name for name, _ in modules_of("msg_adapters")] + ["baxter_dynamics_ros", "baxter_dynamics_ros.errors"])
def test_importing_msg_adapters_loads_only_the_core_records(module: str) -> None:
    loaded = loaded_after_import(module)
    ours = [m for m in loaded if m.startswith("baxter_dynamics_ros.")]
    bad = [m for m in ours if m != "baxter_dynamics_ros.errors" and not any(m == ok or m.startswith(ok + ".") for ok in OWN["msg_adapters"]) and m != "baxter_dynamics_ros.core"]
    assert not bad, f"import {module} loaded {bad}"
    if module != "msg_adapters.joint_state":  # the live node's reader compiles its one call per message
        assert "numba" not in loaded, f"import {module} loaded numba (through {ours})"
