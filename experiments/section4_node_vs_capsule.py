"""Section IV at the full level: the converged default (the hook as a sliding node on 64 span
elements) against the 3 x 100 cases recorded with the capsule contact on 32, case by case.

Reads, for each scenario whose node CSV exists, the rows both sweeps have run (the node sweep is
resumable and may be partial)::

    jaxcable sweep --phase full --fidelity full --scenario I --n 100 \\
        --span-elements 64 --fine-elements 32 --out experiments/results/sweep_two_phase_full_node_I_n100.csv

against ``sweep_two_phase_full_calibrated_<S>_n100.csv`` (capsule, 32 elements). Reports the success
and a_max rates of the same cases under both models, the verdicts that turn, and the change of
a_max, z_max and sigma_max against the capture's offset from the frame's centre. Reads CSVs only
(no solve). Writes ``section4_node_vs_capsule.{json,md,png}``. Usage::

    python experiments/section4_node_vs_capsule.py
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


def compare(node: dict, capsule: dict) -> dict:
    """The cases both sweeps ran, as lists (JSON-able): verdicts, criteria and the capture's offset."""
    cases = np.intersect1d(np.asarray(node["case"], int), np.asarray(capsule["case"], int))
    i_n, i_c = (np.searchsorted(np.asarray(cols["case"], int), cases) for cols in (node, capsule))
    offset = np.maximum(np.abs(np.asarray(node[CAPTURED_PREFIX + "x_m"], float)[i_n]),
                        np.abs(np.asarray(node[CAPTURED_PREFIX + "y_m"], float)[i_n]))  # fmt: skip
    out = {"case": cases.tolist(), "offset_m": offset.tolist()}
    for name, cols, idx in (("node", node, i_n), ("capsule", capsule, i_c)):
        for k in KEYS:
            out[f"{name}_{k}"] = np.asarray(cols[k], float)[idx].tolist()
        for k in FLAGS:
            out[f"{name}_{k}"] = _bool(np.asarray(cols[k])[idx]).tolist()
        out[f"{name}_steps"] = np.asarray(cols["num_steps"], float)[idx].astype(int).tolist() if "num_steps" in cols else None
    return out


