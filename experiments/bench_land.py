"""Benchmark of the passive-deceleration landing (arresting-cable paper; not a test).

Design case throughout: Table 1 defaults, central vertical capture at 20 m/s (``CaptureState()``).
Every landing is one call of :func:`jaxcable.arresting.landing.run_landing`, which jit-compiles on
its first call for a static structure and reuses the compiled code on a second identical call. A
case is therefore timed twice: *first* = compile + run, *run* = the second identical call (scene
build + solve, what a user pays per landing once compiled), *compile* = first - run. Wall-clock
times on a shared machine: the load average (1/5/15 min) is recorded before and after every case.

(1) Fidelity levels ``1dof``, ``rigid``, ``ale``, ``full``, each to ``--t-end`` (default 1.0 s; the
    rocket stops at ~0.8 s) with the level's default solver settings (``LEVEL_DEFAULTS``): run and
    compile time, steps, z_max, a_max, sigma_max, stop time, energy-budget error, solver status.
    ``--quick`` runs ale/full to 0.2 s only.
(2) ALE graded mesh against uniform meshes at the ``ale`` level to ``--mesh-t-end`` (0.3 s): the
    default graded span (16 elements, 8 of them over +-3 m around the hook: 0.75 m, the rest 5.5 m)
    against uniform spans of 16, 32, 64 elements. A uniform span of N elements is the graded builder
    with ``n_fine = N - 2`` over ``+-(N - 2) / N * L / 2`` (L: the span's material length, the hook
    is at its middle in the design case), which leaves one coarse element of the same length at each
    end; the element lengths of each built mesh are recorded. Reference: the finest uniform mesh.
    Reported: each mesh's relative error on z_max, a_max, sigma_max and its run time, and the cost
    of a uniform mesh at the graded mesh's accuracy.
(3) Rigid-level sensitivities (1.0 s each, compiled once): z_max, a_max, sigma_max against the cable
    damping ``cable_damping_s``, the brake's tanh smoothing width ``brake_velocity_width_m_s``, and
    the cable stiffness ``EA_N = 2.64e8 f`` (at ``cable_damping_s = 1e-2``), the last as relative
    differences to the ``1dof`` level (rigid massless cables), to which the rigid level should tend.

Results are written after every case (a killed run keeps what it has). Writes bench_land.json and
bench_land.md (machine, JAX version, precision, load averages) and bench_land_mesh.png. Usage:
    python experiments/bench_land.py             # ~30 min on 2 busy cores: experiments/results/
                                                 # (~20 min of it: the first call of the 64-element mesh)
    python experiments/bench_land.py --quick     # a few minutes; experiments/out/bench_land_quick/
    python experiments/bench_land.py --sections levels --levels rigid ale --keep   # redo one section
    python experiments/bench_land.py --replot --note "..."   # rewrite .md and .png from the .json
"""

from __future__ import annotations

import argparse
import json
import math
import time
import traceback

import _report
import jax
import numpy as np

import jaxcable

STEM = "bench_land"
LEVELS = ("1dof", "rigid", "ale", "full")
SECTIONS = ("levels", "mesh", "sensitivity")
OUTPUT_KEYS = (
    "z_max_m",
    "a_max_g",
    "sigma_max_mpa",
    "stop_time_s",
    "stopped",
    "criteria_met",
    "energy_budget_error",
    "solver_status",
    "num_steps",
)
COMPARED = ("z_max_m", "a_max_g", "sigma_max_mpa")


