"""Speed against error on the user's machine: the harness behind ``jaxcable bench``.

Each registered benchmark case (a scene configuration, :class:`AbstractBenchCase`, registered by its
system with :func:`jaxcable.studies.registry.register_bench_case`) is run at a few solver tolerances
and compared with a tight-tolerance reference of the same scene (same structure, same
discretisation: the error measured is the time-integration error). Errors are relative errors in
the quantities users read (each scene's ``quantities``; the shipped ones are listed in
:mod:`jaxcable.throw.bench_cases` and :mod:`jaxcable.arresting.bench_cases`).

A case's :meth:`~AbstractBenchCase.runner` builds its scene once and returns
``run(solver, rtol, atol, max_steps)``; :func:`prepare_case` wraps it so that its compiled code is
reused across tolerances (tolerances are passed as arrays, so a new tolerance does not recompile)
and its outputs come back as host values; :func:`timed_run` times it (wall clock [s] after
compilation; the first call of a (case, solver) pair is reported separately as compile time).
``experiments/work_precision.py`` runs the full study with the same functions; :func:`run_bench`
is the short version behind ``jaxcable bench`` (:mod:`jaxcable.cli.bench`).

Choices: ``jaxcable bench`` takes its reference with the first solver of the run (default Tsit5
at rtol 1e-10) so that the reference compiles nothing extra; the full study uses Dopri8 at 1e-10
(measured: the errors at rtol 1e-4..1e-8 against either reference agree to two digits).
"""

from __future__ import annotations

import csv
import math
import os
import time
from collections.abc import Callable, Mapping
from typing import ClassVar

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.provenance import machine_info
from jaxcable.core.simulate import simulate, status_message
from jaxcable.core.validation import check_choice, check_positive
from jaxcable.studies import registry

__all__ = [
    "AbstractBenchCase",
    "COLUMNS",
    "QUANTITIES",
    "bench_scenes",
    "format_table",
    "json_safe",
    "make_bench_case",
    "prepare_case",
    "relative_errors",
    "run_bench",
    "simulation_runner",
    "timed_run",
    "write_csv",
]


class AbstractBenchCase(eqx.Module):
    """One scene configuration to time (all fields static: a case is a structure, not a parameter).

    A subclass sets the class attributes ``scene`` (its name in tables), ``levels`` (the model
    levels it accepts) and ``quantities`` (the outputs compared with the reference), adds the fields
    that size its scene, and implements :meth:`runner`.

    Attributes:
        level: the model level (one of the subclass's ``levels``).
        t_end_s: end time of the simulation [s].
    """

    level: str = eqx.field(static=True)
    t_end_s: float = eqx.field(static=True, default=30.0)

    scene: ClassVar[str]
    levels: ClassVar[tuple[str, ...]]
    quantities: ClassVar[tuple[str, ...]]

    def __check_init__(self):
        check_choice(f"level (scene {self.scene})", self.level, self.levels)
        check_positive("t_end_s", self.t_end_s)

    @property
    def label(self) -> str:
        """Short name for tables: the level plus the size that matters for it."""
        return self.level

    def runner(self) -> Callable:
        """Build the scene once; return ``run(solver: str, rtol, atol, max_steps: int) -> dict`` of
        arrays: the ``quantities``, ``num_steps``, ``num_rejected`` (-1 where not reported) and
        ``status`` (0 success, else the diffrax result code; -1: NaN outputs). ``rtol`` and ``atol``
        come in as arrays (a new tolerance does not recompile)."""
        raise NotImplementedError


