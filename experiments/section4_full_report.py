"""Section IV at the full level: the report of the resumable sweeps' CSVs, however far they got (not a
test).

The 3 x 100 two-phase cases at the full level take hours on a 2-core CPU (about a minute a case once
compiled), so they run as resumable sweeps, one CSV a scenario::

    jaxcable sweep --phase full --fidelity full --scenario I --n 100 --rtol 1e-4 --t-end 1.2 \\
        --out experiments/results/sweep_two_phase_full_node80_I_n100_screen.csv
    jaxcable sweep --phase full --fidelity full --scenario I --n 100 \\
        --confirm experiments/results/sweep_two_phase_full_node80_I_n100_screen.csv \\
        --out experiments/results/sweep_two_phase_full_node80_I_n100_confirm.csv

(a screening sweep, then its cases near a limit at the defaults, docs/sweeps.md; rerun the same
command to go on after an interruption). The earlier records: ``sweep_two_phase_full_node_*``, the
node on 64 span elements (``--span-elements 64 --fine-elements 32``), and
``sweep_two_phase_full_calibrated_*``, the capsule contact (``--hook-contact capsule
--span-elements 32 --fine-elements 16``). This script reads the CSVs that exist and
writes, for the cases done so far, the summary in the form of Tables 5-7 and 9 (``jaxcable sweep``'s
own summary), Fig 21's criteria over the landing plane, and the mechanism behind the a_max failures:
a_max against the capture's distance from the frame's centre, beside the design case's value at the
same level (the centred capture), and the same cases at the rigid level (the rigid level's sweep is
run here, about 3 min for 100 cases with its compilation, its rows in the git-ignored
``experiments/out/section4_full/``): which verdicts the full level changes. Writes ``section4_full.{json,md}``, ``section4_full_plane_<S>.png``
and ``section4_full_offset.png``. Usage::

    python experiments/section4_full_report.py                  # the default (node, 80 elements)
    python experiments/section4_full_report.py --model node     # the node on 64 elements
    python experiments/section4_full_report.py --model capsule  # the capsule on 32 elements
"""

from __future__ import annotations

import argparse

import _report
import numpy as np
from section4_node_vs_capsule import (
    NODE,
    NODE80,
    NODE80_CONFIRMED,
    NODE_CONFIRMED,
    first_csv,
)

from jaxcable.arresting.calibration import CALIBRATED_CABLE_DAMPING_S
from jaxcable.arresting.passive import LandingCriteria
from jaxcable.arresting.sweep import CAPTURED_PREFIX, run_qmc_sweep, summarize_sweep
from jaxcable.arresting.sweep_plots import plot_landing_plane
from jaxcable.cli.sweep import summary_markdown
from jaxcable.core.config import enable_x64
from jaxcable.studies.sweep import read_sweep_csv

STEM = "section4_full"
CSV = "sweep_two_phase_full_calibrated_{}_n100.csv"
MODELS = {
    "capsule": {"csvs": (CSV,), "stem": STEM, "label": "the capsule contact on 32 span elements, the default when recorded"},
    "node": {"csvs": (NODE, NODE_CONFIRMED), "stem": STEM + "_node",
             "label": "the hook as a sliding node on 64 span elements, 32 fine, the default when recorded"},
    "node80": {"csvs": (NODE80, NODE80_CONFIRMED), "stem": STEM + "_node80",
               "label": "the hook as a sliding node on 80 span elements, 16 fine, the default"},
}  # fmt: skip
"""The recorded sweeps, by hook model: the CSVs tried in turn (the defaults' sweep, else a screening
sweep with its cases near a limit confirmed at the defaults, docs/sweeps.md), the report's stem."""


def capture_offset(table):
    """Each case's capture offset max(|x|, |y|) from the frame's centre [m]."""
    x = np.asarray(table[CAPTURED_PREFIX + "x_m"], float)
    y = np.asarray(table[CAPTURED_PREFIX + "y_m"], float)
    return np.maximum(np.abs(x), np.abs(y))


def rigid_rows(scenario, cases, n=100):
    """The rigid level's two-phase rows of ``cases`` (same Halton cases, seed 0, calibrated damping)."""
    rows_dir = _report.output_dir(quick=True, sub=STEM)
    table = run_qmc_sweep(scenario, n, phase="full", fidelity="rigid", out=rows_dir / f"rigid_{scenario}_n{n}.csv",
                          seed=0, cable_damping_s=CALIBRATED_CABLE_DAMPING_S, progress=False)  # fmt: skip
    index = {int(c): i for i, c in enumerate(np.asarray(table["case"], int))}
    pick = np.array([index[int(c)] for c in cases])
    return {k: np.asarray(v)[pick] for k, v in table.items()}


