"""Work-precision of the linearly implicit W-method (``rosw``) against explicit Bosh3 and Tsit5 and
implicit Kvaerno5 on stiff cables.

Two cases, over the first ``--t-end`` seconds after capture (default 0.2 s: the capture, the hook
pick-up and the first stress rise), at the ``ale`` and ``full`` levels, at cable Rayleigh damping
beta = 0, 1e-5, 1e-4, 1e-3, 1e-2 s:

* ``design``: the design case (Table 1, central vertical capture at 20 m/s);
* ``iv_a``: the passive phase of the deviated two-phase case of section IV.A (scenario I, the
  defaults of ``run_two_phase``: 13 m off centre, tilted, wind and gust), from the state that its
  tracking phase captures (computed once, rigid rocket), with the air loads.

Solvers (``--solvers``, default all):

* ``rosw`` (:class:`jaxcable.core.rosenbrock.RosenbrockW`, structured linear solve of
  :mod:`jaxcable.arresting.stiff`) at rtol = atol = 1e-4 and 1e-5, the linearisation recomputed
  every ``RosenbrockW.jacobian_every`` accepted steps (the default; the results recorded before it
  moved from 4 to 2 say 4);
* ``bosh3`` (today's default below the stiff threshold) and ``tsit5`` at rtol = atol = 1e-4;
* ``kvaerno5`` (diffrax's implicit ESDIRK: a dense Jacobian of the whole state and a chord
  iteration every step) at rtol = atol = 1e-4;
* the reference: ``rosw`` at ``--ref-rtol`` (1e-7).

All with the levels' PI step-size controller. Each solver has a step budget (``--max-steps``,
explicit and W-method; ``--implicit-max-steps``, Kvaerno5), so a case cannot run for more than a
few minutes: a run that exhausts it is reported as "did not finish within N steps" with the time it
reached, not left out.

Per case: the run time, accepted and rejected steps, z_max, a_max, sigma_max, the energy-budget
error, the relative error of the three against the reference, and the load average. The time is
that of a second identical call (compiled) when the first took under ``SECOND_CALL_BELOW_S``, or
when the first was the first call of its compiled program (then the compile is in it); otherwise
the first (its program compiled by an earlier beta). ``--mesh`` adds the cost per step against
the number of span elements (16, 32, 64) at the ale level. The cases' mesh: ``--span-elements``
(default 16, the mesh of the earlier records; the scenes' default is 32). Writes ``bench_stiff<tag>.json/.md``.
Usage:

    python experiments/bench_stiff.py --mesh --levels ale --cases design --betas 1e-5 1e-4 1e-3 1e-2 \\
        --solvers rosw bosh3                                               # ~25 min on 2 cores
    python experiments/bench_stiff.py --levels full --cases design --betas 1e-5 1e-3 1e-2 \\
        --solvers rosw bosh3 --ref-rtol 1e-6 --tag _full
    python experiments/bench_stiff.py --levels ale --betas 0 1e-4 1e-3 1e-2 --tag _solvers
    python experiments/bench_stiff.py --levels full --cases design --betas 1e-5 6.3e-3 --solvers rosw bosh3 \\
        --t-end 1.0 --ref-rtol 1e-6 --span-elements 32 --max-steps 100000 --tag _full_1s_32
                                           # the whole design case on the scenes' default mesh, ~25 min
    python experiments/bench_stiff.py --quick          # ale, design, beta 1e-5 and 1e-2, 0.05 s
    python experiments/bench_stiff.py --levels ale --cases design --betas 1e-5 1e-2 --solvers rosw bosh3 \\
        --float32 --ref-json experiments/results/bench_stiff_coupling.json --tag _float32
                                           # float32 against an earlier float64 run's references
"""

from __future__ import annotations

import argparse
import functools
import time

import _report

from jaxcable.arresting import two_phase
from jaxcable.arresting.landing import LEVEL_STEP_CONTROL
from jaxcable.arresting.passive import passive_landing_scene
from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import RosenbrockW
from jaxcable.core.simulate import simulate

STEM = "bench_stiff"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa")
CASES = {
    "design": "design case (Table 1, central vertical capture at 20 m/s)",
    "iv_a": "passive phase of the deviated two-phase case of section IV.A (scenario I)",
}
SOLVER_NAMES = ("rosw", "rosw3e-5", "bosh3", "tsit5", "kvaerno5", "rosw_fixed_hooks")
SECOND_CALL_BELOW_S = 60.0
"""A first call shorter than this [s] is repeated and the second (compiled) call timed."""


