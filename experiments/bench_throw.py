"""Benchmark of the line-throwing rocket (not a test).

(a) One 30 deg flight (``dopri5``, rtol = atol = 1e-6, to ground impact) for segment lengths 1, 2 and
    5 m: trace + XLA compile time (ahead of time, ``jax.jit(...).lower(scene).compile()``) and the
    median wall time of 3 runs of the compiled flight (``jax.block_until_ready``), with the solver's
    accepted / rejected steps and the range.
(b) The O(n) chain solver against the paper's dense Kane form as the number of links n grows, at a
    paying-out state (n - 1 full links + a 0.4 m tail). Three things are timed, each jitted:
      * ``chain_accelerations(kin, forces)``: the O(n) solver (tridiagonal tension system);
      * ``chain_accelerations_dense(state, forces)``: the whole dense reference (mass matrix
        ``J^T M J`` and bias by autodiff, then a dense solve). It needs a concrete ``kin.n_free``, so
        the kinematics are built outside jit and closed over; the state and forces are arguments;
      * ``jnp.linalg.solve`` alone on the dense (n+2)x(n+2) Kane mass matrix (the Hessian of the
        kinetic energy in the generalized speeds), the O(n^3) floor of any dense formulation.
    Each is timed per call (dispatch included; median over repeats of many calls) and, for the two
    solvers, per evaluation inside one ``lax.map`` over a batch of force arrays (dispatch amortised,
    the honest scaling). The ratio time(640) / time(64) is reported for each (goal for O(n): <= 12x).

Writes bench_throw.json and bench_throw.md (machine, JAX version, precision in both). Usage:
    python experiments/bench_throw.py            # full: experiments/results/
    python experiments/bench_throw.py --quick    # < 1 min: 5 m flight only, n = 16, 64, 640;
                                                 # writes experiments/out/bench_quick/ unless --out
"""

from __future__ import annotations

import argparse
import statistics
import time

import _report
import equinox as eqx
import jax
import jax.numpy as jnp

import jaxcable
from jaxcable.components.rope import (
    ChainState,
    chain_accelerations,
    chain_accelerations_dense,
    kinematics,
    kinetic_energy,
    launch_theta,
    make_rope,
)
from jaxcable.throw import line_throwing_scene

STEM = "bench_throw"


def parse_args():
    p = argparse.ArgumentParser(description="line-throwing rocket benchmark")
    p.add_argument("--quick", action="store_true", help="reduced run (< 1 min)")
    p.add_argument("--solver", default="dopri5")
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--atol", type=float, default=1e-6)
    p.add_argument("--out", default=None, help="output folder (default experiments/results, or out/ with --quick)")
    return p.parse_args()


def per_call_seconds(fn, *args, min_total_s=0.2, repeats=5):
    """Median wall time of one ``fn(*args)`` (blocked), timeit-style: ``number`` calls per repeat."""
    jax.block_until_ready(fn(*args))
    number = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(number):
            jax.block_until_ready(fn(*args))
        dt = time.perf_counter() - t0
        if dt >= min_total_s or number >= 1 << 16:
            break
        number = max(2 * number, int(number * 1.2 * min_total_s / max(dt, 1e-9)))
    times = [dt / number]
    for _ in range(repeats - 1):
        t0 = time.perf_counter()
        for _ in range(number):
            jax.block_until_ready(fn(*args))
        times.append((time.perf_counter() - t0) / number)
    return statistics.median(times)


# ----------------------------------------------------------------------------------------------
# (a) one flight per segment length
# ----------------------------------------------------------------------------------------------
def bench_flight(segment_length_m, runs, solver, rtol, atol):
    scene = line_throwing_scene(30.0, segment_length_m=segment_length_m, rope_length_m=800.0)
    flight = jax.jit(lambda sc: jaxcable.simulate(sc, 40.0, solver=solver, rtol=rtol, atol=atol))
    t0 = time.perf_counter()
    lowered = flight.lower(scene)
    t_lower = time.perf_counter() - t0
    t0 = time.perf_counter()
    compiled = lowered.compile()
    t_compile = time.perf_counter() - t0
    walls = []
    for _ in range(runs):
        t0 = time.perf_counter()
        res = jax.block_until_ready(compiled(scene))
        walls.append(time.perf_counter() - t0)
    return {
        "segment_length_m": segment_length_m,
        "links": scene.rope.capacity,
        "trace_s": t_lower,
        "xla_compile_s": t_compile,
        "compile_total_s": t_lower + t_compile,
        "run_median_s": statistics.median(walls),
        "run_all_s": walls,
        "steps": int(res.num_steps),
        "rejected_steps": int(res.num_rejected),
        "range_m": float(res.outputs["range_m"]),
        "flight_time_s": float(res.outputs["flight_time_s"]),
        "max_speed_mps": float(res.outputs["max_speed_mps"]),
        "status": res.status_message,
    }


