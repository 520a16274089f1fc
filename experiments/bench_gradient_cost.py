"""Where the forward-mode gradient's cost goes at the rigid level, n = 32 (not a test).

Issue 5's goal is a gradient at most 3x the forward call. At the rigid level the forward-mode
gradient (``diffrax.ForwardMode`` under ``jax.jacfwd``, variables m_w and F_f) costs 2.4x at
n = 8 and 3.7x at n = 32 (``bench_design.py``). Three measurements locate the cost, each
with its variants compiled first and then timed in turn, round by round (best of ``--repeats``):

1. **diffrax's loop alone**: a linear ODE with 25 numbers (the rigid state's size), Tsit5, PID
   1e-12, vmapped over 8 or 32 cases, with 11 or 1201 saved times (the design grid): forward call
   against ``jax.jacfwd`` over 2 parameters with ``ForwardMode``. The vector field costs next
   to nothing, so this is the loop's bookkeeping (solver stages, controller, saving) with tangents.
2. **the rigid vector field's tangent**: its value against its value plus 2 state tangents
   (``jax.jvp`` vmapped), and the same for its parts (hook kinematics, the cables' response with
   the hook kinematics, the rocket's accelerations with the hook kinematics), at mid-landing
   states (the design batch after 0.3 s), 32 cases, evaluated 200 times inside one
   ``lax.fori_loop`` so that no call overhead enters.
3. **the design objective, n = 32**: forward; ``ForwardMode``; the same derivative from one
   *augmented* ODE (the state and its 2 tangents ``S' = df/dy S + df/dp dp`` as ordinary state,
   the step size controlled on the state alone, so the steps and the discrete derivative are
   those of ``ForwardMode``: the gradients agree to round-off); and that augmented system with the
   tangents' right-hand side replaced by ``-S`` (the loop's cost on a state 3x as large, without
   the vector field's tangent).

Writes ``experiments/results/bench_gradient_cost.{json,md}``. Usage:
    python experiments/bench_gradient_cost.py                 # ~5 min on 2 cores
    python experiments/bench_gradient_cost.py --repeats 1 --n 4 --out experiments/out
"""

from __future__ import annotations

import argparse
import _report
import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

import jaxcable
from jaxcable.arresting.passive import smooth_landing_outputs
from jaxcable.arresting.design import (
    LEVEL_DEFAULTS,
    LEVEL_STEP_CONTROL,
    _scene,
    design_problem,
    objective_and_grad,
    objective_terms,
    objective_value,
    paper_start,
)
from jaxcable.core.simulate import make_solver, simulate


# ---- 1. diffrax's loop on a trivial vector field ----------------------------------------------


def loop_section(repeats, batches):
    n_state = 25
    A = -3.0 * jnp.eye(n_state) + 0.1 * jnp.ones((n_state, n_state)) / n_state

    def solve(p, n_save):
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(lambda t, y, a: (A * a) @ y), diffrax.Tsit5(), 0.0, 1.2, 1e-3, jnp.ones(n_state) * p,
            args=p, saveat=diffrax.SaveAt(ts=jnp.linspace(0.0, 1.2, n_save)),
            stepsize_controller=diffrax.PIDController(rtol=1e-12, atol=1e-12), max_steps=20_000,
            adjoint=diffrax.ForwardMode(),
        )  # fmt: skip
        return jnp.sum(jnp.max(sol.ys, axis=0) ** 2)

    rows = []
    for batch in batches:
        for n_save in (11, 1201):
            P, q = jnp.linspace(1.0, 2.0, batch), jnp.ones(2)

            def obj(q_, n_save=n_save, P=P):
                return jnp.sum(jax.vmap(lambda p: solve(p * q_[0] * q_[1], n_save))(P))

            fwd, fm = jax.jit(obj), jax.jit(jax.jacfwd(obj))
            _, _, best = _report.time_rounds(dict(forward=lambda: fwd(q), forward_mode=lambda: fm(q)), repeats)
            rows.append(dict(batch=batch, n_save=n_save, forward_s=best["forward"], forward_mode_s=best["forward_mode"],
                             ratio=best["forward_mode"] / best["forward"]))  # fmt: skip
            print(f"loop batch {batch} saves {n_save}: ratio {rows[-1]['ratio']:.2f}", flush=True)
    return rows


