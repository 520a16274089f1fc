"""Speed against error on the user's machine: ``jaxcable bench`` (issue 6).

Each shipped scene is run at a few solver tolerances and compared with a tight-tolerance reference
of the same scene (same structure, same discretisation: the error measured is the time-integration
error). Errors are relative errors in the quantities users read:

=============  =====================================================================================
scene          quantities
=============  =====================================================================================
``throw``      range [m], max speed [m/s], flight time [s] (line-throwing rocket, to ground impact)
``passive``    z_max [m], a_max [g], sigma_max [MPa] (passive deceleration, design case, Table 1)
``two_phase``  capture margin [m], tracking error at t_c/2 [m], z_max, a_max, sigma_max (deviated
               case of section IV.A, scenario I; both phases at the same solver and tolerances)
=============  =====================================================================================

:class:`BenchCase` names one configuration (scene, level, size, end time); :func:`prepare_case` turns
it into a ``run(solver, rtol, atol, max_steps)`` function whose compiled code is reused across
tolerances (tolerances are passed as arrays, so a new tolerance does not recompile);
:func:`timed_run` times it (wall clock after compilation; the first call of a (case, solver) pair is
reported separately as compile time). ``experiments/work_precision.py`` runs the full study with
the same functions; :func:`bench_main` is the short version behind ``jaxcable bench``.

The ``two_phase`` runner integrates phase 1 with the requested solver too (``two_phase_outputs``
fixes phase 1 at Tsit5, rtol = 1e-6), so it rebuilds the capture outputs here from the
tracking scene's own methods.

Choices: ``jaxcable bench`` takes its reference with the first solver of the run (default Tsit5
at rtol 1e-10) so that the reference compiles nothing extra; the full study uses Dopri8 at 1e-10
(measured: the errors at rtol 1e-4..1e-8 against either reference agree to two digits). In
float32 (``--float32``) the two-phase case draws its noise and gust in float32, a different
realisation than float64 for the same seed (``jax.random`` draws depend on the dtype): compare
float32 with float32 only.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from typing import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import check_choice, check_positive

__all__ = [
    "BenchCase",
    "DEFAULT_BENCH_CASES",
    "QUANTITIES",
    "bench_main",
    "one_dof_params",
    "prepare_case",
    "relative_errors",
    "run_bench",
    "timed_run",
]

SCENES = ("throw", "passive", "two_phase")
QUANTITIES = {
    "throw": ("range_m", "max_speed_mps", "flight_time_s"),
    "passive": ("z_max_m", "a_max_g", "sigma_max_mpa"),
    "two_phase": ("capture_margin_m", "tracking_error_m", "z_max_m", "a_max_g", "sigma_max_mpa"),
}
"""The user quantities compared with the reference, per scene."""

LEVELS = {"throw": ("segments",), "passive": ("1dof", "rigid", "ale", "full"), "two_phase": ("rigid",)}


class BenchCase(eqx.Module):
    """One scene configuration to time (all fields static: a case is a structure, not a parameter).

    Attributes:
        scene: ``"throw"``, ``"passive"`` or ``"two_phase"``.
        level: ``"segments"`` (throw), ``"1dof"``/``"rigid"``/``"ale"``/``"full"`` (passive),
            ``"rigid"`` (two_phase: the passive phase's level).
        t_end_s: end time [s] (throw: latest time, the flight ends at impact ~9.2 s; passive: time
            after capture; two_phase: time after capture of the passive phase).
        segment_length_m: rope segment length [m] (throw).
        rope_length_m: rope in the box [m] (throw; sets the array sizes).
        angle_deg: launch elevation [deg] (throw).
        n_span_elements, n_fine: ALE span mesh (passive ``ale``/``full``), see
            :func:`jaxcable.arresting.passive.passive_landing_scene`.
        scenario: two-phase scenario of Table 4 (``"I"``, ``"II"``, ``"III"``).
    """

    scene: str = eqx.field(static=True)
    level: str = eqx.field(static=True)
    t_end_s: float = eqx.field(static=True, default=30.0)
    segment_length_m: float = eqx.field(static=True, default=1.0)
    rope_length_m: float = eqx.field(static=True, default=750.0)
    angle_deg: float = eqx.field(static=True, default=30.0)
    n_span_elements: int = eqx.field(static=True, default=16)
    n_fine: int = eqx.field(static=True, default=8)
    scenario: str = eqx.field(static=True, default="I")

    def __check_init__(self):
        check_choice("scene", self.scene, SCENES)
        check_choice(f"level (scene {self.scene})", self.level, LEVELS[self.scene])
        check_positive("t_end_s", self.t_end_s)
        check_positive("segment_length_m", self.segment_length_m)
        check_positive("rope_length_m", self.rope_length_m)

    @property
    def label(self) -> str:
        """Short name for tables: the level plus the size that matters for it."""
        if self.scene == "throw":
            return f"{self.segment_length_m:g} m segments"
        if self.scene == "passive" and self.level in ("ale", "full"):
            return f"{self.level} ({self.n_span_elements} el.)"
        return self.level

    @property
    def quantities(self) -> tuple:
        return QUANTITIES[self.scene]


def _float(x):
    return jnp.asarray(x, dtype=float)  # float64 under x64, float32 otherwise


# ---------------------------------------------------------------------------------------------
# Runners: case -> run(solver, rtol, atol, max_steps) -> dict (quantities, num_steps, ...)
# ---------------------------------------------------------------------------------------------


def _simulate_outputs(scene, t1, solver, rtol, atol, max_steps):
    from jaxcable.core.simulate import simulate

    res = simulate(scene, t1, solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
    return res.outputs, res.num_steps, res.num_rejected, res.status


def _throw_runner(case: BenchCase):
    from jaxcable.throw import line_throwing_scene

    scene = line_throwing_scene(case.angle_deg, case.segment_length_m, case.rope_length_m)

    def run(solver, rtol, atol, max_steps):
        out, steps, rejected, status = _simulate_outputs(scene, case.t_end_s, solver, rtol, atol, max_steps)
        return {**{k: out[k] for k in QUANTITIES["throw"]}, "num_steps": steps, "num_rejected": rejected,
                "status": status}  # fmt: skip

    return run


def one_dof_params():
    """:class:`~jaxcable.arresting.one_dof.OneDofParams` of the design case with the mass, layout and
    buffer of the other passive levels (the mapping :func:`jaxcable.arresting.landing.run_landing`
    uses for level ``1dof``)."""
    from jaxcable.arresting.buffer import BufferDevice
    from jaxcable.arresting.layout import ArrestingLayout
    from jaxcable.arresting.one_dof import OneDofParams
    from jaxcable.arresting.landing_rocket import rigid_landing_rocket

    layout, buffer = ArrestingLayout(), BufferDevice()
    return OneDofParams(
        m_r=rigid_landing_rocket(hinged_hooks=False).total_mass_kg,
        v0=20.0,
        l_0=layout.half_span_m,
        alpha=buffer.transfer_rate,
        m_w=buffer.counterweight_mass_kg,
        F_f=buffer.brake_force_N,
        cable_radius=layout.cable_radius_m,
    )


def _one_dof_runner(case: BenchCase):
    """The 1-DOF model of section II.B (:func:`one_dof_params`)."""
    import diffrax

    from jaxcable.arresting.one_dof import simulate_one_dof
    from jaxcable.core.simulate import make_solver

    params = one_dof_params()

    def run(solver, rtol, atol, max_steps):
        controller = diffrax.PIDController(rtol=rtol, atol=atol)
        sol = simulate_one_dof(params, t1=case.t_end_s, solver=make_solver(solver), stepsize_controller=controller,
                               max_steps=max_steps)  # fmt: skip
        # simulate_one_dof reports no step count or status; a failed solve shows as NaN outputs
        nan_i = jnp.asarray(-1)
        return dict(z_max_m=sol.z_max, a_max_g=sol.a_max, sigma_max_mpa=sol.sigma_max, num_steps=nan_i,
                    num_rejected=nan_i, status=jnp.where(jnp.isfinite(sol.z_max), 0, -1))  # fmt: skip

    return run


def _passive_runner(case: BenchCase):
    if case.level == "1dof":
        return _one_dof_runner(case)
    from jaxcable.arresting.passive import passive_landing_scene

    kw = dict(n_span_elements=case.n_span_elements, n_fine=case.n_fine) if case.level != "rigid" else {}
    scene = passive_landing_scene(case.level, t_end_s=case.t_end_s, **kw)

    def run(solver, rtol, atol, max_steps):
        out, steps, rejected, status = _simulate_outputs(scene, case.t_end_s, solver, rtol, atol, max_steps)
        return {**{k: out[k] for k in QUANTITIES["passive"]}, "num_steps": steps, "num_rejected": rejected,
                "status": status}  # fmt: skip

    return run


def _two_phase(scene, t_end_s, solver, rtol, atol, max_steps):
    """Both phases at one solver setting (the outputs of ``two_phase_outputs`` that we compare)."""
    from jaxcable.arresting.passive import passive_landing_scene
    from jaxcable.arresting.two_phase import _captured_state, _event_occurred, _interp
    from jaxcable.core.simulate import simulate

    track = simulate(scene, scene.t_max_s, solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
    final = track.final_state
    passive = passive_landing_scene(
        "rigid", _captured_state(scene, final), scene.layout, frame_centre_xy=scene.frame_centre(final),
        t_end_s=t_end_s,
    )  # fmt: skip
    land = simulate(passive, t_end_s, solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
    o = land.outputs
    ok = _event_occurred(track.status) & land.ok
    return dict(
        capture_margin_m=jnp.min(scene.capture_margins(final)),
        tracking_error_m=_interp(track.ts, track.probes["tracking_error_m"], 0.5 * scene.controller.tracking_time_s),
        z_max_m=o["z_max_m"],
        a_max_g=o["a_max_g"],
        sigma_max_mpa=o["sigma_max_mpa"],
        num_steps=track.num_steps + land.num_steps,
        num_rejected=track.num_rejected + land.num_rejected,
        status=jnp.where(ok, 0, jnp.where(_event_occurred(track.status), land.status, track.status)),
    )


_two_phase_jit = eqx.filter_jit(_two_phase)


def _two_phase_runner(case: BenchCase):
    from jaxcable.arresting.two_phase import tracking_scene

    scene = tracking_scene(scenario=case.scenario)

    def run(solver, rtol, atol, max_steps):
        from jaxcable.core.simulate import make_solver

        return _two_phase_jit(scene, case.t_end_s, make_solver(solver), rtol, atol, max_steps)

    return run


def prepare_case(case: BenchCase) -> Callable:
    """``run(solver, rtol, atol=None, max_steps=100_000) -> dict`` of host values for ``case``: the
    case's quantities (floats), ``num_steps``, ``num_rejected`` (ints; -1 where the runner does not
    report them) and ``status`` (0 success or event, else the diffrax code; -1: NaN outputs).

    The scene is built once here; tolerances go in as arrays, so the compiled solve is reused for
    every tolerance of a (case, solver) pair."""
    runner = {"throw": _throw_runner, "passive": _passive_runner, "two_phase": _two_phase_runner}[case.scene](case)

    def run(solver: str, rtol: float, atol: float | None = None, max_steps: int = 100_000) -> dict:
        import diffrax

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
    from jaxcable.core.simulate import status_message

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
# The short benchmark (``jaxcable bench``)
# ---------------------------------------------------------------------------------------------

DEFAULT_BENCH_CASES = {
    # name: (case, solver of the runs). Sizes chosen to compile and run in ~2 min on 2 cores.
    "throw": BenchCase("throw", "segments", t_end_s=30.0, segment_length_m=5.0),
    "1dof": BenchCase("passive", "1dof", t_end_s=2.0),
    "rigid": BenchCase("passive", "rigid", t_end_s=1.0),
    "two_phase": BenchCase("two_phase", "rigid", t_end_s=1.0),
    "ale": BenchCase("passive", "ale", t_end_s=0.05),
}
DEFAULT_CASE_NAMES = ("throw", "1dof", "rigid", "two_phase")


def run_bench(case_names=DEFAULT_CASE_NAMES, solvers=("tsit5",), rtols=(1e-4, 1e-6, 1e-8),
              reference_solver: str | None = None, reference_rtol: float = 1e-10, repeats: int = 1,
              progress: Callable[[str], None] | None = None) -> dict:  # fmt: skip
    """Run the short benchmark: for each case, a reference at ``reference_rtol`` (with
    ``reference_solver``; ``None``: the first of ``solvers``, which compiles nothing extra) and each
    solver at each tolerance (atol = rtol). Returns a JSON-ready dict: ``machine`` (see
    :func:`jaxcable.core.provenance.machine_info`), ``rows`` (one per run), ``references``."""
    from jaxcable.core.provenance import machine_info

    for r in list(rtols) + [reference_rtol]:
        check_positive("rtol", r)
    unknown = [n for n in case_names if n not in DEFAULT_BENCH_CASES]
    if unknown:
        raise ValueError(f"unknown bench case(s) {unknown}; choose from {sorted(DEFAULT_BENCH_CASES)}")
    ref_solver = reference_solver or solvers[0]
    say = progress or (lambda s: None)
    info = machine_info()
    t_start = time.perf_counter()
    rows, refs = [], {}
    for name in case_names:
        case = DEFAULT_BENCH_CASES[name]
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


def _parse_args(argv):
    p = argparse.ArgumentParser(
        prog="jaxcable bench",
        description="short speed-against-error benchmark of the shipped scenes (see docs/work_precision.md; "
        "the full study is experiments/work_precision.py)",
    )
    p.add_argument("--cases", nargs="+", default=list(DEFAULT_CASE_NAMES), choices=sorted(DEFAULT_BENCH_CASES),
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
    return p.parse_args(argv)


def _json_safe(x):
    """NaN/inf -> None (strict JSON), NumPy scalars -> Python numbers."""
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


def bench_main(argv: list[str] | None = None) -> int:
    """``jaxcable bench``: run :func:`run_bench` and print a table (or ``--json``); ``--out`` CSV."""
    from jaxcable.core.config import enable_x64
    from jaxcable.core.simulate import SOLVERS

    args = _parse_args(argv)
    enable_x64(not args.float32)
    for s in args.solvers + ([args.reference_solver] if args.reference_solver else []):
        check_choice("solver", s, SOLVERS)
    progress = None if (args.quiet or args.json) else (lambda s: print(s, file=sys.stderr, flush=True))
    result = run_bench(args.cases, tuple(args.solvers), tuple(args.rtols), args.reference_solver, args.reference_rtol,
                       args.repeats, progress)  # fmt: skip
    if args.out:
        with open(args.out, "w", newline="") as f:
            w = csv.writer(f)
            quantities = sorted({q for r in result["rows"] for q in r["errors"]})
            w.writerow(list(COLUMNS) + ["num_rejected"] + [f"err_{q}" for q in quantities])
            for r, t in zip(result["rows"], _table_rows(result)):
                w.writerow([t[c] for c in COLUMNS] + [r["num_rejected"]]
                           + [r["errors"].get(q, "") for q in quantities])  # fmt: skip
    if args.json:
        print(json.dumps(_json_safe(result)))
    else:
        print(format_table(result))
    return 0