# ----------------------------------------------------------------------------------------------
# (b) O(n) solver vs dense Kane form
# ----------------------------------------------------------------------------------------------
def chain_case(n, key):
    """A paying-out chain of n links (1 m, 0.43 kg/m), its kinematics and random node forces."""
    rope = make_rope(segment_length_m=1.0, rope_length_m=float(n), linear_density_kg_per_m=0.43)
    theta_l = launch_theta(jnp.deg2rad(35.0))
    k1, k2, k3, k4 = jax.random.split(key, 4)
    state = ChainState(
        r0=jnp.array([50.0, 40.0]),
        v0=30.0 * jax.random.normal(k1, (2,)),
        theta=jax.random.uniform(k2, (n,), minval=-3.0, maxval=3.0),
        omega=2.0 * jax.random.normal(k3, (n,)),
        deployed=jnp.asarray(n - 0.4),
    )
    kin = eqx.filter_jit(kinematics)(state, rope, 20.0, theta_l)  # jitted only to save eager dispatch time
    forces = 40.0 * jax.random.normal(k4, (n + 1, 2)) * (kin.masses > 0)[:, None]
    return rope, theta_l, state, kin, forces


@eqx.filter_jit
def kane_mass_matrix(state, rope, theta_l, n_free):
    """Dense Kane mass matrix in the generalized speeds (v0, omega_1..omega_K): Hessian of the kinetic
    energy (node velocities are linear in the speeds; the tail follows omega_K)."""

    def energy(speeds):
        omega = jnp.concatenate([speeds[2:], jnp.zeros(state.omega.shape[0] - n_free)])
        st = ChainState(r0=state.r0, v0=speeds[:2], theta=state.theta, omega=omega, deployed=state.deployed)
        return kinetic_energy(kinematics(st, rope, 20.0, theta_l))

    speeds = jnp.concatenate([state.v0, state.omega[:n_free]])
    return jax.hessian(energy)(speeds), energy(speeds)


def bench_solver(n, batch, min_total_s, repeats, dense_in_map=True):
    t_start = time.perf_counter()
    rope, theta_l, state, kin, forces = chain_case(n, jax.random.PRNGKey(n))
    seg = 1.0
    lin = jax.jit(lambda kin_, F: chain_accelerations(kin_, F, seg))
    dense = jax.jit(lambda st, F: chain_accelerations_dense(st, kin, F, seg, theta_l))

    # Agreement (and compile time, on the first call).
    t0 = time.perf_counter()
    a_lin, w_lin = jax.block_until_ready(lin(kin, forces))
    compile_lin = time.perf_counter() - t0
    t0 = time.perf_counter()
    a_den, w_den = jax.block_until_ready(dense(state, forces))
    compile_dense = time.perf_counter() - t0
    K = int(kin.n_free)
    diff_a = float(jnp.max(jnp.abs(a_lin - a_den)))
    diff_w = float(jnp.max(jnp.abs(w_lin[:K] - w_den[:K])))

    M, energy = kane_mass_matrix(state, rope, theta_l, K)
    speeds = jnp.concatenate([state.v0, state.omega[:K]])
    energy_check = float(abs(0.5 * speeds @ M @ speeds - energy) / energy)
    rhs = jax.random.normal(jax.random.PRNGKey(7), (K + 2,))
    solve = jax.jit(jnp.linalg.solve)

    Fs = forces[None] * (1.0 + 0.01 * jnp.arange(batch))[:, None, None]
    lin_batch = jax.jit(lambda kin_, Fs_: jax.lax.map(lambda F: chain_accelerations(kin_, F, seg), Fs_))
    dense_batch = jax.jit(
        lambda st, Fs_: jax.lax.map(lambda F: chain_accelerations_dense(st, kin, F, seg, theta_l), Fs_)
    )
    kw = dict(min_total_s=min_total_s, repeats=repeats)
    row = {
        "n": n,
        "n_free": K,
        "max_abs_diff_a0": diff_a,
        "max_abs_diff_domega": diff_w,
        "mass_matrix_energy_check": energy_check,
        "compile_s": {"linear": compile_lin, "dense": compile_dense},
        "per_call_s": {
            "linear": per_call_seconds(lin, kin, forces, **kw),
            "dense": per_call_seconds(dense, state, forces, **kw),
            "dense_solve_only": per_call_seconds(solve, M, rhs, **kw),
        },
        "per_eval_in_map_s": {
            "linear": per_call_seconds(lin_batch, kin, Fs, **kw) / batch,
            "dense": per_call_seconds(dense_batch, state, Fs, **kw) / batch if dense_in_map else None,
        },
        "batch": batch,
    }
    row["wall_s"] = time.perf_counter() - t_start
    return row


