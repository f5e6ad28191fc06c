"""Benchmarks, run with ``./dev bench`` (all) or ``./dev bench <name>`` (``bench/bench_<name>.py``).

Each module has a ``main()`` that prints its figures next to a reference measured in the same run,
and their ratio. Benchmarks are not timed tests: they report, they do not fail on speed.
"""

from __future__ import annotations

__all__: list[str] = []