def simulation_runner(scene, t_end_s: float, quantities) -> Callable:
    """The ``run`` of :meth:`AbstractBenchCase.runner` for a scene whose
    :func:`~jaxcable.core.simulate.simulate` outputs hold ``quantities``, simulated to ``t_end_s`` [s]."""

    def run(solver, rtol, atol, max_steps):
        res = simulate(scene, t_end_s, solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
        return {**{k: res.outputs[k] for k in quantities}, "num_steps": res.num_steps,
                "num_rejected": res.num_rejected, "status": res.status}  # fmt: skip

    return run


def bench_scenes() -> dict[str, type]:
    """The scenes of the registered benchmark cases: ``{scene: its AbstractBenchCase subclass}``."""
    scenes = {}
    for name in registry.names("bench case"):
        cls = type(registry.bench_case(name))
        scenes.setdefault(cls.scene, cls)
    return scenes


def make_bench_case(scene: str, level: str, **options) -> AbstractBenchCase:
    """A benchmark case of a registered ``scene`` at ``level``, with the scene's size options
    (e.g. ``segment_length_m`` for ``"throw"``, ``n_span_elements`` for ``"passive"``) and ``t_end_s``."""
    scenes = bench_scenes()
    check_choice("scene", scene, scenes)
    return scenes[scene](level, **options)


class _SceneQuantities(Mapping):
    """``{scene: quantities}`` of the registered scenes, read from the registry when accessed."""

    def __getitem__(self, scene):
        return bench_scenes()[scene].quantities

    def __iter__(self):
        return iter(bench_scenes())

    def __len__(self):
        return len(bench_scenes())


QUANTITIES: Mapping[str, tuple[str, ...]] = _SceneQuantities()
"""The user quantities compared with the reference, per registered scene."""


def _float(x):
    return jnp.asarray(x, dtype=float)  # float64 under x64, float32 otherwise


# ---------------------------------------------------------------------------------------------
# Running and timing one case
# ---------------------------------------------------------------------------------------------


def prepare_case(case: AbstractBenchCase) -> Callable:
    """``run(solver, rtol, atol=None, max_steps=100_000) -> dict`` of host values for ``case``: the
    case's quantities (floats), ``num_steps``, ``num_rejected`` (ints; -1 where the runner does not
    report them) and ``status`` (0 success or event, else the diffrax code; -1: NaN outputs).

    The scene is built once here; tolerances go in as arrays, so the compiled solve is reused for
    every tolerance of a (case, solver) pair."""
    runner = case.runner()

    def run(solver: str, rtol: float, atol: float | None = None, max_steps: int = 100_000) -> dict:
        atol = rtol if atol is None else atol
        out = runner(solver, _float(rtol), _float(atol), int(max_steps))
        out = jax.tree_util.tree_map(np.asarray, jax.block_until_ready(out))
        rec = {k: float(out[k]) for k in case.quantities}
        rec["num_steps"] = int(out["num_steps"])
        rec["num_rejected"] = int(out["num_rejected"])
        code = int(out["status"])
        event = int(diffrax.RESULTS.event_occurred._value)
        rec["status"] = "successful" if code in (0, event) else _status_name(code)
        rec["ok"] = rec["status"] == "successful" and all(math.isfinite(rec[k]) for k in case.quantities)
        return rec

    return run


def _short_error(err: Exception) -> str:
    """One line naming an exception (equinox runtime errors put the cause after a stack banner)."""
    lines = [ln.strip() for ln in str(err).splitlines() if ln.strip()]
    cause = next((ln for ln in lines if "equinox.EquinoxRuntimeError:" in ln), None)
    cause = cause.split(":", 1)[1].strip() if cause else (lines[0] if lines else "")
    return f"error: {type(err).__name__}: {cause[:160]}"


def _status_name(code: int) -> str:
    if code == -1:
        return "nan_outputs"
    return status_message(code)


def timed_run(run: Callable, solver: str, rtol: float, atol: float | None = None, *, max_steps: int = 100_000,
              repeats: int = 1, first: bool = False) -> dict:  # fmt: skip
    """Run and time one setting: the record of ``run`` plus ``wall_s`` (the fastest of ``repeats``
    calls after compilation) and, with ``first=True`` (first call of this case and solver in the
    process), ``first_call_s`` and ``compile_s`` = first call - ``wall_s`` (trace + XLA compile +
    any one-off cost of the first execution)."""
    t_first = None
    if first:
        t0 = time.perf_counter()
        run(solver, rtol, atol, max_steps)
        t_first = time.perf_counter() - t0
    times = []
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        rec = run(solver, rtol, atol, max_steps)
        times.append(time.perf_counter() - t0)
    rec = dict(rec, solver=solver, rtol=float(rtol), atol=float(rtol if atol is None else atol), wall_s=min(times))
    if first:
        rec["first_call_s"] = t_first
        rec["compile_s"] = max(t_first - rec["wall_s"], 0.0)
    return rec


def relative_errors(rec: dict, ref: dict, quantities) -> dict:
    """|q - q_ref| / |q_ref| per quantity (NaN where the run failed); ``max`` = the largest."""
    errs = {}
    for q in quantities:
        a, b = rec.get(q, math.nan), ref[q]
        errs[q] = abs(a - b) / abs(b) if math.isfinite(a) and b != 0 else math.nan
    vals = list(errs.values())
    errs["max"] = math.nan if any(math.isnan(v) for v in vals) else max(vals)
    return errs


# ---------------------------------------------------------------------------------------------
# The benchmark over registered cases
# ---------------------------------------------------------------------------------------------


def run_bench(case_names, solvers=("tsit5",), rtols=(1e-4, 1e-6, 1e-8),
              reference_solver: str | None = None, reference_rtol: float = 1e-10, repeats: int = 1,
              progress: Callable[[str], None] | None = None) -> dict:  # fmt: skip
    """Run the benchmark cases registered as ``case_names`` (:func:`jaxcable.studies.registry.bench_case`):
    for each case, a reference at ``reference_rtol`` (with ``reference_solver``; ``None``: the first
    of ``solvers``, which compiles nothing extra) and each solver at each tolerance (atol = rtol),
    tolerances dimensionless. Returns a JSON-ready dict: ``machine`` (see
    :func:`jaxcable.core.provenance.machine_info`), ``rows`` (one per run), ``references``."""
    for r in list(rtols) + [reference_rtol]:
        check_positive("rtol", r)
    cases = {name: registry.bench_case(name) for name in case_names}  # ValueError naming an unknown one
    ref_solver = reference_solver or solvers[0]
    say = progress or (lambda s: None)
    info = machine_info()
    t_start = time.perf_counter()
    rows, refs = [], {}
    for name in case_names:
        case = cases[name]
        run = prepare_case(case)
        seen, reported = set(), set()
        say(f"{name}: reference {ref_solver} rtol {reference_rtol:g} (first call compiles)")
        try:
            ref = timed_run(run, ref_solver, reference_rtol, first=True)
        except Exception as err:  # e.g. an event root find that cannot converge in float32
            ref = dict(ok=False, status=_short_error(err))
        seen.add(ref_solver)
        refs[name] = dict(ref, scene=case.scene, level=case.label)
        if not all(math.isfinite(ref.get(q, math.nan)) for q in case.quantities):
            say(f"{name}: the reference run failed ({ref['status']}); case skipped")
            rows.append(dict(case=name, scene=case.scene, level=case.label, t_end_s=case.t_end_s, solver=ref_solver,
                             rtol=reference_rtol, wall_s=math.nan, error=math.nan,
                             errors={q: math.nan for q in case.quantities}, num_steps=-1, num_rejected=-1,
                             status=f"reference failed: {ref['status']}", ok=False))  # fmt: skip
            continue
        for solver in solvers:
            for rtol in sorted(rtols, reverse=True):
                say(f"{name}: {solver} rtol {rtol:g}")
                try:
                    rec = timed_run(run, solver, rtol, repeats=repeats, first=solver not in seen)
                except Exception as err:
                    rec = dict(solver=solver, rtol=rtol, atol=rtol, wall_s=math.nan, num_steps=-1, num_rejected=-1,
                               ok=False, status=_short_error(err))  # fmt: skip
                if solver == ref_solver and solver not in reported:
                    rec["compile_s"] = ref["compile_s"]  # compiled by the reference's first call
                seen.add(solver)
                reported.add(solver)
                errs = relative_errors(rec, ref, case.quantities)
                rows.append(dict(case=name, scene=case.scene, level=case.label, t_end_s=case.t_end_s,
                                 error=errs["max"], errors={q: errs[q] for q in case.quantities}, **rec))  # fmt: skip
    info["load_average_end_1_5_15_min"] = [round(x, 2) for x in os.getloadavg()]
    return dict(
        machine=info,
        precision="float64" if jax.config.jax_enable_x64 else "float32",
        reference=dict(solver=ref_solver, rtol=reference_rtol, atol=reference_rtol),
        references=refs,
        rows=rows,
        total_s=time.perf_counter() - t_start,
    )


COLUMNS = ("scene", "level", "solver", "rtol", "wall_s", "compile_s", "error", "worst", "steps", "status")


def _table_rows(result):
    out = []
    for r in result["rows"]:
        worst = max(r["errors"], key=lambda q: -1.0 if math.isnan(r["errors"][q]) else r["errors"][q])
        out.append(dict(scene=r["scene"], level=r["level"], solver=r["solver"], rtol=r["rtol"], wall_s=r["wall_s"],
                        compile_s=r.get("compile_s", math.nan), error=r["error"], worst=worst,
                        steps=r["num_steps"], status=r["status"]))  # fmt: skip
    return out


def format_table(result) -> str:
    """A plain-text table of a :func:`run_bench` result."""
    rows = _table_rows(result)
    head = ["scene", "level", "solver", "rtol", "wall [s]", "compile [s]", "error vs ref", "worst quantity", "steps",
            "status"]  # fmt: skip

    def fmt(r):
        comp = "" if math.isnan(r["compile_s"]) else f"{r['compile_s']:.1f}"
        steps = "-" if r["steps"] < 0 else str(r["steps"])
        status = r["status"] if len(r["status"]) <= 70 else r["status"][:67] + "..."
        return [r["scene"], r["level"], r["solver"], f"{r['rtol']:.0e}", f"{r['wall_s']:.3f}", comp,
                f"{r['error']:.1e}", r["worst"], steps, status]  # fmt: skip

    cells = [head] + [fmt(r) for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(head))]
    lines = ["  ".join(c[i].ljust(widths[i]) for i in range(len(head))) for c in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    m = result["machine"]
    ref = result["reference"]
    header = (
        f"jaxcable bench: {m['processor']} ({m['cpu_count']} CPUs), JAX {m['jax']} {m['jax_backend']}, "
        f"{result['precision']}, load average {m['load_average_1_5_15_min']}\n"
        f"error = largest relative error over the scene's quantities against {ref['solver']} at rtol = atol = "
        f"{ref['rtol']:g} (same scene); wall = after compilation; {result['total_s']:.0f} s in all"
    )
    return header + "\n" + "\n".join(lines)


def write_csv(result: dict, path) -> None:
    """The rows of a :func:`run_bench` result as a CSV file: the table's columns, ``num_rejected``
    and each quantity's relative error (``err_<quantity>``)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        quantities = sorted({q for r in result["rows"] for q in r["errors"]})
        w.writerow(list(COLUMNS) + ["num_rejected"] + [f"err_{q}" for q in quantities])
        for r, t in zip(result["rows"], _table_rows(result)):
            w.writerow([t[c] for c in COLUMNS] + [r["num_rejected"]]
                       + [r["errors"].get(q, "") for q in quantities])  # fmt: skip


def json_safe(x):
    """NaN/inf -> None (strict JSON), NumPy scalars -> Python numbers."""
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x
