"""Names of what the studies run, filled in by the systems (as Brax registers its environments).

A study (sweep, design, benchmark) never imports a system. Each system registers, at import of its
package, the factories the studies and the command line look up by name:

* case functions (``register_case_function("arresting.passive", factory)``): one case's parameters
  to its scalar outputs, run by :func:`jaxcable.studies.sweep.run_sweep`;
* design problems (``register_design_problem("arresting", factory)``): what ``jaxcable design
  --scene NAME`` optimises;
* benchmark cases (``register_bench_case("throw", case)``): what ``jaxcable bench`` times.

Importing :mod:`jaxcable` imports both systems, so every name is registered.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

_TABLES: dict[str, dict[str, Any]] = {"case function": {}, "design problem": {}, "bench case": {}}


def _register(kind: str, name: str, entry) -> None:
    if not isinstance(name, str) or not name:
        raise ValueError(f"{kind} name must be a non-empty string, got {name!r}")
    _TABLES[kind][name] = entry


def _lookup(kind: str, name: str):
    table = _TABLES[kind]
    if name not in table:
        known = ", ".join(sorted(table)) or "none registered (import jaxcable.throw / jaxcable.arresting)"
        raise ValueError(f"unknown {kind} {name!r}; choose one of: {known}")
    return table[name]


def register_case_function(name: str, factory: Callable) -> None:
    """Register the factory of a sweep's case function under ``name``."""
    _register("case function", name, factory)


def case_function(name: str) -> Callable:
    """The factory registered under ``name`` (ValueError listing the known names otherwise)."""
    return _lookup("case function", name)


def register_design_problem(name: str, entry) -> None:
    """Register a design problem (an object or factory the design command knows how to run)."""
    _register("design problem", name, entry)


def design_problem(name: str):
    """The design problem registered under ``name``."""
    return _lookup("design problem", name)


def register_bench_case(name: str, case) -> None:
    """Register a benchmark case under ``name``."""
    _register("bench case", name, case)


def bench_case(name: str):
    """The benchmark case registered under ``name``."""
    return _lookup("bench case", name)


def names(kind: str) -> tuple[str, ...]:
    """Registered names of ``kind`` (``"case function"``, ``"design problem"``, ``"bench case"``)."""
    return tuple(sorted(_TABLES[kind]))
