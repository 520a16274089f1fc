"""Section IV at the full level: two recorded models of the same 3 x 100 cases, case by case. By
default the hook as a sliding node on 64 span elements (32 fine) against the capsule contact on 32
(16 fine); ``--new node80 --old node64``: the default now (the node on 80 span elements, 16 fine)
against the node on 64; ``--new 1body_screen --old node80_screen``: the default with a rigid rocket
(``--rocket-bodies 1``) against its 5 bodies, both screened.

Reads, for each scenario whose CSVs exist, the rows both sweeps have run (a sweep is resumable and
may be partial), e.g.::

    jaxcable sweep --phase full --fidelity full --scenario I --n 100 \\
        --span-elements 64 --fine-elements 32 --out experiments/results/sweep_two_phase_full_node_I_n100.csv

against ``sweep_two_phase_full_calibrated_<S>_n100.csv`` (capsule, 32 elements); where a model has
no sweep at the defaults, its screening sweep with the cases near a limit confirmed
(``*_confirm_merged.csv``, docs/sweeps.md). Reports the success and a_max rates of the same cases
under both models, the verdicts that turn, and the change of a_max, z_max and sigma_max against the
capture's offset from the frame's centre. Reads CSVs only (no solve). Writes
``section4_<new>_vs_<old>.{json,md,png}`` (``section4_node_vs_capsule`` for the default pair).
Usage::

    python experiments/section4_node_vs_capsule.py
    python experiments/section4_node_vs_capsule.py --new node80 --old node64
    python experiments/section4_node_vs_capsule.py --new 1body_screen --old node80_screen --scenarios I
"""

from __future__ import annotations

import argparse
from pathlib import Path

import _report
import numpy as np

from jaxcable.arresting.sweep import CAPTURED_PREFIX
from jaxcable.core.config import enable_x64
from jaxcable.studies.sweep import read_sweep_csv

STEM = "section4_node_vs_capsule"
NODE = "sweep_two_phase_full_node_{}_n100.csv"
NODE_CONFIRMED = "sweep_two_phase_full_node_{}_n100_confirm_merged.csv"
"""Where no sweep at the defaults exists: a screening sweep with its cases near a limit rerun at the
defaults (``jaxcable sweep --confirm``, docs/sweeps.md)."""
CAPSULE = "sweep_two_phase_full_calibrated_{}_n100.csv"
NODE80 = "sweep_two_phase_full_node80_{}_n100.csv"
NODE80_CONFIRMED = "sweep_two_phase_full_node80_{}_n100_confirm_merged.csv"
NODE80_SCREEN = "sweep_two_phase_full_node80_{}_n100_screen.csv"
"""Before its confirmation: the screening sweep alone (the report names the CSV it read)."""
ONE_BODY_SCREEN = "sweep_two_phase_full_1body_{}_n100_screen.csv"
"""The default model with a rigid rocket (``--rocket-bodies 1``: one body, the hooks sprung on
their hinges), screened like ``NODE80_SCREEN`` (``--rtol 1e-4 --t-end 1.2``); against that screen:
``--new 1body_screen --old node80_screen``."""
RECORDS = {
    "node80": {"csvs": (NODE80, NODE80_CONFIRMED, NODE80_SCREEN), "label": "node, 80 elements, 16 fine (the default)"},
    "node64": {"csvs": (NODE, NODE_CONFIRMED), "label": "node, 64 elements, 32 fine"},
    "capsule": {"csvs": (CAPSULE,), "label": "capsule, 32 elements, 16 fine"},
    "node80_screen": {"csvs": (NODE80_SCREEN,), "label": "5 rocket bodies, screened"},
    "1body_screen": {"csvs": (ONE_BODY_SCREEN,), "label": "1 rocket body, screened"},
}
"""The recorded sweeps by model: the CSVs tried in turn (``first_csv``) and the label of the reports."""
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa")
FLAGS = ("success", "captured", "criteria_met", "z_ok", "a_ok", "sigma_ok")


def first_csv(res: Path, names, scenario: str) -> Path | None:
    """The first of the CSVs ``names`` (formatted with ``scenario``) in ``res`` that holds something,
    or None: for the default model, ``(NODE, NODE_CONFIRMED)``."""
    for name in names:
        path = res / name.format(scenario)
        if path.exists() and path.stat().st_size > 0:
            return path
    return None


