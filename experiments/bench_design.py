"""Benchmark of the gradient-based buffer design (jaxcable.arresting.design; not a test).

Sections (all at the rigid level, Table 8 captures of scenario I, scrambled Halton, float64):

(1) ``cost``: gradient / forward cost ratio at the paper design for batch sizes ``--cost-n`` (8 32):
    the jitted forward objective (:func:`objective_value`) against :func:`objective_and_grad` in
    forward mode (ForwardMode + jacfwd), reverse mode (RecursiveCheckpointAdjoint, diffrax's
    default checkpoints) and reverse mode with ``--checkpoints`` checkpoints. Each function is called
    once to compile, then timed as the best of ``--repeats`` calls; compile = first call - best.
    The gradients of the modes are compared with each other.
(2) ``bias``: smooth (soft-max) criteria minus hard ones per case at the paper design over an
    ``--bias-n`` batch, for the default smoothing widths and half of them.
(3) ``landscape``: worst-case hard criteria and success rate on a grid of (m_w, F_f) over the
    optimisation batch (where the feasible set would be).
(4) ``optimise``: adam (``--steps`` steps, ``--lr``) from the paper design and from poor designs,
    over an ``--opt-n`` batch; Nelder-Mead from the paper design on the same objective and
    reparametrisation (jitted forward), up to ``--nm-evals`` evaluations; evaluations and wall time
    of each to reach adam's final objective from the paper design. Best designs re-checked on an
    independent batch (seed 1, ``--check-n`` cases).

(6) ``chunk``: ``DesignProblem.chunk`` "auto" (on the CPU: the batch as ``lax.map`` over vmapped
    chunks, 32 cases for the forward call and reverse mode, 16 for forward mode) against None (one
    vmap over the whole batch), for batch sizes ``--chunk-n`` (32 64): forward, forward mode and
    reverse mode, all timed in the same rounds; the gradients of the two compared.
(5) ``two_phase``: m_w, F_f and the PD gain a_p on the two-phase objective (``phase="full"``:
    tracking, capture event, passive phase at level rigid) over ``--full-n`` Table 3 cases of
    ``--full-scenario``: adam (``--full-steps``) from the paper design (Table 4's a_p) and from a
    weak gain (0.7 1/s), Nelder-Mead (``--full-nm-evals``) from the paper design; evaluations and
    wall time to reach adam's best. Not in the default sections: it took
    14 min on 2 busy cores (``--sections two_phase --keep`` adds it to an existing report).

Every jitted function is warmed (compiled) before it is timed, so histories' wall times exclude
compiling. Wall-clock times on a shared 2-core machine: load averages are recorded. Writes
``experiments/results/bench_design.{json,md,png}``. Usage:
    python experiments/bench_design.py                       # ~30-40 min on 2 busy cores
    python experiments/bench_design.py --quick               # a few minutes, experiments/out/
    python experiments/bench_design.py --replot              # rewrite .md/.png from the .json
"""

from __future__ import annotations

import argparse
import json
import time

import _report
import jax
import jax.numpy as jnp
import numpy as np

import jaxcable
from jaxcable.arresting.design import (
    CRITERIA,
    ObjectiveWeights,
    batch_criteria,
    criteria_summary,
    design_problem,
    nelder_mead,
    objective_and_grad,
    objective_value,
    optimise,
    paper_start,
)
from jaxcable.arresting.passive import SmoothingWidths

STEM = "bench_design"
SECTIONS = ("cost", "bias", "landscape", "optimise", "two_phase", "chunk")
WEAK_PENALTY = (10.0, 10.0, 10.0)
FAST_LR = 0.5
POOR_STARTS = {
    # heavy counterweight, weak brake: long stroke, high deceleration peaks
    "heavy_weak": {"m_w": 4000.0, "F_f": 2.3e5},
    # light counterweight, strong brake: short stroke, high deceleration and load
    "light_strong": {"m_w": 500.0, "F_f": 4.6e5},
}


def parse_args():
    p = argparse.ArgumentParser(description="design optimisation benchmark")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--sections", nargs="+", default=[s for s in SECTIONS if s not in ("two_phase", "chunk")], choices=SECTIONS)
    p.add_argument("--cost-n", nargs="+", type=int, default=[8, 32])
    p.add_argument("--checkpoints", type=int, default=64)
    p.add_argument("--chunk-n", nargs="+", type=int, default=[32, 64], help="chunk: batch sizes")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--bias-n", type=int, default=64)
    p.add_argument("--opt-n", type=int, default=16)
    p.add_argument("--check-n", type=int, default=64)
    p.add_argument("--steps", type=int, default=30)
    p.add_argument("--lr", type=float, default=0.2)
    p.add_argument("--nm-evals", type=int, default=60)
    p.add_argument("--t-end", type=float, default=1.2)
    p.add_argument("--full-n", type=int, default=8, help="two_phase: cases in the batch")
    p.add_argument("--full-scenario", default="I", choices=["I", "II", "III"], help="two_phase: Table 4 scenario")
    p.add_argument("--full-steps", type=int, default=15, help="two_phase: adam steps")
    p.add_argument("--full-nm-evals", type=int, default=30, help="two_phase: Nelder-Mead evaluations")
    p.add_argument("--keep", action="store_true", help="keep sections of an existing json not redone")
    p.add_argument("--replot", action="store_true")
    p.add_argument("--note", action="append", default=[], help="a note for the report (repeatable; replaces earlier notes)")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    if args.quick:
        args.cost_n, args.repeats, args.bias_n, args.opt_n, args.check_n = [4], 2, 8, 4, 8
        args.steps, args.nm_evals = 5, 12
        args.full_n, args.full_steps, args.full_nm_evals = 2, 2, 4
    return args


