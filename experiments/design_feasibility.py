"""Can the gradient-based design meet every landing criterion over a batch? (issue 5; not a test)

The buffer design (m_w, F_f) at the rigid level with the cables' stiffness-proportional damping
beta = ``--cable-damping`` (the paper gives none; at the scenes' default 1e-5 s no (m_w, F_f) meets
a_max < 5 g, README "Cable damping decides feasibility"). adam (optax) runs from the paper's design
(section II.B: m_t = 2, F_t from eq 19) on a training batch of ``--n`` Table 8 captures (seed 0)
with the objective's penalties asking for a fractional ``--margin`` below each limit; every step's
design is then checked on a fresh batch of ``--n-check`` captures (seed 1) that the optimiser never
saw. Reported: the success rate on both batches at the start, at the end, and at the first step
that met every criterion on the training batch. ``--starts`` adds poor start designs.

Usage:
    python experiments/design_feasibility.py   # ~10 min: experiments/results/design_feasibility.{json,md}
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--n-check", type=int, default=64)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--cable-damping", type=float, default=1e-2)
    ap.add_argument("--margins", default="0,0.01,0.02")
    ap.add_argument("--lr", type=float, default=0.1)
    ap.add_argument("--expected", type=float, default=1.0, help="weight of the expected cost (ObjectiveWeights)")
    ap.add_argument("--tail-criterion", default="a_max", help="CVaR of z_max, a_max, sigma_max or worst")
    ap.add_argument("--alpha", type=float, default=0.75, help="CVaR level")
    ap.add_argument(
        "--starts", default="paper",
        help="comma-separated start designs: paper, heavy_weak (4000 kg, 2.3e5 N), light_strong (500 kg, 4.6e5 N)",
    )  # fmt: skip
    ap.add_argument("--out", default=str(ROOT / "experiments" / "results" / "design_feasibility"))
    args = ap.parse_args(argv)

    import jaxcable
    from jaxcable.arresting.design import (
        ObjectiveWeights, batch_criteria, criteria_summary, design_problem, optimise, paper_start,
    )  # fmt: skip
    from jaxcable.core.provenance import machine_info

    from bench_design import POOR_STARTS  # the benchmark's poor start designs (this directory)

    jaxcable.enable_x64()
    t_all = time.perf_counter()
    check = design_problem("m_w,F_f", n=args.n_check, seed=1, cable_damping_s=args.cable_damping)
    runs = []
    for start, margin in [(st, float(m)) for st in args.starts.split(",") for m in args.margins.split(",")]:
        problem = design_problem(
            "m_w,F_f", n=args.n, seed=0, cable_damping_s=args.cable_damping, weights=ObjectiveWeights(
                margin=margin, expected=args.expected, tail_criterion=args.tail_criterion, alpha=args.alpha
            ),
        )
        x0 = paper_start(problem) if start == "paper" else problem.space.from_dict(POOR_STARTS[start])
        t0 = time.perf_counter()
        hist = optimise(problem, x0, steps=args.steps, learning_rate=args.lr)
        wall = time.perf_counter() - t0
        first_ok = next((i for i, s in enumerate(hist.success_rate) if s == 1.0), None)
        rows = {}
        for label, i in (("start", 0), ("first_all_met", first_ok), ("end", len(hist.objective) - 1)):
            if i is None:
                rows[label] = None
                continue
            x = hist.x[i]
            fresh = criteria_summary(check, batch_criteria(check, x))
            rows[label] = dict(
                step=int(i), m_w_kg=float(x[0]), F_f_N=float(x[1]), objective=float(hist.objective[i]),
                train_success=float(hist.success_rate[i]),
                train_worst=dict(zip(hist.criteria_names, map(float, hist.worst_hard[i]))),
                fresh_success=fresh["success_rate"],
                fresh_worst={k: v["worst"] for k, v in fresh["hard"].items()},
            )  # fmt: skip
        runs.append(dict(start=start, margin=margin, wall_s=wall, history=hist.as_json(), points=rows))
        print(json.dumps(dict(start=start, margin=margin, wall_s=round(wall, 1), points=rows)), flush=True)
    result = dict(
        machine=machine_info(), args=dict(vars(args), out=_relative(args.out)), runs=runs,
        total_s=time.perf_counter() - t_all,
    )  # fmt: skip
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(result, indent=1))
    out.with_suffix(".md").write_text(_markdown(result))
    print(_markdown(result))
    return 0


def _relative(path):
    """``path`` relative to the repository when inside it (results files name no machine paths)."""
    p = Path(path).resolve()
    return str(p.relative_to(ROOT)) if p.is_relative_to(ROOT) else str(path)


def _markdown(res):
    m = res["machine"]
    a = res["args"]
    lines = [
        "# Design feasibility: adam on (m_w, F_f) against every criterion",
        "",
        f"Machine: {m.get('processor', '?')} ({m.get('cpu_count', '?')} logical CPUs). JAX {m.get('jax', '?')} on "
        f"{m.get('jax_backend', '?')}, float64, load average (1/5/15 min) at the end {m.get('load_average_1_5_15_min')}. Generated by `python experiments/design_feasibility.py` "
        f"in {res['total_s']:.0f} s.",
        "",
        f"Rigid level, cable damping beta = {a['cable_damping']} s, t_end 1.2 s. Training batch: {a['n']} "
        f"Table 8 captures (seed 0); check batch: {a['n_check']} fresh captures (seed 1). adam, "
        f"learning rate {a['lr']}, {a['steps']} steps from each start design. Objective weights: expected "
        f"cost {a['expected']}, CVaR_{a['alpha']} of {a['tail_criterion']}, penalties 100. *margin*: the penalties "
        "act above (1 - margin) x each limit. Success = z_max < 10 m, a_max < 5 g, sigma_max < 800 MPa.",
        "",
        "| start | margin | point | step | m_w [kg] | F_f [N] | train success | train worst z / a / sigma | "
        "fresh success | fresh worst z / a / sigma | adam wall [s] |",
        "|---|---:|---|---:|---:|---:|---:|---|---:|---|---:|",
    ]
    for r in res["runs"]:
        for label, p in r["points"].items():
            if p is None:
                lines.append(f"| {r.get('start', 'paper')} | {r['margin']} | {label} | never | | | | | | | |")
                continue
            tw = p["train_worst"]
            fw = p["fresh_worst"]
            lines.append(
                f"| {r.get('start', 'paper')} | {r['margin']} | {label} | {p['step']} | {p['m_w_kg']:.0f} | {p['F_f_N']:.4g} | "
                f"{p['train_success']:.0%} | {tw['z_max_m']:.2f} m / {tw['a_max_g']:.2f} g / "
                f"{tw['sigma_max_mpa']:.0f} MPa | {p['fresh_success']:.0%} | {fw['z_max_m']:.2f} m / "
                f"{fw['a_max_g']:.2f} g / {fw['sigma_max_mpa']:.0f} MPa | {r['wall_s']:.0f} |"
            )
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