def _bool(col):
    return np.asarray([str(v).strip().lower() in ("true", "1", "1.0") for v in col])


def compare(new: dict, old: dict) -> dict:
    """The cases both sweeps ran, as lists (JSON-able): verdicts, criteria and the capture's offset."""
    cases = np.intersect1d(np.asarray(new["case"], int), np.asarray(old["case"], int))
    i_n, i_o = (np.searchsorted(np.asarray(cols["case"], int), cases) for cols in (new, old))
    offset = np.maximum(np.abs(np.asarray(new[CAPTURED_PREFIX + "x_m"], float)[i_n]),
                        np.abs(np.asarray(new[CAPTURED_PREFIX + "y_m"], float)[i_n]))  # fmt: skip
    out = {"case": cases.tolist(), "offset_m": offset.tolist()}
    for name, cols, idx in (("new", new, i_n), ("old", old, i_o)):
        for k in KEYS:
            out[f"{name}_{k}"] = np.asarray(cols[k], float)[idx].tolist()
        for k in FLAGS:
            out[f"{name}_{k}"] = _bool(np.asarray(cols[k])[idx]).tolist()
        out[f"{name}_steps"] = np.asarray(cols["num_steps"], float)[idx].astype(int).tolist() if "num_steps" in cols else None
    return out


