"""Implicit-explicit (IMEX) treatment of the brake on the rigid landing level (not a test).

Why: the rigid level's steps are set by the brake, not by accuracy. The regularised Coulomb brake
``F_f tanh(w'/v_width)`` damps a stuck counterweight with the rate ``F_f / (m_w v_width)``
(6.8e3 1/s at Table 1's values), and an explicit solver must resolve that time constant. On the
design case 85% of a 2 s landing's steps come after the rocket first stops (349 steps to 0.8 s,
2373 to 2 s with Tsit5 1e-6), and a 10x wider brake law needs 374 steps in all.

What this script tries: diffrax's additive Runge-Kutta solvers (KenCarp3/4/5) with the brake's
term on the counterweight coordinates ``u'`` as the implicit part and the rest of the vector field
as the explicit part (``MultiTerm(ODETerm(f - f_I), ODETerm(f_I))``). The implicit part acts on
the four ``u'`` only and each depends on its own ``u'`` (and on ``u`` through a brake profile), so
the Newton iteration's Jacobian is diagonal on those rows and the identity elsewhere:
:class:`MaskedDiagonal` is a lineax solver that gets that diagonal from one Jacobian-vector
product instead of materialising and factorising the 25 x 25 Jacobian (the generic Newton made the
batch 3.5x *slower* than Tsit5 despite 3.3x fewer steps).

It times each solver on the same vmapped batch (the design problem's Table 8 captures of scenario
I, 2 s, the paper's buffer), side by side, round by round, best of the rounds, and measures the
criteria's error against Dopri8 at rtol = atol = 1e-11.

Writes ``experiments/results/bench_imex_brake.{json,md}``. Usage:
    python experiments/bench_imex_brake.py            # n = 32, ~2 min on 2 cores
    python experiments/bench_imex_brake.py --n 8 --repeats 2 --out experiments/out
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import _report
import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx

import jaxcable
from jaxcable.arresting.design import _scene, design_problem, paper_start


class MaskedDiagonal(lx.AbstractLinearSolver):
    """Linear solves with an operator that is the identity on the rows outside ``mask`` and
    diagonal on the rows inside it (a PyTree of bools shaped like the unknown). The diagonal is the
    operator applied to the mask: one Jacobian-vector product, no matrix."""

    mask: Any

    def init(self, operator, options):
        ones = jax.tree_util.tree_map(lambda m: m.astype(float), self.mask)
        column_sums = operator.mv(ones)
        return jax.tree_util.tree_map(lambda m, c: jnp.where(m, c, 1.0), self.mask, column_sums)

    def compute(self, state, vector, options):
        return jax.tree_util.tree_map(lambda v, d: v / d, vector, state), lx.RESULTS.successful, {}

    def transpose(self, state, options):
        return state, {}

    def conj(self, state, options):
        return state, {}

    def assume_full_rank(self):
        return True

    def allow_dependent_columns(self, operator):
        return False

    def allow_dependent_rows(self, operator):
        return False


def brake_rates(scene, y):
    """The brake's part of d(state)/dt: zero except on the counterweight rates ``u'``."""
    b = scene.cables.buffer
    m_eff = b.counterweight_mass_kg * b.transfer_rate**2
    zeros = jax.tree_util.tree_map(jnp.zeros_like, y)
    return eqx.tree_at(lambda s: s.cables.udot, zeros, b.generalized_force(y.cables.udot, y.cables.u) / m_eff)


def imex_terms(scene):
    implicit = lambda t, y, args: brake_rates(scene, y)  # noqa: E731
    explicit = lambda t, y, args: jax.tree_util.tree_map(  # noqa: E731
        lambda a, b: a - b, scene.vector_field(t, y), brake_rates(scene, y)
    )
    return diffrax.MultiTerm(diffrax.ODETerm(explicit), diffrax.ODETerm(implicit))


def brake_mask(scene):
    y0 = scene.initial_state()
    mask = jax.tree_util.tree_map(lambda x: jnp.zeros(jnp.shape(x), bool), y0)
    return eqx.tree_at(lambda s: s.cables.udot, mask, jnp.ones(4, bool))


CONFIGS = {
    # name: (solver kind, rtol)
    "dopri8_1e-11 (reference)": ("dopri8", 1e-11),
    "tsit5_1e-6 (default)": ("tsit5", 1e-6),
    "tsit5_1e-5": ("tsit5", 1e-5),
    "kencarp4_1e-6": ("kencarp4", 1e-6),
    "kencarp5_1e-6": ("kencarp5", 1e-6),
    "kencarp5_1e-7": ("kencarp5", 1e-7),
    "kencarp5_1e-6 generic Newton": ("kencarp5_generic", 1e-6),
}


def batch_function(problem, x, kind, rtol, t_end):
    def one(capture):
        scene = _scene(problem, capture, x)
        ts = scene.default_save_ts(t_end)
        if kind in ("tsit5", "dopri8"):
            term = diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y))
            solver = diffrax.Tsit5() if kind == "tsit5" else diffrax.Dopri8()
        else:
            term = imex_terms(scene)
            cls = diffrax.KenCarp4 if kind == "kencarp4" else diffrax.KenCarp5
            linear = lx.AutoLinearSolver(well_posed=None) if kind.endswith("generic") else MaskedDiagonal(brake_mask(scene))
            solver = cls(root_finder=optx.Newton(rtol=rtol, atol=rtol, linear_solver=linear))
        sol = diffrax.diffeqsolve(
            term, solver, 0.0, t_end, None, scene.initial_state(),
            saveat=diffrax.SaveAt(ts=ts, fn=lambda t, y, args: y),
            stepsize_controller=diffrax.PIDController(rtol=rtol, atol=rtol),
            max_steps=400_000, throw=False,
        )  # fmt: skip
        p = jax.vmap(scene.probe)(ts, sol.ys)
        crit = jnp.stack([
            jnp.max(p["drop_m"]),
            jnp.max(jnp.linalg.norm(p["acceleration_m_s2"], axis=1)) / 9.81,
            jnp.max(p["stress_max_pa"]) / 1e6,
        ])  # fmt: skip
        return crit, sol.stats["num_accepted_steps"], sol.stats["num_rejected_steps"]

    return jax.jit(lambda caps: jax.vmap(one)(caps))


def run(n, repeats, t_end):
    problem = design_problem("m_w,F_f", n=n, t_end_s=t_end)
    x = paper_start(problem)
    fns = {name: batch_function(problem, x, kind, rtol, t_end) for name, (kind, rtol) in CONFIGS.items()}
    outs, compile_s, times = {}, {}, {k: [] for k in fns}
    for name, fn in fns.items():
        t = time.perf_counter()
        outs[name] = jax.block_until_ready(fn(problem.captures))
        compile_s[name] = time.perf_counter() - t
        print(f"compiled {name} ({compile_s[name]:.1f} s)", flush=True)
    for _ in range(repeats):
        for name, fn in fns.items():
            if name.startswith("dopri8"):
                continue
            t = time.perf_counter()
            jax.block_until_ready(fn(problem.captures))
            times[name].append(time.perf_counter() - t)
    ref = np.asarray(outs["dopri8_1e-11 (reference)"][0])
    base = min(times["tsit5_1e-6 (default)"])
    rows = []
    for name, (crit, acc, rej) in outs.items():
        if name.startswith("dopri8"):
            continue
        err = np.max(np.abs(np.asarray(crit) - ref) / np.abs(ref), axis=0)
        best = min(times[name])
        rows.append(dict(
            config=name, wall_s=best, speedup_vs_tsit5=base / best, steps_mean=float(np.mean(acc)),
            rejected_mean=float(np.mean(rej)), rel_err_z=float(err[0]), rel_err_a=float(err[1]),
            rel_err_sigma=float(err[2]), compile_s=compile_s[name] - best, runs_s=times[name],
        ))  # fmt: skip
        print(f"{name:30s} {best:.3f} s x{base / best:.2f} steps {np.mean(acc):.0f} err z/a/s {err[0]:.1e} {err[1]:.1e} {err[2]:.1e}")
    return dict(n=n, t_end_s=t_end, rows=rows, reference_steps_mean=float(np.mean(outs["dopri8_1e-11 (reference)"][1])))


def write_md(data, path):
    L = [
        "# IMEX brake on the rigid landing level",
        "",
        *_report.header(data),
        "",
        "One vmapped batch (design problem's Table 8 captures, scenario I, paper buffer), t_end as given, "
        "1 ms output grid. Best of the rounds; speedup = Tsit5 1e-6 (the level's default) / the row. Error: "
        "largest relative error over the batch of z_max, a_max, sigma_max against Dopri8 1e-11. KenCarp rows: "
        "brake as the implicit term, Newton with rtol = atol = the step's tolerance and the masked-diagonal "
        "linear solve, except the `generic Newton` row (lineax's dense LU of the 25 x 25 Jacobian).",
        "",
    ]
    for block in data["runs"]:
        L += [
            f"## n = {block['n']}, t_end = {block['t_end_s']} s (reference: {block['reference_steps_mean']:.0f} steps a case)",
            "",
            "| configuration | wall [s] | speedup | steps (mean) | rejected (mean) | err z_max | err a_max | err sigma_max | compile [s] |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in block["rows"]:
            L.append(
                f"| {r['config']} | {r['wall_s']:.3f} | {r['speedup_vs_tsit5']:.2f} | {r['steps_mean']:.0f} | "
                f"{r['rejected_mean']:.0f} | {r['rel_err_z']:.1e} | {r['rel_err_a']:.1e} | {r['rel_err_sigma']:.1e} | "
                f"{r['compile_s']:.1f} |"
            )
        L.append("")
    path.write_text("\n".join(L) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--n", nargs="+", type=int, default=[32], help="batch sizes")
    p.add_argument("--t-end", type=float, default=2.0, help="landing duration [s]")
    p.add_argument("--repeats", type=int, default=3, help="timed rounds (best kept)")
    p.add_argument("--out", default=None, help="output folder (default experiments/results)")
    args = p.parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start(runs=[])
    for n in args.n:
        data["runs"].append(run(n, args.repeats, args.t_end))
    _report.finish(data, out, "bench_imex_brake", write_md)


if __name__ == "__main__":
    main()
