"""The buffer design at the calibrated cable damping, checked at the full level (not a test).

The gradient-based design runs at the rigid level (``jaxcable design``: reverse or forward mode
through a vmapped batch of Table 8 captures, seconds per step); the full level (ALE cables with
mass over pulleys, hook-cable contact, the flexible rocket with sprung hooks) costs about a minute
per landing here. So the design is searched at the rigid level and then checked where it matters:

1. adam on (m_w, F_f) from the paper's design over ``--n`` Table 8 captures (scenario I, seed 0),
   minimising the CVaR of each case's worst normalised criterion with a 1% margin (the objective
   that asks for every criterion in every case, ``docs/design.md``), at the scenes' calibrated
   cable damping; the design kept is the lowest objective among the steps with the highest
   success rate (what ``jaxcable design`` reports);
2. the paper's design and the kept design at the full level (the default 32-element mesh, the
   W-method at the level's tolerance), on the design case (centre, vertical, 20 m/s) and on the
   ``--check`` captures of the batch whose rigid-level worst normalised criterion is largest at the
   kept design: z_max, a_max, sigma_max and the stop, beside the rigid level's values.

Writes ``experiments/results/design_full_check.{json,md}``.

    python experiments/design_full_check.py                 # ~15 min on 2 cores
    python experiments/design_full_check.py --quick         # fewer steps and checks, experiments/out/
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np
from _report import finish, header, output_dir, start, write_lines

import jaxcable
from jaxcable.arresting.design import (
    ObjectiveWeights,
    design_problem,
    optimise,
    paper_start,
)
from jaxcable.arresting.design_objective import (
    criterion_limit,
    evaluation_report,
    history_record,
)
from jaxcable.arresting.design_setup import design_buffer
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.layout import CaptureState
from jaxcable.arresting.passive import DEFAULT_CABLE_DAMPING_S
from jaxcable.studies.optimise import beats_kept

STEM = "design_full_check"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa")


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--n",
        type=int,
        default=16,
        help="Table 8 captures in the design batch (default 16)",
    )
    p.add_argument("--steps", type=int, default=40, help="adam steps (default 40)")
    p.add_argument(
        "--check",
        type=int,
        default=3,
        help="batch captures checked at the full level (default 3)",
    )
    p.add_argument(
        "--t-end",
        type=float,
        default=1.2,
        help="simulated time after capture [s] (default 1.2)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="8 captures, 10 steps, 1 check; report to experiments/out/",
    )
    p.add_argument(
        "--out",
        help="report folder (default experiments/results, --quick: experiments/out)",
    )
    args = p.parse_args(argv)
    if args.quick:
        args.n, args.steps, args.check = 8, 10, 1
    return args


def landing_row(level, capture, buffer, t_end):
    t0 = time.perf_counter()
    run = run_landing(level, capture, buffer=buffer, t_end_s=t_end)
    o = run.outputs
    row = {k: float(o[k]) for k in KEYS}
    row.update(stopped=bool(o["stopped"]), criteria_met=bool(o["criteria_met"]), solver_status=o["solver_status"],
               energy_budget_error=float(o["energy_budget_error"]), wall_s=time.perf_counter() - t0)  # fmt: skip
    return row


def main(argv=None):
    args = parse_args(argv)
    jaxcable.enable_x64()
    out = output_dir(args.out, quick=args.quick)
    data = start(
        n=args.n,
        steps=args.steps,
        check=args.check,
        t_end_s=args.t_end,
        cable_damping_s=DEFAULT_CABLE_DAMPING_S,
    )
    weights = ObjectiveWeights(
        expected=0.0, tail_criterion="worst", alpha=0.9, margin=0.01
    )
    problem = design_problem("m_w,F_f", n=args.n, t_end_s=args.t_end, weights=weights)
    x0 = paper_start(problem)
    record = history_record(problem)
    kept = {}

    def progress(i, j, x, aux):
        success = record(aux)[1]
        if i == 0:
            kept["start"] = aux
        if beats_kept(kept.get("best"), success, float(j)):
            kept["best"] = {
                "j": float(j),
                "aux": aux,
                "success": float(success),
                "step": i,
                "x": np.asarray(x),
            }
        print(f"  step {i:3d}  J = {float(j):.5f}  success {float(success):.2f}  " + ", ".join(
            f"{k} = {v:.6g}" for k, v in problem.space.as_dict(x).items()), flush=True)  # fmt: skip

    t0 = time.perf_counter()
    optimise(problem, x0, steps=args.steps, callback=progress)
    data["design_wall_s"] = time.perf_counter() - t0
    best = kept["best"]
    data["before"] = evaluation_report(problem, kept["start"])
    data["after"] = evaluation_report(problem, best["aux"])
    data["best_step"] = best["step"]
    # the batch captures the kept design finds hardest at the rigid level
    hard = {k: np.asarray(best["aux"]["hard"][k], float) for k in KEYS}
    worst = np.max(
        np.stack([hard[k] / criterion_limit(problem, k) for k in KEYS]), axis=0
    )
    picks = [int(i) for i in np.argsort(-worst)[: args.check]]
    captures = [("design case", CaptureState())] + [
        (
            f"batch case {j}",
            jax.tree_util.tree_map(lambda v, j=j: v[j], problem.captures),
        )
        for j in picks
    ]
    designs = {"paper": np.asarray(x0), "designed": best["x"]}
    data["designs"] = {name: problem.space.as_dict(x) for name, x in designs.items()}
    data["checks"] = []
    for label, capture in captures:
        for name, x in designs.items():
            buffer = design_buffer(problem, jax.numpy.asarray(x))
            for level in ("rigid", "full"):
                row = landing_row(level, capture, buffer, args.t_end)
                row.update(
                    case=label,
                    design=name,
                    level=level,
                    x_m=float(capture.x_m),
                    y_m=float(capture.y_m),
                )
                data["checks"].append(row)
                print(f"  {label:14s} {name:8s} {level:5s} " + "  ".join(f"{k} {row[k]:.3f}" for k in KEYS)
                      + f"  met {row['criteria_met']}  ({row['wall_s']:.0f} s)", flush=True)  # fmt: skip
        jax.clear_caches()
    finish(data, out, STEM, write_md)


def write_md(data, path):
    lines = [
        "# The buffer design at the calibrated cable damping, checked at the full level",
        "",
        *header(data),
        "",
    ]
    d = data["designs"]
    a, b = data["after"]["criteria"], data["before"]["criteria"]
    lines += [
        (
            f"Design batch: {data['n']} Table 8 captures (scenario I, seed 0), still air, {data['t_end_s']} s after capture, "
            f"cable damping {data['cable_damping_s']:g} s; adam, {data['steps']} steps from the paper's design, objective: "
            "CVaR (alpha 0.9) of each case's worst normalised criterion, margin 1%. "
            f"Design time {data['design_wall_s']:.0f} s (rigid level, with compiling)."
        ),
        "",
        "| design | m_w [kg] | F_f [N] | rigid-level success on the batch |",
        "|---|---:|---:|---:|",
        f"| paper (section II.B) | {d['paper']['m_w']:.1f} | {d['paper']['F_f']:.4g} | {b['success_rate']:.0%} |",
        f"| designed (step {data['best_step']}) | {d['designed']['m_w']:.1f} | {d['designed']['F_f']:.4g} | {a['success_rate']:.0%} |",
        "",
        (
            "Checks (limits: z_max < 10 m, a_max < 5 g, sigma_max < 800 MPa; the full level on its default "
            "32-element mesh and the W-method):"
        ),
        "",
        "| case (capture x, y [m]) | design | level | z_max [m] | a_max [g] | sigma_max [MPa] | stopped | criteria met | energy budget | time [s] |",
        "|---|---|---|---:|---:|---:|---|---|---:|---:|",
    ]
    for r in data["checks"]:
        lines.append(
            f"| {r['case']} ({r.get('x_m', 0.0):.1f}, {r.get('y_m', 0.0):.1f}) | {r['design']} | {r['level']} | {r['z_max_m']:.3f} | {r['a_max_g']:.3f} | "
            f"{r['sigma_max_mpa']:.1f} | {r['stopped']} | {r['criteria_met']} | {r['energy_budget_error']:.1e} | {r['wall_s']:.0f} |"
        )
    write_lines(path, lines)


if __name__ == "__main__":
    main()
