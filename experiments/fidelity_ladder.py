"""The fidelity ladder at the scenes' defaults: each level's criteria against the full level, and its cost (not a test).

Which level can a user afford for a stated error? Two cases, each level at its defaults (the
calibrated cable damping, the hook as a sliding node on the level's mesh (``LEVEL_CABLE_MESH``:
80 span elements with 16 fine at both levels), the level's solver settings from
``level_solver_settings``):

* the design case (Table 1, centred vertical capture at 20 m/s; ``run_landing``), levels
  ``1dof``, ``rigid``, ``ale``, ``full``, ``--t-end`` seconds (default 1.2; the rocket stops near
  0.8 s);
* section IV.A's deviated case (scenario I, ``run_two_phase`` defaults, seed 0), levels
  ``rigid``, ``ale``, ``full``, ``--t-end`` seconds of passive phase.

Each landing runs twice, identically: *first* = compile + run, *run* = the second call (what a user
pays per landing once compiled). Reported: z_max, a_max, sigma_max (CFC 60 criteria), each level's
relative deviation from the full level of the same case, the run time and its ratio to the full
level's, steps and the energy-budget error. The full level's own numerical error (its mesh: a_max
within 0.9% of 128 span elements on both cases) is in ``convergence_landing*.md``.

Usage (about 25 min on 2 cores):

    python experiments/fidelity_ladder.py                 # experiments/results/fidelity_ladder.{json,md}
    python experiments/fidelity_ladder.py --cases design --levels 1dof rigid --out /tmp/ladder
    python experiments/fidelity_ladder.py --levels ale full full_1body --tag _rocket   # whose is the ale-full gap
"""

from __future__ import annotations

import argparse
import time
import traceback

import _report
from bench_land import clean

import jaxcable

STEM = "fidelity_ladder"
CASES = {"design": ("1dof", "rigid", "ale", "full"), "iva": ("rigid", "ale", "full")}
EXTRA_LEVELS = ("full_1body",)
"""Run on request (``--levels``): ``full_1body``, the full level with one rocket body (a rigid rocket
with the hinged, sprung hooks), which tells the flexible rocket's share of the ale-full difference
from the sprung hooks'."""
CRITERIA = ("z_max_m", "a_max_g", "sigma_max_mpa")
KEYS = CRITERIA + ("stopped", "criteria_met", "energy_budget_error", "num_steps", "solver_status")


def _call(case, level, t_end):
    """One landing of ``case`` at ``level``: its outputs (dict)."""
    from jaxcable.arresting.landing import run_landing
    from jaxcable.arresting.two_phase import run_two_phase

    # the full level with one rocket body: the full level's scene with n_rocket_bodies=1
    fidelity, scene = ("full", {"n_rocket_bodies": 1}) if level == "full_1body" else (level, {})
    if case == "design":
        out = run_landing(fidelity, t_end_s=t_end, **scene).outputs
    else:  # the passive phase's outputs (its steps, its energy budget)
        out = run_two_phase(fidelity=fidelity, passive_t_end_s=t_end, seed=0, passive_kwargs=scene).outputs
    return {k: clean(out[k]) for k in KEYS}


