"""``python -m bench [name ...]``: run every ``bench/bench_*.py`` benchmark, or only those named."""

from __future__ import annotations

import importlib
import pkgutil
import sys
from pathlib import Path

PREFIX = "bench_"


def available() -> list[str]:
    """Names of the benchmarks in this folder (``bench_dynamics.py`` → ``dynamics``), sorted."""
    folder = str(Path(__file__).resolve().parent)
    return sorted(m.name[len(PREFIX) :] for m in pkgutil.iter_modules([folder]) if m.name.startswith(PREFIX))


def main(argv: list[str]) -> int:
    names = available()
    unknown = [n for n in argv if n not in names]
    if unknown:
        print(f"ERROR: no benchmark named {', '.join(unknown)}; available: {', '.join(names)}", file=sys.stderr)
        return 1
    for name in argv or names:
        importlib.import_module(f"{__package__}.{PREFIX}{name}").main()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
