"""Gradient-based buffer design at the ALE level on the design case (not a test).

``experiments/design_ale_check.py`` (session 8) searched m_w, F_f and a 4-knot brake profile with
Nelder-Mead at the ale level (70 landings) and found no design below a_max = 6.61 g on the design
case (central, vertical, 20 m/s; Table 1 layout). Since session 9 the ale-level gradient costs about
6x a forward run in reverse mode (sparse contact derivative), so this script asks the same question
with gradients: L-BFGS (:func:`jaxcable.arresting.design.lbfgs`, reverse mode through the ale solve) on the
design objective with the worst normalised criterion as its tail (``tail_criterion="worst"``, no
expected-cost term, the default squared penalties), over m_w, F_f and a K-knot profile, from
Table 1's buffer (the paper's m_w and F_f with a flat profile). It then lands the best design with
:func:`jaxcable.arresting.landing.run_landing` at ``rigid``, ``ale`` and ``full``.

Writes ``experiments/results/design_ale_gradient.{json,md}``. Usage:
    python experiments/design_ale_gradient.py                       # ~20 min on 2 cores
    python experiments/design_ale_gradient.py --evals 3 --t-end 0.3 --out experiments/out   # quick
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import _report
import jax
import jax.numpy as jnp
import numpy as np
from design_ale_check import LIMITS, land

import jaxcable
from jaxcable.arresting.layout import CaptureState
from jaxcable.arresting.design import ObjectiveWeights, _host_built_scenes, design_problem, lbfgs


def design_case_problem(knots, t_end, fidelity="ale"):
    variables = "m_w,F_f" + (f",profile:{knots}" if knots else "")
    weights = ObjectiveWeights(expected=0.0, tail_criterion="worst")
    p = design_problem(variables, n=1, fidelity="rigid", t_end_s=t_end, gradient="reverse", weights=weights)
    captures = jax.tree_util.tree_map(lambda v: jnp.asarray(v)[None], CaptureState())
    scenes = _host_built_scenes(fidelity, captures, p.layout, p.buffer, t_end, p.cable_damping_s)
    from jaxcable.arresting.landing import LEVEL_DEFAULTS

    rtol = LEVEL_DEFAULTS[fidelity][1]
    return dataclasses.replace(p, captures=captures, scenes=scenes, fidelity=fidelity, rtol=rtol, atol=rtol)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--knots", type=int, default=4, help="brake-profile knots K (0: constant brake)")
    p.add_argument("--evals", type=int, default=30, help="L-BFGS evaluations (value and gradient)")
    p.add_argument("--t-end", type=float, default=1.0, help="simulated time after capture [s]")
    p.add_argument("--out", default=None, help="output folder (default experiments/results)")
    args = p.parse_args()
    jaxcable.enable_x64()
    out_dir = _report.output_dir(args.out)
    data = _report.start(knots=args.knots, t_end_s=args.t_end)
    t_start = time.perf_counter()
    problem = design_case_problem(args.knots, args.t_end)
    space = problem.space
    x0 = np.asarray([920.0, 3.13e5] + [1.0] * args.knots)  # Table 1, flat profile (inside the default bounds)
    rows = []

    def callback(i, j, x, aux):
        hard = {k: float(np.asarray(aux["hard"][k])[0]) for k in LIMITS}
        rows.append(dict(evaluation=i, objective=j, x=space.as_dict(x), wall_s=time.perf_counter() - t_start, **hard))
        print(f"eval {i}: J {j:.4f}  z {hard['z_max_m']:.2f} m  a {hard['a_max_g']:.2f} g  "
              f"sigma {hard['sigma_max_mpa']:.0f} MPa  {space.as_dict(x)}", flush=True)  # fmt: skip

    history = lbfgs(problem, x0, max_evaluations=args.evals, callback=callback)
    best = int(np.argmin(history.objective))
    x_best = np.asarray(history.x[best])
    landed = {level: land(level, space, x_best, args.t_end) for level in ("rigid", "ale", "full")}
    start = {level: land(level, space, x0, args.t_end) for level in ("ale",)}
    data.update(
        evaluations=len(history.objective), objective=history.objective.tolist(),
        wall_s_history=history.wall_s.tolist(), accepted=rows, best_index=best, best_design=space.as_dict(x_best),
        best_objective=float(history.objective[best]), start_design=space.as_dict(x0), start_landed=start, landed=landed,
    )  # fmt: skip
    _report.finish(data, out_dir, "design_ale_gradient", write_md)


def write_md(data, path):
    L = [
        "# Gradient-based buffer design at the ale level (design case)",
        "",
        *_report.header(data),
        "",
        f"L-BFGS, reverse-mode gradients through the ale solve ({data['t_end_s']} s, Bosh3 1e-4), {data['evaluations']} "
        f"evaluations (value and gradient), variables m_w, F_f and {data['knots']} profile factors, objective: "
        "the worst normalised smooth criterion plus the default squared penalties. Start: Table 1's buffer, flat profile.",
        "",
        "| accepted evaluation | objective | z_max [m] | a_max [g] | sigma_max [MPa] | wall [s] | design |",
        "|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in data["accepted"]:
        d = ", ".join(f"{k} {v:.4g}" for k, v in r["x"].items())
        L.append(f"| {r['evaluation']} | {r['objective']:.4f} | {r['z_max_m']:.3f} | {r['a_max_g']:.3f} | "
                 f"{r['sigma_max_mpa']:.1f} | {r['wall_s']:.0f} | {d} |")  # fmt: skip
    L += ["", "Best design landed by `run_landing` at each level:", "",
          "| level | z_max [m] | a_max [g] | sigma_max [MPa] | worst normalised | status |", "|---|---:|---:|---:|---:|---|"]  # fmt: skip
    for level, o in data["landed"].items():
        L.append(f"| {level} | {o['z_max_m']:.3f} | {o['a_max_g']:.3f} | {o['sigma_max_mpa']:.1f} | {o['worst']:.3f} | {o['status']} |")
    o = data["start_landed"]["ale"]
    L += ["", f"Start design at ale: z_max {o['z_max_m']:.3f} m, a_max {o['a_max_g']:.3f} g, sigma_max "
          f"{o['sigma_max_mpa']:.1f} MPa (worst {o['worst']:.3f})."]  # fmt: skip
    path.write_text("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
