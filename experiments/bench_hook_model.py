"""What the converged default costs: the hook as a sliding node on 64 span elements against the
capsule contact on 32 (the default before), the design case at the ale and full levels.

Each configuration is one :func:`jaxcable.arresting.landing.run_landing` of Table 1's design case
(central vertical capture at 20 m/s, calibrated damping, the level's solver: the W-method at rtol
1e-5) to ``--t-end`` (default 1 s; the rocket stops at ~0.8 s). It is called once (compile + run)
and then ``--repeats`` more times, the configurations in turn round by round
(``_report.time_rounds``), so that a change of the machine's load hits each alike: *first* is the
first call, *run* the best later call, *per step* run / steps. Also reported: the criteria, so that
the price sits beside what it buys (``docs/arresting_validation.md``: the node on 64 elements
converges within 0.9% at the full level; the capsule contact on 32 does not off centre).

Writes ``bench_hook_model<tag>.{json,md}``. Usage::

    python experiments/bench_hook_model.py                 # ~15 min on 2 cores
    python experiments/bench_hook_model.py --levels full --repeats 1
    python experiments/bench_hook_model.py --levels ale --tag _ale
"""

from __future__ import annotations

import argparse

import _report

from jaxcable.arresting.landing import run_landing
from jaxcable.core.config import enable_x64

STEM = "bench_hook_model"
MODELS = {
    "node, 64 span elements (32 fine): the default": {"hook_contact": "node", "n_span_elements": 64, "n_fine": 32},
    "capsule, 32 span elements (16 fine): the default before": {"hook_contact": "capsule", "n_span_elements": 32, "n_fine": 16},
}


def write_md(data, path):
    L = ["# The hook model's cost: the node on 64 span elements against the capsule on 32", "", *_report.header(data), ""]
    L += [
        (
            f"Design case (Table 1), {data['t_end_s']:g} s, calibrated damping, the level's solver (W-method, rtol 1e-5). "
            "first: compile + run; run: the best of the later calls, the configurations called in turn; "
            "ratio: run against the capsule contact on 32 elements at the same level."
        ),
        "",
        "| level | hook model, mesh | first [s] | run [s] | ratio | steps | per step [ms] | z_max [m] | a_max [g] | sigma_max [MPa] |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    rows = data["rows"]
    for r in rows:
        base = next((b for b in rows if b["level"] == r["level"] and b["model"].startswith("capsule")), None)
        ratio = f"{r['run_s'] / base['run_s']:.2f}" if base else "-"
        L.append(
            f"| {r['level']} | {r['model']} | {r['first_s']:.1f} | {r['run_s']:.1f} | {ratio} | {r['steps']} | "
            f"{1e3 * r['run_s'] / r['steps']:.2f} | {r['z_max_m']:.3f} | {r['a_max_g']:.3f} | {r['sigma_max_mpa']:.1f} |"
        )  # fmt: skip
    _report.write_lines(path, L)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--levels", nargs="*", default=["full", "ale"], choices=["ale", "full"])
    p.add_argument("--t-end", type=float, default=1.0)
    p.add_argument("--repeats", type=int, default=1, help="timed calls after the first (default 1)")
    p.add_argument("--out", help="report folder (default experiments/results)")
    p.add_argument("--tag", default="", help="suffix of the report's file names (e.g. _ale)")
    args = p.parse_args()
    enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start(precision=_report.precision(), t_end_s=args.t_end, rows=[])
    for level in args.levels:
        calls = {name: (lambda kw=kw, level=level: run_landing(level, t_end_s=args.t_end, **kw)) for name, kw in MODELS.items()}
        outs, first, best = _report.time_rounds(calls, args.repeats)
        for name in MODELS:
            o = outs[name].outputs
            row = dict(level=level, model=name, first_s=first[name], run_s=best[name], steps=int(o["num_steps"]),
                       **{k: float(o[k]) for k in ("z_max_m", "a_max_g", "sigma_max_mpa")})  # fmt: skip
            data["rows"].append(row)
            print(row, flush=True)
        _report.finish(data, out, STEM + args.tag, write_md)


if __name__ == "__main__":
    main()
