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
    status = 0
    for name in argv or names:
        # Each with its defaults: an empty argv, not this command's (its names are no options of theirs).
        status = max(status, importlib.import_module(f"{__package__}.{PREFIX}{name}").main([]) or 0)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
