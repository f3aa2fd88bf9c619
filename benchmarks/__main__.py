"""``python -m benchmarks``: run the speed benchmark (see ``benchmarks/run.py``) and write its JSON."""

from __future__ import annotations

import argparse
from pathlib import Path

import yaml


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description=(
        "Speed of stackx against plain-Python and C transcriptions of the same algorithms: the lab's scene 06, "
        "tall columns, a 10,000-variant sweep, stackx run configs/ and stackx --help, and the first-run compile "
        "cost. Prints ratios and writes every figure to a JSON file."))
    parser.add_argument("--json", type=Path, default=Path("out/speed.json"), help="where the figures go")
    parser.add_argument("--quick", action="store_true",
                        help="fewer repeats, columns up to 1,000 boxes, a 1/27 sweep: a smoke test, not figures")
    parser.add_argument("--tall-solver", type=yaml.safe_load, default=None, metavar="YAML",
                        help="solver section for the tall columns, e.g. '{name: warm-start, iterations: 10}' "
                             "(default: the first of warm-start, exact that holds tall-1000 at its defaults)")
    args = parser.parse_args()
    if args.tall_solver is not None and not (isinstance(args.tall_solver, dict) and "name" in args.tall_solver):
        parser.error("--tall-solver must be a YAML mapping with a name, e.g. '{name: warm-start}'")
    from benchmarks.run import run

    run(args.json, args.quick, args.tall_solver)


main()
