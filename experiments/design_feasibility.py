"""Is there a buffer that meets every criterion on the design case at the full level? (not a test)

The gradient-based design (``jaxcable design``) runs at the rigid level in seconds per step; at the
full level it costs about 75 s per capture and step here, and no design meeting every criterion
has been found there (``docs/design.md``). This script maps the design case (Table 1: centre,
vertical, 20 m/s) over a grid of the two buffer variables the design tunes, the counterweight mass
m_w and the brake force F_f, at a chosen level (default ``full``, the scenes' default mesh and
calibrated cable damping, 1.2 s): z_max, a_max (CFC 60), sigma_max, the stop, and which cells meet
every criterion (z_max < 10 m, a_max < 5 g, sigma_max < 800 MPa, stopped). The rigid level runs on
the same grid beside it, so the map shows how far a rigid-level design moves at the full level.

A capture batch needs every capture to land, so a design that fails the design case fails the
batch whatever the other captures do: an empty feasible set here is an answer for the batch too.

Writes ``design_feasibility.{json,md,png}``. Usage:

    python experiments/design_feasibility.py                     # 3 x 3 grid, full + rigid (~15 min)
    python experiments/design_feasibility.py --quick             # 2 x 2, ale, 0.3 s; experiments/out/
    python experiments/design_feasibility.py --m-w 600 920 1400 --f-f 2.9e5 3.13e5 3.4e5
"""

from __future__ import annotations

import argparse
import time

import _report
import numpy as np

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.passive import LandingCriteria
from jaxcable.core.config import enable_x64

STEM = "design_feasibility"


def one_cell(level, m_w, f_f, t_end):
    t0 = time.perf_counter()
    run = run_landing(level, buffer=BufferDevice(counterweight_mass_kg=m_w, brake_force_N=f_f), t_end_s=t_end)
    o = run.outputs
    keys = ("z_max_m", "a_max_g", "sigma_max_mpa", "stopped", "solve_ok", "criteria_met", "energy_budget_error")
    row = {k: (bool(o[k]) if isinstance(o[k], (bool, np.bool_)) else float(o[k])) for k in keys}
    return dict(level=level, m_w_kg=m_w, F_f_N=f_f, steps=run.num_steps, wall_s=time.perf_counter() - t0, **row)


def write_md(data, path):
    c = data["criteria"]
    lines = ["# Buffers on the design case: which meet every criterion", "", *_report.header(data), ""]
    lines += [
        f"Design case (Table 1: centre, vertical, 20 m/s), {data['t_end_s']:g} s, each level's default mesh, "
        f"solver and calibrated cable damping. Criteria: z_max < {c['z_max_m']:g} m, a_max (CFC 60) < "
        f"{c['a_max_g']:g} g, sigma_max < {c['sigma_max_mpa']:g} MPa, stopped. A cell meeting all is in bold.",
        "",
    ]
    for level in data["levels"]:
        rows = [r for r in data["rows"] if r["level"] == level]
        lines += [f"## {level}", "", "| m_w [kg] | F_f [N] | z_max [m] | a_max [g] | sigma_max [MPa] | stopped | all met | steps | time [s] |",
                  "|---:|---:|---:|---:|---:|---|---|---:|---:|"]  # fmt: skip
        for r in rows:
            met = "**yes**" if r["criteria_met"] else "no"
            lines.append(
                f"| {r['m_w_kg']:.0f} | {r['F_f_N']:.3g} | {r['z_max_m']:.3f} | {r['a_max_g']:.2f} | "
                f"{r['sigma_max_mpa']:.0f} | {r['stopped']} | {met} | {r['steps']} | {r['wall_s']:.0f} |"
            )
        lines.append("")
    lines.append(f"![criteria over the grid]({STEM}.png)")
    _report.write_lines(path, lines)


def plot(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    levels = data["levels"]
    fig, axes = plt.subplots(1, len(levels), figsize=(5.5 * len(levels), 4.5), squeeze=False)
    c = data["criteria"]
    for ax, level in zip(axes[0], levels):
        rows = [r for r in data["rows"] if r["level"] == level]
        for r in rows:
            ok = r["criteria_met"]
            ax.scatter(r["m_w_kg"], r["F_f_N"] / 1e3, s=260, c="tab:green" if ok else "tab:red", alpha=0.35)
            fails = [name for name, key in (("z", "z_max_m"), ("a", "a_max_g"), ("s", "sigma_max_mpa")) if r[key] >= c[key]]
            ax.annotate(
                f"{r['z_max_m']:.2f} m\n{r['a_max_g']:.2f} g\n{r['sigma_max_mpa']:.0f} MPa"
                + (f"\nfails {','.join(fails)}" if fails else ""),
                (r["m_w_kg"], r["F_f_N"] / 1e3), fontsize=7, ha="center", va="center",
            )  # fmt: skip
        ax.set_xlabel("counterweight m_w [kg]")
        ax.set_ylabel("brake F_f [kN]")
        ax.set_title(f"design case, {level} level")
        ax.margins(0.18)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", nargs="+", default=["rigid", "full"], choices=["rigid", "ale", "full"])
    p.add_argument("--m-w", nargs="+", type=float, default=[600.0, 920.0, 1400.0], help="counterweight masses [kg]")
    p.add_argument("--f-f", nargs="+", type=float, default=[2.9e5, 3.13e5, 3.4e5], help="brake forces [N]")
    p.add_argument("--t-end", type=float, default=1.2, help="simulated time [s] (default 1.2)")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    if args.quick:
        args.levels, args.m_w, args.f_f, args.t_end = ["ale"], [920.0, 1400.0], [3.13e5, 3.4e5], 0.3
    enable_x64()
    out = _report.output_dir(args.out, args.quick)
    crit = LandingCriteria()
    data = _report.start(
        t_end_s=args.t_end, levels=args.levels, rows=[],
        criteria={"z_max_m": float(crit.z_max_m), "a_max_g": float(crit.a_max_g), "sigma_max_mpa": float(crit.sigma_max_mpa)},
    )  # fmt: skip
    for level in args.levels:
        for m_w in args.m_w:
            for f_f in args.f_f:
                row = one_cell(level, m_w, f_f, args.t_end)
                data["rows"].append(row)
                print(row, flush=True)
                _report.save(data, out, STEM)
    plot(data, out / f"{STEM}.png")
    _report.finish(data, out, STEM, write_md)


if __name__ == "__main__":
    main()