def plot_offset(tables, path, criteria=None, rigid=None):
    """a_max (CFC 60) against the capture's largest coordinate offset max(|x|, |y|) from the frame's
    centre, one colour per scenario; open markers where another criterion failed or the rocket was not
    captured and stopped; the same cases at the rigid level as grey crosses."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    criteria = LandingCriteria() if criteria is None else criteria
    fig, ax = plt.subplots(figsize=(6.2, 4.2))
    for (scenario, table), colour in zip(tables.items(), ("C0", "C1", "C2")):
        off = capture_offset(table)
        a = np.asarray(table["a_max_g"], float)
        others = (np.asarray(table["z_ok"], bool) & np.asarray(table["sigma_ok"], bool) & np.asarray(table["stopped"], bool)
                  & np.asarray(table["captured"], bool))  # fmt: skip
        ax.plot(off[others], a[others], "o", color=colour, label=f"scenario {scenario} ({len(a)} cases)")
        ax.plot(off[~others], a[~others], "o", color=colour, mfc="white")
        if rigid and scenario in rigid:
            ax.plot(off, np.asarray(rigid[scenario]["a_max_g"], float), "x", color="0.5",
                    label="the same cases, rigid level" if colour == "C0" else None)  # fmt: skip
    ax.axhline(float(criteria.a_max_g), color="k", ls="--", lw=0.8, label="limit")
    ax.set_xlabel("capture offset max(|x|, |y|) from the frame's centre [m]")
    ax.set_ylabel("a_max (CFC 60) [g]")
    ax.set_title("section IV, two-phase, full level")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_md(data, path):
    L = ["# Section IV at the full level (two-phase sweeps, calibrated cable damping)", "", *_report.header(data), "",
         f"Hook model: {data.get('model_label', MODELS['capsule']['label'])}.", ""]  # fmt: skip
    for entry in data["scenarios"].values():
        L += [entry["markdown"], "", f"Rows: `experiments/results/{entry['csv']}`. ![plane]({entry['plane']})", ""]
        L += ["a_max by capture offset max(|x|, |y|) [m]:", "", "| offset | cases | a_max min-max [g] | a_max met |",
              "|---|---:|---|---:|"]  # fmt: skip
        for row in entry["by_offset"]:
            L.append(f"| {row['band']} | {row['n']} | {row['a_min']:.2f}-{row['a_max']:.2f} | {row['met']}/{row['n']} |")
        L.append("")
        if "rigid" in entry:
            r = entry["rigid"]
            L += [(f"The same {r['n']} cases at the rigid level: {r['success']} successful ({r['a_ok']} meet a_max), "
                   f"at the full level {r['success_full']}; a_max full / rigid {r['ratio_min']:.3f}-{r['ratio_max']:.3f} "
                   f"(mean {r['ratio_mean']:.3f}); verdicts: both succeed {r['both']}, rigid only {r['rigid_only']}, "
                   f"full only {r['full_only']}, neither {r['neither']}."), ""]  # fmt: skip
    L.append(f"![a_max against the capture offset]({data.get('stem', STEM)}_offset.png)")
    _report.write_lines(path, L)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenarios", nargs="+", default=["I", "II", "III"], choices=["I", "II", "III"])
    p.add_argument("--out", default=None)
    p.add_argument("--no-rigid", action="store_true", help="skip the rigid level's rows of the same cases")
    p.add_argument("--model", choices=sorted(MODELS), default="node80", help="whose recorded sweeps (default node80)")
    args = p.parse_args()
    model = MODELS[args.model]
    stem = model["stem"]
    enable_x64()  # the sweeps ran in float64, as every landing scene does
    out = _report.output_dir(args.out)
    data = _report.start(precision=_report.precision(), scenarios={}, model_label=model["label"], stem=stem)
    tables, rigid = {}, {}
    for scenario in args.scenarios:
        csv = first_csv(_report.RESULTS, model["csvs"], scenario)
        if csv is None:
            continue
        table = read_sweep_csv(csv)
        if not len(table.get("case", [])):
            continue
        tables[scenario] = table
        title = f"scenario {scenario}, two-phase, full level ({len(table['case'])} of 100 cases)"
        plane = f"{stem}_plane_{scenario}.png"
        plot_landing_plane(table, out / plane, title)
        off = capture_offset(table)
        a = np.asarray(table["a_max_g"], float)
        met = np.asarray(table["a_ok"], bool)
        by_offset = []
        for lo, hi in ((0.0, 5.0), (5.0, 10.0), (10.0, np.inf)):
            m = (off >= lo) & (off < hi)
            if m.any():
                band = f"{lo:g}-{hi:g} m" if np.isfinite(hi) else f">= {lo:g} m"
                by_offset.append({"band": band, "n": int(m.sum()), "a_min": float(a[m].min()), "a_max": float(a[m].max()),
                                  "met": int(met[m].sum())})  # fmt: skip
        summary = summarize_sweep(table)
        data["scenarios"][scenario] = {
            "csv": csv.name, "plane": plane, "n_cases": len(table["case"]), "by_offset": by_offset,
            "success_rate": float(np.mean(np.asarray(table["success"], bool))),
            "markdown": summary_markdown(summary, title),
        }  # fmt: skip
        if not args.no_rigid:
            rig = rigid[scenario] = rigid_rows(scenario, table["case"])
            ok_r, ok_f = np.asarray(rig["success"], bool), np.asarray(table["success"], bool)
            ratio = a / np.asarray(rig["a_max_g"], float)
            data["scenarios"][scenario]["rigid"] = {
                "n": len(ok_r), "success": int(ok_r.sum()), "success_full": int(ok_f.sum()),
                "a_ok": int(np.asarray(rig["a_ok"], bool).sum()), "ratio_min": float(ratio.min()),
                "ratio_max": float(ratio.max()), "ratio_mean": float(ratio.mean()), "both": int((ok_r & ok_f).sum()),
                "rigid_only": int((ok_r & ~ok_f).sum()), "full_only": int((~ok_r & ok_f).sum()),
                "neither": int((~ok_r & ~ok_f).sum()),
            }  # fmt: skip
    if not tables:
        raise SystemExit(f"no sweep CSV found in {_report.RESULTS} ({model['csvs'][0].format('<S>')}); run the sweeps first")
    plot_offset(tables, out / f"{stem}_offset.png", rigid=rigid)
    _report.finish(data, out, stem, write_md)


if __name__ == "__main__":
    main()
