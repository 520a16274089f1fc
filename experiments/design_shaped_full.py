"""Does a shaped brake meet every criterion on the design case at the full level? (not a test)

No constant brake does: the map of (m_w, F_f) on the design case (Table 1: centre, vertical,
20 m/s) at the full level and the calibrated cable damping has its a_max minimum at 900-1100 kg and
322 kN, 5.19-5.20 g converged, 4% over the 5 g limit (``experiments/design_feasibility.py``,
``docs/design.md``). A brake whose force follows the counterweight's rise
(``BufferDevice(brake_profile=...)``, K factors of F_f at equally spaced knots over 0-6 m, an
arresting engine's metering cam) is the remaining buffer freedom. This script searches it at the
full level directly: Nelder-Mead (scipy) over m_w, F_f and K factors, minimising the worst
normalised criterion ``max(z_max / 10 m, a_max / 5 g, sigma_max / 800 MPa)`` (below 1: all three
met; a run that did not stop, or whose solve failed, scores 10), the variables mapped to their
bounds by the design module's scaled logistic (``design_space``). Every evaluation is one
``run_landing`` (no gradient: at this level a gradient costs ~3.5x a landing, and the design notes
found derivative-free search as fast on 6 variables). The best design is then landed on the mesh refined 1.5x and 2x (48 / 64 span elements,
32 fine), since the default mesh is ~3% low on a_max for this buffer family.

``--batch-case J`` lands capture J of the design batch (``design_feasibility.py``'s: 16 Table 8
captures of scenario I, seed 0) beside the design case in every evaluation and scores the worst of
the two: a buffer has to land every capture, and the design batch's case 7 (15.1 m off centre)
wants a lighter counterweight and a weaker brake than the centred design case.

Writes ``design_shaped_full{TAG}.{json,md}`` after every evaluation; ``--refine-only`` refines the best
design of a saved (or stopped) search, keeping the meshes already landed. Usage:

    python experiments/design_shaped_full.py                  # full level, 4 knots, 90 landings (~40 min idle)
    python experiments/design_shaped_full.py --quick          # ale level, 0.3 s, 8 landings; experiments/out/
    python experiments/design_shaped_full.py --knots 6 --evaluations 150
    python experiments/design_shaped_full.py --batch-case 7 --start 600,3.0e5 --tag _pair7
"""

from __future__ import annotations

import argparse
import json
import time

import _report
import numpy as np
from design_feasibility import batch_capture
from scipy.optimize import minimize

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.design_setup import design_space, profile_names
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.passive import DEFAULT_FINE_ELEMENTS as N_FINE
from jaxcable.arresting.passive import DEFAULT_SPAN_ELEMENTS as N_SPAN
from jaxcable.arresting.passive import LandingCriteria
from jaxcable.core.config import enable_x64

STEM = "design_shaped_full"
FAILED = 10.0  # the score of a landing that did not stop or whose solve failed (the worst met is < ~2)

BOUNDS = {  # m_w [kg], F_f [N], the profile's factors [-]
    "m_w": (300.0, 1600.0),
    "F_f": (2.8e5, 3.8e5),
    "factor": (0.3, 2.0),
}


def shaped_space(knots):
    """The design module's space of m_w, F_f and ``knots`` factors (its scaled logistic) on ``BOUNDS``."""
    bounds = {"m_w": BOUNDS["m_w"], "F_f": BOUNDS["F_f"], **{b: BOUNDS["factor"] for b in profile_names(knots)}}
    return design_space(("m_w", "F_f", *profile_names(knots)), bounds)