def _timed(fn, repeats):
    t = time.perf_counter()
    out = jax.block_until_ready(fn())
    first = time.perf_counter() - t
    runs = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = jax.block_until_ready(fn())
        runs.append(time.perf_counter() - t)
    return out, first, min(runs)


def section_cost(args):
    rows = []
    for n in args.cost_n:
        base = design_problem("m_w,F_f", n=n, t_end_s=args.t_end)
        u0 = base.space.to_unconstrained(paper_start(base))
        calls = {"forward": lambda: objective_value(base, u0)}
        for label, settings in (
            ("grad_forward_mode", dict(gradient="forward")),
            ("grad_reverse_mode", dict(gradient="reverse")),
            (f"grad_reverse_{args.checkpoints}_checkpoints", dict(gradient="reverse", checkpoints=args.checkpoints)),
        ):
            pr = design_problem("m_w,F_f", n=n, t_end_s=args.t_end, **settings)
            calls[label] = (lambda p_: (lambda: objective_and_grad(p_, u0)))(pr)
        # compile each (first call), then time them interleaved, round by round, so that a change of
        # the machine's load hits every function alike; best of the rounds
        first, outs, times = {}, {}, {k: [] for k in calls}
        for label, fn in list(calls.items()):
            t = time.perf_counter()
            try:
                outs[label] = jax.block_until_ready(fn())
            except Exception as err:  # record, do not abort the benchmark
                outs[label] = err
                del calls[label]
            first[label] = time.perf_counter() - t
        for _ in range(args.repeats):
            for label, fn in calls.items():
                t = time.perf_counter()
                jax.block_until_ready(fn())
                times[label].append(time.perf_counter() - t)
        fwd = min(times["forward"])
        j, aux = outs["forward"]
        row = dict(n=n, forward=dict(run_s=fwd, compile_s=first["forward"] - fwd, max_steps=int(np.max(aux["num_steps"]))))
        grads = {}
        for label, out in outs.items():
            if label == "forward":
                continue
            if isinstance(out, Exception):
                row[label] = dict(error=f"{type(out).__name__}: {str(out)[:300]}")
                continue
            run = min(times[label])
            grads[label] = np.asarray(out[1])
            row[label] = dict(run_s=run, compile_s=first[label] - run, ratio=run / fwd, grad=grads[label].tolist(), runs_s=times[label])
            print(f"n {n} {label}: run {run:.3f} s (forward {fwd:.3f} s, ratio {run / fwd:.2f}), compile {first[label] - run:.1f} s", flush=True)
        row["forward"]["runs_s"] = times["forward"]
        ref = grads.get("grad_forward_mode")
        for label, g in grads.items():
            row[label]["rel_diff_to_forward_mode"] = float(np.max(np.abs(g - ref) / np.abs(ref)))
        row["objective"] = float(j)
        row["load_average"] = _report.load_average()
        rows.append(row)
    # gradient accuracy against tolerance: the forward-mode gradient at rtol 1e-6 / 1e-8 / 1e-10
    n = min(args.cost_n)
    acc = []
    for rtol in (1e-6, 1e-8, 1e-10):
        pr = design_problem("m_w,F_f", n=n, t_end_s=args.t_end, rtol=rtol, atol=rtol)
        u0 = pr.space.to_unconstrained(paper_start(pr))
        j, g, aux = objective_and_grad(pr, u0)
        acc.append(dict(rtol=rtol, objective=float(j), grad=np.asarray(g).tolist(), max_steps=int(np.max(aux["num_steps"]))))
    gref = np.asarray(acc[-1]["grad"])
    for a in acc:
        a["rel_error_vs_1e-10"] = float(np.max(np.abs(np.asarray(a["grad"]) - gref) / np.abs(gref)))
    return dict(rows=rows, tolerance=dict(n=n, rows=acc))


