"""Line-throwing launch design: adam (optax, gradients through the solve) vs Nelder-Mead.

Maximises the range of the calibrated line-throwing rocket over the launch angle and the rope
diameter (same material: density ~ d^2) under a landing-speed and a rope-pull limit
(:mod:`jaxcable.throw.design`; the limits are illustrative, see its docstring). Both optimisers
start from the flight-tested design (30 deg, 10 mm) on the same reparametrised objective; the
history records every evaluation. The best designs are re-flown with finer rope segments. A coarse
grid of the objective's parts over (angle, diameter) draws the landscape with both paths.

Every jitted function is called once before it is timed (histories' wall times exclude
compiling). Writes ``experiments/results/design_throw.{json,md,png}``. Usage:
    python experiments/design_throw.py --steps 60 --lr 0.2 --nm-evals 80   # the results (~15 min, busy cores)
    python experiments/design_throw.py --quick         # a few steps, experiments/out/
    python experiments/design_throw.py --replot        # rewrite .md/.png from the .json
"""

from __future__ import annotations

import argparse
import json
import time

import _report
import jax.numpy as jnp
import numpy as np

import jaxcable
from jaxcable.throw.design import (
    THROW_CRITERIA,
    calibrated_start,
    nelder_mead_throw,
    optimise_throw,
    throw_objective_and_grad,
    throw_objective_value,
    throw_problem,
    throw_report,
)

STEM = "design_throw"


def parse():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=30, help="adam steps")
    p.add_argument("--lr", type=float, default=0.1, help="adam learning rate in u")
    p.add_argument("--nm-evals", type=int, default=60, help="Nelder-Mead evaluations")
    p.add_argument("--segment-length", type=float, default=10.0, help="segments of the design model [m]")
    p.add_argument("--check-segment-length", type=float, default=2.0, help="segments of the re-check [m]")
    p.add_argument("--grid", type=int, nargs=2, default=(9, 7), metavar=("N_ANGLE", "N_DIAMETER"))
    p.add_argument("--quick", action="store_true", help="4 steps, 8 evaluations, 3x3 grid, experiments/out/")
    p.add_argument("--replot", action="store_true")
    p.add_argument("--out", help="report folder (default experiments/results; --quick: experiments/out)")
    a = p.parse_args()
    if a.quick:
        a.steps, a.nm_evals, a.grid = 4, 8, (3, 3)
    return a


