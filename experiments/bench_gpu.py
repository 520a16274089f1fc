"""Sweep and design benchmarks on whatever accelerator JAX finds (not a test).

Runs on the default JAX backend (a GPU where one exists, else the CPU) and records the device, JAX
version and precision with every figure:

(1) Sweep throughput: ``run_qmc_sweep`` (scenario I, Table 8 captures with the sampled wind) at the
    ``rigid`` level for growing batch sizes and at the ``full`` level (the goal: over 1000
    full-fidelity cases per minute on one H200). Each setting runs twice on fresh output files: the
    first call compiles, the second is timed (cases per second and per minute).
(2) Design: the cost of the gradient of the batch objective (m_w, F_f; forward and reverse mode)
    as a ratio to the forward objective alone (goal: at most 3x), for growing batch sizes.
(3) The MoorDyn peer case vmapped (``experiments/peers/moordyn_line.py``: a 20-segment line
    pulled into snap loads, lumped mass, RK4 at the step that matches MoorDyn's error there): cases
    per second for 64 and more pull speeds, against MoorDyn's throughput as that script recorded it
    on the project's CPU (``experiments/results/peers_moordyn.json``; MoorDyn runs single-threaded
    on a CPU, so its figure does not depend on the accelerator). Goal: 64 cases at 50x MoorDyn.

The stages run in the order peers, rigid sweeps, design, full sweeps; each is saved as it ends, and
``--budget-s`` skips the stages that would start after that many seconds (for a timed lease).

Usage:
    python experiments/bench_gpu.py            # experiments/results/bench_gpu_<backend>.{json,md}
    python experiments/bench_gpu.py --quick    # small sizes, experiments/out/ (what CI-like CPUs can run)
    python experiments/bench_gpu.py --replot   # rewrite the .md from the .json of this backend
    python experiments/bench_gpu.py --lease --budget-s 400   # the sizes one 10-minute device call fits

On the project's CPU (2 cores) the quick run is the sanity check; the full sizes are meant for a GPU.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import _report
import jax

import jaxcable


def _sweep_rate(n, batch, fidelity, t_end):
    from jaxcable.arresting.sweep import run_qmc_sweep

    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(2):
            t0 = time.perf_counter()
            table = run_qmc_sweep(
                "I", n, fidelity=fidelity, out=Path(tmp) / f"s{rep}.csv", batch_size=batch, progress=False,
                t_end_s=t_end,
            )  # fmt: skip
            times.append(time.perf_counter() - t0)
    failed = int(sum(bool(x) for x in table["failed"]))
    return dict(fidelity=fidelity, n=n, batch=batch, t_end_s=t_end, first_s=times[0], run_s=times[1],
                cases_per_s=n / times[1], cases_per_min=60 * n / times[1], failed=failed)  # fmt: skip


def _design_ratio(n, gradient, t_end):
    from jaxcable.arresting.design import design_problem, objective_and_grad, objective_value, paper_start

    problem = design_problem("m_w,F_f", n=n, gradient=gradient, t_end_s=t_end)
    u = paper_start(problem)

    def timed(fn):
        jax.block_until_ready(fn(problem, u))  # compile
        best = float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            jax.block_until_ready(fn(problem, u))
            best = min(best, time.perf_counter() - t0)
        return best

    f = timed(objective_value)
    g = timed(objective_and_grad)
    return dict(n=n, gradient=gradient, forward_s=f, gradient_s=g, ratio=g / f)


def _peer_batch(sizes, ref_cases, loop_steps_s):
    """Throughput of the MoorDyn peer case vmapped over pull speeds (RK4 at MoorDyn's matched
    error), per batch size; the first ``ref_cases`` cases are also run at dt / 8 for their error,
    and with ``RK4(substeps=k)`` at loop steps of ``loop_steps_s`` (k RK4 steps per iteration of the
    solver's loop: the same states on the save grid, fewer loop iterations)."""
    import sys

    import jax.numpy as jnp
    import numpy as np

    from jaxcable.core.explicit_rk import RK4

    sys.path.insert(0, str(Path(__file__).resolve().parent / "peers"))
    import moordyn_line as ml

    recorded = json.loads((_report.RESULTS / "peers_moordyn.json").read_text())
    md_rate = recorded["batch"]["moordyn_cases_per_s"]
    nseg = recorded["case"]["segments"]
    t_end = recorded["dynamic"]["t_end_s"]
    ts = jnp.asarray(np.linspace(0.0, t_end, round(t_end / 0.01) + 1))
    # Newton's start: nodes at equal arc length on a parabola deeper than the answer (sag 2 m against
    # 1.396 m), so that every element starts stretched
    xf = np.linspace(0.0, ml.SPAN_M, 4001)
    zf = ml.HEIGHT_M - 2.0 * (1 - (2 * xf / ml.SPAN_M - 1) ** 2)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xf), np.diff(zf)))])
    x = np.interp(np.linspace(0.0, arc[-1], nseg + 1), arc, xf)
    static = ml.jaxcable_static(nseg, np.stack([x, 0 * x, np.interp(x, xf, zf)], -1))
    rows = []
    for switch, name in (("softplus", "lumped"), ("quadratic", "lumped_quadratic")):
        dt = recorded["accuracy"][name]["rk4"]["matched"]

        def batch(speeds, step, substeps, switch=switch):
            def one(speed):
                scene = ml.fast_scene(nseg, static, speed=speed, switch=switch)
                res = jaxcable.simulate(scene, t_end, solver=RK4(substeps=substeps), dt0=step, save_ts=ts, max_steps=400_000)
                return res.probes.r, res.num_steps, res.status

            return jax.vmap(one)(speeds)

        run = jax.jit(batch, static_argnums=2)
        settings = [(n, dt, 1) for n in sizes] + [(ref_cases, h, round(h / dt)) for h in loop_steps_s]
        r_one = None
        for n, step, k in settings:
            speeds = jnp.asarray(np.linspace(*ml.BATCH_SPEEDS_MPS, n))
            _, first, best = _report.time_rounds({"b": lambda run=run, speeds=speeds, step=step, k=k: run(speeds, step, k)}, 3)
            r, steps, status = run(speeds, step, k)
            row = {"model": name, "switch": switch, "cases": n, "dt_s": dt, "substeps": k, "loop_steps": int(np.max(steps)),
                   "all_successful": bool(np.all(np.asarray(status) == 0)), "first_s": first["b"], "run_s": best["b"],
                   "cases_per_s": n / best["b"], "moordyn_cases_per_s": md_rate,
                   "throughput_over_moordyn": n / best["b"] / md_rate}  # fmt: skip
            if n == ref_cases and k == 1:
                r_one = r
                r_ref = run(speeds, dt / 8, 1)[0]
                row["max_pos_err_m_vs_dt_over_8"] = float(jnp.max(jnp.linalg.norm(r - r_ref, axis=-1)))
            elif n == ref_cases and r_one is not None:
                row["max_pos_diff_m_vs_substeps_1"] = float(jnp.max(jnp.linalg.norm(r - r_one, axis=-1)))
            rows.append(row)
            print(row, flush=True)
    return rows


