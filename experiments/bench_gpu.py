"""Sweep and design benchmarks on whatever accelerator JAX finds (not a test).

Runs on the default JAX backend (a GPU where one exists, else the CPU) and records the device, JAX
version and precision with every figure:

(1) Sweep throughput: ``run_qmc_sweep`` (scenario I, Table 8 captures with the sampled wind) at the
    ``rigid`` level for growing batch sizes and at the ``full`` level (the goal: over 1000
    full-fidelity cases per minute on one H200). Each setting runs twice on fresh output files: the
    first call compiles, the second is timed (cases per second and per minute).
(2) Design: the cost of the gradient of the batch objective (m_w, F_f; forward and reverse mode)
    as a ratio to the forward objective alone (goal: at most 3x), for growing batch sizes.

Usage:
    python experiments/bench_gpu.py            # experiments/results/bench_gpu_<backend>.{json,md}
    python experiments/bench_gpu.py --quick    # small sizes, experiments/out/ (what CI-like CPUs can run)
    python experiments/bench_gpu.py --replot   # rewrite the .md from the .json of this backend

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


def main():
    p = argparse.ArgumentParser(description="sweep/design benchmarks on the default JAX backend")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--replot", action="store_true", help="rewrite the .md from the existing .json")
    p.add_argument("--out", help="report folder (default experiments/results; --quick: experiments/out)")
    args = p.parse_args()
    jaxcable.enable_x64()
    backend = jax.default_backend()
    out_dir = _report.output_dir(args.out, quick=args.quick)
    stem = f"bench_gpu_{backend}"
    if args.replot:
        write_md(json.loads((out_dir / f"{stem}.json").read_text()), out_dir / f"{stem}.md")
        return
    if args.quick:
        rigid, full, design_n, t_end, full_t = [(8, 8)], [(2, 2)], [4], 0.6, 0.05
    else:
        rigid = [(256, 64), (1024, 256), (4096, 1024)]
        full, design_n, t_end, full_t = [(64, 32), (256, 128)], [32, 128, 512], 1.2, 1.0
    res = _report.start(
        backend=backend, devices=[str(d) for d in jax.devices()], precision=_report.precision(), sweep=[], design=[]
    )
    for n, b in rigid:
        res["sweep"].append(_sweep_rate(n, b, "rigid", 2.0 if not args.quick else t_end))
        print(res["sweep"][-1], flush=True)
        _report.save(res, out_dir, stem)
    for n, b in full:
        res["sweep"].append(_sweep_rate(n, b, "full", full_t))
        print(res["sweep"][-1], flush=True)
        _report.save(res, out_dir, stem)
    for n in design_n:
        for gradient in ("forward", "reverse"):
            res["design"].append(_design_ratio(n, gradient, t_end))
            print(res["design"][-1], flush=True)
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
    lines += ["", "Goals: over 1000 full-fidelity cases per minute on one H200; gradient at most 3x the forward sweep."]
    _report.write_lines(path, lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