def section_chunk(args):
    rows = []
    for n in args.chunk_n:
        calls = {}
        for chunk in (None, "auto"):
            for mode in ("value", "forward", "reverse"):
                pr = design_problem("m_w,F_f", n=n, t_end_s=args.t_end, gradient="forward" if mode == "value" else mode, chunk=chunk)
                u0 = pr.space.to_unconstrained(paper_start(pr))
                fn = objective_value if mode == "value" else objective_and_grad
                calls[(chunk, mode)] = (lambda f_, p_, u_: (lambda: f_(p_, u_)))(fn, pr, u0)
        outs, _, best = _report.time_rounds(calls, args.repeats)
        row = dict(n=n, seconds={f"{c}/{m}": best[(c, m)] for (c, m) in best})
        for mode in ("forward", "reverse"):
            g0, g1 = np.asarray(outs[(None, mode)][1]), np.asarray(outs[("auto", mode)][1])
            row[f"{mode}_max_rel_diff"] = float(np.max(np.abs(g1 - g0) / np.abs(g0)))
        fwd_best = min(best[(None, "value")], best[("auto", "value")])
        row["ratio_to_best_forward"] = {f"{c}/{m}": best[(c, m)] / fwd_best for (c, m) in best if m != "value"}
        rows.append(row)
        print(f"chunk n {n}: " + ", ".join(f"{k} {v:.3f} s" for k, v in row["seconds"].items()), flush=True)
    return dict(rows=rows, load_average=_report.load_average())


def section_bias(args):
    out = []
    for factor in (1.0, 0.5):
        d = SmoothingWidths()
        widths = SmoothingWidths(z_m=d.z_m * factor, a_g=d.a_g * factor, sigma_mpa=d.sigma_mpa * factor)
        pr = design_problem("m_w,F_f", n=args.bias_n, t_end_s=args.t_end, widths=widths)
        res = batch_criteria(pr, paper_start(pr))
        row = dict(width_factor=factor, widths=dict(z_m=widths.z_m, a_g=widths.a_g, sigma_mpa=widths.sigma_mpa))
        for k in CRITERIA:
            diff = np.asarray(res["smooth"][k]) - np.asarray(res["hard"][k])
            row[k] = dict(mean=float(diff.mean()), min=float(diff.min()), max=float(diff.max()))
        row["worst_case_bias"] = {
            k: float(np.max(np.asarray(res["smooth"][k])) - np.max(np.asarray(res["hard"][k]))) for k in CRITERIA
        }
        row["summary"] = criteria_summary(pr, res)
        out.append(row)
        print(f"bias x{factor}: " + ", ".join(f"{k} {row[k]['mean']:.3f}" for k in CRITERIA), flush=True)
    from jaxcable.arresting.passive import SAVE_SPACING_S

    return dict(n=args.bias_n, rows=out, n_save=int(round(args.t_end / SAVE_SPACING_S)) + 1)


def section_landscape(args):
    pr = design_problem("m_w,F_f", n=args.opt_n, t_end_s=args.t_end)
    m_ws = [300.0, 500.0, 800.0, 1400.0, 2500.0, 4500.0]
    F_fs = [2.2e5, 2.6e5, 3.0e5, 3.4e5, 3.8e5, 4.4e5]
    grid = []
    t0 = time.perf_counter()
    for m in m_ws:
        for f in F_fs:
            res = batch_criteria(pr, jnp.array([m, f]))
            s = criteria_summary(pr, res)
            grid.append(
                dict(
                    m_w=m,
                    F_f=f,
                    worst={k: s["hard"][k]["worst"] for k in CRITERIA},
                    mean={k: s["hard"][k]["mean"] for k in CRITERIA},
                    success_rate=s["success_rate"],
                    max_steps=s["max_solver_steps"],
                    failures=s["solver_failures"],
                )
            )
            print(f"grid m_w {m:.0f} F_f {f:.2e}: " + ", ".join(f"{k} {grid[-1]['worst'][k]:.2f}" for k in CRITERIA) + f" ok {s['success_rate']:.2f}", flush=True)
    return dict(n=args.opt_n, m_w=m_ws, F_f=F_fs, grid=grid, wall_s=time.perf_counter() - t0)