def land(level, x, t_end, criteria, capture=None, **mesh):
    """One landing of design ``x = (m_w, F_f, factors...)`` (the design case, or ``capture``); its
    criteria and the worst normalised."""
    buffer = BufferDevice(counterweight_mass_kg=float(x[0]), brake_force_N=float(x[1]), brake_profile=np.asarray(x[2:]))
    t0 = time.perf_counter()
    o = run_landing(level, capture, buffer=buffer, t_end_s=t_end, **mesh).outputs
    row = {k: float(o[k]) for k in ("z_max_m", "a_max_g", "sigma_max_mpa", "energy_budget_error")}
    row.update(stopped=bool(o["stopped"]), solve_ok=bool(o["solve_ok"]), criteria_met=bool(o["criteria_met"]))
    worst = max(row["z_max_m"] / float(criteria.z_max_m), row["a_max_g"] / float(criteria.a_max_g),
                row["sigma_max_mpa"] / float(criteria.sigma_max_mpa))  # fmt: skip
    row["worst"] = worst if (row["stopped"] and row["solve_ok"]) else FAILED
    row.update(m_w_kg=float(x[0]), F_f_N=float(x[1]), factors=[float(f) for f in x[2:]], wall_s=time.perf_counter() - t0)
    return row


def land_cases(level, x, t_end, criteria, captures, **mesh):
    """Design ``x`` landed on the design case and on each of ``captures`` (name -> capture); the
    design case's row with the others under ``"cases"`` and ``"worst"`` the largest over all."""
    row = land(level, x, t_end, criteria, **mesh)
    if captures:
        row["cases"] = {name: land(level, x, t_end, criteria, capture, **mesh) for name, capture in captures.items()}
        row["design_case_worst"] = row["worst"]
        row["worst"] = max([row["worst"]] + [r["worst"] for r in row["cases"].values()])
        row["wall_s"] += sum(r["wall_s"] for r in row["cases"].values())
    return row


def _stopped(r):
    """The rocket stopped in every landing of evaluation ``r`` (the design case and its batch cases)."""
    return r["stopped"] and all(c["stopped"] for c in r.get("cases", {}).values())


def _design(r):
    return f"{r['m_w_kg']:.0f} kg, {r['F_f_N']:.4g} N, factors " + " ".join(f"{f:.2f}" for f in r["factors"])


def _criteria(r):
    text = f"{r['z_max_m']:.3f} / {r['a_max_g']:.3f} / {r['sigma_max_mpa']:.0f}"
    for name, c in r.get("cases", {}).items():
        text += f"; {name}: {c['z_max_m']:.3f} / {c['a_max_g']:.3f} / {c['sigma_max_mpa']:.0f}"
    return text


def write_md(data, path):
    rows = data["search"]
    cases = data.get("batch_cases") or []
    title = "the design case" + "".join(f" and the design batch's case {j}" for j in cases)
    lines = [f"# A shaped brake on {title} at the full level", "", *_report.header(data), ""]
    if cases:
        lines += [(f"Each evaluation lands the design case and capture(s) {', '.join(map(str, cases))} of the design "
                   f"batch ({data['batch_n']} Table 8 captures of scenario I, seed 0, as `design_feasibility.py "
                   "--batch-case` maps them); its score is the worst over them, the criteria are listed design case "
                   "first."), ""]  # fmt: skip
    lines += [
        (f"Design case (Table 1: centre, vertical, 20 m/s), level `{data['level']}`, {data['t_end_s']:g} s, "
        f"the level's default mesh ({N_SPAN} span elements, {N_FINE} fine), solver and calibrated cable "
        f"damping. Nelder-Mead over m_w, F_f and {data['knots']} brake factors (bounds: m_w "
        f"{BOUNDS['m_w'][0]:g}-{BOUNDS['m_w'][1]:g} kg, F_f {BOUNDS['F_f'][0]:.3g}-{BOUNDS['F_f'][1]:.3g} N, "
        f"factors {BOUNDS['factor'][0]:g}-{BOUNDS['factor'][1]:g}), minimising the worst normalised "
        "criterion max(z_max / 10 m, a_max / 5 g, sigma_max / 800 MPa) (below 1: all met)."),
        "",
        "| evaluation | worst | z_max [m] / a_max [g] / sigma_max [MPa] | stopped | design |",
        "|---:|---:|---|---|---|",
    ]
    best = np.inf
    for i, r in enumerate(rows):
        if i == 0 or r["worst"] < best:
            best = r["worst"]
            lines.append(f"| {i} | {r['worst']:.4f} | {_criteria(r)} | {_stopped(r)} | {_design(r)} |")
    per = f" of {1 + len(cases)} landings each" if cases else ""
    lines += ["", f"{len(rows)} evaluations{per}; the rows above are the start and each improvement.", ""]
    if data.get("note"):
        lines += [data["note"], ""]
    if data.get("search_date"):
        start, end = data["search_load"]
        when = f"{data['search_date']} (load average at its start {start}, " + (
            f"at its end {end})" if end else "stopped before its end, by hand, when its gains fell below 0.1%)")
        lines += [f"The search ran on {when}; the refined landings below after it (`--refine-only`).", ""]
    if data.get("refined"):
        lines += ["The best design on refined meshes (the convergence check):", "",
                  "| mesh (span / fine elements) | worst | z_max [m] / a_max [g] / sigma_max [MPa] | stopped |",
                  "|---|---:|---|---|"]  # fmt: skip
        for r in data["refined"]:
            lines.append(f"| {r['mesh'][0]} / {r['mesh'][1]} | {r['worst']:.4f} | {_criteria(r)} | {_stopped(r)} |")
        lines.append("")
    _report.write_lines(path, lines)


