"""The diagnosis' documentation pages, regenerated: ``python -m baxter_dynamics_ros.cli.validation_pages``.

Without ``--real``: every withheld-effect scenario of :mod:`baxter_dynamics_ros.diagnosis.validation`
and its page (docs/diagnosis_validation.md); with ``--real DATA_DIR``: the real recordings in every
rotation (docs/real_robot_diagnosis.md). Exit status 1 when a scenario fails, or when s1_spring is
not ranked first in a real rotation.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from msg_adapters.recording_files import read_recording

from ..diagnosis.validation import SCENARIOS, real_rotations_page, run_scenario, write_validation_page

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """``python -m baxter_dynamics_ros.cli.validation_pages [--real DATA_DIR] [OUT.md]``.

    Without --real: run every simulated scenario and write the validation page (default
    docs/diagnosis_validation.md). With --real: diagnose the real recordings' four rotations
    (default page docs/real_robot_diagnosis.md).
    """
    parser = argparse.ArgumentParser(prog="python -m baxter_dynamics_ros.cli.validation_pages")
    parser.add_argument("--real", metavar="DATA_DIR", help="folder of the real recordings (../shared/data/baxter_real)")
    parser.add_argument("out", nargs="?", help="the page to write")
    args = parser.parse_args(argv)
    command = "python -m baxter_dynamics_ros.cli.validation_pages " + " ".join(argv if argv is not None else sys.argv[1:])
    if args.real:
        out = args.out or "docs/real_robot_diagnosis.md"
        recordings = [(f.name, read_recording(f)) for f in sorted(Path(args.real).glob("*.csv"))]
        results = real_rotations_page(out, recordings, command)
        print(f"wrote {out}")
        return 0 if all(r.effects[0].name == "s1_spring" for r in results) else 1
    out = args.out or "docs/diagnosis_validation.md"
    outcomes = []
    for scenario in SCENARIOS:
        outcomes.append(run_scenario(scenario))
        o = outcomes[-1]
        print(f"{scenario.label}: selected {', '.join(o.selected) or 'nothing'}; shrink {o.shrink_fraction:.0%}; {'pass' if o.passed else 'FAIL'}", flush=True)
    write_validation_page(out, outcomes, command)
    print(f"wrote {out}")
    return 0 if all(o.passed for o in outcomes) else 1


if __name__ == "__main__":
    raise SystemExit(main())