def parse_args():
    p = argparse.ArgumentParser(description="passive-landing benchmark")
    p.add_argument("--quick", action="store_true", help="reduced run (a few minutes)")
    p.add_argument("--t-end", type=float, default=1.0, help="end time of the fidelity-level runs [s]")
    p.add_argument("--mesh-t-end", type=float, default=None, help="end time of the mesh study [s] (0.3; quick 0.05)")
    p.add_argument("--sections", nargs="+", default=list(SECTIONS), choices=SECTIONS)
    p.add_argument("--levels", nargs="+", default=list(LEVELS), choices=LEVELS)
    p.add_argument("--meshes", nargs="+", type=int, default=None, help="uniform span element counts (16 32 64)")
    p.add_argument("--note", action="append", default=[], help="a note to add to the report (repeatable)")
    p.add_argument("--replot", action="store_true", help="rewrite bench_land.md and the plot from bench_land.json")
    p.add_argument(
        "--keep", action="store_true", help="keep the sections of an existing bench_land.json that this run does not redo"
    )
    p.add_argument("--out", default=None, help="output folder (default experiments/results, or out/ with --quick)")
    return p.parse_args()


def clean(v):
    """JSON-able scalar (NaN/inf -> None, NumPy -> Python)."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v


def landing(fidelity, *, repeat=True, **kwargs):
    """One case: first call (compile + run) and, if ``repeat``, a second identical call (run only)."""
    from jaxcable.arresting.landing import run_landing

    row = {"fidelity": fidelity, "load_before": _report.load_average()}
    try:
        t0 = time.perf_counter()
        run = run_landing(fidelity, **kwargs)
        row["first_call_s"] = time.perf_counter() - t0
        if repeat:
            t0 = time.perf_counter()
            run2 = run_landing(fidelity, **kwargs)
            row["run_s"] = time.perf_counter() - t0
            row["compile_s"] = row["first_call_s"] - row["run_s"]
            row["repeat_identical"] = all(
                clean(run.outputs[k]) == clean(run2.outputs[k]) for k in OUTPUT_KEYS
            )
        row.update({k: clean(run.outputs[k]) for k in OUTPUT_KEYS})
        row["energy_budget_J"] = {k: clean(v) for k, v in run.outputs["energy_budget_J"].items()}
    except Exception as exc:  # record and go on: a failed case is a result
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["traceback"] = traceback.format_exc(limit=4)
    row["load_after"] = _report.load_average()
    return row


def fmt(v, spec=".3g"):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return format(v, spec)
    return str(v)


def brief(row):
    if "error" in row:
        return f"FAILED {row['error']}"
    t = f"run {fmt(row.get('run_s'), '.2f')} s, compile {fmt(row.get('compile_s'), '.1f')} s" if "run_s" in row else (
        f"first call {row['first_call_s']:.2f} s"
    )
    return (
        f"{t}, {row['num_steps']} steps, z_max {fmt(row['z_max_m'], '.4f')} m, a_max {fmt(row['a_max_g'], '.4f')} g, "
        f"sigma_max {fmt(row['sigma_max_mpa'], '.2f')} MPa, stop {fmt(row['stop_time_s'], '.4f')} s, "
        f"energy err {fmt(row['energy_budget_error'], '.1e')}, {row['solver_status']}, load {row['load_after']}"
    )


# ----------------------------------------------------------------------------------------------
# (2) mesh study
# ----------------------------------------------------------------------------------------------
def span_material_length():
    """Material length of an arresting span in the design case [m] (from the default ale scene)."""
    from jaxcable.arresting.passive import passive_landing_scene

    s = np.asarray(passive_landing_scene("ale").cables.subsystems.route.s_boundary0)
    return float(s[0, 3] - s[0, 2])


def mesh_element_lengths(mesh_kwargs):
    """(min, max) element length of the arresting spans of the built ale scene [m]."""
    from jaxcable.arresting.passive import passive_landing_scene

    route = passive_landing_scene("ale", **mesh_kwargs).cables.subsystems.route
    s = np.asarray(route.s_boundary0)
    fr = np.asarray(route.fractions[2])
    lengths = np.concatenate([np.diff(np.concatenate([[0.0], fr[k], [1.0]])) * (s[k, 3] - s[k, 2]) for k in range(4)])
    return float(lengths.min()), float(lengths.max())


def mesh_cases(uniform_counts, total):
    cases = [("graded 16 (8 fine, +-3 m)", dict(n_span_elements=16, n_fine=8, fine_half_width_m=3.0), "graded")]
    for n in uniform_counts:
        cases.append(
            (f"uniform {n}", dict(n_span_elements=n, n_fine=n - 2, fine_half_width_m=(n - 2) / n * total / 2), "uniform")
        )
    return cases


def mesh_summary(rows):
    """Relative errors against the finest uniform mesh and the cost at the graded mesh's accuracy."""
    ok = [r for r in rows if "error" not in r]
    uni = sorted((r for r in ok if r["kind"] == "uniform"), key=lambda r: r["n_span_elements"])
    graded = next((r for r in ok if r["kind"] == "graded"), None)
    if not uni:
        return {}
    ref = uni[-1]
    for r in ok:
        errs = {k: abs(r[k] - ref[k]) / abs(ref[k]) for k in COMPARED if r.get(k) is not None and ref.get(k)}
        r["rel_error_vs_reference"] = errs
        r["max_rel_error"] = max(errs.values()) if errs else None
    summary = {"reference": ref["label"]}
    if graded is None or graded.get("max_rel_error") is None or "run_s" not in graded:
        return summary
    e_g = graded["max_rel_error"]
    coarser = [r for r in uni[:-1] if r.get("max_rel_error") is not None]
    # cheapest uniform mesh at least as accurate as the graded one (the reference always is: error 0)
    match = next((r for r in uni if r.get("max_rel_error") is not None and r["max_rel_error"] <= e_g), ref)
    summary.update(
        graded_max_rel_error=e_g,
        uniform_match=match["label"],
        uniform_match_is_reference=match is ref,
        cost_ratio_uniform_over_graded=match["run_s"] / graded["run_s"] if "run_s" in match else None,
        steps_ratio_uniform_over_graded=match["num_steps"] / graded["num_steps"] if graded["num_steps"] else None,
        cost_ratios_all={r["label"]: r["run_s"] / graded["run_s"] for r in uni if "run_s" in r},
        coarser_uniform_errors={r["label"]: r["max_rel_error"] for r in coarser},
    )
    per_output = {}
    for k in COMPARED:
        e_k = graded["rel_error_vs_reference"].get(k)
        if e_k is None:
            continue
        m_k = next((r for r in uni if r["rel_error_vs_reference"].get(k, math.inf) <= e_k), ref)
        per_output[k] = {
            "graded_rel_error": e_k,
            "uniform_match": m_k["label"],
            "uniform_match_is_reference": m_k is ref,
            "cost_ratio_uniform_over_graded": m_k["run_s"] / graded["run_s"] if "run_s" in m_k else None,
        }
    summary["per_output"] = per_output
    return summary