# ---- 2. the rigid vector field's tangent ------------------------------------------------------


def field_section(repeats, n, evaluations=200):
    pr = design_problem("m_w,F_f", n=n, t_end_s=1.2)
    x = pr.space.to_physical(pr.space.to_unconstrained(paper_start(pr)))
    scenes = jax.vmap(lambda c: _scene(pr, c, x))(pr.captures)
    states = eqx.filter_jit(jax.vmap(lambda sc: simulate(sc, 0.3, jit=False).final_state))(scenes)
    dyn, static = eqx.partition(scenes, eqx.is_inexact_array)

    def hooks(sc, st):
        return sc.hooks(st.rocket)

    def cables(sc, st):
        return sc.cables.respond(st.cables, sc.hooks(st.rocket), 0.3)

    def rocket(sc, st):
        h = sc.hooks(st.rocket)
        return sc.rocket.derivative(st.rocket, sc.gravity, hook_forces_N=jnp.zeros_like(h.positions), point_forces=())

    def field(sc, st):
        return sc.vector_field(0.3, st)

    tangents = jax.tree_util.tree_map(lambda v: jax.random.normal(jax.random.PRNGKey(0), (2,) + v.shape), states)

    def looped(g):
        def run(d, st, t):
            def body(i, acc):
                st_i = jax.tree_util.tree_map(lambda v: v * (1.0 + 1e-9 * i), st)
                out = g(d, st_i, t)
                return acc + sum(jnp.sum(leaf) for leaf in jax.tree_util.tree_leaves(out))

            return jax.lax.fori_loop(0, evaluations, body, 0.0)

        return jax.jit(run)

    rows = []
    for name, f in (("vector field", field), ("hook kinematics", hooks), ("cables + hooks", cables), ("rocket + hooks", rocket)):

        def value(d, st, t, f=f):
            return jax.vmap(lambda d_, s_: f(eqx.combine(d_, static), s_))(d, st)

        def with_tangents(d, st, t, f=f):
            def one(d_, s_, t_):
                g = lambda s: f(eqx.combine(d_, static), s)  # noqa: E731
                return jax.vmap(lambda a: jax.jvp(g, (s_,), (a,)), out_axes=(None, 0))(t_)

            return jax.vmap(one, in_axes=(0, 0, 1))(d, st, t)

        def tangents_outer(d, st, t, value=value):
            # the tangent axis outside the cases' (jax.jacfwd's layout)
            return jax.vmap(lambda t_: jax.jvp(lambda s: value(d, s, None), (st,), (t_,)), out_axes=(None, 0))(t)

        v, w, o = looped(value), looped(with_tangents), looped(tangents_outer)
        calls = dict(value=lambda: v(dyn, states, tangents), jvp=lambda: w(dyn, states, tangents), outer=lambda: o(dyn, states, tangents))
        _, _, best = _report.time_rounds(calls, repeats)
        rows.append(dict(part=name, value_us=best["value"] / evaluations * 1e6, value_and_2_tangents_us=best["jvp"] / evaluations * 1e6,
                         ratio=best["jvp"] / best["value"], tangent_axis_outer_us=best["outer"] / evaluations * 1e6,
                         tangent_axis_outer_ratio=best["outer"] / best["value"]))  # fmt: skip
        print(f"field {name}: {rows[-1]['value_us']:.1f} / {rows[-1]['value_and_2_tangents_us']:.1f} / {rows[-1]['tangent_axis_outer_us']:.1f} us", flush=True)
    return rows


# ---- 3. the design objective: ForwardMode against the augmented sensitivity system -----------


def _depends(jaxpr) -> list:
    """For each output of a (linear) jaxpr, whether it depends on an input; one that does not is
    zero."""
    from jax.extend.core import Literal

    dep = set(jaxpr.invars)
    for eqn in jaxpr.eqns:
        if any(not isinstance(v, Literal) and v in dep for v in eqn.invars):
            dep.update(eqn.outvars)
    return [not isinstance(v, Literal) and v in dep for v in jaxpr.outvars]


