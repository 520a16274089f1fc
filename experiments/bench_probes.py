"""Probes inside the solver's loop or after it: the same batch, side by side (not a test).

``jaxcable.core.simulate`` saves a scene's output histories (its ``probe``) on a grid of times. It can
call the probe inside diffrax's loop at each saved time (``probes_after=False``), or save the
state there and call the probe once, vectorised, on all saved states after the solve
(``probes_after=True``). ``None`` (the default) picks "after" when the state is no larger than the
probe's output (:func:`jaxcable.core.simulate.probes_after_solve`): the rigid landing level.

This script times both on the design problem's batch (rigid level, Table 8 captures of scenario I,
scrambled Halton seed 0, t_end = 1.2 s, Tsit5 rtol = atol = 1e-6, 1201 saved samples, the paper's
m_w and F_f (eq 19)), for three jitted functions of (m_w, F_f): the batch mean of the smooth
criteria (forward), its forward-mode Jacobian (``diffrax.ForwardMode`` + ``jax.jacfwd``) and its
reverse-mode gradient (``RecursiveCheckpointAdjoint`` with ``jaxcable.arresting.design.REVERSE_CHECKPOINTS``).
Every function is compiled first; then all are called in turn, round by round (``--repeats``), so a
change of the machine's load hits all alike, and each keeps its best time. It checks that the two
ways give the same values and gradients.

Writes ``experiments/results/bench_probes.{json,md}``. Usage:
    python experiments/bench_probes.py                 # n = 8 and 32, ~5 min on 2 cores
    python experiments/bench_probes.py --n 8 --repeats 2 --out experiments/out   # quick
"""

from __future__ import annotations

import argparse
import time

import _report
import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxcable
from jaxcable.arresting.passive import smooth_landing_outputs
from jaxcable.arresting.design import REVERSE_CHECKPOINTS, _scene, design_problem, paper_start
from jaxcable.core.provenance import machine_info
from jaxcable.core.simulate import simulate


def parse_args():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--n", nargs="+", type=int, default=[8, 32], help="batch sizes")
    p.add_argument("--repeats", type=int, default=4, help="timed rounds (best kept)")
    p.add_argument("--out", default=None, help="output folder (default experiments/results)")
    return p.parse_args()


def functions(problem, probes_after):
    """Forward value, forward-mode Jacobian and reverse-mode gradient of the batch-mean smooth
    criteria (z_max/10 m + a_max/5 g + sigma_max/800 MPa) w.r.t. (m_w, F_f)."""

    def mean_criteria(x, adjoint):
        def one(capture):
            res = simulate(
                _scene(problem, capture, x), problem.t_end_s, rtol=problem.rtol, atol=problem.atol,
                max_steps=problem.max_steps, adjoint=adjoint, probes_after=probes_after,
            )  # fmt: skip
            s = smooth_landing_outputs(res.ts, res.probes, problem.widths)
            return s["z_max_m"] / 10.0 + s["a_max_g"] / 5.0 + s["sigma_max_mpa"] / 800.0

        return jnp.mean(jax.vmap(one)(problem.captures))

    reverse = diffrax.RecursiveCheckpointAdjoint(checkpoints=REVERSE_CHECKPOINTS)
    return {
        "forward": eqx.filter_jit(lambda x: mean_criteria(x, None)),
        "forward_mode_grad": eqx.filter_jit(lambda x: jax.jacfwd(lambda x_: mean_criteria(x_, diffrax.ForwardMode()))(x)),
        "reverse_mode_grad": eqx.filter_jit(lambda x: jax.value_and_grad(lambda x_: mean_criteria(x_, reverse))(x)),
    }


def run(n, repeats):
    problem = design_problem("m_w,F_f", n=n, t_end_s=1.2)
    x = paper_start(problem)
    calls = {}
    for where, flag in (("inside", False), ("after", True)):
        for name, fn in functions(problem, flag).items():
            calls[(name, where)] = fn
    compile_s, outs, times = {}, {}, {k: [] for k in calls}
    for key, fn in calls.items():
        t = time.perf_counter()
        outs[key] = jax.block_until_ready(fn(x))
        compile_s[key] = time.perf_counter() - t
    for _ in range(repeats):
        for key, fn in calls.items():
            t = time.perf_counter()
            jax.block_until_ready(fn(x))
            times[key].append(time.perf_counter() - t)
    rows = []
    for name in ("forward", "forward_mode_grad", "reverse_mode_grad"):
        inside, after = min(times[(name, "inside")]), min(times[(name, "after")])
        a, b = jax.tree_util.tree_leaves(outs[(name, "inside")]), jax.tree_util.tree_leaves(outs[(name, "after")])
        diff = max(float(np.max(np.abs(np.asarray(u) - np.asarray(v)) / np.maximum(np.abs(np.asarray(u)), 1e-300))) for u, v in zip(a, b))
        rows.append(dict(
            function=name, inside_s=inside, after_s=after, speedup=inside / after,
            compile_inside_s=compile_s[(name, "inside")] - inside, compile_after_s=compile_s[(name, "after")] - after,
            max_rel_diff=diff, runs_inside_s=times[(name, "inside")], runs_after_s=times[(name, "after")],
        ))  # fmt: skip
        print(f"n {n} {name}: inside {inside:.3f} s, after {after:.3f} s (x{inside / after:.2f}), max rel. diff {diff:.1e}", flush=True)
    fwd = {r["function"]: r for r in rows}["forward"]
    for r in rows:
        r["ratio_to_forward_inside"] = r["inside_s"] / fwd["inside_s"]
        r["ratio_to_forward_after"] = r["after_s"] / fwd["after_s"]
    return dict(n=n, rows=rows, load_average=machine_info()["load_average_1_5_15_min"])


def write_md(data, path):
    L = [
        "# Probes inside the solver's loop or after it",
        "",
        *_report.header(data),
        "",
        "Rigid level, design batch (Table 8 captures, scenario I), t_end = 1.2 s, Tsit5 1e-6, 1201 saved samples, "
        "paper design. Best of the rounds; speedup = inside / after; ratio = the function's time over the "
        "forward value's time done the same way; max rel. diff = largest relative difference between the two ways' "
        "results (values and gradients).",
        "",
        "| n | function | inside [s] | after [s] | speedup | ratio to forward (inside) | ratio to forward (after) | max rel. diff |",
        "|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    for block in data["runs"]:
        for r in block["rows"]:
            L.append(
                f"| {block['n']} | {r['function']} | {r['inside_s']:.3f} | {r['after_s']:.3f} | {r['speedup']:.2f} | "
                f"{r['ratio_to_forward_inside']:.2f} | {r['ratio_to_forward_after']:.2f} | {r['max_rel_diff']:.1e} |"
            )
    path.write_text("\n".join(L) + "\n")


def main():
    args = parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start(runs=[])
    for n in args.n:
        data["runs"].append(run(n, args.repeats))
    _report.finish(data, out, "bench_probes", write_md)


if __name__ == "__main__":
    main()