def measure(case, level, t_end):
    """First call and an identical second call; a row."""
    row = {"case": case, "level": level, "t_end_s": t_end, "load_before": _report.load_average()}
    try:
        t0 = time.perf_counter()
        first = _call(case, level, t_end)
        row["first_call_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        second = _call(case, level, t_end)
        row["run_s"] = time.perf_counter() - t0
        row["compile_s"] = row["first_call_s"] - row["run_s"]
        row["repeat_identical"] = all(first[k] == second[k] for k in CRITERIA)
        row.update(first)
    except Exception as exc:  # noqa: BLE001 (a failed level is a result)
        row["error"] = f"{type(exc).__name__}: {exc}"
        row["traceback"] = traceback.format_exc(limit=4)
    row["load_after"] = _report.load_average()
    return row


def compare(rows):
    """Each row's relative deviation from the full level of its case, and its run-time ratio."""
    for case in CASES:
        full = next((r for r in rows if r["case"] == case and r["level"] == "full" and "error" not in r), None)
        for r in rows:
            if r["case"] != case or "error" in r or full is None:
                continue
            r["vs_full"] = {k: (r[k] - full[k]) / full[k] for k in CRITERIA if r.get(k) is not None and full.get(k)}
            r["run_ratio_vs_full"] = r["run_s"] / full["run_s"] if full.get("run_s") else None


def _pct(v):
    return "-" if v is None else f"{100 * v:+.1f}%"


def _meshes():
    from jaxcable.arresting.passive import LEVEL_CABLE_MESH

    return ", ".join(f"{lv} {span} span elements, {fine} fine" for lv, (span, fine) in LEVEL_CABLE_MESH.items())


def write_md(data, path):
    lines = _report.header(data) + [
        "",
        (
            "Each level at the scenes' defaults (calibrated cable damping, the hook as a sliding node on the level's "
            f"mesh: {_meshes()}; the level's solver settings). *run*: the second, identical call (compiled); "
            "*compile*: first call - run. Deviations are from the full level of the same case. a_max and "
            "sigma_max after the CFC 60 filter."
        ),
        "",
    ]
    titles = {
        "design": "Design case (Table 1, centred vertical capture at 20 m/s)",
        "iva": "Section IV.A's deviated case (scenario I, seed 0; passive phase at the level, tracking phase rigid)",
    }
    for case in CASES:
        rows = [r for r in data["rows"] if r["case"] == case]
        if not rows:
            continue
        lines += [
            f"## {titles[case]}",
            "",
            f"End time {rows[0]['t_end_s']:g} s after capture.",
            "",
            "| level | z_max [m] | a_max [g] | sigma_max [MPa] | dz vs full | da vs full | dsigma vs full | run [s] | run / full | compile [s] | steps | energy budget | stopped |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
        ]
        for r in rows:
            if "error" in r:
                lines.append(f"| {r['level']} | failed: {r['error']} |" + " |" * 11)
                continue
            d = r.get("vs_full", {})
            ratio = r.get("run_ratio_vs_full")
            budget = r.get("energy_budget_error")
            lines.append(
                f"| {r['level']} | {r['z_max_m']:.3f} | {r['a_max_g']:.3f} | {r['sigma_max_mpa']:.1f} | "
                f"{_pct(d.get('z_max_m'))} | {_pct(d.get('a_max_g'))} | {_pct(d.get('sigma_max_mpa'))} | "
                f"{r['run_s']:.2f} | {'-' if ratio is None else f'{ratio:.3g}'} | {r['compile_s']:.1f} | "
                f"{r['num_steps'] if r['num_steps'] is not None else '-'} | "
                f"{'-' if budget is None else f'{budget:.1e}'} | {'yes' if r['stopped'] else 'no'} |"
            )
        lines.append("")
    return _report.write_lines(path, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    p.add_argument("--levels", nargs="+", choices=list(CASES["design"]) + list(EXTRA_LEVELS), default=None,
                   help="default: every level of each case; full_1body (on request): the full level with a rigid rocket")
    p.add_argument("--tag", default="", help="suffix of the results' file names")
    p.add_argument("--t-end", type=float, default=1.2, help="time simulated after capture [s] (default 1.2)")
    p.add_argument("--out", default=None, help="output folder (default experiments/results)")
    args = p.parse_args()
    jaxcable.enable_x64()
    out_dir = _report.output_dir(args.out)
    data = _report.start(rows=[])
    stem = STEM + args.tag
    for case in args.cases:
        for level in CASES[case] + EXTRA_LEVELS:
            if (args.levels and level not in args.levels) or (not args.levels and level in EXTRA_LEVELS):
                continue
            row = measure(case, level, args.t_end)
            data["rows"].append(row)
            compare(data["rows"])
            brief = row.get("error") or (
                f"run {row['run_s']:.2f} s (compile {row['compile_s']:.1f} s), z {row['z_max_m']:.4f} m, "
                f"a {row['a_max_g']:.4f} g, sigma {row['sigma_max_mpa']:.2f} MPa, steps {row['num_steps']}"
            )
            print(f"{case} {level}: {brief}", flush=True)
            _report.save(data, out_dir, stem)
    _report.finish(data, out_dir, stem, write_md)


if __name__ == "__main__":
    main()