def scene_tangents(build, u, directions):
    """``build(u)`` and its tangents along the rows of ``directions`` (leading axis k) on the leaves
    that depend on ``u`` (``None`` on the others, so that no zero tangents are pushed through the
    fixed parameters)."""
    scene = build(u)
    leaves, treedef = jax.tree_util.tree_flatten(scene)
    inexact = [eqx.is_inexact_array(leaf) for leaf in leaves]
    _, lin = jax.linearize(lambda u_: [l for l, m in zip(jax.tree_util.tree_leaves(build(u_)), inexact) if m], u)
    pairs = iter(zip(jax.vmap(lin)(directions), _depends(jax.make_jaxpr(lin)(directions[0]).jaxpr)))
    out = []
    for m in inexact:
        t, d = next(pairs) if m else (None, False)
        out.append(t if d else None)
    return scene, jax.tree_util.tree_unflatten(treedef, out)


def _jvp_k(fn, dyn, static, primals, tangents, dyn_tangents):
    """``fn(scene, *primals)`` and its k tangents (leading axis), the primal evaluated once."""

    def one(t_args, t_dyn):
        return jax.jvp(lambda d, *a: fn(eqx.combine(d, static), *a), (dyn,) + tuple(primals), (t_dyn,) + tuple(t_args))

    return jax.vmap(one, out_axes=(None, 0))(tangents, dyn_tangents)


def augmented_solve(scene, dscene, t1, *, solver, rtol, atol, pcoeff, icoeff, max_steps, dummy=False):
    """The rigid scene (state saved, probed after the solve) with its k tangents as one ODE; the
    controller's norm sees the state's error only. ``dummy``: the tangents' right-hand side is -S."""
    treedef = jax.tree_util.tree_structure(scene)
    carries = jax.tree_util.tree_unflatten(treedef, [t is not None for t in treedef.flatten_up_to(dscene)])
    dyn, static = eqx.partition(scene, carries)
    y0, s0 = _jvp_k(lambda sc: sc.initial_state(), dyn, static, (), (), dscene)

    def field(t, Y, args):
        y, S = Y
        if dummy:
            return scene.vector_field(t, y), jax.tree_util.tree_map(jnp.negative, S)
        return _jvp_k(lambda sc, y_: sc.vector_field(t, y_), dyn, static, (y,), (S,), dscene)

    controller = diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=pcoeff, icoeff=icoeff, norm=lambda e: optx.rms_norm(e[0]))
    ts = scene.default_save_ts(t1)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field), make_solver(solver), 0.0, t1, None, (y0, s0),
        saveat=diffrax.SaveAt(ts=ts), stepsize_controller=controller, max_steps=max_steps, throw=False,
    )  # fmt: skip
    ys, Ss = sol.ys
    probes, dprobes = jax.vmap(lambda t, y, S: _jvp_k(lambda sc, y_: sc.probe(t, y_), dyn, static, (y,), (S,), dscene))(sol.ts, ys, Ss)
    return sol.ts, probes, jax.tree_util.tree_map(lambda v: jnp.moveaxis(v, 1, 0), dprobes), sol.stats["num_accepted_steps"]


def augmented_gradient(problem, u, dummy=False):
    basis = jnp.eye(u.shape[0])
    pc, ic = LEVEL_STEP_CONTROL[problem.fidelity]

    def case(c):
        scene, dscene = scene_tangents(lambda u_: _scene(problem, c, problem.space.to_physical(u_)), u, basis)
        ts, probes, dprobes, steps = augmented_solve(
            scene, dscene, problem.t_end_s, solver=LEVEL_DEFAULTS[problem.fidelity][0], rtol=problem.rtol,
            atol=problem.atol, pcoeff=pc, icoeff=ic, max_steps=problem.max_steps, dummy=dummy,
        )  # fmt: skip
        smooth = lambda p: smooth_landing_outputs(ts, p, problem.widths)  # noqa: E731
        return jax.vmap(lambda dp: jax.jvp(smooth, (probes,), (dp,)), out_axes=(None, 0))(dprobes)

    sm, dsm = jax.vmap(case)(problem.captures)
    x, dx = jax.vmap(lambda e: jax.jvp(problem.space.to_physical, (u,), (e,)), out_axes=(None, 0))(basis)
    dsm = jax.tree_util.tree_map(lambda v: jnp.moveaxis(v, 1, 0), dsm)
    total = lambda x_, s_: objective_terms(problem, x_, s_)["total"]  # noqa: E731
    return jax.vmap(lambda a, b: jax.jvp(total, (x, sm), (a, b)), out_axes=(None, 0))(dx, dsm)


