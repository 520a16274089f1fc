"""The ``jaxcable`` command line. Each subcommand builds a scene from the same objects the Python API
uses, runs it in float64, and prints a short report or one JSON object (``--json``).

    jaxcable throw [--angle DEG] [--segment-length M] [--plot PATH] [--json]
    jaxcable land  [--fidelity 1dof|rigid|ale|full] [--x M --y M --vz M/S ...] [--plot PATH] [--json]
    jaxcable land  --phase full [--scenario I|II|III] [the 15 uncertain parameters] [--json]
    jaxcable sweep --scenario I --n 100 [--phase passive|full] [--fidelity ...] --out results.csv
    jaxcable design [--vars m_w,F_f,a_p] [--n 64] [--steps 50] [--json]
    jaxcable bench [--cases ...] [--solvers ...] [--rtols ...] [--json]

One argparse tree: each subcommand's module (``jaxcable.cli.throw``, ``.land``, ...) gives its flags
(``add_arguments(parser)``) and its work (``run(args) -> Report``); :func:`jaxcable.cli.report.emit`
prints every report and turns a ``ValueError`` into ``jaxcable COMMAND: error: ...`` with exit
status 2.

Compiled code is cached on disk (:func:`jaxcable.core.config.enable_compilation_cache`), so a
command compiles once per machine and later runs read the compiled programs back: in
``$JAXCABLE_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/jaxcable/jax`` or ``~/.cache/jaxcable/jax``.
``jaxcable --no-cache COMMAND ...`` or ``JAXCABLE_NO_CACHE=1`` turn it off.
"""

from __future__ import annotations

import argparse
import sys

from jaxcable.cli import bench, design, land, sweep, throw
from jaxcable.cli.report import emit
from jaxcable.core.config import cache_disabled_by_env, enable_compilation_cache

COMMANDS = {"throw": throw, "land": land, "sweep": sweep, "design": design, "bench": bench}
"""Each subcommand's module: its ``HELP`` (one line), ``DESCRIPTION``, ``add_arguments(parser)`` and
``run(args) -> Report``."""

_NO_CACHE_HELP = (
    "do not read or write the on-disk compilation cache (also: JAXCABLE_NO_CACHE=1; its folder: $JAXCABLE_CACHE_DIR, "
    "default $XDG_CACHE_HOME/jaxcable/jax or ~/.cache/jaxcable/jax)"
)


def build_parser() -> argparse.ArgumentParser:
    """The whole command line: the top-level flags and one subparser per command of :data:`COMMANDS`."""
    parser = argparse.ArgumentParser(prog="jaxcable", description=" ".join(__doc__.split("\n\n")[0].split()))
    parser.add_argument("--no-cache", action="store_true", help=_NO_CACHE_HELP)
    # the same flag after the command's name; SUPPRESS: absent there, it leaves the top level's value
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--no-cache", action="store_true", default=argparse.SUPPRESS, help=_NO_CACHE_HELP)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, module in COMMANDS.items():
        p = sub.add_parser(name, help=module.HELP, description=module.DESCRIPTION, parents=[common])
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns its exit status (0 done, 1 the solver failed, 2 bad input)."""
    args = build_parser().parse_args(sys.argv[1:] if argv is None else list(argv))
    if argv is None and args.command == "sweep":
        # the process's own command line: its CPU devices are set before JAX starts
        sweep.configure_devices(args)
    if not (args.no_cache or cache_disabled_by_env()):
        enable_compilation_cache()
    return emit(args.command, args.run, args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