def summary_lines(scenario: str, c: dict) -> list:
    n = len(c["case"])
    succ_n, succ_c = np.asarray(c["node_success"]), np.asarray(c["capsule_success"])
    a_n, a_c = np.asarray(c["node_a_max_g"]), np.asarray(c["capsule_a_max_g"])
    L = [
        f"## Scenario {scenario}: the {n} cases both models ran",
        "",
        f"Node rows from `{c.get('node_csv', NODE.format(scenario))}`.",
        "",
        "| model | successful | a_max < 5 g | z_max < 10 m | sigma_max < 800 MPa | a_max: median [g] | range [g] |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for name, label in (("node", "node, 64 elements (the default)"), ("capsule", "capsule, 32 elements (recorded)")):
        a = np.asarray(c[f"{name}_a_max_g"])
        L.append(
            f"| {label} | {int(np.sum(c[f'{name}_success']))} | {int(np.sum(c[f'{name}_a_ok']))} | "
            f"{int(np.sum(c[f'{name}_z_ok']))} | {int(np.sum(c[f'{name}_sigma_ok']))} | {np.median(a):.2f} | "
            f"{a.min():.2f}-{a.max():.2f} |"
        )
    gained = [k for k, (x, y) in enumerate(zip(succ_n, succ_c)) if x and not y]
    lost = [k for k, (x, y) in enumerate(zip(succ_n, succ_c)) if y and not x]
    L += ["", f"Verdicts that turn: {len(gained)} succeed only with the node, {len(lost)} only with the capsule."]
    if gained or lost:
        L += ["", "| case | offset [m] | capsule: z / a / sigma | node: z / a / sigma | verdict |", "|---:|---:|---|---|---|"]
        for k in gained + lost:
            L.append(
                f"| {c['case'][k]} | {c['offset_m'][k]:.1f} | {c['capsule_z_max_m'][k]:.3f} / {c['capsule_a_max_g'][k]:.2f} / "
                f"{c['capsule_sigma_max_mpa'][k]:.0f} | {c['node_z_max_m'][k]:.3f} / {c['node_a_max_g'][k]:.2f} / "
                f"{c['node_sigma_max_mpa'][k]:.0f} | {'node only' if k in gained else 'capsule only'} |"
            )
    L += ["", "The node against the capsule, by the capture's offset max(|x|, |y|):", "",
          "| offset | cases | a_max: node - capsule [g] | z_max: node - capsule [m] | sigma_max: node / capsule - 1 | a_max < 5 g: node / capsule |",
          "|---|---:|---|---|---|---|"]  # fmt: skip
    off = np.asarray(c["offset_m"])
    dz = np.asarray(c["node_z_max_m"]) - np.asarray(c["capsule_z_max_m"])
    ds = np.asarray(c["node_sigma_max_mpa"]) / np.asarray(c["capsule_sigma_max_mpa"]) - 1.0
    for lo, hi, label in ((0, 5, "0-5 m"), (5, 10, "5-10 m"), (10, np.inf, ">= 10 m")):
        m = (off >= lo) & (off < hi)
        if not np.any(m):
            continue
        da = a_n[m] - a_c[m]
        L.append(
            f"| {label} | {int(m.sum())} | {da.min():+.2f} to {da.max():+.2f} (median {np.median(da):+.2f}) | "
            f"{dz[m].min():+.3f} to {dz[m].max():+.3f} | {100 * ds[m].min():+.1f}% to {100 * ds[m].max():+.1f}% | "
            f"{int(np.sum(np.asarray(c['node_a_ok'])[m]))} / {int(np.sum(np.asarray(c['capsule_a_ok'])[m]))} |"
        )
    return L


def write_md(data, path):
    L = ["# Section IV at the full level: the hook as a sliding node (64 elements) against the capsule (32)", "",
         *_report.header(data), "",
         ("The same Halton cases (seed 0) of each scenario, read from the two sweeps' CSVs; the node sweep is the "
         "scenes' default now and may be partial (resumable). Criteria: Table 1 (z_max < 10 m, CFC 60 a_max < 5 g, "
         "sigma_max < 800 MPa) and capture. The machine line is this report's; where the sweeps ran is in `docs/arresting_validation.md`."), ""]  # fmt: skip
    for s, c in data["scenarios"].items():
        L += summary_lines(s, c) + [""]
    _report.write_lines(path, L)


def plot(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for s, c in data["scenarios"].items():
        ax.plot(c["offset_m"], c["capsule_a_max_g"], "o", mfc="none", label=f"{s}: capsule, 32 elements")
        ax.plot(c["offset_m"], c["node_a_max_g"], "x", label=f"{s}: node, 64 elements")
    ax.axhline(5.0, color="k", lw=0.8, ls="--", label="criterion 5 g")
    ax.set_xlabel("capture offset max(|x|, |y|) [m]")
    ax.set_ylabel("a_max (CFC 60) [g]")
    ax.set_title("Section IV, full level: the same cases under both hook models")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenarios", nargs="+", default=["I", "II", "III"], choices=["I", "II", "III"])
    p.add_argument("--results", default=None, help="folder of the CSVs (default experiments/results)")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    enable_x64()  # the sweeps ran in float64; the header states this process's setting
    res = Path(args.results) if args.results else Path(__file__).parent / "results"
    out = _report.output_dir(args.out)
    data = _report.start(scenarios={})
    for s in args.scenarios:
        node_csv, capsule_csv = first_csv(res, (NODE, NODE_CONFIRMED), s), res / CAPSULE.format(s)
        if node_csv is None or not capsule_csv.exists():
            print(f"scenario {s}: {NODE.format(s) if node_csv is None else capsule_csv.name} missing, skipped")
            continue
        try:
            node = read_sweep_csv(node_csv)
        except ValueError as err:  # a sweep just started: its CSV holds no row yet
            print(f"scenario {s}: {err}, skipped")
            continue
        data["scenarios"][s] = dict(compare(node, read_sweep_csv(capsule_csv)), node_csv=node_csv.name)
        print(f"scenario {s}: {len(data['scenarios'][s]['case'])} cases in both", flush=True)
    if not data["scenarios"]:
        raise SystemExit("no scenario has both CSVs")
    _report.finish(data, out, STEM, write_md)
    plot(data, out / f"{STEM}.png")


if __name__ == "__main__":
    main()