def run(args):
    jaxcable.enable_x64()
    report = _report.start(precision=_report.precision())
    problem = throw_problem("angle_deg,rope_diameter_m", segment_length_m=args.segment_length)
    x0 = calibrated_start(problem)
    u0 = problem.space.to_unconstrained(x0)
    t = time.perf_counter()
    throw_objective_and_grad(problem, u0)[0].block_until_ready()
    compile_grad = time.perf_counter() - t
    t = time.perf_counter()
    throw_objective_value(problem, u0)[0].block_until_ready()
    compile_value = time.perf_counter() - t

    def progress(i, j, x, aux):
        print(f"  adam {i:3d}  J = {j:+.5f}  angle {x[0]:.3f} deg, d {1e3 * x[1]:.3f} mm  "
              f"range {float(aux['range_m']):.1f} m, v {float(aux['impact_speed_mps']):.2f} m/s, "
              f"T {float(aux['max_tension_N']):.0f} N", flush=True)  # fmt: skip

    adam = optimise_throw(problem, x0, steps=args.steps, learning_rate=args.lr, callback=progress)
    nm = nelder_mead_throw(problem, x0, max_evaluations=args.nm_evals)
    print(f"  nelder-mead: best J = {nm.objective.min():+.5f} after {len(nm.objective)} evaluations", flush=True)

    def reach(hist, target):
        r = hist.evaluations_to_reach(target)
        return None if r is None else dict(evaluations=r[0], wall_s=r[1])

    # "the same objective": adam's best, and 0.1 % of the reference range above it
    target = float(adam.objective.min())
    tol = 1e-3
    comparison = {
        "target_objective": target,
        "tolerance": tol,
        "adam": reach(adam, target + tol),
        "nelder_mead": reach(nm, target + tol),
        "nelder_mead_best": float(nm.objective.min()),
    }

    # start and best designs, evaluated on the design model and re-flown with finer segments
    fine = throw_problem("angle_deg,rope_diameter_m", segment_length_m=args.check_segment_length)
    designs = {}
    for name, x in (("start", np.asarray(x0)), ("adam", adam.x[adam.best]), ("nelder_mead", nm.x[nm.best])):
        u = problem.space.to_unconstrained(jnp.asarray(x))
        _, aux = throw_objective_value(problem, u)
        _, aux_f = throw_objective_value(fine, u)
        designs[name] = dict(model=throw_report(problem, aux), check=throw_report(fine, aux_f))

    # landscape on a grid (forward only)
    na, nd = args.grid
    lo, hi = np.asarray(problem.space.lower), np.asarray(problem.space.upper)
    angles = np.linspace(20.0, 45.0, na)
    diameters = np.linspace(0.005, 0.012, nd)
    grid = {k: np.full((nd, na), np.nan) for k in (*THROW_CRITERIA, "objective")}
    for i, d in enumerate(diameters):
        for k, a in enumerate(angles):
            j, aux = throw_objective_value(problem, problem.space.to_unconstrained(jnp.array([a, d])))
            grid["objective"][i, k] = float(j)
            for c in THROW_CRITERIA:
                grid[c][i, k] = float(aux[c])
        print(f"  grid row {i + 1}/{nd}", flush=True)

    return dict(
        problem=dict(
            variables=list(problem.space.names),
            bounds={n: [float(a), float(b)] for n, a, b in zip(problem.space.names, lo, hi)},
            segment_length_m=args.segment_length,
            check_segment_length_m=args.check_segment_length,
            rope_length_m=float(problem.scene.rope.length_m),
            solver=dict(solver=problem.solver, rtol=problem.rtol, atol=problem.atol),
            gradient=problem.gradient,
            limits=dict(landing_speed_mps=float(problem.limits.landing_speed_mps), max_tension_N=float(problem.limits.max_tension_N)),
            weights=dict(range_reference_m=float(problem.weights.range_reference_m), speed_penalty=float(problem.weights.speed_penalty),
                         tension_penalty=float(problem.weights.tension_penalty), tension_width_N=float(problem.weights.tension_width_N),
                         margin=float(problem.weights.margin)),
        ),  # fmt: skip
        compile_s=dict(value=compile_value, value_and_grad=compile_grad),
        adam=adam.as_json(),
        adam_settings=dict(steps=args.steps, lr=args.lr),
        nelder_mead=nm.as_json(),
        comparison=comparison,
        designs=designs,
        grid=dict(angle_deg=angles.tolist(), diameter_m=diameters.tolist(), **{k: v.tolist() for k, v in grid.items()}),
        **report,
    )


