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

    python experiments/design_feasibility.py                     # 7 x 4 grid, rigid + full (~15 min)
    python experiments/design_feasibility.py --quick             # 2 x 2, ale, 0.3 s; experiments/out/
    python experiments/design_feasibility.py --levels full --m-w 900 950 --f-f 3.2e5
    python experiments/design_feasibility.py --levels full --span-elements 48 --fine-elements 32 --tag _fine_x2
    python experiments/design_feasibility.py --batch-case 7 --m-w 300 600 920 --f-f 2.6e5 2.9e5 3.2e5 --tag _case7

``--batch-case J`` maps capture J of the design batch (``--batch-n`` Table 8 captures of scenario I,
seed 0, still air: the captures ``jaxcable design`` and ``experiments/design_full_check.py`` use)
instead of the design case: a buffer has to land every capture of a batch, so the captures that
want different buffers bound what any design can reach.
"""

from __future__ import annotations

import argparse
import json
import time

import _report
import numpy as np

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.passive import DEFAULT_FINE_ELEMENTS as N_FINE
from jaxcable.arresting.passive import DEFAULT_HOOK_CONTACT, LandingCriteria
from jaxcable.arresting.passive import DEFAULT_SPAN_ELEMENTS as N_SPAN
from jaxcable.core.config import enable_x64
from jaxcable.core.validation import check_positive

STEM = "design_feasibility"


def batch_capture(j, n):
    """Capture ``j`` of the design batch: ``n`` Table 8 captures of scenario I, seed 0."""
    import jax

    from jaxcable.arresting.uncertainty import captures_from_samples, halton_samples

    if not 0 <= j < n:
        raise ValueError(f"--batch-case must be in [0, {n}), got {j}")
    captures = captures_from_samples(halton_samples(n, scenario="I", phase="passive", seed=0))
    return jax.tree_util.tree_map(lambda v: v[j], captures)


def one_cell(level, m_w, f_f, t_end, capture=None, profile=None, **scene_options):
    t0 = time.perf_counter()
    buffer = BufferDevice(counterweight_mass_kg=m_w, brake_force_N=f_f, brake_profile=profile)
    run = run_landing(level, capture, buffer=buffer, t_end_s=t_end, **scene_options)
    o = run.outputs
    keys = ("z_max_m", "a_max_g", "sigma_max_mpa", "stopped", "solve_ok", "criteria_met", "energy_budget_error")
    row = {k: (bool(o[k]) if isinstance(o[k], (bool, np.bool_)) else float(o[k])) for k in keys}
    return dict(level=level, m_w_kg=m_w, F_f_N=f_f, steps=run.num_steps, wall_s=time.perf_counter() - t0, **row)


def write_md(data, path, stem=STEM):
    c = data["criteria"]
    case = data.get("case", "design case")
    lines = [f"# Buffers on the {case}: which meet every criterion", "", *_report.header(data), ""]
    where = "Design case (Table 1: centre, vertical, 20 m/s)" if case == "design case" else (
        f"The design batch's {case} (Table 8, scenario I, seed 0; capture at x = {data['capture_xy_m'][0]:.1f} m, "
        f"y = {data['capture_xy_m'][1]:.1f} m, still air)")
    lines += [
        (
            f"{where}, {data['t_end_s']:g} s, "
            + (f"{data['mesh'][0]} span elements ({data['mesh'][1]} fine) at the ale and full levels, "
               if data.get("mesh") else "each level's default mesh of the time, ")
            + "each level's solver and calibrated cable damping"
            + (", the hook as a sliding node" if data.get("hook_contact", "capsule") == "node" else "")
            + (f", a shaped brake (factors {', '.join(f'{f:g}' for f in data['brake_profile'])} of F_f over the stroke)"
               if data.get("brake_profile") else "")
            + ". "
            f"Criteria: z_max < {c['z_max_m']:g} m, a_max (CFC 60) < "
            f"{c['a_max_g']:g} g, sigma_max < {c['sigma_max_mpa']:g} MPa, stopped. A cell meeting all is in bold."
        ),
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
    lines.append(f"![criteria over the grid]({stem}.png)")
    _report.write_lines(path, lines)


def plot(data, path):
    """a_max against m_w, one line per F_f and one panel per level; filled markers where z_max and
    sigma_max meet their limits and the rocket stopped (then the cell meets every criterion if its
    a_max is below the dashed limit), open markers where they do not."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    levels = data["levels"]
    c = data["criteria"]
    fig, axes = plt.subplots(1, len(levels), figsize=(5.5 * len(levels), 4.2), squeeze=False, sharey=True)
    forces = sorted({r["F_f_N"] for r in data["rows"]})
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(forces)))
    for ax, level in zip(axes[0], levels):
        for f_f, colour in zip(forces, colours):
            rows = sorted((r for r in data["rows"] if r["level"] == level and r["F_f_N"] == f_f), key=lambda r: r["m_w_kg"])
            m = [r["m_w_kg"] for r in rows]
            a = [r["a_max_g"] for r in rows]
            ax.plot(m, a, "-", color=colour, lw=1.0, label=f"F_f = {f_f / 1e3:.0f} kN")
            for r in rows:
                ok = r["z_max_m"] < c["z_max_m"] and r["sigma_max_mpa"] < c["sigma_max_mpa"] and r["stopped"]
                ax.plot(r["m_w_kg"], r["a_max_g"], "o", color=colour, mfc=colour if ok else "white", ms=6)
        ax.axhline(c["a_max_g"], color="k", ls="--", lw=0.8)
        ax.set_xlabel("counterweight m_w [kg]")
        ax.set_title(f"{data.get('case', 'design case')}, {level} level")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("a_max (CFC 60) [g]")
    axes[0, -1].legend(fontsize=8, title="filled: z_max, sigma_max met", title_fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--levels", nargs="+", default=["rigid", "full"], choices=["rigid", "ale", "full"])
    p.add_argument("--m-w", nargs="+", type=float, default=[300.0, 600.0, 800.0, 920.0, 1000.0, 1100.0, 1400.0],
                   help="counterweight masses [kg]")
    p.add_argument("--f-f", nargs="+", type=float, default=[3.2e5, 3.25e5, 3.3e5, 3.4e5], help="brake forces [N]")
    p.add_argument("--t-end", type=float, default=1.2, help="simulated time [s] (default 1.2)")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=None)
    p.add_argument("--replot", action="store_true", help="redraw the figure and the table from the saved JSON")
    p.add_argument("--tag", default="", help="suffix of the results' file names (e.g. _fine)")
    p.add_argument("--span-elements", type=int, default=N_SPAN, help=f"elements per arresting span (default {N_SPAN})")
    p.add_argument("--fine-elements", type=int, default=N_FINE, help=f"of them in the fine region under the hook (default {N_FINE})")
    p.add_argument("--batch-case", type=int, default=None, help="map capture J of the design batch instead of the design case")
    p.add_argument("--batch-n", type=int, default=16, help="captures in the design batch (default 16)")
    p.add_argument("--brake-profile", nargs="+", type=float, default=None,
                   help="a shaped brake: factors of F_f at equally spaced knots over the stroke (BufferDevice.brake_profile)")
    p.add_argument("--hook-contact", default=DEFAULT_HOOK_CONTACT, choices=["capsule", "node"],
                   help=f"hook-cable contact model at the ale and full levels (default {DEFAULT_HOOK_CONTACT}; "
                        "the records before the node became the default: capsule, 32 span elements, 16 fine)")
    args = p.parse_args()
    stem = STEM + args.tag
    if args.replot:
        out = _report.output_dir(args.out, args.quick)
        data = json.loads((out / f"{stem}.json").read_text())
        plot(data, out / f"{stem}.png")
        write_md(data, out / f"{stem}.md", stem)
        return
    if args.quick:
        args.levels, args.m_w, args.f_f, args.t_end = ["ale"], [920.0, 1400.0], [3.13e5, 3.4e5], 0.3
    enable_x64()
    out = _report.output_dir(args.out, args.quick)
    crit = LandingCriteria()
    check_positive("--span-elements", args.span_elements)
    check_positive("--fine-elements", args.fine_elements)
    scene_options = {"n_span_elements": args.span_elements, "n_fine": args.fine_elements, "hook_contact": args.hook_contact}
    data = _report.start(
        t_end_s=args.t_end, levels=args.levels, rows=[], mesh=[args.span_elements, args.fine_elements],
        criteria={"z_max_m": float(crit.z_max_m), "a_max_g": float(crit.a_max_g), "sigma_max_mpa": float(crit.sigma_max_mpa)},
    )  # fmt: skip
    capture = None
    if args.batch_case is not None:
        capture = batch_capture(args.batch_case, args.batch_n)
        data.update(case=f"batch case {args.batch_case} of {args.batch_n}",
                    capture_xy_m=[float(capture.x_m), float(capture.y_m)])  # fmt: skip
    data.update(brake_profile=args.brake_profile, hook_contact=args.hook_contact)
    for level in args.levels:
        for m_w in args.m_w:
            for f_f in args.f_f:
                row = one_cell(level, m_w, f_f, args.t_end, capture, args.brake_profile, **(scene_options if level != "rigid" else {}))
                data["rows"].append(row)
                print(row, flush=True)
                _report.save(data, out, stem)
    plot(data, out / f"{stem}.png")
    _report.finish(data, out, stem, lambda d, path: write_md(d, path, stem))


if __name__ == "__main__":
    main()
