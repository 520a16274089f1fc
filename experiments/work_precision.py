"""Work-precision study of the shipped scenes ("speed against error"; not a test).

For each scene configuration (a bench case, :func:`jaxcable.studies.bench.make_bench_case`) a
reference is run with Dopri8 at rtol = atol = 1e-10 in float64; every other run (solver x tolerance, atol = rtol) is compared
with it in the quantities users read (relative errors):

* line-throwing flight (30 deg, to ground impact): range, max speed, flight time; segment lengths
  10, 5, 2, 1 m (the default scene has 1 m);
* passive deceleration, design case (Table 1): z_max, a_max, sigma_max at levels ``1dof`` and
  ``rigid`` (2 s after capture: the whole stop), ``ale`` (16 and 32 span elements) and ``full``
  over the first 0.3 s only (a 1 s ale landing costs ~15-50 s per run; the 0.3 s window contains
  the hook impact and the stress peak);
* two-phase landing (deviated case of section IV.A, scenario I, passive level rigid, 2 s after
  capture): capture margin, tracking error at t_c / 2, z_max, a_max, sigma_max.

Wall time = one call after compilation (the fastest of up to 3 calls when a call takes < 0.5 s);
compile time = first call - that (trace + XLA + first-execution costs). The reference run's error
is the time-integration error only: the segment-length and mesh errors are reported separately as
the difference between references. float32 runs go to a subprocess with x64 off and are compared
with the float64 reference.

Each (case, precision, solver family) runs in its own worker process with a time limit, so an
unaffordable configuration (implicit solvers on large states, float32 failures) is recorded as such
instead of stalling the study; within a worker a solver stops at the first tolerance whose run
exceeds the per-run cap. Rows are appended to a JSONL file as they finish (a killed run keeps them).

Usage:
    python experiments/work_precision.py            # full study, ~60 min on 2 cores under load 3-13
    python experiments/work_precision.py --quick    # a few minutes -> experiments/out/work_precision_quick/
    python experiments/work_precision.py --report   # rewrite md/csv/png from the JSONL of the last run
    python experiments/work_precision.py --extras   # PI controller and tracking jump-time checks (~3 min)
Writes work_precision.{jsonl,json,csv,md}, work_precision_meta.json and work_precision_<scene>.png (error vs wall time, one
panel per quantity) under experiments/results/ (quick: experiments/out/work_precision_quick/).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import _report

REF_SOLVER, REF_TOL = "dopri8", 1e-10
EXPLICIT = ("tsit5", "dopri5", "dopri8", "bosh3", "heun")
IMPLICIT = ("kvaerno3", "kvaerno5")
TOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)
TOLS_F32 = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
# low-order solvers at tight tolerances take 10-1000x more steps: their useful range is loose
LOW_ORDER_TOLS = {"heun": (1e-3, 1e-4, 1e-5), "bosh3": (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)}


def case_spec(name):
    """Case name -> BenchCase keyword arguments (names are stable keys in the data files)."""
    specs = {
        "throw_10m": dict(scene="throw", level="segments", t_end_s=30.0, segment_length_m=10.0),
        "throw_5m": dict(scene="throw", level="segments", t_end_s=30.0, segment_length_m=5.0),
        "throw_2m": dict(scene="throw", level="segments", t_end_s=30.0, segment_length_m=2.0),
        "throw_1m": dict(scene="throw", level="segments", t_end_s=30.0, segment_length_m=1.0),
        "passive_1dof": dict(scene="passive", level="1dof", t_end_s=2.0),
        "passive_rigid": dict(scene="passive", level="rigid", t_end_s=2.0),
        "passive_ale16": dict(scene="passive", level="ale", t_end_s=0.3, n_span_elements=16, n_fine=8),
        "passive_ale32": dict(scene="passive", level="ale", t_end_s=0.3, n_span_elements=32, n_fine=16),
        "passive_full16": dict(scene="passive", level="full", t_end_s=0.3, n_span_elements=16, n_fine=8),
        "two_phase_rigid": dict(scene="two_phase", level="rigid", t_end_s=2.0),
    }
    return specs[name]


def plan(quick: bool):
    """Worker jobs: dict(case, precision, solvers, tols per solver, reference?, timeout_s, cap_s)."""
    jobs = []

    def job(case, solvers, tols=TOLS, precision="float64", reference=True, timeout=1500, cap=60.0):
        per = {s: [t for t in tols if t in LOW_ORDER_TOLS.get(s, tols)] for s in solvers}
        jobs.append(dict(case=case, precision=precision, solvers=per, reference=reference and precision == "float64",
                         timeout_s=timeout, cap_s=cap))  # fmt: skip

    if quick:
        q = (1e-3, 1e-5, 1e-7)
        job("throw_10m", ("tsit5", "dopri8"), q, timeout=300, cap=10)
        job("passive_1dof", ("tsit5", "kvaerno5"), q, timeout=200, cap=10)
        job("passive_rigid", ("tsit5", "dopri8"), q, timeout=300, cap=10)
        job("two_phase_rigid", ("tsit5",), q, timeout=300, cap=10)
        job("throw_10m", ("tsit5",), (1e-3, 1e-5), precision="float32", timeout=200, cap=10)
        return jobs
    # Ordered by importance: a run cut short (the machine is shared) keeps the main results.
    # explicit solvers, float64
    job("throw_10m", ("tsit5", "dopri5", "dopri8", "bosh3", "heun"))
    job("passive_1dof", ("tsit5", "dopri5", "dopri8", "bosh3", "heun"))
    job("passive_rigid", ("tsit5", "dopri5", "dopri8", "bosh3", "heun"))
    job("two_phase_rigid", ("tsit5", "dopri8"))
    job("throw_5m", ("tsit5", "dopri8"))
    job("throw_1m", ("tsit5", "dopri8"), TOLS[:-1], cap=30)
    job("passive_ale16", ("tsit5", "dopri8"), TOLS[:-2], cap=45)
    # float32 (x64 off): compared with the float64 reference
    for case, solvers, tols in (("throw_10m", ("tsit5", "dopri8"), TOLS_F32), ("passive_1dof", ("tsit5",), TOLS_F32),
                                ("passive_rigid", ("tsit5",), TOLS_F32), ("two_phase_rigid", ("tsit5",), TOLS_F32),
                                ("passive_ale16", ("tsit5",), (1e-4, 1e-6))):  # fmt: skip
        job(case, solvers, tols, precision="float32", timeout=600, cap=45)
    # implicit solvers where the state is small (the ale level: 40 s per simulated ms, see
    # docs/notes/ale_vector_field.md; not repeated here)
    imp = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
    job("passive_1dof", IMPLICIT, imp, reference=False, timeout=400, cap=30)
    job("passive_rigid", IMPLICIT, imp, reference=False, timeout=600, cap=30)
    job("passive_full16", ("tsit5",), (1e-3, 1e-5, 1e-7), cap=45)
    job("throw_10m", ("kvaerno5",), imp[:4], reference=False, timeout=500, cap=30)
    job("throw_2m", ("tsit5",), (1e-3, 1e-5, 1e-7), cap=30)
    job("passive_ale32", ("tsit5",), (1e-3, 1e-5, 1e-7), cap=45)
    return jobs


# ---------------------------------------------------------------------------------------------
# worker: one job in its own process
# ---------------------------------------------------------------------------------------------


def worker(job_json: str, out_path: str) -> int:
    job = json.loads(job_json)
    import jaxcable

    jaxcable.enable_x64(job["precision"] == "float64")
    import jaxcable.arresting  # noqa: F401  (registers the arresting bench cases)
    from jaxcable.studies.bench import make_bench_case as BenchCase, prepare_case, timed_run

    case = BenchCase(**case_spec(job["case"]))
    run = prepare_case(case)

    def emit(rec):
        rec.update(case=job["case"], precision=job["precision"], load_1min=_report.load_average()[0])
        with open(out_path, "a") as f:
            f.write(json.dumps(rec) + "\n")

    def one(solver, tol, first, role):
        max_steps = 400_000 if case.level in ("ale", "full") else 200_000
        t = time.perf_counter()
        try:
            probe = timed_run(run, solver, tol, first=first, max_steps=max_steps)
            if probe["wall_s"] < 0.5:  # short runs: the fastest of 3 (dispatch noise)
                more = timed_run(run, solver, tol, repeats=2, max_steps=max_steps)
                probe["wall_s"] = min(probe["wall_s"], more["wall_s"])
                if first:
                    probe["compile_s"] = max(probe["first_call_s"] - probe["wall_s"], 0.0)
            rec = probe
        except Exception as e:  # a solver that cannot run this case: record why
            rec = dict(solver=solver, rtol=tol, atol=tol, ok=False, status=f"error: {type(e).__name__}: "
                       f"{str(e).splitlines()[0][:200]}", wall_s=time.perf_counter() - t)  # fmt: skip
        rec["role"] = role
        emit(rec)
        return rec

    if job["reference"]:
        one(REF_SOLVER, REF_TOL, True, "reference")
    seen = {REF_SOLVER} if job["reference"] else set()
    for solver, tols in job["solvers"].items():
        for tol in sorted(tols, reverse=True):
            rec = one(solver, tol, solver not in seen, "run")
            seen.add(solver)
            failed = rec["status"].startswith("error") or rec["status"] == "max_steps_reached"
            if rec["wall_s"] > job["cap_s"] or failed:
                emit(dict(solver=solver, rtol=None, role="skip", status=f"tighter tolerances skipped: run at rtol "
                          f"{tol:g} took {rec['wall_s']:.1f} s (cap {job['cap_s']} s) or failed"))  # fmt: skip
                break
    return 0


def run_jobs(jobs, out_dir: Path, log):
    jsonl = out_dir / "work_precision.jsonl"
    for i, job in enumerate(jobs):
        t0 = time.perf_counter()
        log(f"[{i + 1}/{len(jobs)}] {job['case']} {job['precision']} {list(job['solvers'])} "
            f"(timeout {job['timeout_s']} s), load {_report.load_average()[0]:.2f}")  # fmt: skip
        cmd = [sys.executable, __file__, "--worker", json.dumps(job), "--worker-out", str(jsonl)]
        env = dict(os.environ, JAX_ENABLE_X64="1" if job["precision"] == "float64" else "0")
        try:
            p = subprocess.run(cmd, env=env, timeout=job["timeout_s"], capture_output=True, text=True)
            if p.returncode != 0:
                tail = (p.stderr or "").strip().splitlines()[-3:]
                _append(jsonl, dict(case=job["case"], precision=job["precision"], role="skip", solver=None,
                                    status=f"worker failed (rc {p.returncode}): {' | '.join(tail)[:300]}"))  # fmt: skip
        except subprocess.TimeoutExpired:
            _append(jsonl, dict(case=job["case"], precision=job["precision"], role="skip", solver=None,
                                solvers=list(job["solvers"]),
                                status=f"worker timed out after {job['timeout_s']} s (not affordable here)"))  # fmt: skip
        log(f"    done in {time.perf_counter() - t0:.0f} s")


def _append(path, rec):
    with open(path, "a") as f:
        f.write(json.dumps(rec) + "\n")


# ---------------------------------------------------------------------------------------------
# report: errors against the references, tables, Pareto fronts, plots
# ---------------------------------------------------------------------------------------------


def load_rows(out_dir: Path):
    rows = []
    with open(out_dir / "work_precision.jsonl") as f:
        for line in f:
            if line.strip():
                rows.append(json.loads(line))
    return rows


# vector-field evaluations per attempted step (FSAL tableaus reuse their last stage); a measure of
# work that the machine's load does not change (diffrax tableaus: Tsit5/Dopri5 7 stages, Dopri8 14,
# Bosh3 4, all FSAL; Heun 2). Implicit solvers: Newton iterations vary, not counted.
EVALS_PER_STEP = dict(tsit5=6, dopri5=6, dopri8=13, bosh3=3, heun=2)


def rhs_evals(r):
    per = EVALS_PER_STEP.get(r.get("solver"))
    if per is None or r.get("num_steps", -1) < 0:
        return math.nan
    return per * (r["num_steps"] + r["num_rejected"])


def analyse(rows):
    import jaxcable.arresting  # noqa: F401  (registers the arresting bench cases)
    from jaxcable.studies.bench import QUANTITIES, relative_errors

    refs = {r["case"]: r for r in rows if r.get("role") == "reference" and r.get("ok")}
    out = []
    for r in rows:
        if r.get("role") != "run":
            continue
        spec = case_spec(r["case"])
        qs = QUANTITIES[spec["scene"]]
        ref = refs.get(r["case"])
        errs = relative_errors(r, ref, qs) if ref and all(q in r for q in qs) else {q: math.nan for q in qs + ("max",)}
        out.append(dict(r, scene=spec["scene"], errors=errs, error=errs["max"], rhs_evals=rhs_evals(r)))
    return refs, out


def pareto(points):
    """Indices of the (time, error) points not dominated by another (cheaper and more accurate)."""
    idx = [i for i, (t, e) in enumerate(points) if math.isfinite(e)]
    idx.sort(key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in idx:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def cheapest_within(rows, target):
    """The fastest successful run whose max error is <= target (None if there is none)."""
    good = [r for r in rows if r.get("ok") and math.isfinite(r["error"]) and r["error"] <= target]
    return min(good, key=lambda r: r["wall_s"]) if good else None


def _fmt(x, spec=".1e"):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return format(x, spec)


def write_report(out_dir: Path, meta: dict, quick: bool):
    import jaxcable.arresting  # noqa: F401  (registers the arresting bench cases)
    from jaxcable.studies.bench import QUANTITIES

    rows = load_rows(out_dir)
    refs, runs = analyse(rows)
    skips = [r for r in rows if r.get("role") == "skip"]
    # JSON
    data = dict(meta=meta, reference=dict(solver=REF_SOLVER, rtol=REF_TOL, atol=REF_TOL), references=refs,
                runs=runs, skipped=skips)  # fmt: skip
    _report.write_json(out_dir / "work_precision.json", json.loads(json.dumps(data, default=str)))
    # CSV
    qcols = sorted({q for v in QUANTITIES.values() for q in v})
    with open(out_dir / "work_precision.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "scene", "precision", "solver", "rtol", "atol", "wall_s", "compile_s", "num_steps",
                    "num_rejected", "rhs_evals", "status", "ok", "error_max", "load_1min"] + [f"err_{q}" for q in qcols]
                   + qcols)  # fmt: skip
        for r in runs:
            w.writerow([r["case"], r["scene"], r["precision"], r["solver"], r["rtol"], r["atol"], r["wall_s"],
                        r.get("compile_s", ""), r.get("num_steps", ""), r.get("num_rejected", ""), r["rhs_evals"], r["status"],
                        r.get("ok"), r["error"], r.get("load_1min")]
                       + [r["errors"].get(q, "") for q in qcols] + [r.get(q, "") for q in qcols])  # fmt: skip
    # markdown
    L = [
        "# Work-precision: error against wall time for the shipped scenes",
        "",
        *_report.header(_provenance(meta)),
        "",
        f"Run: {'quick' if quick else 'full'}. Precision float64 (x64) unless a row says float32 (x64 off, own process); "
        "per-run 1-min load in the CSV (2 cores shared with other jobs: wall times are noisy, +-30%).",
        "",
        f"Reference: each case run with {REF_SOLVER} at rtol = atol = {REF_TOL:g} in float64. Error = relative "
        "error of each quantity against the reference of the same case (time-integration error); "
        "*max* = the largest over the case's quantities. atol = rtol throughout (mixed error on the "
        "state, as `simulate` uses them). Wall = one call after compilation (fastest of 3 when < 0.5 s); "
        "compile = first call - wall.",
        "",
        "## References",
        "",
    ]
    L.append("| case | quantities (reference values) | steps | wall [s] | compile [s] |")
    L.append("|---|---|---:|---:|---:|")
    for c, r in refs.items():
        qs = QUANTITIES[case_spec(c)["scene"]]
        L.append(f"| {c} | {', '.join(f'{q} {r[q]:.6g}' for q in qs)} | {r['num_steps']} | {r['wall_s']:.2f} | "
                 f"{_fmt(r.get('compile_s'), '.1f')} |")  # fmt: skip
    # discretisation errors between references
    tr = {c: refs[c] for c in ("throw_10m", "throw_5m", "throw_2m", "throw_1m") if c in refs}
    if "throw_1m" in tr and len(tr) > 1:
        L += ["", "Segment-length error (reference of each segment length against the 1 m reference, relative):", ""]
        L.append("| segments | range | max speed | flight time |")
        L.append("|---|---:|---:|---:|")
        for c, r in tr.items():
            b = tr["throw_1m"]
            L.append(f"| {c} | " + " | ".join(_fmt(abs(r[q] - b[q]) / abs(b[q])) for q in QUANTITIES["throw"]) + " |")
    if "passive_ale16" in refs and "passive_ale32" in refs:
        a, b = refs["passive_ale16"], refs["passive_ale32"]
        L += ["", "ALE mesh: 16 against 32 span elements (0.3 s references, relative): "
              + ", ".join(f"{q} {abs(a[q] - b[q]) / abs(b[q]):.1e}" for q in QUANTITIES["passive"])
              + " (full mesh study: `experiments/results/bench_land.md` section 2).", ""]  # fmt: skip
    # per case tables
    L += ["", "## Runs", ""]
    for case in dict.fromkeys(r["case"] for r in runs):
        cr = [r for r in runs if r["case"] == case]
        qs = QUANTITIES[case_spec(case)["scene"]]
        f64 = [r for r in cr if r["precision"] == "float64"]
        front = {id(f64[i]) for i in pareto([(r["wall_s"], r["error"]) for r in f64])}
        front_ev = {id(f64[i]) for i in pareto([(r["rhs_evals"], r["error"]) for r in f64])}
        L += [f"### {case}", ""]
        L.append("| precision | solver | rtol | wall [s] | compile [s] | steps (rej.) | f-evals | " + " | ".join(f"err {q}" for q in qs)
                 + " | err max | status | Pareto (wall / f-evals) |")  # fmt: skip
        L.append("|---|---|---:|---:|---:|---:|---:|" + "---:|" * len(qs) + "---:|---|---|")
        for r in cr:
            steps = "-" if r.get("num_steps", -1) < 0 else f"{r['num_steps']} ({r['num_rejected']})"
            st = r["status"] if len(r["status"]) < 40 else r["status"][:37] + "..."
            L.append(f"| {r['precision']} | {r['solver']} | {r['rtol']:.0e} | {r['wall_s']:.3f} | "
                     f"{_fmt(r.get('compile_s'), '.1f')} | {steps} | {_fmt(r['rhs_evals'], '.0f')} | "
                     + " | ".join(_fmt(r["errors"][q]) for q in qs)
                     + f" | {_fmt(r['error'])} | {st} | {'w' if id(r) in front else ''}"
                     f"{' f' if id(r) in front_ev else ''} |")  # fmt: skip
        sk = [s for s in skips if s["case"] == case]
        for s in sk:
            L.append(f"\n- skipped ({s['precision']}, {s.get('solver') or s.get('solvers')}): {s['status']}")
        L.append("")
    # cheapest at target accuracy
    L += ["## Cheapest float64 run at a target accuracy (max relative error over the case's quantities)", ""]
    targets = (1e-2, 1e-3, 1e-4, 1e-6)
    L.append("| case | " + " | ".join(f"err <= {t:g}" for t in targets) + " |")
    L.append("|---|" + "---|" * len(targets))
    for case in dict.fromkeys(r["case"] for r in runs):
        cr = [r for r in runs if r["case"] == case and r["precision"] == "float64"]
        cells = []
        for t in targets:
            b = cheapest_within(cr, t)
            cells.append("-" if b is None else f"{b['solver']} {b['rtol']:.0e} ({b['wall_s']:.2f} s)")
        L.append(f"| {case} | " + " | ".join(cells) + " |")
    L += ["", "Same, cheapest in vector-field evaluations (explicit solvers; independent of the machine's load):", ""]
    L.append("| case | " + " | ".join(f"err <= {t:g}" for t in targets) + " |")
    L.append("|---|" + "---|" * len(targets))
    for case in dict.fromkeys(r["case"] for r in runs):
        cr = [r for r in runs if r["case"] == case and r["precision"] == "float64" and math.isfinite(r["rhs_evals"])]
        cells = []
        for t in targets:
            good = [r for r in cr if r.get("ok") and math.isfinite(r["error"]) and r["error"] <= t]
            b = min(good, key=lambda r: r["rhs_evals"]) if good else None
            cells.append("-" if b is None else f"{b['solver']} {b['rtol']:.0e} ({b['rhs_evals']:.0f})")
        L.append(f"| {case} | " + " | ".join(cells) + " |")
    L += [""] + [f"* {n}" for n in meta.get("notes", [])]
    _report.write_lines(out_dir / "work_precision.md", L)
    plot(out_dir, runs, refs)


def _provenance(meta: dict) -> dict:
    """The fields :func:`_report.header` reads, from a run's meta file (older ones name them
    ``started``, ``total_s`` and ``load_average_end``)."""
    m = meta["machine"]
    return dict(
        machine=m, load_start=meta.get("load_start", m.get("load_average_1_5_15_min")),
        date=meta.get("date", meta.get("started")), load_end=meta.get("load_end", meta.get("load_average_end")),
        wall_s=meta.get("wall_s", meta.get("total_s")), command=meta.get("command"),
    )  # fmt: skip


def plot(out_dir: Path, runs, refs):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import jaxcable.arresting  # noqa: F401  (registers the arresting bench cases)
    from jaxcable.studies.bench import QUANTITIES

    from matplotlib.ticker import NullFormatter

    solvers = ("tsit5", "dopri5", "dopri8", "bosh3", "heun", "kvaerno3", "kvaerno5")
    case_markers = "oDs^vPX<>"
    for scene, qs in QUANTITIES.items():
        sr = [r for r in runs if r["scene"] == scene]
        if not sr:
            continue
        cases = list(dict.fromkeys(r["case"] for r in sr))
        fig, axes = plt.subplots(1, len(qs), figsize=(4.2 * len(qs), 4.0), squeeze=False)
        cmap = plt.get_cmap("tab10")
        for ax, q in zip(axes[0], qs):
            for ci, case in enumerate(cases):
                for prec, ls in (("float64", "-"), ("float32", ":")):
                    for si, solver in enumerate(solvers):
                        pts = sorted((r["rtol"], r["wall_s"], r["errors"][q]) for r in sr
                                     if r["case"] == case and r["precision"] == prec and r["solver"] == solver
                                     and math.isfinite(r["errors"][q]))  # fmt: skip
                        if not pts:
                            continue
                        floor = 1e-16  # an exact match would vanish on a log axis
                        ax.plot([p[1] for p in pts], [max(p[2], floor) for p in pts], ls, marker=case_markers[ci % 9],
                                color=cmap(si % 10), ms=4, lw=1, mfc="none" if prec == "float32" else None,
                                label=f"{case} {solver}" + (" f32" if prec == "float32" else ""))  # fmt: skip
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_xlabel("wall time after compilation [s]")
            ax.set_ylabel(f"relative error of {q}")
            ax.grid(True, which="both", alpha=0.3)
        h, lab = axes[0][0].get_legend_handles_labels()
        fig.legend(h, lab, loc="lower center", ncol=min(6, max(1, len(lab))), fontsize=6, frameon=False)
        fig.suptitle(f"work-precision: {scene} (reference {REF_SOLVER} rtol {REF_TOL:g}, float64)", fontsize=10)
        rows_leg = math.ceil(len(lab) / 6)
        fig.tight_layout(rect=(0, 0.04 + 0.035 * rows_leg, 1, 1))
        fig.savefig(out_dir / f"work_precision_{scene}.png", dpi=110)
        plt.close(fig)


def extras(out_dir: Path, log):
    """Two checks of settings the scenes do not expose yet (each changes a file this study does not
    own): (a) the PI step-size controller (pcoeff 0.4, icoeff 0.3) against diffrax's default
    I controller that ``simulate`` builds, on throw_10m and passive_rigid with Tsit5; (b) the
    tracking phase with the measurement-noise sample times as ``jump_ts`` (the noise track is
    piecewise linear in t, so the vector field has a kink every 0.02 s). Both call ``simulate``'s
    compiled solve directly with a custom controller. Writes work_precision_extras.{json,md}."""
    import diffrax
    import jax
    import jax.numpy as jnp
    import numpy as np

    import jaxcable
    from jaxcable.arresting.passive import passive_landing_scene
    from jaxcable.arresting.two_phase import tracking_scene
    from jaxcable.core.simulate import _solve_jit

    jaxcable.enable_x64()
    data = _report.start()

    def solve(scene, t1, solver, ctrl):
        args = (scene, t1, jnp.asarray(scene.default_save_ts(t1), float), jnp.asarray(scene.default_snapshot_ts(t1), float),
                solver, ctrl, diffrax.RecursiveCheckpointAdjoint(), 200_000, None, diffrax.NoProgressMeter())  # fmt: skip
        jax.block_until_ready(_solve_jit(*args).final_state)
        t0 = time.perf_counter()
        res = _solve_jit(*args)
        jax.block_until_ready(res.final_state)
        return res, time.perf_counter() - t0

    rows = []
    scenes = {"throw_10m": (jaxcable.line_throwing_scene(segment_length_m=10.0), 30.0),
              "passive_rigid": (passive_landing_scene("rigid", t_end_s=2.0), 2.0)}  # fmt: skip
    for name, (scene, t1) in scenes.items():
        for tol in (1e-4, 1e-6, 1e-8):
            for label, (pc, ic) in (("I (simulate's default)", (0.0, 1.0)), ("PI 0.4/0.3", (0.4, 0.3))):
                ctrl = diffrax.PIDController(rtol=jnp.asarray(tol), atol=jnp.asarray(tol), pcoeff=pc, icoeff=ic)
                if scene.jump_times() is not None:
                    ctrl = diffrax.ClipStepSizeController(ctrl, jump_ts=scene.jump_times())
                res, wall = solve(scene, t1, diffrax.Tsit5(), ctrl)
                out = {k: float(v) for k, v in res.outputs.items() if np.ndim(v) == 0 and k in
                       ("range_m", "max_speed_mps", "flight_time_s", "z_max_m", "a_max_g", "sigma_max_mpa")}  # fmt: skip
                rows.append(dict(check="controller", case=name, rtol=tol, variant=label, solver="tsit5",
                                 num_steps=int(res.num_steps), num_rejected=int(res.num_rejected), wall_s=wall, **out))  # fmt: skip
                log(f"  extras: {rows[-1]}")
    scene = tracking_scene(scenario="I")
    for tol in (1e-4, 1e-6, 1e-8):
        for label in ("no jump_ts (current)", "jump_ts = noise sample times"):
            for sname, solver in (("tsit5", diffrax.Tsit5()), ("dopri8", diffrax.Dopri8())):
                ctrl = diffrax.PIDController(rtol=jnp.asarray(tol), atol=jnp.asarray(tol))
                if label.startswith("jump"):
                    ctrl = diffrax.ClipStepSizeController(ctrl, jump_ts=scene.noise.sample_times)
                res, wall = solve(scene, scene.t_max_s, solver, ctrl)
                rows.append(dict(check="tracking_jump_ts", case="tracking phase (scenario I, deviated case)", rtol=tol,
                                 variant=label, solver=sname, num_steps=int(res.num_steps),
                                 num_rejected=int(res.num_rejected), wall_s=wall,
                                 capture_margin_m=float(jnp.min(scene.capture_margins(res.final_state))),
                                 capture_time_s=float(res.t_final)))  # fmt: skip
                log(f"  extras: {rows[-1]}")
    _report.write_json(out_dir / "work_precision_extras.json", {**data, "rows": rows})
    refs = {}
    if (out_dir / "work_precision.jsonl").exists():
        refs, _ = analyse(load_rows(out_dir))
    data["load_end"] = _report.load_average()
    L = ["# Work-precision extras: step-size controller and jump times", "", *_report.header(data), "",
         "float64. Errors are relative to the Dopri8 rtol 1e-10 references of work_precision.md "
         "(capture margin: to the two-phase reference, whose phase 1 is the same run).", ""]  # fmt: skip
    L.append("| check | case | solver | rtol | variant | steps | rejected | attempted | wall [s] | errors |")
    L.append("|---|---|---|---:|---|---:|---:|---:|---:|---|")
    for r in rows:
        ref = refs.get(r["case"]) or (refs.get("two_phase_rigid") if r["check"] == "tracking_jump_ts" else None)
        errs = []
        for q in ("range_m", "max_speed_mps", "flight_time_s", "z_max_m", "a_max_g", "sigma_max_mpa", "capture_margin_m"):
            if q in r and ref and q in ref:
                errs.append(f"{q} {abs(r[q] - ref[q]) / abs(ref[q]):.1e}")
        L.append(f"| {r['check']} | {r['case']} | {r['solver']} | {r['rtol']:.0e} | {r['variant']} | {r['num_steps']} | "
                 f"{r['num_rejected']} | {r['num_steps'] + r['num_rejected']} | {r['wall_s']:.3f} | {', '.join(errs)} |")  # fmt: skip
    _report.write_lines(out_dir / "work_precision_extras.md", L)


def main():
    p = argparse.ArgumentParser(description="work-precision study")
    p.add_argument("--quick", action="store_true", help="a few minutes; writes to experiments/out/work_precision_quick/")
    p.add_argument("--out", default=None, help="output folder (default experiments/results or the quick folder)")
    p.add_argument("--report", action="store_true", help="only rewrite json/csv/md/png from the JSONL")
    p.add_argument("--cases", nargs="+", default=None, help="run only the jobs of these cases")
    p.add_argument("--keep", action="store_true", help="append to an existing JSONL instead of starting afresh")
    p.add_argument("--note", action="append", default=[], help="a note for the report (repeatable)")
    p.add_argument("--extras", action="store_true", help="only run the controller / jump-time checks (extras())")
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--worker-out", default=None, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        return worker(args.worker, args.worker_out)
    out_dir = _report.output_dir(args.out, quick=args.quick, sub="work_precision_quick")
    meta_path = out_dir / "work_precision_meta.json"
    if args.extras:
        extras(out_dir, lambda m: print(m, flush=True))
        return 0
    if args.report:
        meta = json.loads(meta_path.read_text())
        meta["notes"] = meta.get("notes", []) + [n for n in args.note if n not in meta.get("notes", [])]
        _report.write_json(meta_path, meta)
        write_report(out_dir, meta, meta.get("quick", False))
        return 0
    import jaxcable

    jaxcable.enable_x64()
    meta = _report.start(quick=args.quick, notes=args.note)
    jsonl = out_dir / "work_precision.jsonl"
    if jsonl.exists() and not args.keep:
        jsonl.unlink()
    jobs = plan(args.quick)
    if args.cases:
        jobs = [j for j in jobs if j["case"] in args.cases]

    def log(s):
        print(s, flush=True)

    run_jobs(jobs, out_dir, log)
    meta["load_end"] = _report.load_average()
    meta["wall_s"] = time.perf_counter() - meta["_t0"]
    _report.write_json(meta_path, meta)
    write_report(out_dir, meta, args.quick)
    log(f"wrote {out_dir}/work_precision.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
