"""What holds the W-method's step on the full level, and what loosening it buys.

The design case (Table 1) at the full level with the scenes' defaults (the hook as a sliding node,
64 span elements, calibrated cable damping: ``rosw`` at rtol = atol = 1e-5,
``STIFF_LEVEL_DEFAULTS``), ``--t-end`` seconds after capture.

1. **Which state numbers the error estimate is made of.** Every attempted step reports, through a
   host callback, each state leaf's share of the squared RMS error norm that the step-size
   controller compares with 1 (the error scaled by ``atol + rtol max(|y0|, |y1|)``), and the
   number where it is largest.
2. **Work against error.** The same case at looser tolerances and with the cable nodes' velocities
   weighted down in the error norm (weight ``w`` on their share: ``w = 0.1`` is 10x looser
   tolerances for those numbers only), against a reference at rtol = atol = 1e-6: steps, wall time
   after compilation, the criteria and the energy budget.

3. **The energy integrals weighted** (``--energy-weights``): the level's rtol with the energy
   integrals' scaled errors multiplied by each weight, on a mesh of ``--mesh``: does the energy
   budget close without shorter steps for the mechanics?

Writes ``bench_step_limit.{json,md}`` (``bench_step_limit_energy_<span>_<fine>.{json,md}`` for 3). Usage::

    python experiments/bench_step_limit.py            # 1 s after capture
    python experiments/bench_step_limit.py --t-end 0.2 --out /tmp/quick
    python experiments/bench_step_limit.py --mesh 80 16 --energy-weights 1 10 100
"""

from __future__ import annotations

import argparse
import collections
import importlib
import time

import _report
import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.arresting.landing import LEVEL_STEP_CONTROL, level_solver_settings
from jaxcable.arresting.passive import (
    DEFAULT_FINE_ELEMENTS,
    DEFAULT_SPAN_ELEMENTS,
    passive_landing_scene,
)
from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import RosenbrockW

simulate_module = importlib.import_module("jaxcable.core.simulate")  # the package re-exports the function

STEM = "bench_step_limit"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa", "energy_budget_error")
RUNS = ((1e-6, 1.0), (1e-5, 1.0), (1e-5, 0.3), (1e-5, 0.1), (1e-4, 1.0))
"""(rtol = atol, weight of the cable nodes' velocities); the first is the reference."""


class WeightedRMS(eqx.Module):
    """diffrax's RMS norm of the scaled error, with some leaves weighted by ``w`` (an array: one
    compiled program for every weight): ``which="nodes"``, the cable nodes' velocities
    (``state.cables.qdot.r``); ``which="energy"``, the energy integrals (``cables.dissipated``,
    ``contact_work``, ``hook_damping_work``, ``aero_work``); ``which="rocket"``, the rocket bodies'
    velocities (``state.rocket.v``)."""

    w: jax.Array
    which: str = eqx.field(static=True, default="nodes")

    def __call__(self, e):
        squares = jax.tree_util.tree_map(lambda x: jnp.sum(x**2), e)
        n = sum(x.size for x in jax.tree_util.tree_leaves(e))
        if self.which == "nodes":
            part = squares.cables.qdot.r
        elif self.which == "rocket":
            part = squares.rocket.v
        else:
            part = squares.cables.dissipated + squares.contact_work + squares.hook_damping_work + squares.aero_work
        total = sum(jax.tree_util.tree_leaves(squares)) + (self.w**2 - 1.0) * part
        return jnp.sqrt(total / n)


class RecordingRosenbrockW(RosenbrockW):
    """The W-method, reporting each attempted step's error shares to ``record`` (host callback)."""

    rtol: float = 1e-5
    atol: float = 1e-5
    record: object = eqx.field(static=True, default=None)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        y1, err, dense, state, result = super().step(terms, t0, t1, y0, args, solver_state, made_jump)
        scaled = jax.tree_util.tree_map(
            lambda e, a, b: e / (self.atol + self.rtol * jnp.maximum(jnp.abs(a), jnp.abs(b))), err, y0, y1
        )
        leaves = jax.tree_util.tree_leaves(scaled)
        n = sum(x.size for x in leaves)
        shares = jnp.stack([jnp.sum(x**2) / n for x in leaves])
        where = jnp.stack([jnp.argmax(jnp.abs(x).reshape(-1)) for x in leaves])
        jax.debug.callback(self.record, t0, t1 - t0, shares, where)
        return y1, err, dense, state, result


def _controller(scene, rtol, atol, norm=None):
    pcoeff, icoeff = LEVEL_STEP_CONTROL["full"]
    kw = {} if norm is None else {"norm": norm}
    c = diffrax.PIDController(rtol=rtol, atol=atol, pcoeff=pcoeff, icoeff=icoeff, **kw)
    jumps = scene.jump_times()
    return c if jumps is None else diffrax.ClipStepSizeController(c, jump_ts=jumps)