def section_optimise(args):
    pr = design_problem("m_w,F_f", n=args.opt_n, t_end_s=args.t_end)
    x_paper = paper_start(pr)
    starts = {"paper": x_paper, **{k: pr.space.from_dict(v) for k, v in POOR_STARTS.items()}}
    # warm both jitted functions so the histories' wall times exclude compiling
    u = pr.space.to_unconstrained(x_paper)
    _, c_grad, _ = _timed(lambda: objective_and_grad(pr, u), 1)
    _, c_fwd, _ = _timed(lambda: objective_value(pr, u), 1)
    runs = {}
    for name, x0 in starts.items():
        t = time.perf_counter()
        h = optimise(pr, x0, steps=args.steps, learning_rate=args.lr)
        runs[f"adam_{name}"] = h
        b = h.best
        print(
            f"adam from {name}: J {h.objective[0]:.4f} -> best {h.objective[b]:.4f} at step {b}, x {h.x[b]}, "
            f"success {h.success_rate[0]:.2f} -> {h.success_rate[b]:.2f}, {time.perf_counter() - t:.1f} s",
            flush=True,
        )
    # adam with a larger learning rate, same objective
    t = time.perf_counter()
    h = optimise(pr, x_paper, steps=args.steps, learning_rate=FAST_LR)
    runs[f"adam_paper_lr{FAST_LR}"] = h
    b = h.best
    print(f"adam lr {FAST_LR}: J {h.objective[0]:.4f} -> best {h.objective[b]:.4f} at step {b}, x {h.x[b]}, {time.perf_counter() - t:.1f} s", flush=True)
    # the same from the paper design with weaker penalties (a different objective, so its J is not
    # comparable with the others): how the weights move the compromise
    pr_w = design_problem("m_w,F_f", n=args.opt_n, t_end_s=args.t_end, weights=ObjectiveWeights(penalty=WEAK_PENALTY))
    t = time.perf_counter()
    h = optimise(pr_w, x_paper, steps=args.steps, learning_rate=args.lr)
    runs["adam_paper_weak_penalty"] = h
    b = h.best
    print(f"adam weak penalty: J {h.objective[0]:.4f} -> best {h.objective[b]:.4f} at step {b}, x {h.x[b]}, {time.perf_counter() - t:.1f} s", flush=True)
    target = float(runs["adam_paper"].objective[-1])
    t = time.perf_counter()
    nm = nelder_mead(pr, x_paper, max_evaluations=args.nm_evals)
    runs["nelder_mead_paper"] = nm
    print(f"nelder-mead: best {nm.objective.min():.4f} after {len(nm.objective)} evaluations, {time.perf_counter() - t:.1f} s", flush=True)
    reach = {}
    for label in ("adam_paper", "nelder_mead_paper"):
        r = runs[label].evaluations_to_reach(target)
        reach[label] = None if r is None else dict(evaluations=r[0], wall_s=r[1])
    # the best designs on an independent batch
    check = design_problem("m_w,F_f", n=args.check_n, t_end_s=args.t_end, seed=1)
    checks = {}
    for label, h in runs.items():
        x = jnp.asarray(h.x[h.best])
        res = batch_criteria(check, x)
        checks[label] = dict(design=check.space.as_dict(x), summary=criteria_summary(check, res))
    res = batch_criteria(check, x_paper)
    checks["paper_design"] = dict(design=check.space.as_dict(x_paper), summary=criteria_summary(check, res))
    best_label = min((k for k in runs if k != "adam_paper_weak_penalty"), key=lambda k: runs[k].objective.min())
    hb = runs[best_label]
    _, _, aux_best = objective_and_grad(pr, pr.space.to_unconstrained(jnp.asarray(hb.x[hb.best])))
    _, _, aux_paper = objective_and_grad(pr, u)
    return dict(
        n=args.opt_n,
        steps=args.steps,
        lr=args.lr,
        compile_s=dict(objective_and_grad=c_grad, objective_value=c_fwd),
        target_objective=target,
        reach=reach,
        histories={k: h.as_json() for k, h in runs.items()},
        best=dict(label=best_label, summary=criteria_summary(pr, aux_best), terms={k: float(v) for k, v in aux_best["terms"].items()}),
        paper=dict(summary=criteria_summary(pr, aux_paper), terms={k: float(v) for k, v in aux_paper["terms"].items()}),
        check=dict(n=args.check_n, seed=1, rows=checks),
        bounds=dict(lower=np.asarray(pr.space.lower).tolist(), upper=np.asarray(pr.space.upper).tolist()),
        weights=dict(penalty=np.asarray(pr.weights.penalty).tolist(), alpha=float(pr.weights.alpha), tail=pr.weights.tail_criterion),
        weak_penalty=list(WEAK_PENALTY),
        fast_lr=FAST_LR,
    )