@functools.cache
def _iv_a_capture():
    """Keyword arguments of ``passive_landing_scene`` for the passive phase of the IV.A case: the
    state its tracking phase captures, the frame's centre then, the layout and the air (as
    ``run_two_phase`` builds them)."""
    scene = two_phase.tracking_scene()
    _, out = two_phase._tracking_jit(scene)
    return two_phase._passive_kwargs(scene, out)


def build_scene(case, level, beta, t_end, n_span=16, default_model=False):
    """The case's passive scene on ``n_span`` span elements, half of them fine, with the capsule
    contact (the model of the records); ``default_model``: the scenes' default instead (the hook
    as a sliding node on the level's own mesh, ``passive.LEVEL_CABLE_MESH``)."""
    kwargs = _iv_a_capture() if case == "iv_a" else {}
    if default_model:
        return passive_landing_scene(level, t_end_s=t_end, cable_damping_s=beta, **kwargs)
    return passive_landing_scene(
        level, t_end_s=t_end, cable_damping_s=beta, n_span_elements=n_span, n_fine=n_span // 2, hook_contact="capsule",
        **kwargs,
    )  # fmt: skip


def _call(scene, level, t_end, solver, rtol, max_steps):
    pcoeff, icoeff = LEVEL_STEP_CONTROL[level]
    t0 = time.perf_counter()
    res = simulate(scene, t_end, solver=solver, rtol=rtol, atol=rtol, max_steps=max_steps, pcoeff=pcoeff, icoeff=icoeff)
    out = {k: float(v) for k, v in res.outputs.items() if k != "status"}
    return res, out, time.perf_counter() - t0


_COMPILED = set()


def run(scene, level, t_end, solver, rtol, max_steps, program, repeat=True):
    """One case; ``program`` names its compiled program (the same for every beta: beta is an array
    in the scene), so a first call can be told apart from a compiled one. ``repeat=False``: one
    call, whatever it took (the reference, whose time is not compared)."""
    res, out, first = _call(scene, level, t_end, solver, rtol, max_steps)
    fresh = program not in _COMPILED
    _COMPILED.add(program)
    second = None
    if repeat and (first < SECOND_CALL_BELOW_S or fresh):
        res, out, second = _call(scene, level, t_end, solver, rtol, max_steps)
    finished = res.status_message == "successful"
    return dict(
        wall_s=first if second is None else second, first_call_s=first, second_call_s=second,
        steps=int(res.num_steps), rejected=int(res.num_rejected), max_steps=max_steps, status=res.status_message,
        finished=finished, t_reached_s=float(res.t_final), load=_report.load_average(),
        energy_budget_error=out["energy_budget_error"], **{k: out[k] for k in KEYS},
    )  # fmt: skip


def _solvers(names, max_steps, implicit_max_steps):
    rosw = RosenbrockW()
    table = {
        "rosw": [("rosw", rosw, 1e-4, max_steps), ("rosw", rosw, 1e-5, max_steps)],
        # the ale level's default tolerance (``STIFF_LEVEL_DEFAULTS``)
        "rosw3e-5": [("rosw", rosw, 3e-5, max_steps)],
        "bosh3": [("bosh3", "bosh3", 1e-4, max_steps)],
        "tsit5": [("tsit5", "tsit5", 1e-4, max_steps)],
        "kvaerno5": [("kvaerno5", "kvaerno5", 1e-4, implicit_max_steps)],
        # the W-method without the cable rows' columns on the rocket (the hooks held fixed in J)
        "rosw_fixed_hooks": [("rosw_fixed_hooks", None, 1e-5, max_steps)],
    }
    return [row for name in names for row in table[name]]


def _fixed_hooks(scene, t, y):
    return scene.stiff_linearisation(t, y, hook_coupling=False)


def _projected_s(c, t_end):
    """An unfinished run's time to ``t_end`` at the pace it kept until it stopped [s] (an estimate)."""
    return c["wall_s"] * t_end / c["t_reached_s"] if c["t_reached_s"] > 0 else float("inf")


def _time_cell(c, t_end):
    if not c["finished"]:
        return (
            f"did not finish within {c['max_steps']:,} steps: t = {c['t_reached_s']:.3g} s in {c['wall_s']:.0f} s "
            f"({1e3 * c['wall_s'] / max(c['steps'] + c['rejected'], 1):.0f} ms per step; at that pace "
            f"~{_projected_s(c, t_end) / 60:.0f} min to {t_end:g} s)"
        )
    mark = "" if c.get("second_call_s") is not None else "*"
    return f"{c['wall_s']:.2f}{mark}"


