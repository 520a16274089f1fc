"""Section IV at the full level: a screening sweep (looser passive tolerance, shorter passive phase)
against the same cases at the defaults, case by case.

The screening sweep::

    jaxcable sweep --phase full --fidelity full --scenario I --n 100 --rtol 1e-4 --t-end 1.2 \\
        --span-elements 64 --fine-elements 32 --out experiments/results/sweep_two_phase_full_node_I_n100_screen.csv

against ``sweep_two_phase_full_node_<S>_n100.csv`` (the defaults: rtol 1e-5, 2 s after capture).
Reports the verdicts that agree, the criteria's deviations, the W-method's steps, and the band
around each limit inside which a screened verdict must be confirmed at the defaults: the largest
deviation seen, doubled. Reads CSVs only (no solve). Writes ``section4_screening.{json,md}``::

    python experiments/section4_screening.py
    python experiments/section4_screening.py --default "sweep_two_phase_full_1body_{}_n100_screen.csv" \\
        --screen "sweep_two_phase_full_1body_{}_n100_screen3.csv" --confirmed "sweep_two_phase_full_1body_{}_n100_confirm3.csv" \\
        --stem section4_screening_coarse
"""

from __future__ import annotations

import argparse
from pathlib import Path

import _report
import numpy as np
from section4_node_vs_capsule import KEYS, NODE, _bool

from jaxcable.arresting.passive import LandingCriteria
from jaxcable.arresting.screening import cases_to_confirm, measured_band
from jaxcable.core.config import enable_x64
from jaxcable.studies.sweep import read_sidecar, read_sweep_csv

STEM = "section4_screening"
DEFAULT = NODE
SCREEN = NODE.replace(".csv", "_screen.csv")
FLAGS = ("success", "captured", "stopped", "z_ok", "a_ok", "sigma_ok")


def _limits():
    c = LandingCriteria()
    return {"z_max_m": c.z_max_m, "a_max_g": c.a_max_g, "sigma_max_mpa": c.sigma_max_mpa}


def compare(default: dict, screen: dict, confirm_band=None) -> dict:
    cases = sorted(set(np.asarray(default["case"], int)) & set(np.asarray(screen["case"], int)))
    rows = {}
    for name, t in (("default", default), ("screen", screen)):
        index = {int(c): i for i, c in enumerate(np.asarray(t["case"], int))}
        pick = np.asarray([index[c] for c in cases])
        rows[name] = {k: np.asarray(t[k], float)[pick] for k in (*KEYS, "num_steps")}
        rows[name].update({f: _bool(np.asarray(t[f])[pick]) for f in FLAGS})
    d, s = rows["default"], rows["screen"]
    out = {"cases": len(cases), "agree": {f: int(np.sum(d[f] == s[f])) for f in FLAGS}}
    out["success"] = {"default": int(d["success"].sum()), "screen": int(s["success"].sum())}
    out["turned"] = [int(c) for c, a, b in zip(cases, d["success"], s["success"]) if a != b]
    limits = _limits()
    out["deviation"], out["band"], out["to_confirm"] = {}, {}, {}
    near = np.zeros(len(cases), bool)
    for k in KEYS:
        rel = np.abs(s[k] / d[k] - 1.0)
        out["deviation"][k] = {"max": float(rel.max()), "p95": float(np.percentile(rel, 95)), "median": float(np.median(rel))}
        band = 2.0 * float(rel.max())
        out["band"][k] = band
        close = np.abs(s[k] / limits[k] - 1.0) < band
        out["to_confirm"][k] = int(close.sum())
        near |= close
    out["to_confirm_any"] = int(near.sum())
    out["turned_outside_band"] = [int(c) for c, a, b, n in zip(cases, d["success"], s["success"], near) if a != b and not n]
    # what `jaxcable sweep --confirm` would rerun without --band: the band measured for the screen's
    # tolerance (None: none is measured, --confirm needs --band)
    if confirm_band is not None:
        picked = cases_to_confirm(screen, confirm_band)
        out["confirm_default_band"] = {"band": confirm_band, "cases": picked.tolist()}
        out["turned_outside_default_band"] = [c for c in out["turned"] if c not in set(picked.tolist())]
    out["steps_median"] = {"default": float(np.median(d["num_steps"])), "screen": float(np.median(s["num_steps"]))}
    return out


def _settings(sidecar) -> str:
    """A CSV's passive-phase tolerance and time after capture, from its sidecar's case function."""
    fn = (sidecar or {}).get("case_fn", {})
    rtol = fn.get("passive_rtol")
    tol = f"rtol {rtol:g}" if rtol is not None else "the level's rtol"
    return f"{tol}, {fn.get('t_end_s', 2.0):g} s after capture"


def confirmation(screen: dict, confirmed: dict, merged: dict) -> dict:
    """A confirmation (``jaxcable sweep --confirm``) of ``screen``: its cases, their median steps, how far
    they moved from the screen, the verdicts it turned and the merged table's successes."""
    index = {int(c): i for i, c in enumerate(np.asarray(screen["case"], int))}
    cases = np.asarray(confirmed["case"], int)
    pick = np.asarray([index[int(c)] for c in cases], int)
    moved = {k: float(np.max(np.abs(np.asarray(confirmed[k], float) / np.asarray(screen[k], float)[pick] - 1.0))) for k in KEYS}
    ok_c, ok_s = _bool(np.asarray(confirmed["success"])), _bool(np.asarray(screen["success"])[pick])
    return {
        "cases": sorted(cases.tolist()), "steps_median": float(np.median(confirmed["num_steps"])), "moved": moved,
        "turned": sorted(int(c) for c, a, b in zip(cases, ok_c, ok_s) if a != b),
        "success_merged": int(_bool(np.asarray(merged["success"])).sum()),
    }  # fmt: skip