def _solve(scene, t_end, solver, controller, max_steps):
    save_ts = jnp.asarray(scene.default_save_ts(t_end), float)
    snapshot_ts = jnp.asarray(scene.default_snapshot_ts(t_end), float)
    t = time.perf_counter()
    res = simulate_module._solve_jit(
        scene, t_end, save_ts, snapshot_ts, solver, controller, diffrax.RecursiveCheckpointAdjoint(),
        max_steps, None, diffrax.NoProgressMeter(), None,
    )  # fmt: skip
    jax.block_until_ready(res.final_state)
    return res, time.perf_counter() - t


def error_shares(scene, t_end, rtol, atol, max_steps) -> dict:
    y0 = scene.initial_state()
    flat = jax.tree_util.tree_flatten_with_path(y0)[0]
    names = [jax.tree_util.keystr(p) for p, _ in flat]
    shapes = [tuple(np.shape(x)) for _, x in flat]
    rows = []
    solver = RecordingRosenbrockW(
        linearise=scene.stiff_linearisation, rtol=rtol, atol=atol,
        record=lambda t0, h, s, w: rows.append((float(t0), float(h), np.asarray(s), np.asarray(w))),
    )  # fmt: skip
    res, _ = _solve(scene, t_end, solver, _controller(scene, rtol, atol), max_steps)
    t0 = np.array([r[0] for r in rows])
    h = np.array([r[1] for r in rows])
    shares = np.array([r[2] for r in rows])
    where = np.array([r[3] for r in rows])
    total = shares.sum(1)
    dominant = shares.argmax(1)
    out = {
        "attempts": len(rows), "steps": int(res.num_steps), "rejected": int(res.num_rejected),
        "leaves": {
            names[k]: {"shape": shapes[k], "dominant_in": int(np.sum(dominant == k)), "mean_share": float(np.mean(shares[:, k] / total))}
            for k in range(len(names)) if np.any(dominant == k) or np.mean(shares[:, k] / total) > 1e-3
        },
        "windows": [],
    }  # fmt: skip
    k_v = names.index(".cables.qdot.r")
    n_nodes = shapes[k_v][1]
    node = (where[:, k_v] // 3) % n_nodes
    for a, b in ((0.0, 0.02), (0.02, 0.1), (0.1, 0.3), (0.3, 0.6), (0.6, 1.0), (1.0, 2.0)):
        m = (t0 >= a) & (t0 < b)
        if m.any():
            top = collections.Counter(dominant[m]).most_common(1)[0]
            on_v = m & (dominant == k_v)
            out["windows"].append({
                "t_s": [a, b], "attempts": int(m.sum()), "median_step_s": float(np.median(h[m])),
                "dominant": names[top[0]], "dominant_fraction": float(top[1] / m.sum()),
                "node_range_of_largest": [int(np.percentile(node[on_v], 5)), int(np.percentile(node[on_v], 95))] if on_v.any() else None,
            })  # fmt: skip
    return out


def work_precision(scene, t_end, max_steps) -> list:
    rows = []
    solver = RosenbrockW(linearise=scene.stiff_linearisation)
    for rtol, w in RUNS:
        tol = jnp.asarray(rtol)
        c = _controller(scene, tol, tol, WeightedRMS(jnp.asarray(w)))
        if not rows:  # compiles once: the tolerances and the weight are arrays
            _solve(scene, t_end, solver, c, max_steps)
        res, wall = _solve(scene, t_end, solver, c, max_steps)
        row = {"rtol": rtol, "weight": w, "wall_s": wall, "steps": int(res.num_steps), "rejected": int(res.num_rejected), "status": int(res.status)}
        row.update({k: float(res.outputs[k]) for k in KEYS})
        rows.append(row)
        print(row, flush=True)
    ref = rows[0]
    for r in rows:
        for k in KEYS[:3]:
            r[f"{k}_rel_error"] = abs(r[k] / ref[k] - 1.0)
    return rows


def write_md(data, path):
    lines = [f"# What holds the W-method's step: full level, design case, {data['t_end_s']} s", ""]
    lines += _report.header(data) + [""]
    s = data["shares"]
    lines += [
        f"rosw at rtol = atol = {data['rtol']:g} (the level's default): {s['steps']} steps, {s['rejected']} rejected.",
        "",
        "| state leaf | shape | largest share in (attempts) | mean share of the squared error norm |",
        "|---|---|---:|---:|",
    ]
    for name, v in sorted(s["leaves"].items(), key=lambda kv: -kv[1]["mean_share"]):
        lines.append(f"| `{name}` | {tuple(v['shape'])} | {v['dominant_in']} | {v['mean_share']:.3f} |")
    lines += ["", "| t after capture [s] | attempts | median step [s] | largest share | in | nodes (5-95%) |", "|---|---:|---:|---|---:|---|"]
    for w in s["windows"]:
        lines.append(
            f"| {w['t_s'][0]}-{w['t_s'][1]} | {w['attempts']} | {w['median_step_s']:.2e} | `{w['dominant']}` | "
            f"{100 * w['dominant_fraction']:.0f}% | {w['node_range_of_largest']} |"
        )
    lines += [
        "",
        "Work against error (reference: the first row). `w`: weight of the cable nodes' velocities in the error norm.",
        "",
        "| rtol = atol | w | steps (rejected) | wall [s] | z_max [m] | a_max [g] | sigma_max [MPa] | error z / a / sigma | energy budget |",
        "|---:|---:|---|---:|---:|---:|---:|---|---:|",
    ]
    for r in data["runs"]:
        lines.append(
            f"| {r['rtol']:g} | {r['weight']:g} | {r['steps']} ({r['rejected']}) | {r['wall_s']:.1f} | {r['z_max_m']:.4f} | "
            f"{r['a_max_g']:.4f} | {r['sigma_max_mpa']:.2f} | {r['z_max_m_rel_error']:.1e} / {r['a_max_g_rel_error']:.1e} / "
            f"{r['sigma_max_mpa_rel_error']:.1e} | {r['energy_budget_error']:.1e} |"
        )
    _report.write_lines(path, lines)


def energy_weights(scene, t_end, rtol, max_steps, weights, which="energy") -> list:
    """The level's rtol with the energy integrals' errors (``which="rocket"``: the rocket bodies'
    velocities) weighted by each of ``weights``."""
    rows = []
    solver = RosenbrockW(linearise=scene.stiff_linearisation)
    tol = jnp.asarray(rtol)
    for w in weights:
        c = _controller(scene, tol, tol, WeightedRMS(jnp.asarray(w), which=which))
        if not rows:
            _solve(scene, t_end, solver, c, max_steps)
        res, wall = _solve(scene, t_end, solver, c, max_steps)
        row = {"weight": w, "wall_s": wall, "steps": int(res.num_steps), "rejected": int(res.num_rejected), "status": int(res.status)}
        row.update({k: float(res.outputs[k]) for k in KEYS})
        rows.append(row)
        print(row, flush=True)
    return rows


def write_energy_md(data, path):
    rocket = data.get("weigh") == "rocket"
    what = "the rocket bodies' velocities" if rocket else "the energy integrals"
    lines = [f"# {what[0].upper() + what[1:]} weighted in the error norm: full level, design case, {data['t_end_s']} s", ""]
    lines += _report.header(data) + [""]
    lines += [
        (f"rosw at rtol = atol = {data['rtol']:g}, {data['mesh'][0]} span elements ({data['mesh'][1]} fine); `w`: weight of "
         + ("the rocket bodies' velocities' scaled errors (`rocket.v`)." if rocket else
            "the energy integrals' scaled errors (`cables.dissipated`, `contact_work`, `hook_damping_work`, `aero_work`).")),
        "",
        "| w | steps (rejected) | wall [s] | z_max [m] | a_max [g] | sigma_max [MPa] | energy budget |",
        "|---:|---|---:|---:|---:|---:|---:|",
    ]  # fmt: skip
    for r in data["runs"]:
        lines.append(
            f"| {r['weight']:g} | {r['steps']} ({r['rejected']}) | {r['wall_s']:.1f} | {r['z_max_m']:.4f} | {r['a_max_g']:.4f} | "
            f"{r['sigma_max_mpa']:.2f} | {r['energy_budget_error']:.1e} |"
        )
    _report.write_lines(path, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--t-end", type=float, default=1.0, help="time after capture [s]")
    p.add_argument("--mesh", nargs=2, type=int, metavar=("SPAN", "FINE"), default=None,
                   help="span elements and fine ones (default: the scenes')")
    p.add_argument("--energy-weights", nargs="+", type=float, default=None, metavar="W",
                   help="only: the level's rtol with the energy integrals weighted by each W; writes bench_step_limit_energy_<span>_<fine>")
    p.add_argument("--weigh", choices=["energy", "rocket"], default="energy",
                   help="with --energy-weights: weigh the energy integrals (default) or the rocket bodies' velocities (writes ..._rocket_<span>_<fine>)")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    enable_x64()
    out = _report.output_dir(args.out)
    mesh = {} if args.mesh is None else {"n_span_elements": args.mesh[0], "n_fine": args.mesh[1]}
    scene = passive_landing_scene("full", t_end_s=args.t_end, **mesh)
    if args.energy_weights is not None:
        _, rtol, _, max_steps = level_solver_settings("full")
        span = args.mesh or (DEFAULT_SPAN_ELEMENTS, DEFAULT_FINE_ELEMENTS)
        data = _report.start(t_end_s=args.t_end, rtol=rtol, mesh=list(span), weigh=args.weigh)
        data["runs"] = energy_weights(scene, args.t_end, rtol, max_steps, args.energy_weights, args.weigh)
        _report.finish(data, out, f"{STEM}_{args.weigh}_{span[0]}_{span[1]}", write_energy_md)
        return
    solver_name, rtol, atol, max_steps = level_solver_settings("full")
    assert solver_name == "rosw", solver_name
    data = _report.start(t_end_s=args.t_end, rtol=rtol, atol=atol)
    data["shares"] = error_shares(scene, args.t_end, rtol, atol, max_steps)
    _report.save(data, out, STEM)
    data["runs"] = work_precision(scene, args.t_end, max_steps)
    _report.finish(data, out, STEM, write_md)


if __name__ == "__main__":
    main()
