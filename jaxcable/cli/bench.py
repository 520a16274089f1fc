"""short speed-against-error benchmark of the shipped scenes (see docs/work_precision.md; the full study is experiments/work_precision.py)

``jaxcable bench``: :func:`jaxcable.studies.bench.run_bench` over the benchmark cases the systems
register (:mod:`jaxcable.throw.bench_cases`, :mod:`jaxcable.arresting.bench_cases`), printed as a
table (wall times [s], relative errors against a tight-tolerance reference) or ``--json``;
``--out`` also writes the rows as CSV.
"""

from __future__ import annotations

import argparse
import sys

from jaxcable.arresting import bench_cases as _arresting_cases  # noqa: F401  (registers the arresting cases)
from jaxcable.cli.report import Report, emit
from jaxcable.core.config import enable_x64
from jaxcable.core.simulate import SOLVERS
from jaxcable.studies import registry
from jaxcable.studies.bench import format_table, json_safe, run_bench, write_csv
from jaxcable.throw import bench_cases as _throw_cases  # noqa: F401  (registers the throw case)

__all__ = ["DEFAULT_CASE_NAMES", "DESCRIPTION", "HELP", "add_arguments", "bench_main", "run"]

HELP = "short speed-against-error benchmark on this machine"
DESCRIPTION = __doc__.split("\n\n")[0]

DEFAULT_CASE_NAMES = ("throw", "1dof", "rigid", "two_phase")
"""The cases ``jaxcable bench`` runs by default (~2 min on 2 cores; ``ale`` only when asked)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``jaxcable bench``."""
    p = parser
    p.add_argument("--cases", nargs="+", default=list(DEFAULT_CASE_NAMES), choices=registry.names("bench case"),
                   help="cases to run (default: %(default)s; 'ale' is the ALE level's first 0.05 s)")  # fmt: skip
    p.add_argument("--solvers", nargs="+", default=["tsit5"], help="solvers (names of jaxcable.SOLVERS)")
    p.add_argument("--rtols", nargs="+", type=float, default=[1e-4, 1e-6, 1e-8], help="tolerances (atol = rtol)")
    p.add_argument("--reference-solver", default=None, help="solver of the reference (default: the first solver)")
    p.add_argument("--reference-rtol", type=float, default=1e-10)
    p.add_argument("--repeats", type=int, default=1, help="timed calls per setting (the fastest is reported)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--out", default=None, help="also write the rows to this CSV file")
    p.add_argument("--float32", action="store_true", help="run in float32 (default float64)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress messages on stderr")


def _check(args: argparse.Namespace) -> None:
    """Bad values, refused with the flag named (ValueError)."""
    for flag, names in (("--solvers", args.solvers), ("--reference-solver", [args.reference_solver] if args.reference_solver else [])):
        for s in names:
            if s not in SOLVERS:
                raise ValueError(f"{flag}: unknown solver {s!r}; choose one of {sorted(SOLVERS)}")
    for flag, values in (("--rtols", args.rtols), ("--reference-rtol", [args.reference_rtol])):
        for r in values:
            if not r > 0:
                raise ValueError(f"{flag} must be positive, got {r:g}")


def run(args: argparse.Namespace) -> Report:
    """Run the benchmark of ``args``: the result (data, NaN as null), the table (text)."""
    _check(args)
    enable_x64(not args.float32)
    progress = None if (args.quiet or args.json) else (lambda s: print(s, file=sys.stderr, flush=True))
    result = run_bench(args.cases, tuple(args.solvers), tuple(args.rtols), args.reference_solver, args.reference_rtol,
                       args.repeats, progress)  # fmt: skip
    if args.out:
        write_csv(result, args.out)
    return Report(json_safe(result), format_table(result))


def bench_main(argv: list[str] | None = None) -> int:
    """``jaxcable bench`` on its own: parse ``argv``, run, print the table or ``--json``."""
    parser = argparse.ArgumentParser(prog="jaxcable bench", description=DESCRIPTION)
    add_arguments(parser)
    return emit("bench", run, parser.parse_args(argv))