def main():
    p = argparse.ArgumentParser(description="sweep/design benchmarks on the default JAX backend")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--replot", action="store_true", help="rewrite the .md from the existing .json")
    p.add_argument("--lease", action="store_true", help="the sizes one 10-minute device call fits")
    p.add_argument("--stages", default="peers,rigid,design,full", help="comma-separated subset of peers,rigid,design,full")
    p.add_argument("--budget-s", type=float, default=float("inf"), help="start no stage after this many seconds")
    p.add_argument("--out", help="report folder (default experiments/results; --quick: experiments/out)")
    args = p.parse_args()
    t_start = time.perf_counter()

    stages = set(args.stages.split(","))
    if not stages <= {"peers", "rigid", "design", "full"}:
        p.error(f"--stages: unknown {sorted(stages - {'peers', 'rigid', 'design', 'full'})}")

    def in_budget(stage):
        if stage.split()[0] not in stages:
            return False
        left = args.budget_s - (time.perf_counter() - t_start)
        if left <= 0:
            print(f"skipped (over --budget-s): {stage}", flush=True)
            res.setdefault("skipped", []).append(stage)
        return left > 0

    jaxcable.enable_x64()
    backend = jax.default_backend()
    out_dir = _report.output_dir(args.out, quick=args.quick)
    stem = f"bench_gpu_{backend}"
    if args.replot:
        write_md(json.loads((out_dir / f"{stem}.json").read_text()), out_dir / f"{stem}.md")
        return
    if args.quick:
        rigid, full, design_n, t_end, full_t = [(8, 8)], [(2, 2)], [4], 0.6, 0.05
        peers, loop_steps = [8], [1e-3]
    elif args.lease:
        # no full-level sweep: its first call compiles for about 8 min on the project's CPU
        rigid, full, design_n, t_end, full_t = [(1024, 1024), (4096, 4096)], [], [128], 1.2, 0.25
        peers, loop_steps = [64, 1024, 8192], [1e-3, 2e-3]
    else:
        peers, loop_steps = [64, 256, 1024, 4096], [1e-3, 2e-3]
        rigid = [(256, 64), (1024, 256), (4096, 1024)]
        full, design_n, t_end, full_t = [(64, 32), (256, 128)], [32, 128, 512], 1.2, 1.0
    res = _report.start(
        backend=backend, devices=[str(d) for d in jax.devices()], precision=_report.precision(), sweep=[], design=[],
        peers=[],
    )  # fmt: skip
    if in_budget("peers"):
        res["peers"] = _peer_batch(peers, peers[0], loop_steps)
        _report.save(res, out_dir, stem)
    for n, b in rigid:
        if not in_budget(f"rigid sweep {n}"):
            continue
        res["sweep"].append(_sweep_rate(n, b, "rigid", 2.0 if not args.quick else t_end))
        print(res["sweep"][-1], flush=True)
        _report.save(res, out_dir, stem)
    for n in design_n:
        for gradient in ("forward", "reverse"):
            if not in_budget(f"design {n} {gradient}"):
                continue
            res["design"].append(_design_ratio(n, gradient, t_end))
            print(res["design"][-1], flush=True)
            _report.save(res, out_dir, stem)
    for n, b in full:
        if not in_budget(f"full sweep {n}"):
            continue
        res["sweep"].append(_sweep_rate(n, b, "full", full_t))
        print(res["sweep"][-1], flush=True)
        _report.save(res, out_dir, stem)
    _report.finish(res, out_dir, stem, write_md)