def section_two_phase(args):
    """m_w, F_f and the PD gain a_p on the two-phase objective (tracking + capture + passive, rigid):
    adam from the paper design (Table 4's a_p) and from a weak gain, Nelder-Mead from the paper
    design; evaluations and wall time to reach adam's best from the paper design."""
    pr = design_problem("m_w,F_f,a_p", n=args.full_n, scenario=args.full_scenario, t_end_s=args.t_end)
    x_paper = paper_start(pr)
    starts = {"paper": x_paper, "weak_gain": pr.space.from_dict({**pr.space.as_dict(x_paper), "a_p": 0.7})}
    u = pr.space.to_unconstrained(x_paper)
    _, c_grad, _ = _timed(lambda: objective_and_grad(pr, u), 1)
    _, c_fwd, _ = _timed(lambda: objective_value(pr, u), 1)
    runs = {}
    for name, x0 in starts.items():
        t = time.perf_counter()
        h = optimise(pr, x0, steps=args.full_steps, learning_rate=args.lr)
        runs[f"adam_{name}"] = h
        b = h.best
        print(f"two-phase adam from {name}: J {h.objective[0]:.4f} -> {h.objective[b]:.4f} at step {b}, x {h.x[b]}, "
              f"success {h.success_rate[0]:.2f} -> {h.success_rate[b]:.2f}, {time.perf_counter() - t:.1f} s", flush=True)  # fmt: skip
    t = time.perf_counter()
    nm = nelder_mead(pr, x_paper, max_evaluations=args.full_nm_evals)
    runs["nelder_mead_paper"] = nm
    print(f"two-phase nelder-mead: best {nm.objective.min():.4f} after {len(nm.objective)} evaluations, {time.perf_counter() - t:.1f} s", flush=True)
    target = float(runs["adam_paper"].objective.min())
    reach = {}
    for label in ("adam_paper", "nelder_mead_paper"):
        r = runs[label].evaluations_to_reach(target)
        reach[label] = None if r is None else dict(evaluations=r[0], wall_s=r[1])
    rows = {}
    for label, x in [("paper_design", np.asarray(x_paper))] + [(k, h.x[h.best]) for k, h in runs.items()]:
        j, aux = objective_value(pr, pr.space.to_unconstrained(jnp.asarray(x)))
        rows[label] = dict(design=pr.space.as_dict(x), objective=float(j), terms={k: float(v) for k, v in aux["terms"].items()},
                           summary=criteria_summary(pr, aux))  # fmt: skip
    return dict(
        n=args.full_n,
        scenario=args.full_scenario,
        steps=args.full_steps,
        lr=args.lr,
        compile_s=dict(objective_and_grad=c_grad, objective_value=c_fwd),
        capture_reference_m=float(pr.capture_reference_m),
        target_objective=target,
        reach=reach,
        histories={k: h.as_json() for k, h in runs.items()},
        rows=rows,
        bounds=dict(lower=np.asarray(pr.space.lower).tolist(), upper=np.asarray(pr.space.upper).tolist()),
    )


def _md_two_phase(data):
    o = data["two_phase"]
    L = [
        "## 6. Two-phase objective: m_w, F_f and the PD gain a_p",
        "",
        _provenance(o),
        f"Scenario {o['scenario']}, {o['n']} Table 3 terminal-guidance cases with Table 4 wind, gust, delay and noise "
        f"(scrambled Halton, seed 0); tracking with the rigid rocket, the capture event, {data['t_end_s']:g} s of the passive "
        f"phase at level rigid; forward-mode gradients. Compile: objective + gradient {o['compile_s']['objective_and_grad']:.0f} s, "
        f"objective {o['compile_s']['objective_value']:.0f} s. Capture criterion normalised by the centred capture's margin "
        f"{o['capture_reference_m']:.3f} m; tracking error limit 1 m.",
        "",
        "| run | m_w [kg] | F_f [N] | a_p [1/s] | J | worst z / a / sigma | smallest capture margin [m] | largest tracking error [m] | success |",
        "|---|---:|---:|---:|---:|---|---:|---:|---:|",
    ]
    for label, r in o["rows"].items():
        d, h = r["design"], r["summary"]["hard"]
        L.append(
            f"| {label} | {d['m_w']:.0f} | {d['F_f']:.4g} | {d['a_p']:.3f} | {r['objective']:.4f} | "
            f"{h['z_max_m']['worst']:.2f} m / {h['a_max_g']['worst']:.2f} g / {h['sigma_max_mpa']['worst']:.0f} MPa | "
            f"{h['capture_margin_m']['worst']:.3f} | {h['tracking_error_m']['worst']:.3f} | {r['summary']['success_rate']:.0%} |"
        )
    L += ["", f"Evaluations and wall time (compiled) to reach adam's best from the paper design, J = {o['target_objective']:.4f}:", ""]
    for label, r in o["reach"].items():
        h = o["histories"][label]
        L.append(f"* {label}: " + ("not reached" if r is None else f"{r['evaluations']} evaluations, {r['wall_s']:.1f} s")
                 + f" (ran {len(h['objective'])} evaluations, {h['wall_s'][-1]:.1f} s)")  # fmt: skip
    L.append("")
    return L


# ------------------------------------------------------------------------------------------------
# Report
# ------------------------------------------------------------------------------------------------


def _provenance(section):
    r = section.get("run")
    if r is None:
        return ""
    return f"_Section run {r['date']}, load average {r['load_start']} -> {r['load_end']}, {section['section_wall_s']:.0f} s._\n"


