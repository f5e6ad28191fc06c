"""Every path and module the documentation names exists: README.md, docs/*.md, and the docstrings
and comments of the package, its adapters, the tests and the benchmarks.

Checked: paths in the checkout (``baxter_dynamics_ros/…``, ``msg_adapters/…``, ``config/…``,
``launch/…``, ``test/…``, ``bench/…``, ``docs/…``; in the Markdown also ``core/…`` and the other
subpackages, read under ``baxter_dynamics_ros/``), the Markdown's relative links, the modules of
``python -m MODULE`` commands, and dotted names ``baxter_dynamics_ros.x.y`` / ``msg_adapters.x``
(a module, or a name defined in one).
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import io
import re
import sys
import tokenize
from pathlib import Path

import pytest
from repo_paths import REPO

TOP = ("baxter_dynamics_ros", "msg_adapters", "config", "launch", "test", "bench", "docs", "resource")
SUBPACKAGES = ("core", "monitoring", "simulation", "diagnosis", "ros", "cli")
PATH = re.compile(r"(?<![\w./<-])((?:%s)/[\w./*<>-]*[\w/*>])" % "|".join(TOP + SUBPACKAGES))
DOTTED = re.compile(r"(?<![\w.])((?:baxter_dynamics_ros|msg_adapters)(?:\.\w+)+)")
PYTHON_M = re.compile(r"python3? -m ([\w.]+)")
LINK = re.compile(r"\]\(([^)#\s]+)")
MARKDOWN = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
SOURCES = sorted(
    p
    for folder in ("baxter_dynamics_ros", "msg_adapters", "test", "bench")
    for p in (REPO / folder).rglob("*.py")
    if p != Path(__file__).resolve()  # its own examples name what does not exist
)


def documentation_of(source: Path) -> str:
    """A Markdown file's text; a Python file's docstrings and comments (not its code and data)."""
    text = source.read_text(encoding="utf-8")
    if source.suffix == ".md":
        return text
    nodes = [n for n in ast.walk(ast.parse(text)) if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))]
    docstrings = [ast.get_docstring(n, clean=False) or "" for n in nodes]
    comments = [t.string for t in tokenize.generate_tokens(io.StringIO(text).readline) if t.type == tokenize.COMMENT]
    return "\n".join(docstrings + comments)


def named_paths(text: str, markdown: bool) -> set[str]:
    """Checkout paths a text names; in Python sources only those under a top-level folder."""
    found = set(PATH.findall(text))
    if not markdown:
        found = {p for p in found if p.split("/")[0] in TOP}
    return {p.rstrip(".") for p in found if "<" not in p}  # bench/bench_<name>.py is a pattern


def resolve(path: str) -> Path:
    first = path.split("/")[0]
    return REPO / path if first in TOP else REPO / "baxter_dynamics_ros" / path


def exists(path: str) -> bool:
    """The path exists; a glob (``config/baxter_*_arm.yaml``) matches something."""
    if "*" in path:
        return any(REPO.glob(str(resolve(path).relative_to(REPO))))
    return resolve(path).exists()


def missing_in(source: Path) -> list[str]:
    text = documentation_of(source)
    markdown = source.suffix == ".md"
    out = [f"path {p}" for p in sorted(named_paths(text, markdown)) if not exists(p)]
    if markdown:
        links = [link for link in LINK.findall(text) if "://" not in link]
        out += [f"link {link}" for link in links if not (source.parent / link).exists()]
    out += [f"python -m {m}" for m in sorted(set(PYTHON_M.findall(text))) if not module_exists(m)]
    out += [f"name {d}" for d in sorted(set(DOTTED.findall(text))) if not dotted_exists(d)]
    return out


def module_exists(name: str) -> bool:
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def dotted_exists(name: str) -> bool:
    """A module, or a module's attribute (a class's too: ``module.Class.method``)."""
    parts = name.split(".")
    for cut in range(len(parts), 0, -1):
        module = ".".join(parts[:cut])
        if module_exists(module):
            obj = importlib.import_module(module)
            for attr in parts[cut:]:
                if not hasattr(obj, attr):
                    return False
                obj = getattr(obj, attr)
            return True
    return False


@pytest.mark.parametrize("source", MARKDOWN + SOURCES, ids=lambda p: str(p.relative_to(REPO)))
def test_every_named_path_and_module_exists(source: Path) -> None:
    missing = missing_in(source)
    assert not missing, f"{source.relative_to(REPO)} names what does not exist:\n" + "\n".join(missing)


def test_the_check_finds_a_wrong_path() -> None:
    text = "see `core/lagrange_eulr.py`, `test/test_lagrange_euler.py` and python -m baxter_dynamics_ros.node"
    paths = named_paths(text, markdown=True)
    assert {p for p in paths if not exists(p)} == {"core/lagrange_eulr.py", "test/test_lagrange_euler.py"}
    assert exists("config/baxter_*_arm.yaml") and not exists("config/baxter_*_leg.yaml")
    assert not module_exists("baxter_dynamics_ros.node") and module_exists("baxter_dynamics_ros.ros.node")
    assert not dotted_exists("baxter_dynamics_ros.core.arm_model.load_arm_modle")
    assert dotted_exists("baxter_dynamics_ros.core.arm_model.ArmModel.inverse_dynamics")
