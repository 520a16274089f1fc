"""Cost of the hook-cable contact's derivative at the ale level, side by side (not a test).

``AleCables.contact_tangent_pairs`` = M lets a JVP carry tangents through only the M contact pairs
of largest penetration (``jaxcable.arresting.cable_sets._contact_all_pairs``; the values are always
computed for all 512 pairs, and the derivative is exact while at most M pairs touch). ``None``
carries tangents through every pair.

Two sections, each with every variant compiled first and then called in turn, round by round
(``--repeats``), best time kept:

1. the ale vector field at a mid-landing state (the design case after 0.06 s): its value, a JVP
   with one random state tangent and a VJP, in microseconds a call;
2. the ale design objective over ``--t-end`` seconds (the design case, variables m_w and F_f):
   forward value, forward-mode gradient (``diffrax.ForwardMode`` + ``jax.jacfwd``) and
   reverse-mode gradient (``RecursiveCheckpointAdjoint``), with the ratio to the forward call and
   the largest relative difference of each gradient to the M = None one.

Writes ``experiments/results/bench_contact_tangent.{json,md}``. Usage:
    python experiments/bench_contact_tangent.py                 # ~6 min on 2 cores
    python experiments/bench_contact_tangent.py --repeats 1 --t-end 0.05 --out experiments/out
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import _report
import jax
import jax.numpy as jnp
import numpy as np

import jaxcable
from jaxcable.arresting.passive import passive_landing_scene
from jaxcable.core.simulate import simulate
VARIANTS = (None, 48, 24)


def with_pairs(scene, m):
    return dataclasses.replace(scene, cables=dataclasses.replace(scene.cables, contact_tangent_pairs=m))


def time_calls(calls, repeats, inner=1):
    """Compile each call, then time them round by round; best seconds per call."""
    outs, compile_s = {}, {}
    for k, (fn, args) in calls.items():
        t = time.perf_counter()
        outs[k] = jax.block_until_ready(fn(*args))
        compile_s[k] = time.perf_counter() - t
    best = {k: np.inf for k in calls}
    for _ in range(repeats):
        for k, (fn, args) in calls.items():
            t = time.perf_counter()
            for _ in range(inner):
                out = fn(*args)
            jax.block_until_ready(out)
            best[k] = min(best[k], (time.perf_counter() - t) / inner)
    return outs, compile_s, best


def vector_field_section(repeats):
    base = passive_landing_scene("ale", t_end_s=0.3)
    y = simulate(base, 0.06, solver="bosh3", rtol=1e-4, atol=1e-4, max_steps=100_000).final_state
    ty = jax.tree_util.tree_map(lambda x: jax.random.normal(jax.random.PRNGKey(0), x.shape), y)
    calls = {}
    for m in VARIANTS:
        sc = with_pairs(base, m)
        vf = lambda y_, sc=sc: sc.vector_field(0.06, y_)  # noqa: E731
        calls[(m, "value")] = (jax.jit(vf), (y,))
        calls[(m, "jvp")] = (jax.jit(lambda y_, t_, vf=vf: jax.jvp(vf, (y_,), (t_,))), (y, ty))
        calls[(m, "vjp")] = (jax.jit(lambda y_, vf=vf: jax.vjp(vf, y_)[1](vf(y_))), (y,))
    outs, _, best = time_calls(calls, repeats, inner=200)
    touching = int(base.probe(0.06, y)["contact_pairs_touching"])
    rows = []
    for m in VARIANTS:
        r = dict(m=m, **{f"{k}_us": best[(m, k)] * 1e6 for k in ("value", "jvp", "vjp")})
        for k in ("jvp", "vjp"):
            a = jax.tree_util.tree_leaves(outs[(None, k)])
            b = jax.tree_util.tree_leaves(outs[(m, k)])
            scale = max(float(jnp.max(jnp.abs(x))) for x in a if x.size)
            r[f"{k}_max_diff"] = max(float(jnp.max(jnp.abs(u - v))) for u, v in zip(a, b) if u.size) / scale
        rows.append(r)
        print(f"vf M={m}: value {r['value_us']:.0f} us, jvp {r['jvp_us']:.0f} us, vjp {r['vjp_us']:.0f} us", flush=True)
    return dict(touching=touching, rows=rows)


def design_section(repeats, t_end):
    from jaxcable.arresting.design import design_problem, objective, objective_value, paper_start, value_and_grad_by_mode, _adjoint

    calls, problems = {}, {}
    for mode in ("forward", "reverse"):
        p = design_problem("m_w,F_f", n=1, fidelity="ale", t_end_s=t_end, gradient=mode)
        for m in VARIANTS:
            pm = dataclasses.replace(p, scenes=with_pairs(p.scenes, m))
            problems[(m, mode)] = pm
            u = paper_start(pm)
            fn = jax.jit(lambda u_, pm=pm: value_and_grad_by_mode(lambda v: objective(pm, v, _adjoint(pm)), u_, pm.gradient)[:2])
            calls[(m, mode)] = (fn, (u,))
    for m in VARIANTS:
        pm = problems[(m, "forward")]
        calls[(m, "value")] = (lambda u_, pm=pm: objective_value(pm, u_)[0], (paper_start(pm),))
    outs, compile_s, best = time_calls(calls, repeats)
    rows = []
    for m in VARIANTS:
        fwd = best[(m, "value")]
        r = dict(m=m, forward_s=fwd, forward_compile_s=compile_s[(m, "value")] - fwd)
        for mode in ("forward", "reverse"):
            g, g0 = np.asarray(outs[(m, mode)][1]), np.asarray(outs[(None, mode)][1])
            r[f"{mode}_mode_s"] = best[(m, mode)]
            r[f"{mode}_mode_ratio"] = best[(m, mode)] / fwd
            r[f"{mode}_mode_compile_s"] = compile_s[(m, mode)] - best[(m, mode)]
            r[f"{mode}_mode_grad"] = g.tolist()
            r[f"{mode}_mode_max_rel_diff"] = float(np.max(np.abs(g - g0)) / max(float(np.max(np.abs(g0))), 1e-300))
        rows.append(r)
        print(f"design M={m}: forward {fwd:.2f} s, FM {r['forward_mode_s']:.2f} s (x{r['forward_mode_ratio']:.1f}), "
              f"reverse {r['reverse_mode_s']:.2f} s (x{r['reverse_mode_ratio']:.1f})", flush=True)  # fmt: skip
    return dict(t_end_s=t_end, rows=rows)


def write_md(data, path):
    L = [
        "# Contact derivative at the ale level: all pairs or the M deepest",
        "",
        *_report.header(data),
        "",
        "M = `AleCables.contact_tangent_pairs` (None: every one of the 512 pairs carries tangents). Best of "
        "the rounds, every variant timed in the same rounds.",
        "",
        f"## Vector field (design case at 0.06 s, {data['vf']['touching']} pairs touching), us a call",
        "",
        "| M | value | JVP | VJP | JVP / value | max diff of JVP to M = None | max diff of VJP |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in data["vf"]["rows"]:
        L.append(f"| {r['m']} | {r['value_us']:.0f} | {r['jvp_us']:.0f} | {r['vjp_us']:.0f} | "
                 f"{r['jvp_us'] / r['value_us']:.2f} | {r['jvp_max_diff']:.1e} | {r['vjp_max_diff']:.1e} |")  # fmt: skip
    d = data["design"]
    L += [
        "",
        f"## Design objective at the ale level (design case, m_w and F_f, {d['t_end_s']} s), s a call",
        "",
        "| M | forward | forward mode | ratio | reverse mode | ratio | max diff FM / reverse to M = None (relative to the largest component) | compile fwd / FM / rev [s] |",
        "|---|---:|---:|---:|---:|---:|---|---|",
    ]
    for r in d["rows"]:
        L.append(
            f"| {r['m']} | {r['forward_s']:.2f} | {r['forward_mode_s']:.2f} | {r['forward_mode_ratio']:.1f} | "
            f"{r['reverse_mode_s']:.2f} | {r['reverse_mode_ratio']:.1f} | {r['forward_mode_max_rel_diff']:.1e} / "
            f"{r['reverse_mode_max_rel_diff']:.1e} | {r['forward_compile_s']:.0f} / {r['forward_mode_compile_s']:.0f} / "
            f"{r['reverse_mode_compile_s']:.0f} |"
        )
    path.write_text("\n".join(L) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeats", type=int, default=3, help="timed rounds (best kept)")
    p.add_argument("--t-end", type=float, default=0.1, help="simulated time of the design objective [s]")
    p.add_argument("--out", default=None, help="output folder (default experiments/results)")
    args = p.parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start()
    data["vf"] = vector_field_section(args.repeats)
    data["design"] = design_section(args.repeats, args.t_end)
    _report.finish(data, out, "bench_contact_tangent", write_md)


if __name__ == "__main__":
    main()