def plot_pair(data, path):
    """Each evaluation of a search with batch cases: the design case's worst normalised criterion
    against each batch case's, coloured by m_w; the quadrant where both are below 1 (every
    criterion met on both) shaded. A design that lands both captures lies in it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in data["search"] if r.get("cases") and r["worst"] < FAILED]
    names = list(rows[0]["cases"]) if rows else []
    fig, axes = plt.subplots(1, max(len(names), 1), figsize=(5.6 * max(len(names), 1), 4.6), squeeze=False)
    for ax, name in zip(axes[0], names):
        x = [r["design_case_worst"] for r in rows]
        y = [r["cases"][name]["worst"] for r in rows]
        sc = ax.scatter(x, y, c=[r["m_w_kg"] for r in rows], cmap="viridis", s=22)
        best = min(rows, key=lambda r: r["worst"])
        ax.plot(best["design_case_worst"], best["cases"][name]["worst"], "r*", ms=12, label="best (" + _design(best) + ")")
        lo = 0.95 * min(min(x), min(y), 1.0)
        ax.fill_between([lo, 1.0], lo, 1.0, color="tab:green", alpha=0.15, label="every criterion met on both")
        ax.axvline(1.0, color="k", ls="--", lw=0.8)
        ax.axhline(1.0, color="k", ls="--", lw=0.8)
        ax.set_xlim(left=lo)
        ax.set_ylim(bottom=lo)
        ax.set_xlabel("design case: max(z/10 m, a/5 g, sigma/800 MPa)")
        ax.set_ylabel(f"{name}: max(z/10 m, a/5 g, sigma/800 MPa)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
        fig.colorbar(sc, ax=ax, label="counterweight m_w [kg]")
    fig.suptitle(f"Nelder-Mead over m_w, F_f and {data['knots']} brake factors, {data['level']} level", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--level", default="full", choices=["rigid", "ale", "full"])
    p.add_argument("--knots", type=int, default=4, help="brake profile factors (default 4)")
    p.add_argument("--evaluations", type=int, default=90, help="landings in the search (default 90)")
    p.add_argument("--start", default="900,3.22e5", help="m_w [kg],F_f [N] of the start (flat profile); "
                   "default the best constant brake at the full level")  # fmt: skip
    p.add_argument("--t-end", type=float, default=1.2, help="simulated time [s] (default 1.2)")
    p.add_argument("--refine", nargs="*", default=["48,32", "64,32"], help="span,fine meshes to land the best on")
    p.add_argument("--refine-only", action="store_true",
                   help="skip the search: land the best design of the saved JSON on the --refine meshes")
    p.add_argument("--batch-case", type=int, nargs="*", default=[],
                   help="captures J of the design batch (design_feasibility.py's) landed with the design case; "
                   "the score is the worst over all")  # fmt: skip
    p.add_argument("--batch-n", type=int, default=16, help="captures in the design batch (default 16)")
    p.add_argument("--tag", default="", help="suffix of the results' file names (e.g. _pair7)")
    p.add_argument("--replot", action="store_true", help="redraw the figure and the table from the saved JSON")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    stem = STEM + args.tag
    if args.replot:
        out = _report.output_dir(args.out, args.quick)
        data = json.loads((out / f"{stem}.json").read_text())
        if data.get("batch_cases"):
            plot_pair(data, out / f"{stem}.png")
        write_md(data, out / f"{stem}.md")
        return
    if args.quick:
        args.level, args.evaluations, args.t_end, args.refine = "ale", 8, 0.3, []
    if args.knots < 2:
        p.error(f"--knots must be at least 2, got {args.knots}")
    enable_x64()
    out = _report.output_dir(args.out, args.quick)
    criteria = LandingCriteria()
    space = shaped_space(args.knots)
    data = _report.start(level=args.level, knots=args.knots, t_end_s=args.t_end, search=[], refined=[],
                         batch_cases=args.batch_case, batch_n=args.batch_n)  # fmt: skip
    if args.refine_only:  # the search of an earlier (possibly stopped) run, refined now
        saved = json.loads((out / f"{stem}.json").read_text())
        data.update(search=saved["search"], level=saved["level"], knots=saved["knots"], t_end_s=saved["t_end_s"],
                    search_date=saved.get("search_date", saved["date"]),
                    search_load=saved.get("search_load", [saved["load_start"], saved.get("load_end")]),
                    refined=[r for r in saved.get("refined", []) if r["mesh"] != [N_SPAN, N_FINE]])  # fmt: skip
        args.level, args.t_end = saved["level"], saved["t_end_s"]
        # the search's own captures (and its note), whatever --batch-case says now
        data.update(batch_cases=saved.get("batch_cases") or [], batch_n=saved.get("batch_n", args.batch_n),
                    **({"note": saved["note"]} if saved.get("note") else {}))  # fmt: skip
    captures = {f"case {j}": batch_capture(j, data["batch_n"]) for j in data["batch_cases"]}

    def f(u):
        row = land_cases(args.level, np.asarray(space.to_physical(u)), args.t_end, criteria, captures)
        data["search"].append(row)
        print(len(data["search"]), f"{row['worst']:.4f}", _criteria(row), _design(row), f"{row['wall_s']:.1f} s", flush=True)
        _report.save(data, out, stem)
        return row["worst"]

    if not args.refine_only:
        start = [float(v) for v in args.start.split(",")]
        if len(start) not in (2, 2 + args.knots):
            p.error(f"--start takes m_w,F_f or m_w,F_f and {args.knots} factors; got {args.start!r}")
        u0 = np.asarray(space.to_unconstrained(np.array(start + [1.0] * (2 + args.knots - len(start)))))
        # initial simplex: each variable moved by 0.4 in the logistic's argument (about 10% of its range)
        simplex = np.vstack([u0] + [u0 + 0.4 * np.eye(len(u0))[i] for i in range(len(u0))])
        minimize(f, u0, method="Nelder-Mead",
                 options={"maxfev": args.evaluations, "initial_simplex": simplex, "xatol": 1e-3, "fatol": 1e-4})  # fmt: skip
    best = min(data["search"], key=lambda r: r["worst"])
    x_best = np.array([best["m_w_kg"], best["F_f_N"], *best["factors"]])
    for mesh in args.refine:
        n_span, n_fine = (int(v) for v in mesh.split(","))
        if [n_span, n_fine] in [r["mesh"] for r in data["refined"]]:
            continue  # landed by an earlier run (--refine-only keeps its rows)
        row = land_cases(args.level, x_best, args.t_end, criteria, captures, n_span_elements=n_span, n_fine=n_fine)
        row["mesh"] = [n_span, n_fine]
        data["refined"].append(row)
        print("refined", mesh, f"{row['worst']:.4f}", _criteria(row), flush=True)
        _report.save(data, out, stem)
    if data["refined"]:
        data["refined"].insert(0, dict(best, mesh=[N_SPAN, N_FINE]))
        data["refined"].sort(key=lambda r: r["mesh"])
    if data["batch_cases"]:
        plot_pair(data, out / f"{stem}.png")
    _report.finish(data, out, stem, write_md)


if __name__ == "__main__":
    main()