def ratio(rows, key, sub, hi=640, lo=64):
    by_n = {r["n"]: r for r in rows}
    if hi in by_n and lo in by_n and by_n[hi][key][sub] is not None and by_n[lo][key][sub] is not None:
        return by_n[hi][key][sub] / by_n[lo][key][sub]
    return None


def opt_us(seconds):
    return "-" if seconds is None else f"{seconds * 1e6:.0f}"


def write_md(report, path):
    lines = [
        "# Line-throwing rocket benchmark",
        "",
        *_report.header(report),
        "",
        f"Run: {'quick' if report['quick'] else 'full'}.",
        "",
        "## (a) One 30° flight to ground impact",
        "",
        f"Solver {report['flight_settings']['solver']}, rtol = {report['flight_settings']['rtol']:g}, "
        f"atol = {report['flight_settings']['atol']:g}, rope 800 m. Compile = trace/lower + XLA compile "
        f"(ahead of time); run = median of {report['flight_settings']['runs']} compiled runs.",
        "",
        "| segment [m] | links | compile [s] (trace + XLA) | run, median [s] | steps | rejected | range [m] | flight time [s] | status |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in report["flights"]:
        lines.append(
            f"| {r['segment_length_m']:g} | {r['links']} | {r['compile_total_s']:.1f} ({r['trace_s']:.1f} + {r['xla_compile_s']:.1f}) "
            f"| {r['run_median_s']:.2f} | {r['steps']} | {r['rejected_steps']} | {r['range_m']:.1f} | {r['flight_time_s']:.2f} | {r['status']} |"
        )
    lines += [
        "",
        "## (b) O(n) chain solver vs the dense Kane form",
        "",
        "One evaluation of the accelerations at a paying-out state (n - 1 full 1 m links + a 0.4 m tail), jitted. "
        "*O(n)*: `chain_accelerations`. *dense*: the whole `chain_accelerations_dense` (mass matrix and bias "
        "by autodiff + dense solve; kinematics built outside jit because it needs a concrete `n_free`). "
        "*solve only*: `jnp.linalg.solve` on the (n+2)x(n+2) Kane mass matrix. Per call includes dispatch "
        f"(median of repeats of many calls); in `lax.map` = per evaluation inside one jitted map over {report['solver_rows'][0]['batch'] if report['solver_rows'] else '-'} force arrays.",
        "",
        "| n | O(n) per call [µs] | O(n) in map [µs] | dense per call [µs] | dense in map [µs] | solve only [µs] | max abs diff a0 / domega |",
        "|---:|---:|---:|---:|---:|---:|---|",
    ]
    us = 1e6
    for r in report["solver_rows"]:
        c, b = r["per_call_s"], r["per_eval_in_map_s"]
        lines.append(
            f"| {r['n']} | {c['linear'] * us:.1f} | {b['linear'] * us:.1f} | {c['dense'] * us:.0f} | {opt_us(b['dense'])} "
            f"| {c['dense_solve_only'] * us:.1f} | {r['max_abs_diff_a0']:.1e} / {r['max_abs_diff_domega']:.1e} |"
        )
    rt = report["ratios_640_over_64"]
    fmt = lambda v: "-" if v is None else f"{v:.1f}x"
    lines += [
        f"| **t(640)/t(64)** | **{fmt(rt['linear_per_call'])}** | **{fmt(rt['linear_in_map'])}** | {fmt(rt['dense_per_call'])} "
        f"| {fmt(rt['dense_in_map'])} | {fmt(rt['dense_solve_only'])} | |",
        "",
        "Linear scaling predicts 10x from n = 64 to 640, cubic 1000x; the goal for the O(n) solver is <= 12x. "
        "Per-call times include dispatch (~0.1 ms here), so the in-map columns are the fairer measure; even there "
        "the O(n) solver's cost up to n = 640 is mostly fixed per-operation overhead, so its ratio sits well "
        "below the linear 10x. Timings are wall-clock on a shared machine (see the load average above).",
    ]
    _report.write_lines(path, lines)


def main():
    args = parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out, quick=args.quick, sub="bench_quick")
    report = _report.start(quick=args.quick)  # load average taken before the runs: the timings are wall times
    segs = (5.0,) if args.quick else (1.0, 2.0, 5.0)
    ns = (16, 64, 640) if args.quick else (16, 32, 64, 128, 256, 640)
    runs = 3
    batch = 8 if args.quick else 32
    min_total_s, repeats = (0.05, 3) if args.quick else (0.25, 5)

    flights = []
    for seg in segs:
        print(f"(a) 30 deg flight, {seg:g} m segments ...", flush=True)
        r = bench_flight(seg, runs, args.solver, args.rtol, args.atol)
        flights.append(r)
        print(
            f"    compile {r['compile_total_s']:.1f} s (trace {r['trace_s']:.1f} + XLA {r['xla_compile_s']:.1f}), "
            f"run {r['run_median_s']:.2f} s (median of {runs}), {r['steps']} steps ({r['rejected_steps']} rejected), "
            f"range {r['range_m']:.1f} m, {r['status']}",
            flush=True,
        )

    rows = []
    print("(b) one acceleration evaluation, O(n) vs dense Kane [us]:", flush=True)
    print(f"    {'n':>4} {'O(n) call':>10} {'O(n) map':>9} {'dense call':>11} {'dense map':>10} {'solve':>9}  max|diff|")
    for n in ns:
        r = bench_solver(n, batch, min_total_s, repeats, dense_in_map=not args.quick)
        rows.append(r)
        c, b = r["per_call_s"], r["per_eval_in_map_s"]
        print(
            f"    {n:4d} {c['linear'] * 1e6:10.1f} {b['linear'] * 1e6:9.1f} {c['dense'] * 1e6:11.0f} {opt_us(b['dense']):>10} "
            f"{c['dense_solve_only'] * 1e6:9.1f}  {max(r['max_abs_diff_a0'], r['max_abs_diff_domega']):.1e}   ({r['wall_s']:.0f} s)",
            flush=True,
        )
    ratios = {
        "linear_per_call": ratio(rows, "per_call_s", "linear"),
        "linear_in_map": ratio(rows, "per_eval_in_map_s", "linear"),
        "dense_per_call": ratio(rows, "per_call_s", "dense"),
        "dense_in_map": ratio(rows, "per_eval_in_map_s", "dense"),
        "dense_solve_only": ratio(rows, "per_call_s", "dense_solve_only"),
    }
    fmt = lambda v: "n/a" if v is None else f"{v:.1f}x"
    print("    t(640)/t(64): " + ", ".join(f"{k} {fmt(v)}" for k, v in ratios.items()))
    ok = ratios["linear_in_map"] is not None and ratios["linear_in_map"] <= 12.0
    print(f"    O(n) goal t(640)/t(64) <= 12x (in map): {'met' if ok else 'NOT met'}")

    report |= {
        "flight_settings": {"angle_deg": 30.0, "rope_length_m": 800.0, "solver": args.solver, "rtol": args.rtol, "atol": args.atol, "runs": runs},
        "flights": flights,
        "solver_rows": rows,
        "ratios_640_over_64": ratios,
        "linear_goal_met": ok,
    }
    _report.finish(report, out, STEM, write_md)


if __name__ == "__main__":
    main()