def mesh_plot(rows, path):
    """Left: max relative error vs run time (the reference, error 0 by definition, as a dashed line);
    right: run time vs the smallest span element."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if "error" not in r and "run_s" in r]
    if not ok:
        return False
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for r in ok:
        c = "C3" if r["kind"] == "graded" else "C0"
        err = r.get("max_rel_error")
        if err:
            ax[0].scatter(r["run_s"], err, color=c)
            ax[0].annotate(r["label"], (r["run_s"], err), fontsize=8, xytext=(4, 4), textcoords="offset points")
        else:
            ax[0].axvline(r["run_s"], color=c, ls="--", lw=1)
            ax[0].annotate(f"{r['label']} (reference)", (r["run_s"], 0.5), xycoords=("data", "axes fraction"),
                           rotation=90, fontsize=8, ha="right")
        ax[1].scatter(r["h_min_m"], r["run_s"], color=c)
        ax[1].annotate(r["label"], (r["h_min_m"], r["run_s"]), fontsize=8, xytext=(4, 4), textcoords="offset points")
    for a in ax:
        a.set_xscale("log")
        a.set_yscale("log")
    ax[0].set_xlabel("run time after compile [s]")
    ax[0].set_ylabel("max rel. error of z_max, a_max, sigma_max\nvs the finest uniform mesh")
    ax[1].set_xlabel("smallest span element [m]")
    ax[1].set_ylabel("run time after compile [s]")
    fig.suptitle("ALE graded vs uniform span mesh (ale level, design case; red: graded)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


# ----------------------------------------------------------------------------------------------
# (3) rigid-level sensitivities
# ----------------------------------------------------------------------------------------------
def sensitivity_cases(quick):
    from jaxcable.arresting.buffer import BufferDevice
    from jaxcable.arresting.layout import ArrestingLayout

    damping = (0.0, 1e-4, 1e-2) if quick else (0.0, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2)
    widths = (0.01, 0.1) if quick else (0.01, 0.02, 0.05, 0.1)
    factors = (1.0, 1000.0) if quick else (1.0, 10.0, 100.0, 1000.0)
    cases = [("cable_damping_s", b, dict(cable_damping_s=float(b))) for b in damping]
    cases += [("brake_velocity_width_m_s", w, dict(buffer=BufferDevice(brake_velocity_width_m_s=float(w)))) for w in widths]
    cases += [
        ("EA_factor", f, dict(layout=ArrestingLayout(EA_N=2.64e8 * f), cable_damping_s=1e-2)) for f in factors
    ]
    return cases


def rel_to(row, ref):
    return {
        k: (row[k] - ref[k]) / ref[k]
        for k in COMPARED + ("stop_time_s",)
        if row.get(k) is not None and ref.get(k)
    }


# ----------------------------------------------------------------------------------------------
# Markdown
# ----------------------------------------------------------------------------------------------
def write_md(report, path):
    s = report["settings"]
    L = [
        "# Passive-landing benchmark",
        "",
        *_report.header(report),
        "",
        f"Run: {'quick' if report['quick'] else 'full'}; per-case load averages are in the JSON.",
        "",
        "Design case: Table 1 defaults, central vertical capture at 20 m/s. Each case is called twice through "
        "`run_landing`: *run* = the second, identical call (scene build + integration with compiled code), "
        "*compile* = first call - second call. Solver settings: each level's defaults "
        + (f"at the scenes' default damping and hook model, `level_solver_settings(level)` ({s['solver_settings']})"
           if "solver_settings" in s else f"(`LEVEL_DEFAULTS`, {s['level_defaults']})")
        + "; the `1dof` level is the closed-form/ODE model of section II.B.",
        "",
    ]
    if "levels" in report:
        L += [
            "## 1. Fidelity levels",
            "",
            f"End time: {s['t_end_s']:g} s for 1dof and rigid, {s['t_end_heavy_s']:g} s for ale and full "
            "(z_max, a_max, sigma_max, stop time are over [0, t_end]; a stop time of '-' means the rocket had "
            "not stopped by t_end).",
            "",
            "| level | t_end [s] | run [s] | compile [s] | steps | z_max [m] | a_max [g] | σ_max [MPa] | stop [s] | criteria met | energy-budget error | status | load (1 min) |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---|---:|",
        ]
        for r in report["levels"]:
            if "error" in r:
                L.append(f"| {r['fidelity']} | {r['t_end_s']:g} | failed: {r['error'][:120]} |||||||||||")
                continue
            L.append(
                f"| {r['fidelity']} | {r['t_end_s']:g} | {fmt(r.get('run_s'), '.2f')} | {fmt(r.get('compile_s'), '.1f')} "
                f"| {r['num_steps']} | {fmt(r['z_max_m'], '.3f')} | {fmt(r['a_max_g'], '.3f')} | {fmt(r['sigma_max_mpa'], '.1f')} "
                f"| {fmt(r['stop_time_s'], '.4f')} | {fmt(r['criteria_met'])} | {fmt(r['energy_budget_error'], '.1e')} "
                f"| {r['solver_status']} | {r['load_after'][0]:.1f} |"
            )
        L.append("")
    if "mesh" in report:
        mesh = report["mesh"]
        L += [
            "## 2. ALE span mesh: graded vs uniform",
            "",
            f"Level `ale`, end time {mesh['t_end_s']:g} s (so z_max is the drop at {mesh['t_end_s']:g} s, before the "
            f"stop), span material length {mesh['span_material_length_m']:.3f} m. Errors are relative to the "
            f"reference ({mesh['summary'].get('reference', '-')}); max = the largest of the three.",
            "",
            "| mesh | span elements | element length min / max [m] | run [s] | compile [s] | steps | z_max [m] | a_max [g] | σ_max [MPa] | err z | err a | err σ | max err | status |",
            "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
        ]
        for r in mesh["rows"]:
            if "error" in r:
                L.append(f"| {r['label']} | {r['n_span_elements']} | failed: {r['error'][:120]} |||||||||||")
                continue
            e = r.get("rel_error_vs_reference", {})
            L.append(
                f"| {r['label']} | {r['n_span_elements']} | {r['h_min_m']:.3f} / {r['h_max_m']:.3f} | {fmt(r.get('run_s'), '.2f')} "
                f"| {fmt(r.get('compile_s'), '.1f')} | {r['num_steps']} | {fmt(r['z_max_m'], '.4f')} | {fmt(r['a_max_g'], '.4f')} "
                f"| {fmt(r['sigma_max_mpa'], '.2f')} | {fmt(e.get('z_max_m'), '.1e')} | {fmt(e.get('a_max_g'), '.1e')} "
                f"| {fmt(e.get('sigma_max_mpa'), '.1e')} | {fmt(r.get('max_rel_error'), '.1e')} | {r['solver_status']} |"
            )
        sm = mesh["summary"]
        if "uniform_match" in sm:
            caveat = (
                " (the reference itself: no coarser uniform mesh reaches the graded accuracy, so the equal-accuracy "
                "ratio lies between the next coarser mesh's ratio and this one)"
                if sm["uniform_match_is_reference"]
                else ""
            )
            L += [
                "",
                f"Equal accuracy: the graded mesh's max error is {sm['graded_max_rel_error']:.1e}; the cheapest uniform "
                f"mesh at least as accurate is **{sm['uniform_match']}**{caveat}: it costs "
                f"**{fmt(sm['cost_ratio_uniform_over_graded'], '.2f')}x** the graded mesh's run time "
                f"({fmt(sm['steps_ratio_uniform_over_graded'], '.2f')}x its steps). Run-time ratios uniform/graded: "
                + ", ".join(f"{k} {v:.2f}x" for k, v in sm["cost_ratios_all"].items())
                + ".",
            ]
            if sm.get("per_output"):
                L += ["", "Per output (cheapest uniform mesh at least as accurate as the graded one on that output alone):", "",
                      "| output | graded error | uniform match | run-time ratio uniform/graded |", "|---|---:|---|---:|"]
                for k, v in sm["per_output"].items():
                    ref_mark = " (reference)" if v["uniform_match_is_reference"] else ""
                    L.append(f"| {k} | {v['graded_rel_error']:.1e} | {v['uniform_match']}{ref_mark} "
                             f"| {fmt(v['cost_ratio_uniform_over_graded'], '.2f')}x |")
        compiles = [r["compile_s"] for r in mesh["rows"] if r.get("compile_s") is not None]
        if compiles:
            med = float(np.median(compiles))
            for r in mesh["rows"]:
                if r.get("compile_s") is not None and r["compile_s"] > 5 * med:
                    L += ["", f"Compile-time outlier: {r['label']} {r['compile_s']:.0f} s against a median of {med:.0f} s. "
                          "'compile' = first call - second call, so it includes any one-off cost of the first "
                          "execution of the compiled program, not only tracing and XLA compilation."]
        L.append("")
    if "sensitivity" in report:
        sens = report["sensitivity"]
        L += [
            "## 3. Rigid-level sensitivities",
            "",
            f"Level `rigid`, end time {sens['t_end_s']:g} s; one warm-up call compiles the level (first call "
            f"{fmt(sens.get('warmup_rigid', {}).get('first_call_s'), '.1f')} s), then one call per value (call = its wall time; "
            "the values are arrays in the scene, so they reuse the compiled code). "
            "Default values: cable_damping_s = 1e-5 s, brake width 0.05 m/s, EA = 2.64e8 N.",
            "",
        ]
        one = sens.get("one_dof")
        groups = (
            ("cable_damping_s", "cable damping β [s] (brake width 0.05 m/s)"),
            ("brake_velocity_width_m_s", "brake tanh width [m/s] (β = 1e-5 s)"),
            ("EA_factor", "EA / 2.64e8 N (β = 1e-2 s)"),
        )
        for key, title in groups:
            rows = [r for r in sens["rows"] if r["parameter"] == key]
            if not rows:
                continue
            extra = key == "EA_factor" and one is not None and "error" not in one
            head = f"| {title} | call [s] | steps | z_max [m] | a_max [g] | σ_max [MPa] | stop [s] | energy err | status |"
            sep = "|---:|---:|---:|---:|---:|---:|---:|---:|---|"
            if extra:
                head += " Δz/z (1dof) | Δa/a (1dof) | Δσ/σ (1dof) | Δstop/stop (1dof) |"
                sep += "---:|---:|---:|---:|"
            L += [head, sep]
            for r in rows:
                if "error" in r:
                    L.append(f"| {r['value']:g} | failed: {r['error'][:120]} ||||||||")
                    continue
                line = (
                    f"| {r['value']:g} | {r['first_call_s']:.2f} | {r['num_steps']} | {fmt(r['z_max_m'], '.4f')} "
                    f"| {fmt(r['a_max_g'], '.4f')} | {fmt(r['sigma_max_mpa'], '.2f')} | {fmt(r['stop_time_s'], '.4f')} "
                    f"| {fmt(r['energy_budget_error'], '.1e')} | {r['solver_status']} |"
                )
                if extra:
                    d = r.get("rel_diff_vs_1dof", {})
                    line += "".join(f" {fmt(d.get(k), '+.2e')} |" for k in COMPARED + ("stop_time_s",))
                L.append(line)
            L.append("")
        if one is not None and "error" not in one:
            L += [
                f"1dof reference ({sens['t_end_s']:g} s): z_max {one['z_max_m']:.4f} m, a_max {one['a_max_g']:.4f} g, "
                f"σ_max {one['sigma_max_mpa']:.2f} MPa, stop {fmt(one['stop_time_s'], '.4f')} s.",
                "",
            ]
    if report.get("notes"):
        L += ["## Notes", ""] + [f"* {n}" for n in report["notes"]]
    _report.write_lines(path, L)


def main():
    args = parse_args()
    jaxcable.enable_x64()
    from jaxcable.arresting.landing import LEVEL_DEFAULTS, level_solver_settings

    out = _report.output_dir(args.out, quick=args.quick, sub="bench_land_quick")
    if args.replot:
        report = json.loads((out / "bench_land.json").read_text())
        report.setdefault("notes", [])
        report["notes"] += [n for n in args.note if n not in report["notes"]]
        if "mesh" in report:
            report["mesh"]["summary"] = mesh_summary(report["mesh"]["rows"])
            mesh_plot(report["mesh"]["rows"], out / "bench_land_mesh.png")
        _report.save(report, out, STEM)
        write_md(report, out / f"{STEM}.md")
        print(f"rewrote bench_land.md and bench_land_mesh.png in {out}")
        return
    t_heavy = 0.2 if args.quick else args.t_end
    mesh_t = args.mesh_t_end if args.mesh_t_end is not None else (0.05 if args.quick else 0.3)
    uniform_counts = args.meshes or ([16, 32] if args.quick else [16, 32, 64])
    report = _report.start(
        quick=args.quick,
        settings={
            "t_end_s": args.t_end,
            "t_end_heavy_s": t_heavy,
            "level_defaults": {k: list(v) for k, v in LEVEL_DEFAULTS.items()},
            # what run_landing runs at the scenes' defaults (the W-method at ale and full with the hook node)
            "solver_settings": {k: list(level_solver_settings(k)) for k in LEVEL_DEFAULTS},
            "case": "CaptureState() (centre, vertical, 20 m/s), Table 1 defaults",
        },
        notes=list(args.note),
    )
    if args.keep and (out / "bench_land.json").exists():
        old = json.loads((out / "bench_land.json").read_text())
        for sec in SECTIONS:
            if sec not in args.sections and sec in old:
                report[sec] = old[sec]
                report["notes"].append(f"section '{sec}' kept from the run of {old['date']} (load then: see its rows)")
        report["notes"] += [n for n in old.get("notes", []) if n not in report["notes"]]

    def finish():
        _report.finish(report, out, STEM, write_md)

    # (3) first: cheap, and it compiles the rigid level once.
    if "sensitivity" in args.sections:
        print(f"(3) rigid-level sensitivities, t_end {args.t_end:g} s", flush=True)
        sens = {"t_end_s": args.t_end, "rows": []}
        report["sensitivity"] = sens
        sens["one_dof"] = landing("1dof", t_end_s=args.t_end, repeat=False)
        sens["warmup_rigid"] = landing("rigid", t_end_s=args.t_end, repeat=False)  # compiles the rigid level
        print(f"    1dof: {brief(sens['one_dof'])}", flush=True)
        print(f"    rigid warm-up (compile + run): {brief(sens['warmup_rigid'])}", flush=True)
        for key, value, kw in sensitivity_cases(args.quick):
            row = landing("rigid", t_end_s=args.t_end, repeat=False, **kw)
            row.update(parameter=key, value=value)
            if "error" not in row and "error" not in sens["one_dof"]:
                row["rel_diff_vs_1dof"] = rel_to(row, sens["one_dof"])
            sens["rows"].append(row)
            print(f"    {key} = {value:g}: {brief(row)}", flush=True)
            finish()

    if "mesh" in args.sections:
        total = span_material_length()
        print(f"(2) ale mesh study, t_end {mesh_t:g} s, span material length {total:.3f} m", flush=True)
        mesh = {"t_end_s": mesh_t, "span_material_length_m": total, "rows": [], "summary": {}}
        report["mesh"] = mesh
        for label, kw, kind in mesh_cases(uniform_counts, total):
            h_min, h_max = mesh_element_lengths(kw)
            jax.clear_caches()  # uniform 16 has the graded mesh's shapes: without this it would reuse its compile
            row = landing("ale", t_end_s=mesh_t, **kw)
            row.update(label=label, kind=kind, h_min_m=h_min, h_max_m=h_max, **kw)
            mesh["rows"].append(row)
            mesh["summary"] = mesh_summary(mesh["rows"])
            print(f"    {label} (h {h_min:.3f}-{h_max:.3f} m): {brief(row)}", flush=True)
            finish()
        print(f"    summary: {mesh['summary']}", flush=True)
        if mesh_plot(mesh["rows"], out / "bench_land_mesh.png"):
            print(f"    wrote {out / 'bench_land_mesh.png'}", flush=True)

    if "levels" in args.sections:
        print(f"(1) fidelity levels, t_end {args.t_end:g} s (ale/full {t_heavy:g} s)", flush=True)
        report["levels"] = []
        for level in args.levels:
            t_end = t_heavy if level in ("ale", "full") else args.t_end
            jax.clear_caches()  # honest compile time: the other sections may have compiled this structure
            row = landing(level, t_end_s=t_end)
            row["t_end_s"] = t_end
            report["levels"].append(row)
            print(f"    {level}: {brief(row)}", flush=True)
            finish()

    finish()


if __name__ == "__main__":
    main()
