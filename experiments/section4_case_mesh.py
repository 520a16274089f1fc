"""Single section IV cases at the full level on several cable meshes (not a test).

The section IV sweeps at the full level ran on two meshes that both converge on the design case and
on section IV.A's case (80 span elements with 16 fine, the default; 64 with 32 fine, the default
before): their rates agree, but single cases' a_max differ by up to about 5% between them
(``experiments/results/section4_node80_vs_node64.md``). This script lands chosen cases of a
scenario's Halton sweep (seed 0) as the sweep does (the same tracking phase, noise and gust keys,
``run_two_phase``'s passive phase from the captured state) on each mesh of ``--meshes``, so that a
case's verdict can be checked against a finer mesh. Passive phase ``--t-end`` s at the level's
default tolerance. Writes ``section4_case_mesh<tag>.{json,md}``. Usage::

    python experiments/section4_case_mesh.py --scenario I --cases 47 95 --meshes 80,16 64,32 160,32
"""

from __future__ import annotations

import argparse
import time

import _report
from bench_land import clean

from jaxcable.arresting import two_phase
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.sweep import qmc_case_fn
from jaxcable.arresting.uncertainty import UNCERTAIN_PARAMETERS, halton_samples
from jaxcable.core.config import enable_x64

STEM = "section4_case_mesh"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa", "stopped", "criteria_met", "energy_budget_error", "num_steps")


def captured_kwargs(scenario: str, case: int, n: int = 100, seed: int = 0) -> dict:
    """``run_landing`` keyword arguments of the passive phase of ``case`` of the scenario's sweep of
    ``n`` cases (seed ``seed``): the sweep's own tracking scene of the case
    (``TwoPhaseCaseFunction.scene``), run as ``run_two_phase`` runs it."""
    samples = halton_samples(n, scenario, "full", seed)
    scene = qmc_case_fn(scenario, phase="full", fidelity="full", seed=seed).scene(
        {k: samples[k][case] for k in UNCERTAIN_PARAMETERS}
    )
    _, out = two_phase._tracking_jit(scene)
    return two_phase._passive_kwargs(scene, out, True)


def write_md(data, path):
    intro = (
        f"Scenario {data['scenario']}, Halton sweep of 100 cases, seed 0; passive phase {data['t_end_s']:g} s at the "
        "full level's default tolerance, the hook as a sliding node; a_max and sigma_max after the CFC 60 filter."
    )
    L = ["# Single section IV cases on several cable meshes (full level)", "", *_report.header(data), "", intro, "",
         "| case | span / fine elements | z_max [m] | a_max [g] | sigma_max [MPa] | criteria met | steps | energy budget | run [s] |",
         "|---:|---|---:|---:|---:|---|---:|---:|---:|"]  # fmt: skip
    for r in data["rows"]:
        L.append(
            f"| {r['case']} | {r['mesh'][0]} / {r['mesh'][1]} | {r['z_max_m']:.3f} | {r['a_max_g']:.3f} | "
            f"{r['sigma_max_mpa']:.1f} | {'yes' if r['criteria_met'] else 'no'} | {r['num_steps']:,} | "
            f"{r['energy_budget_error']:.1e} | {r['wall_s']:.0f} |"
        )
    _report.write_lines(path, L)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", choices=["I", "II", "III"], default="I")
    p.add_argument("--cases", nargs="+", type=int, required=True, help="case indices of the sweep (0-99)")
    p.add_argument("--meshes", nargs="+", default=["80,16", "160,32"], help="span,fine element counts")
    p.add_argument("--t-end", type=float, default=1.2, help="passive phase [s] (every case stops by 0.8 s)")
    p.add_argument("--tag", default="")
    p.add_argument("--out", default=None)
    a = p.parse_args()
    enable_x64()
    meshes = [tuple(int(v) for v in m.split(",")) for m in a.meshes]
    out = _report.output_dir(a.out)
    data = _report.start(scenario=a.scenario, t_end_s=a.t_end, rows=[])
    for case in a.cases:
        kwargs = captured_kwargs(a.scenario, case)
        for span, fine in meshes:
            t0 = time.perf_counter()
            res = run_landing("full", t_end_s=a.t_end, n_span_elements=span, n_fine=fine, **kwargs).outputs
            row = {"case": case, "mesh": [span, fine], "wall_s": time.perf_counter() - t0, **{k: clean(res[k]) for k in KEYS}}
            data["rows"].append(row)
            print(row, flush=True)
            _report.save(data, out, STEM + a.tag)
    _report.finish(data, out, STEM + a.tag, write_md)


if __name__ == "__main__":
    main()
