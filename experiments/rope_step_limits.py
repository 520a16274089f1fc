"""What sets the line-throwing flight's step count: stiffness or the segment completions (not a test).

The 30 deg flight at 1 m segments takes ~1,700 step attempts; the rope's transverse modes under
kilonewtons (~500 rad/s) suggested an implicit method would take fewer. Two measurements decide:

(a) Tsit5 at 1 m segments (``--segment``), rtol = atol from 1e-3 to 1e-6: accepted and rejected
    steps, the number of segments pulled out (each completion releases a hinge over the last 5% of
    the segment's growth, a sharp but C1 change of the accelerations), steps per completion, the
    range and the run time (second call, compiled). A stability-limited count stays flat as the
    tolerance loosens; a count that falls to about one step per completion is set by the
    completions.
(b) The W-method (``rosw``, ROS34PW2) with the *exact* dense Jacobian, fresh at every step, against
    Tsit5 at 10 m and 5 m segments (``--dense-segments``; the dense Jacobian costs one JVP per state
    number, so only coarse ropes), rtol = atol = 1e-4: steps, rejected steps and the range. No
    structured linearisation can take fewer steps than the exact one.
(c) The step-size controller at 1 m segments: Tsit5 with diffrax's I controller (``pcoeff=0,
    icoeff=1``, ``simulate``'s default) against the PI controller (``pcoeff=0.4, icoeff=0.3``) at
    rtol = atol 1e-4 and 1e-3: steps, rejected steps, the largest relative error of range, max
    speed and flight time against Tsit5 at 1e-8, and the run time (the fastest of ``--repeats``
    calls, the settings interleaved so that a load change hits them alike).
(d) The windowed evaluation at 1 m segments: Tsit5 with the PI controller (``jaxcable throw``'s
    settings) evaluating every link of the box at every call (``window_links=()``, the only
    evaluation when the saved parts a-c ran) against the default windows (the vector field computed on the smallest of 64, 128, 256,
    512 links that holds the deployed rope): steps, error against Tsit5 at 1e-8, the first call
    (tracing and compiling included) and the fastest of ``--repeats`` interleaved calls.
(e) The explicit solver at 1 m segments with ``jaxcable throw``'s settings (windows, PI
    controller): Tsit5 against Bosh3 (3 evaluations a step), Dopri5 and Dopri8 (12 new evaluations a
    step, order 8) at the tolerances of ``--solver-settings``: steps, error against Tsit5 at 1e-8,
    first call and the fastest of ``--repeats`` interleaved calls. If the completions alone set
    the steps, the cheapest step would win; if the accuracy between them does, the higher order.

(f) The saved samples at 1 m segments with ``jaxcable throw``'s settings: the default save grid
    (every 0.01 s, about 900 samples before the impact, each a probe with one evaluation of the
    vector field on the largest window) against 10 samples: steps, error against Tsit5 at 1e-8,
    first call and the fastest of ``--repeats`` interleaved calls: what the saved histories cost.

Writes ``rope_step_limits.json/.md``. Usage (about 3 min on 2 cores):

    python experiments/rope_step_limits.py
    python experiments/rope_step_limits.py --quick     # 5 m segments, two tolerances, 10 m dense
    python experiments/rope_step_limits.py --parts d   # only (d); the others kept from the saved JSON
    python experiments/rope_step_limits.py --parts e   # only (e), about 5 min
    python experiments/rope_step_limits.py --parts f   # only (f), about 2 min
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import _report
import jax

import jaxcable
from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import DenseLinearisation, RosenbrockW
from jaxcable.throw import line_throwing_scene

STEM = "rope_step_limits"
T1_S = 40.0


QUANTITIES = ("range_m", "max_speed_mps", "flight_time_s")
CONTROLLERS = {"I": (0.0, 1.0), "PI": (0.4, 0.3)}  # (pcoeff, icoeff)


def _interleaved(run, settings, repeats):
    """``_report.time_rounds`` of ``run(*setting)`` for each setting: ``(results, first-call seconds,
    the seconds of every round)`` by setting."""
    walls = {}
    results, first, _ = _report.time_rounds({s: (lambda s=s: run(*s)) for s in settings}, repeats, times=walls)
    return results, first, walls


def _error(r, ref):
    """Largest relative error of range, max speed and flight time against ``ref``."""
    return max(abs(float(r.outputs[k]) - float(ref.outputs[k])) / abs(float(ref.outputs[k])) for k in QUANTITIES)


def controllers(segment_m, rtols, repeats):
    """Part (c): Tsit5 with the I and the PI controller at each of ``rtols``; rows."""
    scene = line_throwing_scene(angle_deg=30.0, segment_length_m=segment_m)

    def run(rtol, name):
        pcoeff, icoeff = CONTROLLERS[name]
        r = jaxcable.simulate(scene, T1_S, solver="tsit5", rtol=rtol, atol=rtol, pcoeff=pcoeff, icoeff=icoeff)
        jax.block_until_ready(r.t_final)
        return r

    ref = run(1e-8, "I")
    settings = [(rtol, name) for rtol in rtols for name in CONTROLLERS]
    results, _, walls = _interleaved(run, settings, repeats)
    rows = []
    for (rtol, name), r in results.items():
        err = _error(r, ref)
        rows.append({"segment_m": segment_m, "rtol": rtol, "controller": name, "pcoeff_icoeff": list(CONTROLLERS[name]),
                     "steps": int(r.num_steps), "rejected": int(r.num_rejected), "error": err,
                     "run_s": min(walls[(rtol, name)]), "runs_s": walls[(rtol, name)]})  # fmt: skip
    return rows, int(ref.num_steps)


WINDOWS = {"whole box": (), "default windows": None}  # LineThrowingScene.window_links


def windows(segment_m, rtols, repeats):
    """Part (d): Tsit5 with the PI controller, every link against the default windows; rows."""
    base = line_throwing_scene(angle_deg=30.0, segment_length_m=segment_m)
    scenes = {name: dataclasses.replace(base, window_links=w) for name, w in WINDOWS.items()}
    pcoeff, icoeff = CONTROLLERS["PI"]

    def run(rtol, name, **kw):
        kw = kw or {"pcoeff": pcoeff, "icoeff": icoeff}
        r = jaxcable.simulate(scenes[name], T1_S, solver="tsit5", rtol=rtol, atol=rtol, **kw)
        jax.block_until_ready(r.t_final)
        return r

    ref = run(1e-8, "default windows", pcoeff=0.0, icoeff=1.0)
    settings = [(rtol, name) for rtol in rtols for name in WINDOWS]
    results, first, walls = _interleaved(run, settings, repeats)
    rows = []
    for (rtol, name), r in results.items():
        err = _error(r, ref)
        rows.append({"segment_m": segment_m, "rtol": rtol, "evaluation": name,
                     "windows": list(scenes[name].windows), "steps": int(r.num_steps),
                     "rejected": int(r.num_rejected), "error": err, "first_call_s": first[(rtol, name)],
                     "run_s": min(walls[(rtol, name)]), "runs_s": walls[(rtol, name)],
                     "run_ratio": min(walls[(rtol, name)]) / min(walls[(rtol, "whole box")])})  # fmt: skip
    return rows, int(ref.num_steps)


SOLVER_SETTINGS = ("tsit5:1e-4", "tsit5:3e-4", "bosh3:1e-4", "bosh3:1e-5", "dopri5:1e-4", "dopri8:1e-4", "dopri8:1e-3")


def solvers(segment_m, settings, repeats):
    """Part (e): each ``solver:rtol`` of ``settings`` with the default windows and the PI controller; rows."""
    scene = line_throwing_scene(angle_deg=30.0, segment_length_m=segment_m)
    pcoeff, icoeff = CONTROLLERS["PI"]

    def run(solver, rtol, **kw):
        kw = kw or {"pcoeff": pcoeff, "icoeff": icoeff}
        r = jaxcable.simulate(scene, T1_S, solver=solver, rtol=rtol, atol=rtol, **kw)
        jax.block_until_ready(r.t_final)
        return r

    ref = run("tsit5", 1e-8, pcoeff=0.0, icoeff=1.0)
    pairs = [(s.split(":")[0], float(s.split(":")[1])) for s in settings]
    results, first, walls = _interleaved(run, pairs, repeats)
    base = min(walls[pairs[0]])
    rows = []
    for (solver, rtol), r in results.items():
        rows.append({"segment_m": segment_m, "solver": solver, "rtol": rtol, "steps": int(r.num_steps),
                     "rejected": int(r.num_rejected), "error": _error(r, ref), "first_call_s": first[(solver, rtol)],
                     "run_s": min(walls[(solver, rtol)]), "runs_s": walls[(solver, rtol)],
                     "run_ratio": min(walls[(solver, rtol)]) / base})  # fmt: skip
    return rows, int(ref.num_steps)


SAVES = {"every 0.01 s (default)": None, "10 samples": 10}


def saves(segment_m, rtols, repeats):
    """Part (f): Tsit5 with the PI controller and the default windows, the default save grid
    against 10 saved samples over the flight; rows."""
    scene = line_throwing_scene(angle_deg=30.0, segment_length_m=segment_m)
    pcoeff, icoeff = CONTROLLERS["PI"]

    def run(rtol, name, **kw):
        kw = kw or {"pcoeff": pcoeff, "icoeff": icoeff}
        n = SAVES[name]
        save_ts = None if n is None else jax.numpy.linspace(0.0, 9.0, n)
        r = jaxcable.simulate(scene, T1_S, solver="tsit5", rtol=rtol, atol=rtol, save_ts=save_ts, **kw)
        jax.block_until_ready(r.t_final)
        return r

    # the maximum speed is read off the saved samples: each grid has its own reference
    refs = {name: run(1e-8, name, pcoeff=0.0, icoeff=1.0) for name in SAVES}
    settings = [(rtol, name) for rtol in rtols[:1] for name in SAVES]
    results, first, walls = _interleaved(run, settings, repeats)
    rows = []
    for (rtol, name), r in results.items():
        saved = int(jax.numpy.sum(jax.numpy.isfinite(r.ts)))
        rows.append({"segment_m": segment_m, "rtol": rtol, "saves": name, "saved_samples": saved,
                     "steps": int(r.num_steps), "rejected": int(r.num_rejected), "error": _error(r, refs[name]),
                     "first_call_s": first[(rtol, name)], "run_s": min(walls[(rtol, name)]),
                     "runs_s": walls[(rtol, name)],
                     "run_ratio": min(walls[(rtol, name)]) / min(walls[settings[0]])})  # fmt: skip
    return rows, int(refs[settings[0][1]].num_steps)


def flight(segment_m, solver, rtol):
    """One 30 deg flight to impact, timed on the second (compiled) call; returns a row."""
    scene = line_throwing_scene(angle_deg=30.0, segment_length_m=segment_m)
    if solver == "rosw_dense":
        lin = lambda t, y: DenseLinearisation.of(scene.vector_field, t, y)
        solver_obj = RosenbrockW(linearise=lin, jacobian_every=1)
    else:
        solver_obj = solver
    run = lambda: jaxcable.simulate(scene, T1_S, solver=solver_obj, rtol=rtol, atol=rtol)
    jax.block_until_ready(run().t_final)
    t0 = time.perf_counter()
    r = run()
    jax.block_until_ready(r.t_final)
    wall = time.perf_counter() - t0
    completions = float(r.outputs["deployed_rope_m"]) / segment_m
    steps = int(r.num_steps)
    return {
        "segment_m": segment_m, "solver": solver, "rtol": rtol, "status": int(r.status), "steps": steps,
        "rejected": int(r.num_rejected), "completions": round(completions, 1),
        "steps_per_completion": steps / max(completions, 1.0), "range_m": float(r.outputs["range_m"]),
        "flight_time_s": float(r.t_final), "run_s": wall,
    }  # fmt: skip


PARTS = {"a": ("tolerance",), "b": ("dense",), "c": ("controllers", "controllers_reference_steps", "controllers_repeats"),
         "d": ("windows", "windows_reference_steps", "windows_repeats"),
         "e": ("solvers", "solvers_reference_steps", "solvers_repeats"),
         "f": ("saves", "saves_reference_steps", "saves_repeats")}  # fmt: skip


def _kept_list(kept):
    """The saved provenance of kept parts: a list of ``{parts, date, machine, command}`` (one dict in
    files written before part d)."""
    if not kept:
        return []
    return [kept] if isinstance(kept, dict) else list(kept)


def _keep(data, old, run_parts):
    """Copy the parts not run from the saved JSON ``old``, each with the provenance of the run that
    measured it (the old run itself, or the earlier run it had kept it from)."""
    origin = {}
    for entry in _kept_list(old.get("kept")):
        for part in entry["parts"]:
            origin[part] = {k: entry[k] for k in ("date", "machine", "command")}
    own = {"date": old["date"], "machine": _report.machine_line(old["machine"]), "command": old["command"]}
    groups = {}
    for part, keys in PARTS.items():
        if part in run_parts or not any(k in old for k in keys):
            continue
        data.update({k: old[k] for k in keys if k in old})
        prov = origin.get(part, own)
        groups.setdefault((prov["date"], prov["machine"], prov["command"]), []).append(part)
    data["kept"] = [{"parts": parts, "date": d, "machine": m, "command": c} for (d, m, c), parts in groups.items()]


def write_md(data, path):
    lines = ["# What sets the line-throwing flight's step count", "", *_report.header(data), ""]
    for k in _kept_list(data.get("kept")):
        lines += [(f"Part{'s' if len(k['parts']) > 1 else ''} {', '.join(k['parts'])} "
                   f"{'are' if len(k['parts']) > 1 else 'is'} kept from an earlier run: {k['date']}, {k['machine']} "
                   f"`{k['command']}`."), ""]  # fmt: skip
    lines += ["## (a) Tsit5 against the tolerance", "",
              "| segment | rtol = atol | steps | rejected | segments pulled out | steps per completion | range [m] | run [s] |",
              "|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in data["tolerance"]:
        lines.append(
            f"| {r['segment_m']:g} m | {r['rtol']:.0e} | {r['steps']} | {r['rejected']} | {r['completions']:.0f} | "
            f"{r['steps_per_completion']:.2f} | {r['range_m']:.2f} | {r['run_s']:.2f} |"
        )
    lines += ["", "## (b) The W-method with the exact Jacobian against Tsit5", "",
              "| segment | solver | rtol = atol | steps | rejected | range [m] | run [s] |",
              "|---:|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in data["dense"]:
        lines.append(
            f"| {r['segment_m']:g} m | {r['solver']} | {r['rtol']:.0e} | {r['steps']} | {r['rejected']} | "
            f"{r['range_m']:.2f} | {r['run_s']:.2f} |"
        )
    lines += ["", "`rosw_dense`: ROS34PW2 with `jax.jacfwd` of the whole vector field at every step (the exact",
              "Jacobian; its run time is that of the dense Jacobian and LU, not a candidate product setting)."]  # fmt: skip
    if data.get("controllers"):
        lines += ["", "## (c) The step-size controller (Tsit5)", "",
                  (f"Error: the largest relative error of range, max speed and flight time against Tsit5 at 1e-8 "
                  f"({data['controllers_reference_steps']} steps). Run: the fastest of {data['controllers_repeats']} "
                  "calls, the settings interleaved."), "",
                  "| segment | rtol = atol | controller (pcoeff, icoeff) | steps | rejected | attempts | error | run [s] |",
                  "|---:|---:|---|---:|---:|---:|---:|---:|"]  # fmt: skip
        for r in data["controllers"]:
            pc, ic = r["pcoeff_icoeff"]
            lines.append(
                f"| {r['segment_m']:g} m | {r['rtol']:.0e} | {r['controller']} ({pc:g}, {ic:g}) | {r['steps']} | "
                f"{r['rejected']} | {r['steps'] + r['rejected']} | {r['error']:.1e} | {r['run_s']:.2f} |"
            )
    if data.get("windows"):
        lines += ["", "## (d) The windowed evaluation (Tsit5, PI controller)", "",
                  ("Every link of the box at every call (`window_links=()`, the only evaluation when the saved parts a-c "
                   "ran) against the default "
                   "windows. Error: as in (c), against Tsit5 at 1e-8 with the default windows "
                   f"({data['windows_reference_steps']} steps). First call: tracing, compiling and one run. Run: "
                   f"the fastest of {data['windows_repeats']} calls, the settings interleaved; ratio: to the whole "
                   "box at the same tolerance."), "",
                  "| segment | rtol = atol | evaluation | steps | rejected | error | first call [s] | run [s] | ratio |",
                  "|---:|---:|---|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        for r in data["windows"]:
            lines.append(
                f"| {r['segment_m']:g} m | {r['rtol']:.0e} | {r['evaluation']} {tuple(r['windows']) or ''} | "
                f"{r['steps']} | {r['rejected']} | {r['error']:.1e} | {r['first_call_s']:.1f} | {r['run_s']:.2f} | "
                f"{r['run_ratio']:.2f} |"
            )
    if data.get("solvers"):
        lines += ["", "## (e) The explicit solver (windows, PI controller)", "",
                  ("Error: as in (c), against Tsit5 at 1e-8 "
                   f"({data['solvers_reference_steps']} steps). First call: tracing, compiling and one run. Run: the "
                   f"fastest of {data['solvers_repeats']} calls, the settings interleaved; ratio: to the first row."), "",
                  "| segment | solver | rtol = atol | steps | rejected | error | first call [s] | run [s] | ratio |",
                  "|---:|---|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        for r in data["solvers"]:
            lines.append(
                f"| {r['segment_m']:g} m | {r['solver']} | {r['rtol']:.0e} | {r['steps']} | {r['rejected']} | "
                f"{r['error']:.1e} | {r['first_call_s']:.1f} | {r['run_s']:.2f} | {r['run_ratio']:.2f} |"
            )
    if data.get("saves"):
        lines += ["", "## (f) The saved samples (windows, PI controller)", "",
                  ("Error: as in (c), against Tsit5 at 1e-8 on the same save grid (the maximum speed is "
                   f"read off the saved samples; {data['saves_reference_steps']} steps). Saved: samples before the impact, each a probe "
                   "(one evaluation of the vector field, on the largest window while the rope fits in it). First "
                   f"call: tracing, compiling and one run. Run: the fastest of {data['saves_repeats']} calls, the "
                   "settings interleaved; ratio: to the first row."), "",
                  "| segment | rtol = atol | saves | saved | steps | rejected | error | first call [s] | run [s] | ratio |",
                  "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        for r in data["saves"]:
            lines.append(
                f"| {r['segment_m']:g} m | {r['rtol']:.0e} | {r['saves']} | {r['saved_samples']} | {r['steps']} | "
                f"{r['rejected']} | {r['error']:.1e} | {r['first_call_s']:.1f} | {r['run_s']:.2f} | {r['run_ratio']:.2f} |"
            )
    _report.write_lines(path, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--segment", type=float, default=1.0, help="segment length of part (a) [m]")
    p.add_argument("--rtols", nargs="+", type=float, default=[1e-3, 1e-4, 1e-5, 1e-6])
    p.add_argument("--dense-segments", nargs="+", type=float, default=[10.0, 5.0])
    p.add_argument("--controller-rtols", nargs="+", type=float, default=[1e-4, 1e-3], help="tolerances of parts (c), (d); the first also of (f)")
    p.add_argument("--repeats", type=int, default=5, help="timed calls per setting in parts (c)-(f) (default 5)")
    p.add_argument("--solver-settings", nargs="+", default=list(SOLVER_SETTINGS), help="solver:rtol pairs of part (e); the first is the ratios' base")
    p.add_argument("--parts", nargs="+", default=list(PARTS), choices=list(PARTS),
                   help="parts to run (default all); the others are kept from the saved JSON")  # fmt: skip
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    enable_x64()
    if args.quick:
        args.segment, args.rtols, args.dense_segments = 5.0, [1e-3, 1e-4], [10.0]
    out = _report.output_dir(args.out, args.quick)
    data = _report.start(tolerance=[], dense=[], controllers=[], windows=[], solvers=[], saves=[])
    saved = out / f"{STEM}.json"
    if set(args.parts) != set(PARTS) and saved.exists():
        _keep(data, json.loads(saved.read_text()), args.parts)
    timed = (("c", "controllers", controllers, args.controller_rtols), ("d", "windows", windows, args.controller_rtols),
             ("e", "solvers", solvers, args.solver_settings), ("f", "saves", saves, args.controller_rtols))  # fmt: skip
    for part, key, measure, settings in timed:
        if part in args.parts:
            data[key], data[f"{key}_reference_steps"] = measure(args.segment, settings, args.repeats)
            data[f"{key}_repeats"] = args.repeats
            for row in data[key]:
                print(row, flush=True)
            _report.save(data, out, STEM)
    for rtol in args.rtols if "a" in args.parts else []:
        data["tolerance"].append(flight(args.segment, "tsit5", rtol))
        print(data["tolerance"][-1], flush=True)
        _report.save(data, out, STEM)
    for seg in args.dense_segments if "b" in args.parts else []:
        for solver in ("tsit5", "rosw_dense"):
            data["dense"].append(flight(seg, solver, 1e-4))
            print(data["dense"][-1], flush=True)
            _report.save(data, out, STEM)
    _report.finish(data, out, STEM, write_md)


if __name__ == "__main__":
    main()