def write_md(res, path):
    pr, c = res["problem"], res["comparison"]
    lines = [
        "# Line-throwing launch design: adam vs Nelder-Mead",
        "",
        *_report.header(res),
        "",
        f"Maximise the range over {', '.join(pr['variables'])} (bounds {pr['bounds']}) with the landing speed "
        f"<= {pr['limits']['landing_speed_mps']:g} m/s and the rope's pull on the rocket <= {pr['limits']['max_tension_N']:g} N "
        f"(squared-hinge penalties from {100 * (1 - pr['weights']['margin']):g} % of each limit, weight "
        f"{pr['weights']['speed_penalty']:g}; range / {pr['weights']['range_reference_m']:g} m). "
        f"Calibrated scene, {pr['segment_length_m']:g} m segments, {pr['rope_length_m']:g} m of rope, "
        f"{pr['solver']['solver']} rtol {pr['solver']['rtol']:g}; gradients in {pr['gradient']} mode. "
        f"Compile: objective {res['compile_s']['value']:.0f} s, objective + gradient {res['compile_s']['value_and_grad']:.0f} s.",
        "",
        "| design | angle [deg] | rope d [mm] | range [m] | landing speed [m/s] | max pull [N] | within limits | "
        f"range at {pr['check_segment_length_m']:g} m segments | landing speed | max pull |",
        "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|",
    ]
    for name, d in res["designs"].items():
        m, k = d["model"], d["check"]
        lines.append(
            f"| {name} | {m['design']['angle_deg']:.2f} | {1e3 * m['design']['rope_diameter_m']:.2f} | {m['range_m']:.1f} | "
            f"{m['impact_speed_mps']:.2f} | {m['max_tension_N']:.0f} | {m['within_limits']} | {k['range_m']:.1f} | "
            f"{k['impact_speed_mps']:.2f} | {k['max_tension_N']:.0f} |"
        )
    a, n = res["adam"], res["nelder_mead"]
    lines += [
        "",
        "| optimiser | evaluations | wall time [s] | best J | evaluations to adam's best + 1e-3 | wall time to it [s] |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for key, h in (("adam", a), ("nelder_mead", n)):
        r = c[key]
        reach_evals = "-" if r is None else str(r["evaluations"])
        reach_wall = "-" if r is None else f"{r['wall_s']:.1f}"
        lines.append(
            f"| {h['method']} | {len(h['objective'])} | {h['wall_s'][-1]:.1f} | {min(h['objective']):+.5f} | "
            f"{reach_evals} | {reach_wall} |"
        )
    lines += [
        "",
        "An adam evaluation is the objective and its gradient (forward mode: the two tangents ride along the same",
        "solve); a Nelder-Mead evaluation is the objective alone. Wall times exclude compiling.",
        "",
        "![design_throw](design_throw.png)",
    ]
    _report.write_lines(path, lines)


def plot(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, n, g = res["adam"], res["nelder_mead"], res["grid"]
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.3))
    # distance to the best objective either optimiser found (log scale shows the convergence)
    best = min(min(a["objective"]), min(n["objective"]))
    ja = np.asarray(a["objective"]) - best + 1e-6
    jn = np.minimum.accumulate(n["objective"]) - best + 1e-6
    ax[0].semilogy(np.arange(len(ja)) + 1, ja, "o-", ms=3, label="adam (value + gradient)")
    ax[0].semilogy(np.arange(len(jn)) + 1, jn, "s-", ms=3, label="Nelder-Mead (best so far)")
    ax[0].set_xlabel("objective evaluations")
    ax[0].set_ylabel("J - J_best + 1e-6  (J = -range/600 m + penalties)")
    ax[0].legend(fontsize=8)
    ax[1].semilogy(a["wall_s"], ja, "o-", ms=3, label="adam")
    ax[1].semilogy(n["wall_s"], jn, "s-", ms=3, label="Nelder-Mead")
    ax[1].set_xlabel("wall time [s] (compiled)")
    ax[1].legend(fontsize=8)
    ang, dia = np.asarray(g["angle_deg"]), 1e3 * np.asarray(g["diameter_m"])
    cs = ax[2].contourf(ang, dia, np.asarray(g["range_m"]), levels=15, cmap="viridis")
    fig.colorbar(cs, ax=ax[2], label="range [m]")
    lim = res["problem"]["limits"]
    c1 = ax[2].contour(ang, dia, np.asarray(g["impact_speed_mps"]), levels=[lim["landing_speed_mps"]], colors="w")
    c2 = ax[2].contour(ang, dia, np.asarray(g["max_tension_N"]), levels=[lim["max_tension_N"]], colors="r")
    ax[2].clabel(c1, fmt=f"v = {lim['landing_speed_mps']:g} m/s", fontsize=7)
    ax[2].clabel(c2, fmt=f"T = {lim['max_tension_N']:g} N", fontsize=7)
    xa, xn = np.asarray(a["x"]), np.asarray(n["x"])
    ax[2].plot(xa[:, 0], 1e3 * xa[:, 1], "o-", color="orange", ms=3, label="adam")
    ax[2].plot(xn[:, 0], 1e3 * xn[:, 1], "s", color="m", ms=3, label="Nelder-Mead evaluations")
    ax[2].set_xlim(ang.min(), ang.max())
    ax[2].set_ylim(dia.min(), dia.max())
    ax[2].set_xlabel("launch angle [deg]")
    ax[2].set_ylabel("rope diameter [mm]")
    ax[2].legend(fontsize=7, loc="upper right")
    fig.suptitle("line-throwing launch design: range under a landing-speed and a rope-pull limit", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main():
    args = parse()
    out = _report.output_dir(args.out, quick=args.quick)
    if args.replot:
        res = json.loads((out / f"{STEM}.json").read_text())
        write_md(res, out / f"{STEM}.md")
    else:
        res = run(args)
        _report.finish(res, out, STEM, write_md)
    plot(res, out / f"{STEM}.png")
    print((out / f"{STEM}.md").read_text())


if __name__ == "__main__":
    main()