def write_md(data, path):
    lines = ["# Stiff cables: the W-method against Bosh3, Tsit5 and Kvaerno5", "", *_report.header(data), ""]
    mesh = (
        "the scenes' default model (the hook as a sliding node on the level's own mesh, 80 span elements, 16 fine)"
        if data.get("default_model")
        else f"{data.get('span_elements', 16)} elements per arresting span (the capsule contact)"
    )
    lines += [
        f"First {data['t_end_s']} s after capture, {mesh}. Cases: "
        + "; ".join(f"`{k}`, the {v}" for k, v in CASES.items() if k in data.get("case_names", CASES))
        + f". Error: largest relative error of z_max, a_max, sigma_max (the CFC 60 criteria) against the "
        f"reference (rosw at {data.get('ref_rtol', 1e-7):g}). Time: second identical call (compiled); "
        f"*: one call, a run of over {SECOND_CALL_BELOW_S:.0f} s whose program an earlier beta compiled "
        f"(the reference: one call, compile included at its first beta). A run that exhausted its step "
        f"budget: the time it reached, its wall time and the time per attempted step. All solvers with "
        f"the levels' PI step-size controller (0.4, 0.3). Load: 1-min load average after the case.",
        "",
        *([f"References (float64) taken from `{data['ref_json']}`.", ""] if data.get("ref_json") else []),
        "| case | level | beta [s] | solver | rtol | time [s] | steps | rejected | max rel. error "
        + "| energy budget | status | load |",
        "|---|---|---:|---|---:|---|---:|---:|---:|---:|---|---:|",
    ]
    for c in data["cases"]:
        err = c.get("max_rel_error")
        load = c.get("load")
        lines.append(
            f"| {c.get('case', 'design')} | {c['level']} | {c['beta']:g} | {c['solver']} | {c['rtol']:g} | "
            f"{_time_cell(c, data['t_end_s']) if 'finished' in c else format(c['wall_s'], '.2f')} | {c['steps']} | "
            f"{c['rejected']} | {'' if err is None else f'{err:.1e}'} | "
            f"{format(c['energy_budget_error'], '.1e') if c.get('finished', True) else ''} | "
            f"{c['status']} | {'' if load is None else load[0]} |"
        )
    lines += _ratio_lines(data)
    if data.get("mesh"):
        lines += ["", "Cost per step against span elements (ale, rosw 1e-4, beta 1e-2):", "",
                  "| span elements | time [s] | steps | ms per step |", "|---:|---:|---:|---:|"]  # fmt: skip
        for m in data["mesh"]:
            lines.append(f"| {m['n_span']} | {m['wall_s']:.2f} | {m['steps']} | {1e3 * m['wall_s'] / max(m['steps'], 1):.3f} |")
    _report.write_lines(path, lines)