def write_md(data, path):
    L = [
        "# Design-optimisation benchmark",
        "",
        *_report.header(data),
        "",
        f"Run: {data['mode']}.",
        "",
        "Problem: rigid level, Table 8 captured states of scenario I (scrambled Halton, seed 0), "
        f"t_end = {data['t_end_s']} s, rtol = atol = 1e-6 (the rigid level's default), design variables m_w [kg], F_f [N] "
        "with the default bounds (300-5000 kg, 2e5-5e5 N) and the default objective weights (expected cost 1, CVaR_0.75 of a_max/5g weight 1, "
        f"squared penalties {data.get('optimise', {}).get('weights', {}).get('penalty', '')} for (z, a, σ)).",
        "",
    ]
    if "chunk" in data:
        L += [
            "## Batch chunks (`DesignProblem.chunk`)",
            "",
            _provenance(data["chunk"]),
            '"auto" on the CPU runs the batch as `lax.map` over vmapped chunks (32 cases forward and reverse mode, 16 forward mode); '
            "None is one vmap over the whole batch. Every call timed in the same rounds, best kept; ratio = gradient / the faster forward call.",
            "",
            "| n | chunk | forward [s] | forward mode [s] | ratio | reverse mode [s] | ratio | gradient diff. FM / reverse (relative) |",
            "|---:|---|---:|---:|---:|---:|---:|---|",
        ]
        for r in data["chunk"]["rows"]:
            for c in ("None", "auto"):
                sec, rat = r["seconds"], r["ratio_to_best_forward"]
                diff = f"{r['forward_max_rel_diff']:.1e} / {r['reverse_max_rel_diff']:.1e}" if c == "auto" else ""
                L.append(f"| {r['n']} | {c} | {sec[c + '/value']:.3f} | {sec[c + '/forward']:.3f} | {rat[c + '/forward']:.2f} | "
                         f"{sec[c + '/reverse']:.3f} | {rat[c + '/reverse']:.2f} | {diff} |")  # fmt: skip
        L.append("")
    if "cost" in data:
        c = data["cost"]
        L += [
            "## 1. Gradient cost",
            "",
            _provenance(data["cost"]),
            "At the paper design (m_t_bar = 2, eq 19). Each function is compiled by a first call, then the functions are called in turn, round by round "
            f"({data.get('repeats', '?')} rounds), and each keeps its best time. ratio = gradient call / forward call (the gradient call also returns the objective).",
            "",
            "| n | forward [s] | forward compile [s] | max steps | mode | gradient [s] | ratio | compile [s] | max rel. diff. to forward mode |",
            "|---:|---:|---:|---:|---|---:|---:|---:|---:|",
        ]
        for r in c["rows"]:
            for label in (k for k in r if k.startswith("grad_")):
                g = r[label]
                if "error" in g:
                    L.append(f"| {r['n']} | {r['forward']['run_s']:.3f} | {r['forward']['compile_s']:.1f} | {r['forward']['max_steps']} | {label[5:]} | - | - | - | {g['error']} |")
                    continue
                L.append(
                    f"| {r['n']} | {r['forward']['run_s']:.3f} | {r['forward']['compile_s']:.1f} | {r['forward']['max_steps']} | {label[5:]} | "
                    f"{g['run_s']:.3f} | {g['ratio']:.2f} | {g['compile_s']:.1f} | {g['rel_diff_to_forward_mode']:.1e} |"
                )
        t = c["tolerance"]
        L += [
            "",
            f"Gradient of the discrete solve against the solver tolerance (forward mode, n = {t['n']}): relative error of dJ/du against rtol = 1e-10.",
            "",
            "| rtol | J | dJ/du (m_w, F_f) | max steps | rel. error |",
            "|---:|---:|---|---:|---:|",
        ]
        for r in t["rows"]:
            L.append(f"| {r['rtol']:.0e} | {r['objective']:.8f} | {r['grad'][0]:.6f}, {r['grad'][1]:.6f} | {r['max_steps']} | {r['rel_error_vs_1e-10']:.1e} |")
        L.append("")
    if "bias" in data:
        b = data["bias"]
        L += [
            "## 2. Bias of the smooth criteria",
            "",
            _provenance(data["bias"]),
            f"Soft max (width log-sum-exp over the {b.get('n_save', 401)} saved samples) minus hard max, per case, paper design, n = {b['n']}. "
            f"The soft max is an upper bound (bias >= 0) and exceeds the max by at most width log({b.get('n_save', 401)}) = {np.log(b.get('n_save', 401)):.1f} widths; "
            "it is largest where the history stays near its maximum for many samples (z after the stop).",
            "",
            "| widths (z [m], a [g], σ [MPa]) | z_max bias mean / min / max [m] | a_max bias mean / min / max [g] | σ_max bias mean / min / max [MPa] | worst-case bias z, a, σ |",
            "|---|---|---|---|---|",
        ]
        for r in b["rows"]:
            w = r["widths"]
            cells = [f"{r[k]['mean']:.3f} / {r[k]['min']:.3f} / {r[k]['max']:.3f}" for k in CRITERIA]
            wc = r["worst_case_bias"]
            L.append(f"| {w['z_m']:g}, {w['a_g']:g}, {w['sigma_mpa']:g} | " + " | ".join(cells) + f" | {wc['z_max_m']:.3f}, {wc['a_max_g']:.3f}, {wc['sigma_max_mpa']:.2f} |")
        L.append("")
    if "landscape" in data:
        g = data["landscape"]
        L += [
            "## 3. Landscape: worst case over the batch (hard criteria)",
            "",
            _provenance(data["landscape"]),
            f"n = {g['n']} (the optimisation batch). Each cell: worst z_max [m] / worst a_max [g] / worst σ_max [MPa] / success rate.",
            "",
            "| m_w [kg] \\ F_f [N] | " + " | ".join(f"{f:.2e}" for f in g["F_f"]) + " |",
            "|---:|" + "---|" * len(g["F_f"]),
        ]
        cells = {(r["m_w"], r["F_f"]): r for r in g["grid"]}
        for mw in g["m_w"]:
            row = []
            for f in g["F_f"]:
                r = cells[(mw, f)]
                w = r["worst"]
                row.append(f"{w['z_max_m']:.2f} / {w['a_max_g']:.2f} / {w['sigma_max_mpa']:.0f} / {r['success_rate']:.0%}")
            L.append(f"| {mw:.0f} | " + " | ".join(row) + " |")
        best_a = min((r for r in g["grid"] if r["worst"]["z_max_m"] < 10.0), key=lambda r: r["worst"]["a_max_g"], default=None)
        if best_a is not None:
            L += ["", f"Lowest worst-case a_max among grid designs with worst-case z_max < 10 m: {best_a['worst']['a_max_g']:.2f} g (m_w = {best_a['m_w']:.0f} kg, F_f = {best_a['F_f']:.2e} N)."]
        L.append("")
    if "optimise" in data:
        o = data["optimise"]
        L += [
            "## 4. Optimisation",
            "",
            _provenance(data["optimise"]),
            f"Batch n = {o['n']}; adam (lr {o['lr']} in the unconstrained variables) for {o['steps']} steps; Nelder-Mead (scipy, same reparametrisation, "
            f"initial simplex steps 0.5) from the paper design. `adam_paper_lr{o.get('fast_lr')}`: adam with that learning rate. "
            f"`adam_paper_weak_penalty`: adam from the paper design with the penalty weights {tuple(o.get('weak_penalty', []))} instead of "
            f"{tuple(o['weights']['penalty'])} (a different objective: its J is not comparable). Compile times (excluded from the histories): objective_and_grad "
            f"{o['compile_s']['objective_and_grad']:.1f} s, objective_value {o['compile_s']['objective_value']:.1f} s.",
            "",
            "| run | J start | J best (eval) | design at best (m_w [kg], F_f [N]) | worst z / a / σ at best | success start -> best | evaluations | wall [s] |",
            "|---|---:|---:|---|---|---|---:|---:|",
        ]
        for label, h in o["histories"].items():
            obj = np.asarray(h["objective"])
            b = int(np.argmin(obj))
            w = h["worst_hard"][b]
            L.append(
                f"| {label} | {obj[0]:.4f} | {obj[b]:.4f} ({b + 1}) | {h['x'][b][0]:.1f}, {h['x'][b][1]:.4g} | {w[0]:.2f} / {w[1]:.2f} / {w[2]:.0f} | "
                f"{h['success_rate'][0]:.0%} -> {h['success_rate'][b]:.0%} | {len(obj)} | {h['wall_s'][-1]:.1f} |"
            )
        L += ["", f"Evaluations and wall time (compiling excluded) to reach adam's final objective from the paper design, J = {o['target_objective']:.4f} (same objective; an adam evaluation is a value and a gradient, a Nelder-Mead one a value):", ""]
        reach = {}
        for label, h in o["histories"].items():
            if not label.startswith(("adam_paper", "nelder_mead_paper")) or label.endswith("weak_penalty"):
                continue
            hit = np.nonzero(np.asarray(h["objective"]) <= o["target_objective"])[0]
            reach[label] = None if hit.size == 0 else (int(hit[0]) + 1, float(h["wall_s"][int(hit[0])]))
            r = reach[label]
            L.append(f"* {label}: " + ("not reached" if r is None else f"{r[0]} evaluations, {r[1]:.1f} s"))
        ra, rn = reach.get("adam_paper"), reach.get("nelder_mead_paper")
        if ra is not None and rn is not None:
            L.append(f"* ratio Nelder-Mead / adam (lr {o['lr']}): {rn[0] / ra[0]:.2f} in evaluations, {rn[1] / ra[1]:.2f} in wall time")
        L += [
            "",
            f"Best designs re-checked on an independent batch (seed {o['check']['seed']}, n = {o['check']['n']}), hard criteria:",
            "",
            "| design | m_w [kg] | F_f [N] | worst z / a / σ | mean z / a / σ | success rate | per criterion (z, a, σ) |",
            "|---|---:|---:|---|---|---:|---|",
        ]
        for label, r in o["check"]["rows"].items():
            s = r["summary"]
            hw = s["hard"]
            pc = s["success_rate_per_criterion"]
            L.append(
                f"| {label} | {r['design']['m_w']:.1f} | {r['design']['F_f']:.4g} | "
                + " / ".join(f"{hw[k]['worst']:.2f}" for k in CRITERIA)
                + " | "
                + " / ".join(f"{hw[k]['mean']:.2f}" for k in CRITERIA)
                + f" | {s['success_rate']:.0%} | "
                + ", ".join(f"{pc[k]:.0%}" for k in CRITERIA)
                + " |"
            )
        L.append("")
    if data.get("notes"):
        L += ["## 5. Findings", ""]
        for note in data["notes"]:
            L += [f"* {note}"]
        L.append("")
    if "two_phase" in data:
        L += _md_two_phase(data)
    _report.write_lines(path, L)


