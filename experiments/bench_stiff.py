"""Work-precision of the linearly implicit W-method (``rosw``) against explicit Bosh3 on stiff cables.

The design case (Table 1, central vertical capture at 20 m/s) at the ``ale`` and ``full`` levels,
over the first ``--t-end`` seconds (default 0.2 s: the capture, the hook pick-up and the first
stress rise), at cable Rayleigh damping beta = 1e-5, 1e-4, 1e-3, 1e-2 s. Solvers:

* ``rosw`` (:class:`jaxcable.core.rosenbrock.RosenbrockW`, structured linear solve of
  :mod:`jaxcable.arresting.stiff`) at rtol = atol = 1e-4 and 1e-5, the linearisation recomputed
  every 4 accepted steps;
* ``bosh3`` at rtol = atol = 1e-4 with the levels' PI controller (0.4, 0.3), today's default;
* the reference: ``rosw`` at ``--ref-rtol`` (1e-7).

Per case: the run time of a second identical call (compiled), accepted and rejected steps, z_max,
a_max, sigma_max, the energy-budget error, and the relative error of the three against the
reference. ``--mesh`` adds the cost per step against the number of span elements (16, 32, 64) at
the ale level. Writes ``bench_stiff.json`` and ``bench_stiff.md``. Usage:

    python experiments/bench_stiff.py --mesh --levels ale                    # ~25 min on 2 cores
    python experiments/bench_stiff.py --levels full --betas 1e-5 1e-3 1e-2 --ref-rtol 1e-6 --tag _full
    python experiments/bench_stiff.py --quick          # ale only, beta 1e-5 and 1e-2, 0.05 s
"""

from __future__ import annotations

import argparse
import time

import _report

from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import RosenbrockW
from jaxcable.core.simulate import simulate
from jaxcable.arresting.landing import LEVEL_STEP_CONTROL
from jaxcable.arresting.passive import passive_landing_scene

STEM = "bench_stiff"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa")


def run(level, beta, t_end, solver, rtol, repeats=2, n_span=16):
    scene = passive_landing_scene(level, t_end_s=t_end, cable_damping_s=beta, n_span_elements=n_span)
    pcoeff, icoeff = LEVEL_STEP_CONTROL[level]
    best = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = simulate(scene, t_end, solver=solver, rtol=rtol, atol=rtol, max_steps=2_000_000, pcoeff=pcoeff, icoeff=icoeff)
        out = {k: float(v) for k, v in res.outputs.items() if k != "status"}
        wall = time.perf_counter() - t0
        best = wall if best is None else min(best, wall)
    return dict(
        wall_s=best, steps=int(res.num_steps), rejected=int(res.num_rejected), status=res.status_message,
        energy_budget_error=out["energy_budget_error"], **{k: out[k] for k in KEYS},
    )  # fmt: skip


def write_md(data, path):
    lines = ["# Stiff cables: the W-method against explicit Bosh3", "", *_report.header(data), ""]
    lines += [
        f"Design case, first {data['t_end_s']} s. Error: largest relative error of z_max, a_max, "
        f"sigma_max (the CFC 60 criteria) against the reference (rosw at {data.get('ref_rtol', 1e-7):g}). "
        "Time: second identical call (compiled); Bosh3 at beta >= 1e-3 s: one call (minutes; compile included).",
        "",
        "| level | beta [s] | solver | rtol | time [s] | steps | rejected | max rel. error | energy budget | status |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for c in data["cases"]:
        err = c.get("max_rel_error")
        lines.append(
            f"| {c['level']} | {c['beta']:g} | {c['solver']} | {c['rtol']:g} | {c['wall_s']:.2f} | {c['steps']} | "
            f"{c['rejected']} | {'' if err is None else f'{err:.1e}'} | {c['energy_budget_error']:.1e} | {c['status']} |"
        )
    if data.get("mesh"):
        lines += ["", "Cost per step against span elements (ale, rosw 1e-4, beta 1e-2):", "",
                  "| span elements | time [s] | steps | ms per step |", "|---:|---:|---:|---:|"]  # fmt: skip
        for m in data["mesh"]:
            lines.append(f"| {m['n_span']} | {m['wall_s']:.2f} | {m['steps']} | {1e3 * m['wall_s'] / max(m['steps'], 1):.3f} |")
    _report.write_lines(path, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--t-end", type=float, default=0.2)
    p.add_argument("--levels", nargs="+", default=["ale", "full"])
    p.add_argument("--betas", nargs="+", type=float, default=[1e-5, 1e-4, 1e-3, 1e-2])
    p.add_argument("--mesh", action="store_true", help="also the cost per step at 16, 32, 64 span elements")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--ref-rtol", type=float, default=1e-7, help="tolerance of the rosw reference")
    p.add_argument("--tag", default="", help="suffix of the results' file names (e.g. _full)")
    p.add_argument("--out", default=None)
    a = p.parse_args()
    enable_x64()
    if a.quick:
        a.levels, a.betas, a.t_end = ["ale"], [1e-5, 1e-2], 0.05
    stem = STEM + a.tag
    out = _report.output_dir(a.out, a.quick, stem)
    data = _report.start(t_end_s=a.t_end, ref_rtol=a.ref_rtol, cases=[], mesh=[])
    rosw = RosenbrockW(jacobian_every=4)
    for level in a.levels:
        for beta in a.betas:
            ref = run(level, beta, a.t_end, rosw, a.ref_rtol, repeats=1)
            data["cases"].append(dict(level=level, beta=beta, solver="rosw (reference)", rtol=a.ref_rtol, **ref))
            for name, solver, rtol in (("rosw", rosw, 1e-4), ("rosw", rosw, 1e-5), ("bosh3", "bosh3", 1e-4)):
                # a run of minutes needs no second call to separate the compile
                c = run(level, beta, a.t_end, solver, rtol, repeats=1 if (name == "bosh3" and beta >= 1e-3) else 2)
                c["max_rel_error"] = max(abs(c[k] - ref[k]) / abs(ref[k]) for k in KEYS)
                data["cases"].append(dict(level=level, beta=beta, solver=name, rtol=rtol, **c))
                print(data["cases"][-1], flush=True)
                _report.finish(data, out, stem, write_md)
    if a.mesh:
        for n_span in (16, 32, 64):
            m = run("ale", 1e-2, 0.02, rosw, 1e-4, n_span=n_span)
            data["mesh"].append(dict(n_span=n_span, **m))
            print(data["mesh"][-1], flush=True)
            _report.finish(data, out, stem, write_md)
    _report.finish(data, out, stem, write_md)


if __name__ == "__main__":
    main()
