"""Benchmark of the full two-phase landing per fidelity level (not a test).

The deviated case of section IV.A in scenario I (``run_two_phase`` defaults: x = y = 13 m, tilt 5 deg,
wind 90 deg, 10% gust, tau = 0.1 s, sigma_r = 0.1 m), phase 2 at each level ``rigid``, ``ale``,
``full`` for ``--t-end`` seconds of passive deceleration (default 1.0 s: the rocket stops at ~0.8 s).

Each level runs twice with different seeds (noise and gust differ, so the captured state differs):
*first* = compile + run (phase 1 is compiled once for all levels; its compile is in the first row),
*second* = a new case with the compiled code (what a user pays per case once compiled), split into
phase 1 (tracking, rigid rocket, compiled) and phase 2 (passive, at the level; the ale/full levels
mesh the cables on the host from the captured state). Load averages are recorded per case: the
machine is shared and wall-clock times are noisy.

Usage:
    python experiments/bench_two_phase.py            # ~5 min: experiments/results/bench_two_phase.{json,md}
    python experiments/bench_two_phase.py --quick    # rigid only, 0.3 s passive: experiments/out/
"""

from __future__ import annotations

import argparse
import time

import _report

import jaxcable

STEM = "bench_two_phase"
LEVELS = ("rigid", "ale", "full")
KEYS = ("captured", "capture_margin_m", "tracking_error_m", "z_max_m", "a_max_g", "sigma_max_mpa", "passive_steps")


def _time_case(level, t_end, seed):
    from jaxcable.arresting import two_phase

    t0 = time.perf_counter()
    scene = two_phase.tracking_scene(seed=seed)
    track, out = two_phase._tracking_jit(scene)
    float(out["capture_margin_m"])  # block
    t1 = time.perf_counter()
    run = two_phase.run_two_phase(fidelity=level, passive_t_end_s=t_end, seed=seed)
    t2 = time.perf_counter()
    res = run.outputs
    return dict(
        level=level,
        seed=seed,
        phase1_s=t1 - t0,
        # run_two_phase repeats phase 1 (compiled): subtract it to get phase 2
        phase2_s=(t2 - t1) - (t1 - t0) if seed else None,
        total_s=t2 - t1,
        load=_report.load_average(),
        **{k: (res[k] if not hasattr(res[k], "item") else res[k].item()) for k in KEYS},
    )


def main():
    p = argparse.ArgumentParser(description="two-phase landing benchmark per fidelity level")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--t-end", type=float, default=None, help="passive-phase end time [s] (1.0; quick 0.3)")
    p.add_argument("--levels", nargs="+", default=None, choices=LEVELS)
    p.add_argument("--out", help="report folder (default experiments/results; --quick: experiments/out)")
    args = p.parse_args()
    jaxcable.enable_x64()
    t_end = args.t_end or (0.3 if args.quick else 1.0)
    levels = args.levels or (["rigid"] if args.quick else list(LEVELS))
    out_dir = _report.output_dir(args.out, quick=args.quick)
    data = _report.start(t_end_s=t_end, rows=[])
    rows = data["rows"]
    for level in levels:
        first = _time_case(level, t_end, seed=0)
        second = _time_case(level, t_end, seed=1)
        row = dict(level=level, first_s=first["phase1_s"] + first["total_s"], second=second)
        rows.append(row)
        print(f"{level}: first {first['total_s']:.1f} s, second {second['total_s']:.1f} s "
              f"(phase 1 {second['phase1_s']:.2f} s, phase 2 {second['phase2_s']:.1f} s), load {second['load']}", flush=True)  # fmt: skip
        _report.save(data, out_dir, STEM)
    _report.finish(data, out_dir, STEM, write_md)


def write_md(data, path):
    t_end, rows = data["t_end_s"], data["rows"]
    lines = [
        "# Two-phase landing: wall time per fidelity level",
        "",
        *_report.header(data),
        "",
        f"Case: deviated case of section IV.A, scenario I, passive phase {t_end} s.",
        "",
        "| level | first call (compile + run) [s] | case after compile [s] | phase 1 [s] | phase 2 [s] | passive steps | captured | margin [m] | z_max [m] | a_max [g] | sigma_max [MPa] | load (1/5/15 min) |",
        "|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        s = r["second"]
        lines.append(
            f"| {r['level']} | {r['first_s']:.1f} | {s['total_s']:.1f} | {s['phase1_s']:.2f} | {s['phase2_s']:.1f} | "
            f"{s['passive_steps']} | {s['captured']} | {s['capture_margin_m']:.3f} | {s['z_max_m']:.3f} | "
            f"{s['a_max_g']:.2f} | {s['sigma_max_mpa']:.0f} | {s['load']} |"
        )
    lines += [
        "",
        "Goal: under 10 s per case at full fidelity on this 2-core CPU. *Case after compile* is",
        "a second case (new seed) with the compiled code; phase 2 at the ale/full levels is the passive",
        "landing, whose steps are set by the fine elements' axial modes, the contact's stick creep and,",
        "after the stop, by accuracy (docs/notes/contact_slip.md).",
    ]
    _report.write_lines(path, lines)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