def plot(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if "optimise" not in data:
        return
    o = data["optimise"]
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    for label, h in o["histories"].items():
        obj = np.asarray(h["objective"])
        other = label.endswith("weak_penalty")
        style = "--" if other else ("-o" if "adam" in label else "-")
        ax[0].plot(np.arange(1, len(obj) + 1), obj, style, ms=3, label=label + (" (other J)" if other else ""))
    ax[0].axhline(o["target_objective"], color="k", lw=0.7, ls=":")
    ax[0].set_xlabel("objective evaluations (adam: value + gradient; Nelder-Mead: value)")
    ax[0].set_ylabel("objective J")
    ax[0].set_yscale("log")
    ax[0].legend(fontsize=8)
    ax[0].grid(alpha=0.3)
    ax[0].set_title(f"objective history (n = {o['n']} captures, rigid)", fontsize=10)
    if "landscape" in data:
        g = data["landscape"]
        M, F = np.meshgrid(g["m_w"], g["F_f"], indexing="ij")
        cells = {(r["m_w"], r["F_f"]): r for r in g["grid"]}
        A = np.array([[cells[(m, f)]["worst"]["a_max_g"] for f in g["F_f"]] for m in g["m_w"]])
        Z = np.array([[cells[(m, f)]["worst"]["z_max_m"] for f in g["F_f"]] for m in g["m_w"]])
        S = np.array([[cells[(m, f)]["worst"]["sigma_max_mpa"] for f in g["F_f"]] for m in g["m_w"]])
        cs = ax[1].contourf(M, F, A, levels=12, cmap="viridis")
        fig.colorbar(cs, ax=ax[1], label="worst-case a_max [g]")
        c1 = ax[1].contour(M, F, Z, levels=[10.0], colors="k", linestyles="--")
        ax[1].clabel(c1, fmt="z=10 m", fontsize=8)
        c2 = ax[1].contour(M, F, S, levels=[800.0], colors="w", linestyles="--")
        ax[1].clabel(c2, fmt="σ=800 MPa", fontsize=8)
        c3 = ax[1].contour(M, F, A, levels=[5.0], colors="orange")
        if c3.allsegs and any(len(s) for s in c3.allsegs[0]):
            ax[1].clabel(c3, fmt="a=5 g", fontsize=8)
    for label, h in o["histories"].items():
        x = np.asarray(h["x"])
        ax[1].plot(x[:, 0], x[:, 1], "-" if "adam" in label else ":", lw=1.2, label=label)
        ax[1].plot(x[0, 0], x[0, 1], "ks", ms=4)
        b = int(np.argmin(h["objective"]))
        ax[1].plot(x[b, 0], x[b, 1], "r*", ms=8)
    ax[1].set_xscale("log")
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    ax[1].xaxis.set_major_formatter(ScalarFormatter())
    ax[1].xaxis.set_minor_formatter(NullFormatter())
    ax[1].set_xticks([300, 500, 1000, 2000, 5000])
    ax[1].set_xlabel("m_w [kg]")
    ax[1].set_ylabel("F_f [N]")
    ax[1].set_title("design paths (start ■, best ★) over the worst-case a_max of the grid", fontsize=10)
    ax[1].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    args = parse_args()
    out_dir = _report.output_dir(args.out, quick=args.quick, sub="bench_design_quick")
    jpath, mpath, ppath = out_dir / f"{STEM}.json", out_dir / f"{STEM}.md", out_dir / f"{STEM}.png"
    if args.replot:
        data = json.loads(jpath.read_text())
        if args.note:
            data["notes"] = args.note
            _report.save(data, out_dir, STEM)
        write_md(data, mpath)
        plot(data, ppath)
        return
    jaxcable.enable_x64()
    data = json.loads(jpath.read_text()) if args.keep and jpath.exists() else {}
    data.update(_report.start(mode="quick" if args.quick else "full", t_end_s=args.t_end, repeats=args.repeats))
    fns = dict(cost=section_cost, bias=section_bias, landscape=section_landscape, optimise=section_optimise, two_phase=section_two_phase, chunk=section_chunk)
    for s in args.sections:
        ts = time.perf_counter()
        load0 = _report.load_average()
        data[s] = fns[s](args)
        data[s]["section_wall_s"] = time.perf_counter() - ts
        data[s]["run"] = dict(date=_report.now(), command=data["command"], load_start=load0, load_end=_report.load_average())
        _report.finish(data, out_dir, STEM, write_md)
        plot(data, ppath)


if __name__ == "__main__":
    main()