def _ratio_lines(data):
    """Each solver's time over rosw 1e-5's on the same case (> 1: rosw 1e-5 is faster)."""
    groups = {}
    for c in data["cases"]:
        groups.setdefault((c.get("case", "design"), c["level"], c["beta"]), {})[(c["solver"], c["rtol"])] = c
    others = [("bosh3", 1e-4), ("tsit5", 1e-4), ("kvaerno5", 1e-4), ("rosw", 1e-4), ("rosw_fixed_hooks", 1e-5)]
    rows = []
    for (case, level, beta), g in groups.items():
        base = g.get(("rosw", 1e-5))
        if base is None:
            continue
        cells = []
        for key in others:
            c = g.get(key)
            if c is None:
                cells.append("")
            elif c.get("finished", True):
                cells.append(f"{c['wall_s'] / base['wall_s']:.2g}")
            else:
                projected = _projected_s(c, data["t_end_s"]) / base["wall_s"]
                cells.append(f"> {c['wall_s'] / base['wall_s']:.2g} (unfinished; ~{projected:.0f} at its pace)")
        rows.append(f"| {case} | {level} | {beta:g} | {base['wall_s']:.2f} | " + " | ".join(cells) + " |")
    if not rows:
        return []
    return [
        "",
        "Time over rosw 1e-5's on the same case (> 1: the W-method at 1e-5 is faster; an unfinished run: its "
        + "time until it stopped, and the time to the end at the pace it kept, an estimate):",
        "",
        "| case | level | beta [s] | rosw 1e-5 [s] | Bosh3 1e-4 | Tsit5 1e-4 | Kvaerno5 1e-4 | rosw 1e-4 | rosw 1e-5, hooks fixed in J |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
        *rows,
    ]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--t-end", type=float, default=0.2)
    p.add_argument("--levels", nargs="+", default=["ale", "full"])
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    p.add_argument("--betas", nargs="+", type=float, default=[0.0, 1e-5, 1e-4, 1e-3, 1e-2])
    p.add_argument("--solvers", nargs="+", default=[n for n in SOLVER_NAMES if n != "rosw3e-5"], choices=SOLVER_NAMES)
    p.add_argument("--max-steps", type=int, default=500_000,
                   help="step budget of the explicit solvers and rosw (Bosh3 takes 407k at beta 1e-2, ale)")  # fmt: skip
    p.add_argument("--implicit-max-steps", type=int, default=200,
                   help="step budget of Kvaerno5 (0.3-0.8 s per step on the ale level, 2 cores)")  # fmt: skip
    p.add_argument("--span-elements", type=int, default=16,
                   help="elements of each arresting span (16: the mesh of the results recorded before the scenes' "
                        "default moved to 32)")  # fmt: skip
    p.add_argument("--default-model", action="store_true",
                   help="the scenes' default model: the hook as a sliding node on the level's own mesh "
                        "(80 span elements, 16 fine), instead of the capsule on --span-elements")
    p.add_argument("--mesh", action="store_true", help="also the cost per step at 16, 32, 64 span elements")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--ref-rtol", type=float, default=1e-7, help="tolerance of the rosw reference")
    p.add_argument("--tag", default="", help="suffix of the results' file names (e.g. _full)")
    p.add_argument("--out", default=None)
    p.add_argument("--float32", action="store_true",
                   help="run the solvers in float32 (x64 off); the references come from --ref-json")  # fmt: skip
    p.add_argument("--ref-json", default=None,
                   help="with --float32: an earlier float64 run's json whose references (same case, level, "
                        "beta, t_end) the errors are taken against")  # fmt: skip
    a = p.parse_args()
    if a.float32 and not a.ref_json:
        p.error("--float32 needs --ref-json (a float64 run's results; x64 is process-wide, and a scene "
                "built in float64 keeps float64 leaves that a float32 solve cannot mix with)")
    enable_x64(not a.float32)
    refs = {}
    if a.ref_json:
        import json

        with open(a.ref_json) as f:
            earlier = json.load(f)
        if abs(earlier["t_end_s"] - a.t_end) > 1e-12:
            p.error(f"--ref-json was run to t_end = {earlier['t_end_s']} s, not {a.t_end} s")
        refs = {(c.get("case", "design"), c["level"], c["beta"]): c for c in earlier["cases"]
                if c["solver"] == "rosw (reference)"}  # fmt: skip
    if a.quick:
        a.levels, a.cases, a.betas, a.t_end = ["ale"], ["design"], [1e-5, 1e-2], 0.05
    stem = STEM + a.tag
    out = _report.output_dir(a.out, a.quick, stem)
    data = _report.start(t_end_s=a.t_end, ref_rtol=a.ref_rtol, case_names=a.cases, span_elements=a.span_elements,
                         default_model=a.default_model, cases=[], mesh=[])
    rosw = RosenbrockW()
    for case in a.cases:
        for level in a.levels:
            for beta in a.betas:
                scene = build_scene(case, level, beta, a.t_end, n_span=a.span_elements, default_model=a.default_model)
                if a.ref_json:
                    ref = refs[(case, level, beta)]
                    data["ref_json"] = a.ref_json
                else:
                    ref = run(scene, level, a.t_end, rosw, a.ref_rtol, a.max_steps, (case, level, "ref"), repeat=False)
                    data["cases"].append(dict(case=case, level=level, beta=beta, solver="rosw (reference)", rtol=a.ref_rtol, **ref))
                for name, solver, rtol, max_steps in _solvers(a.solvers, a.max_steps, a.implicit_max_steps):
                    program = (case, level, name, rtol)
                    if name == "rosw_fixed_hooks":
                        solver = RosenbrockW(linearise=functools.partial(_fixed_hooks, scene))
                        program = program + (beta,)  # a new closure: compiled again
                    c = run(scene, level, a.t_end, solver, rtol, max_steps, program)
                    c["max_rel_error"] = (
                        max(abs(c[k] - ref[k]) / abs(ref[k]) for k in KEYS) if c["finished"] and ref["finished"] else None
                    )
                    label = name + (" (float32)" if a.float32 else "")
                    data["cases"].append(dict(case=case, level=level, beta=beta, solver=label, rtol=rtol, **c))
                    print(data["cases"][-1], flush=True)
                    _report.finish(data, out, stem, write_md)
    if a.mesh:
        for n_span in (16, 32, 64):
            scene = build_scene("design", "ale", 1e-2, 0.02, n_span=n_span)
            m = run(scene, "ale", 0.02, rosw, 1e-4, a.max_steps, ("mesh", n_span))
            data["mesh"].append(dict(n_span=n_span, **m))
            print(data["mesh"][-1], flush=True)
            _report.finish(data, out, stem, write_md)
    _report.finish(data, out, stem, write_md)


if __name__ == "__main__":
    main()