def _reruns(r) -> str:
    picked = r.get("confirm_default_band")
    return "needs `--band`" if picked is None else str(len(picked["cases"]))


def write_md(data, path):
    lines = ["# Section IV at the full level: screening sweeps against a reference", ""]
    lines += _report.header(data) + [""]
    lines += [
        (f"Screening sweeps `{data.get('screen_csv', SCREEN)}` ({data.get('screen_settings', '')}) against "
        f"`{data.get('default_csv', DEFAULT)}` ({data.get('default_settings', '')}; the columns' 'reference'). "
        "Band: twice the largest relative deviation seen; a screened case whose criterion lies within the band "
        "of its limit is rerun at the reference's settings."),
        "",
        "| scenario | cases | successful (reference / screen) | verdicts agree (success, z, a, sigma) | max deviation z / a / sigma | to confirm | turned outside the band | `--confirm` reruns (its measured band) | W-method steps, median (reference / screen) |",
        "|---|---:|---|---|---|---:|---|---:|---|",
    ]
    for sc, r in data["scenarios"].items():
        a, dv = r["agree"], r["deviation"]
        lines.append(
            f"| {sc} | {r['cases']} | {r['success']['default']} / {r['success']['screen']} | "
            f"{a['success']}, {a['z_ok']}, {a['a_ok']}, {a['sigma_ok']} | "
            f"{dv['z_max_m']['max']:.1e} / {dv['a_max_g']['max']:.1e} / {dv['sigma_max_mpa']['max']:.1e} | "
            f"{r['to_confirm_any']} | {r['turned_outside_band'] or 'none'} | {_reruns(r)} | "
            f"{r['steps_median']['default']:.0f} / {r['steps_median']['screen']:.0f} |"
        )
    if any("confirmation" in r for r in data["scenarios"].values()):
        lines += [
            "",
            f"Confirmed at the defaults: `{data.get('confirmed_csv', '')}` ({data.get('confirmed_settings', '')}), "
            "the screen's rows merged with them in `*_merged.csv`.",
            "",
            "| scenario | confirmed cases | median steps | moved from the screen z / a / sigma | verdicts turned | successful (merged / reference) |",
            "|---|---:|---:|---|---|---|",
        ]
        for sc, r in data["scenarios"].items():
            c = r.get("confirmation")
            if c is None:
                continue
            m = c["moved"]
            lines.append(
                f"| {sc} | {len(c['cases'])} | {c['steps_median']:.0f} | {m['z_max_m']:.1e} / {m['a_max_g']:.1e} / "
                f"{m['sigma_max_mpa']:.1e} | {', '.join(map(str, c['turned'])) or 'none'} | {c['success_merged']} / {r['success']['default']} |"
            )
    _report.write_lines(path, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenarios", nargs="+", default=["I", "II", "III"], choices=["I", "II", "III"])
    p.add_argument("--results", default=None, help="folder of the CSVs (default experiments/results)")
    p.add_argument("--out", default=None)
    p.add_argument("--default", default=DEFAULT, help=f"the reference CSVs' name, {{}} for the scenario (default {DEFAULT})")
    p.add_argument("--screen", default=SCREEN, help=f"the screening CSVs' name (default {SCREEN})")
    p.add_argument("--confirmed", default=None, help="the confirmations' name, {} for the scenario (their merged "
                   "tables beside them as *_merged.csv); default none")
    p.add_argument("--stem", default=STEM, help=f"the outputs' name (default {STEM})")
    args = p.parse_args()
    enable_x64()
    res = Path(args.results) if args.results else Path(__file__).parent / "results"
    out = _report.output_dir(args.out)
    data = _report.start(scenarios={})
    for sc in args.scenarios:
        paths = res / args.default.format(sc), res / args.screen.format(sc)
        try:
            tables = [read_sweep_csv(path) for path in paths]
        except (FileNotFoundError, ValueError) as err:  # not run yet, or just started
            print(f"scenario {sc}: {err}, skipped")
            continue
        try:
            confirm_band = measured_band(paths[1])
        except ValueError:  # a tolerance with no measured band (this comparison measures it)
            confirm_band = None
        data["scenarios"][sc] = compare(*tables, confirm_band)
        if args.confirmed:
            path = res / args.confirmed.format(sc)
            try:
                confirmed, merged = read_sweep_csv(path), read_sweep_csv(path.with_name(path.stem + "_merged.csv"))
            except (FileNotFoundError, ValueError) as err:
                print(f"scenario {sc}: {err}, no confirmation")
            else:
                data["scenarios"][sc]["confirmation"] = confirmation(tables[1], confirmed, merged)
        print(f"scenario {sc}: {data['scenarios'][sc]['cases']} cases in both", flush=True)
    if not data["scenarios"]:
        raise SystemExit("no scenario has both CSVs")
    data["default_csv"], data["screen_csv"] = args.default, args.screen
    first = args.scenarios[0]
    data["default_settings"] = _settings(read_sidecar(res / args.default.format(first)))
    data["screen_settings"] = _settings(read_sidecar(res / args.screen.format(first)))
    if args.confirmed:
        data["confirmed_csv"] = args.confirmed
        data["confirmed_settings"] = _settings(read_sidecar(res / args.confirmed.format(first)))
    _report.finish(data, out, args.stem, write_md)


if __name__ == "__main__":
    main()