def design_section(repeats, n):
    base = design_problem("m_w,F_f", n=n, t_end_s=1.2)
    fm = design_problem("m_w,F_f", n=n, t_end_s=1.2, gradient="forward")
    u0 = base.space.to_unconstrained(paper_start(base))
    aug = eqx.filter_jit(augmented_gradient)
    calls = dict(
        forward=lambda: objective_value(base, u0), forward_mode=lambda: objective_and_grad(fm, u0),
        augmented=lambda: aug(base, u0), augmented_dummy_tangents=lambda: aug(base, u0, True),
    )  # fmt: skip
    outs, _, best = _report.time_rounds(calls, repeats)
    g_fm, g_aug = np.asarray(outs["forward_mode"][1]), np.asarray(outs["augmented"][1])
    row = dict(n=n, seconds=best, ratio={k: v / best["forward"] for k, v in best.items()},
               grad_forward_mode=g_fm.tolist(), grad_augmented=g_aug.tolist(),
               max_rel_diff=float(np.max(np.abs(g_fm - g_aug) / np.abs(g_fm))),
               steps=int(np.max(outs["forward"][1]["num_steps"])))  # fmt: skip
    print(f"design n {n}: " + ", ".join(f"{k} {v:.2f}x" for k, v in row["ratio"].items()), flush=True)
    return row


def write_md(data, path):
    lines = ["# Where the forward-mode gradient's cost goes (rigid level)", "", *_report.header(data), ""]
    lines += ["## 1. diffrax's loop on a trivial vector field (25 numbers, Tsit5, 2 parameters)", "",
              "| cases | saved times | forward [ms] | ForwardMode + jacfwd [ms] | ratio |", "|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in data["loop"]:
        lines.append(f"| {r['batch']} | {r['n_save']} | {r['forward_s'] * 1e3:.1f} | {r['forward_mode_s'] * 1e3:.1f} | {r['ratio']:.2f} |")
    lines += ["", f"## 2. The rigid vector field and its parts, {data['n']} cases, inside a loop", "",
              "| part | value [us] | value + 2 tangents, tangent axis inside the cases' [us] | ratio | tangent axis outside [us] | ratio |",
              "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in data["field"]:
        lines.append(f"| {r['part']} | {r['value_us']:.1f} | {r['value_and_2_tangents_us']:.1f} | {r['ratio']:.2f} | "
                     f"{r['tangent_axis_outer_us']:.1f} | {r['tangent_axis_outer_ratio']:.2f} |")
    d = data["design"]
    lines += ["", f"## 3. Design objective, n = {d['n']} ({d['steps']} steps), m_w and F_f", "",
              "| call | s | ratio to forward |", "|---|---:|---:|"]  # fmt: skip
    for k, s in d["seconds"].items():
        lines.append(f"| {k} | {s:.3f} | {d['ratio'][k]:.2f} |")
    lines += ["", f"Augmented-system gradient against ForwardMode's: largest relative difference {d['max_rel_diff']:.1e}."]
    path.write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--n", type=int, default=32, help="cases of sections 2 and 3")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start(n=args.n)
    data["loop"] = loop_section(args.repeats, (8, args.n))
    data["field"] = field_section(args.repeats, args.n)
    data["design"] = design_section(args.repeats, args.n)
    _report.finish(data, out, "bench_gradient_cost", write_md)


if __name__ == "__main__":
    main()