def summary_lines(scenario: str, c: dict, labels: dict) -> list:
    n = len(c["case"])
    succ_n, succ_o = np.asarray(c["new_success"]), np.asarray(c["old_success"])
    a_n, a_o = np.asarray(c["new_a_max_g"]), np.asarray(c["old_a_max_g"])
    ln, lo_ = labels["new"], labels["old"]
    L = [
        f"## Scenario {scenario}: the {n} cases both models ran",
        "",
        f"Rows from `{c['new_csv']}` ({ln}) and `{c['old_csv']}` ({lo_}).",
        "",
        "| model | successful | a_max < 5 g | z_max < 10 m | sigma_max < 800 MPa | a_max: median [g] | range [g] |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name in ("new", "old"):
        a = np.asarray(c[f"{name}_a_max_g"])
        L.append(
            f"| {labels[name]} | {int(np.sum(c[f'{name}_success']))} | {int(np.sum(c[f'{name}_a_ok']))} | "
            f"{int(np.sum(c[f'{name}_z_ok']))} | {int(np.sum(c[f'{name}_sigma_ok']))} | {np.median(a):.2f} | "
            f"{a.min():.2f}-{a.max():.2f} |"
        )
    gained = [k for k, (x, y) in enumerate(zip(succ_n, succ_o)) if x and not y]
    lost = [k for k, (x, y) in enumerate(zip(succ_n, succ_o)) if y and not x]
    L += ["", f"Verdicts that turn: {len(gained)} succeed only with {ln}, {len(lost)} only with {lo_}."]
    if gained or lost:
        L += ["", f"| case | offset [m] | {lo_}: z / a / sigma | {ln}: z / a / sigma | success with |",
              "|---:|---:|---|---|---|"]  # fmt: skip
        for k in gained + lost:
            L.append(
                f"| {c['case'][k]} | {c['offset_m'][k]:.1f} | {c['old_z_max_m'][k]:.3f} / {c['old_a_max_g'][k]:.2f} / "
                f"{c['old_sigma_max_mpa'][k]:.0f} | {c['new_z_max_m'][k]:.3f} / {c['new_a_max_g'][k]:.2f} / "
                f"{c['new_sigma_max_mpa'][k]:.0f} | {ln if k in gained else lo_} |"
            )
    L += ["", f"{ln} against {lo_}, by the capture's offset max(|x|, |y|):", "",
          "| offset | cases | a_max: new - old [g] | z_max: new - old [m] | sigma_max: new / old - 1 | a_max < 5 g: new / old |",
          "|---|---:|---|---|---|---|"]  # fmt: skip
    off = np.asarray(c["offset_m"])
    dz = np.asarray(c["new_z_max_m"]) - np.asarray(c["old_z_max_m"])
    ds = np.asarray(c["new_sigma_max_mpa"]) / np.asarray(c["old_sigma_max_mpa"]) - 1.0
    for lo, hi, label in ((0, 5, "0-5 m"), (5, 10, "5-10 m"), (10, np.inf, ">= 10 m")):
        m = (off >= lo) & (off < hi)
        if not np.any(m):
            continue
        da = a_n[m] - a_o[m]
        L.append(
            f"| {label} | {int(m.sum())} | {da.min():+.2f} to {da.max():+.2f} (median {np.median(da):+.2f}) | "
            f"{dz[m].min():+.3f} to {dz[m].max():+.3f} | {100 * ds[m].min():+.1f}% to {100 * ds[m].max():+.1f}% | "
            f"{int(np.sum(np.asarray(c['new_a_ok'])[m]))} / {int(np.sum(np.asarray(c['old_a_ok'])[m]))} |"
        )
    if c.get("new_steps") and c.get("old_steps"):
        steps = (
            f"W-method steps a case, median: {int(np.median(c['new_steps'])):,} ({ln}) against "
            f"{int(np.median(c['old_steps'])):,} ({lo_}), as each CSV records them (a screened row counts "
            "its screen's steps)."
        )
        L += ["", steps]
    return L


def write_md(data, path):
    labels = data["labels"]
    L = [f"# Section IV at the full level: {labels['new']} against {labels['old']}", "",
         *_report.header(data), "",
         ("The same Halton cases (seed 0) of each scenario, read from the two sweeps' CSVs; a sweep may be "
         "partial (resumable). Criteria: Table 1 (z_max < 10 m, CFC 60 a_max < 5 g, "
         "sigma_max < 800 MPa) and capture. The machine line is this report's; where the sweeps ran is in `docs/arresting_validation.md`."), ""]  # fmt: skip
    for s, c in data["scenarios"].items():
        L += summary_lines(s, c, labels) + [""]
    _report.write_lines(path, L)


def plot(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = data["labels"]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for s, c in data["scenarios"].items():
        ax.plot(c["offset_m"], c["old_a_max_g"], "o", mfc="none", label=f"{s}: {labels['old']}")
        ax.plot(c["offset_m"], c["new_a_max_g"], "x", label=f"{s}: {labels['new']}")
    ax.axhline(5.0, color="k", lw=0.8, ls="--", label="criterion 5 g")
    ax.set_xlabel("capture offset max(|x|, |y|) [m]")
    ax.set_ylabel("a_max (CFC 60) [g]")
    ax.set_title("Section IV, full level: the same cases under both models")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenarios", nargs="+", default=["I", "II", "III"], choices=["I", "II", "III"])
    p.add_argument("--new", choices=sorted(RECORDS), default="node64", help="the model compared (default node64)")
    p.add_argument("--old", choices=sorted(RECORDS), default="capsule", help="the model compared with (default capsule)")
    p.add_argument("--results", default=None, help="folder of the CSVs (default experiments/results)")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    if args.new == args.old:
        p.error(f"--new and --old name the same model, {args.new!r}")
    enable_x64()  # the sweeps ran in float64; the header states this process's setting
    stem = STEM if (args.new, args.old) == ("node64", "capsule") else f"section4_{args.new}_vs_{args.old}"
    res = Path(args.results) if args.results else Path(__file__).parent / "results"
    out = _report.output_dir(args.out)
    labels = {"new": RECORDS[args.new]["label"], "old": RECORDS[args.old]["label"]}
    data = _report.start(scenarios={}, labels=labels, models={"new": args.new, "old": args.old})
    for s in args.scenarios:
        new_csv, old_csv = first_csv(res, RECORDS[args.new]["csvs"], s), first_csv(res, RECORDS[args.old]["csvs"], s)
        if new_csv is None or old_csv is None:
            print(f"scenario {s}: no CSV of {args.new if new_csv is None else args.old}, skipped")
            continue
        try:
            new, old = read_sweep_csv(new_csv), read_sweep_csv(old_csv)
        except ValueError as err:  # a sweep just started: its CSV holds no row yet
            print(f"scenario {s}: {err}, skipped")
            continue
        data["scenarios"][s] = dict(compare(new, old), new_csv=new_csv.name, old_csv=old_csv.name)
        print(f"scenario {s}: {len(data['scenarios'][s]['case'])} cases in both", flush=True)
    if not data["scenarios"]:
        raise SystemExit("no scenario has both models' CSVs")
    _report.finish(data, out, stem, write_md)
    plot(data, out / f"{stem}.png")


if __name__ == "__main__":
    main()