def write_md(res, path):
    lines = [
        f"# Sweep and design benchmarks on `{res['backend']}`",
        "",
        *_report.header(res),
        "",
        f"Device(s): {', '.join(res['devices'])}.",
        "",
        *[f"Run {i + 1}: {r['date']}, `{r['command']}`, {r['wall_s']:.0f} s: {r['what']}." for i, r in enumerate(res.get("runs", []))],
        "",
        "| level | cases | batch | simulated [s] | first call [s] | run [s] | cases/s | cases/min | failed |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in res["sweep"]:
        lines.append(
            f"| {r['fidelity']} | {r['n']} | {r['batch']} | {r['t_end_s']} | {r['first_s']:.1f} | {r['run_s']:.2f} | "
            f"{r['cases_per_s']:.2f} | {r['cases_per_min']:.0f} | {r['failed']} |"
        )
    lines += ["", "| design batch | gradient | objective [s] | objective + gradient [s] | ratio |", "|---:|---|---:|---:|---:|"]
    for r in res["design"]:
        lines.append(f"| {r['n']} | {r['gradient']} | {r['forward_s']:.3f} | {r['gradient_s']:.3f} | {r['ratio']:.2f}x |")
    if res.get("peers"):
        r0 = res["peers"][0]
        lines += [
            "",
            (
                "MoorDyn peer case vmapped over pull speeds (20 segments, 1 s pull, RK4 at MoorDyn's matched error), against "
                f"MoorDyn's {r0['moordyn_cases_per_s']:.2f} cases/s recorded on the project's CPU (single thread, "
                "`experiments/results/peers_moordyn.json`):"
            ),
            "",
            (
                "| model | cases | RK4 dt [s] | RK4 steps per loop step | loop steps | first call [s] | run [s] | cases/s | "
                "throughput / MoorDyn | pos err vs dt/8 [m] | vs 1 step per loop step [m] | all successful |"
            ),
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
        ]

        def e(r, key):
            return f"{r[key]:.1e}" if key in r else ""

        for r in res["peers"]:
            lines.append(
                f"| {r['model']} | {r['cases']} | {r['dt_s']:g} | {r['substeps']} | {r['loop_steps']} | "
                f"{r['first_s']:.1f} | {r['run_s']:.3f} | {r['cases_per_s']:.1f} | {r['throughput_over_moordyn']:.1f}x | "
                f"{e(r, 'max_pos_err_m_vs_dt_over_8')} | {e(r, 'max_pos_diff_m_vs_substeps_1')} | {r['all_successful']} |"
            )
    if res.get("skipped"):
        lines += ["", f"Skipped over the time budget: {', '.join(res['skipped'])}."]
    goals = (
        "Goals: over 1000 full-fidelity cases per minute on one H200; gradient at most 3x the forward sweep; "
        "the MoorDyn peer's 64 cases at 50x MoorDyn's throughput."
    )
    lines += ["", goals]
    _report.write_lines(path, lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
