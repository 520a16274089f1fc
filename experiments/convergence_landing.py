"""Convergence of the landing criteria: z_max, a_max, sigma_max against mesh, contact, tolerance, saves.

Two cases at the ``ale`` and ``full`` levels, at the calibrated cable damping
(``jaxcable.arresting.calibration``, ``--beta``):

* ``design``: Table 1's design case (central vertical capture at 20 m/s), 1 s;
* ``iva``: section IV.A's deviated case, scenario I: the tracking phase (rigid rocket, seed 0) to
  capture, then the passive phase from the captured state, ``--iva-t-end`` s.

Variants, each against the level's default (the level's mesh, ``passive.LEVEL_CABLE_MESH``: 80 span
elements with 16 fine at both levels, or ``--mesh`` for both; the hook as a sliding node,
or ``--hook-contact capsule``; the contact law of ``passive.scene_contact_law``, the level's solver
settings, 1 ms saves):

==============  ==============================================================================
``mesh_half``   every span element doubled (half the span elements and the fine ones)
``mesh_x2``     every span element halved (twice the span elements and the fine ones)
``mesh_x4``     every span element quartered: the diagnostic of ``mesh_x2``
``fine_x2``     the fine elements halved (the coarse ones unchanged)
``fine_x4``     the fine elements quartered (the coarse ones unchanged)
``fine_wide``   the fine region widened from +-3 m to +-6 m around the hook at the same fine element
                length: does the hook leave the fine region as the cable slides over it?
``fine_wide_x2`` +-6 m with the fine elements halved
``contact_x2``  hook-cable contact stiffness k x 2 (the Hunt-Crossley factor c unchanged, so the
                restitution of an impact is unchanged)
``contact_half`` k / 2
``contact_c_x2`` the contact's Hunt-Crossley damping factor c x 2 (restitution at 5 m/s 0.59 -> 0.41)
``contact_c_half`` c / 2 (restitution at 5 m/s 0.59 -> 0.75)
``rtol_10``     rtol = atol / 10
``rtol_x3``     rtol = atol x 3 (looser: what a cheaper default tolerance would cost)
``rtol_x10``    rtol = atol x 10
``save_4``      save spacing / 4 (0.25 ms; the criteria's CFC 60 filter runs on the saves)
==============  ==============================================================================

The hook is a sliding node (``AleCables``, ``hook_contact="node"``, the scenes' default; the contact
variants then scale the ring, whose stiffness is the law's tangent stiffness at its design load);
results ``convergence_landing_node.{json,md}``. ``--hook-contact capsule`` runs the capsule contact
instead; results ``convergence_landing.{json,md}`` (the record there: ``--mesh 32 16``, the
default before the node).

Goals: z_max within 1%, the criteria a_max and sigma_max (CFC 60) within 3% of the default.
Writes ``convergence_landing.{json,md}`` after every run (a killed run resumes: rows already in the
JSON for the same beta and their level's default mesh are kept). ``convergence_landing_mesh16.{json,md}`` and
``convergence_landing_mesh32_node.{json,md}`` are records of the same study with 16 span elements (8
fine, capsule) and 32 (16 fine, node) as the default; ``convergence_landing_{ale80,full80}_node``
the study of each level at its default mesh (80 span elements, 16 fine; ``--tag _ale80``,
``--tag _full80``), ``convergence_landing_node`` at the former default (64, 32 fine). Usage::

    python experiments/convergence_landing.py --levels ale --variants default mesh_x2
    python experiments/convergence_landing.py --levels full --cases iva --variants default mesh_x2  # ~10 min
    python experiments/convergence_landing.py --levels full --cases design
    python experiments/convergence_landing.py --quick                    # ale, design, 0.1 s, 2 variants
    python experiments/convergence_landing.py --levels full --cases design --buffer 900 3.22e5 --tag _buffer_900 \\
        --hook-contact capsule --mesh 32 16
"""

from __future__ import annotations

import argparse
import json
import time

import _report
import equinox as eqx
import numpy as np

from jaxcable.core.config import enable_x64
from jaxcable.core.validation import check_finite, check_positive
from jaxcable.arresting import calibration as C
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import level_solver_settings, run_landing
from jaxcable.arresting.passive import DEFAULT_FINE_HALF_WIDTH_M as FINE_HALF_WIDTH_M
from jaxcable.arresting.passive import DEFAULT_HOOK_CONTACT
from jaxcable.arresting.passive import SAVE_SPACING_S, cable_mesh_at, scene_contact_law

STEM = "convergence_landing"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa")
GOALS = {"z_max_m": 0.01, "a_max_g": 0.03, "sigma_max_mpa": 0.03}
MESH = None
"""The study's default mesh (span elements, fine ones) at both levels (``--mesh``); None: each level's."""
VARIANTS = ("default", "mesh_half", "mesh_x2", "mesh_x4", "fine_x2", "fine_x4", "fine_wide", "fine_wide_x2", "contact_x2", "contact_half", "contact_c_x2", "contact_c_half", "rtol_10", "save_4", "rtol_x3", "rtol_x10")


DIAGNOSTIC_VARIANTS = ("mesh_x4", "fine_x4", "fine_wide", "fine_wide_x2", "rtol_x3", "rtol_x10")
"""Variants run on request only (``--variants``): the mesh diagnostics of the deviated case's sigma_max,
and the looser tolerances."""


def level_mesh(level):
    """The study's default mesh at ``level``: ``--mesh``, else the level's (``LEVEL_CABLE_MESH``)."""
    return tuple(MESH) if MESH is not None else cable_mesh_at(level)


def variant_kwargs(name, level, beta):
    law = scene_contact_law()
    solver, rtol, _, steps = level_solver_settings(level, beta)
    N_SPAN, N_FINE = level_mesh(level)
    return {
        "default": {"n_span_elements": N_SPAN, "n_fine": N_FINE},
        "mesh_half": {"n_span_elements": N_SPAN // 2, "n_fine": N_FINE // 2},
        "mesh_x2": dict(n_span_elements=2 * N_SPAN, n_fine=2 * N_FINE),
        "mesh_x4": dict(n_span_elements=4 * N_SPAN, n_fine=4 * N_FINE),
        "fine_x2": dict(n_span_elements=N_SPAN + N_FINE, n_fine=2 * N_FINE),
        "fine_x4": {"n_span_elements": N_SPAN + 3 * N_FINE, "n_fine": 4 * N_FINE},
        "fine_wide": {"n_span_elements": N_SPAN + N_FINE, "n_fine": 2 * N_FINE, "fine_half_width_m": 2 * FINE_HALF_WIDTH_M},
        "fine_wide_x2": {"n_span_elements": N_SPAN + 3 * N_FINE, "n_fine": 4 * N_FINE, "fine_half_width_m": 2 * FINE_HALF_WIDTH_M},
        "contact_x2": dict(contact=eqx.tree_at(lambda c: c.k, law, 2.0 * law.k)),
        "contact_half": dict(contact=eqx.tree_at(lambda c: c.k, law, 0.5 * law.k)),
        "contact_c_x2": dict(contact=eqx.tree_at(lambda c: c.c, law, 2.0 * law.c)),
        "contact_c_half": dict(contact=eqx.tree_at(lambda c: c.c, law, 0.5 * law.c)),
        "rtol_10": dict(solver=solver, rtol=rtol / 10, atol=rtol / 10, max_steps=4 * steps),
        "rtol_x3": {"solver": solver, "rtol": rtol * 3, "atol": rtol * 3, "max_steps": steps},
        "rtol_x10": {"solver": solver, "rtol": rtol * 10, "atol": rtol * 10, "max_steps": steps},
        "save_4": dict(save_spacing_s=SAVE_SPACING_S / 4),
    }[name]


def iva_passive_kwargs():
    from jaxcable.arresting.two_phase import _passive_kwargs, _tracking_jit, deviated_case, tracking_scene

    scene = tracking_scene(deviated_case(), scenario="I")
    _, out = _tracking_jit(scene)
    return _passive_kwargs(scene, out, True)


def one_run(case, level, variant, beta, t_end, iva_kwargs, buffer=None, hook_contact=DEFAULT_HOOK_CONTACT):
    kw = dict(cable_damping_s=beta, hook_contact=hook_contact, **variant_kwargs(variant, level, beta))
    if case == "iva":
        kw.update(iva_kwargs)
    elif buffer is not None:
        kw["buffer"] = buffer
    rtol = kw.get("rtol", level_solver_settings(level, beta)[1])
    t0 = time.perf_counter()
    run = run_landing(level, t_end_s=t_end, **kw)
    wall = time.perf_counter() - t0
    o = run.outputs
    return dict(
        case=case, level=level, variant=variant, beta_s=beta, t_end_s=t_end, wall_s=wall, default_mesh=list(level_mesh(level)), rtol=rtol,
        **{k: float(o[k]) for k in (*KEYS, "a_max_raw_g", "sigma_max_raw_mpa", "energy_budget_error")},
        stopped=bool(o["stopped"]), solver_status=str(o["solver_status"]), num_steps=int(o["num_steps"]),
    )  # fmt: skip


def deviations(rows):
    """Relative deviation of each row's criteria from its (case, level) default row."""
    base = {(r["case"], r["level"]): r for r in rows if r["variant"] == "default"}
    out = []
    for r in rows:
        b = base.get((r["case"], r["level"]))
        if b is None:
            continue
        out.append({**r, **{f"d_{k}": (r[k] - b[k]) / abs(b[k]) for k in KEYS}})
    return out


def _mesh_text(mesh):
    """``[span, fine]`` (one for both levels) or ``{level: [span, fine]}`` in words."""
    if isinstance(mesh, dict):
        return ", ".join(f"{lv} level {m[0]} span elements, {m[1]} fine" for lv, m in mesh.items())
    return f"{mesh[0]} span elements, {mesh[1]} fine"


def write_md(data, path):
    L = ["# Convergence of the landing criteria", "", *_report.header(data), ""]
    L += [
        f"Cable damping beta = {data['beta_s']:.4g} s (calibrated, `experiments/calibrate_damping.py`). "
        + (f"Design case with the buffer m_w = {data['buffer'][0]:g} kg, F_f = {data['buffer'][1]:g} N (Table 1: 920 kg, "
           "3.13e5 N). " if data.get("buffer") else "")
        + f"Default mesh: {_mesh_text(data.get('default_mesh', [16, 8]))}. "
        + ("Hooks as sliding nodes (`hook_contact=\"node\"`). " if data.get("hook_contact") == "node" else "")
        + "Deviation of each variant from the level's default; goals: z_max 1%, a_max and sigma_max (CFC 60) 3%. "
        "Raw (unfiltered) maxima beside. A cell marked * misses its goal.",
        "",
        "| case | level | variant | z_max [m] | dz | a_max [g] | da | sigma_max [MPa] | ds | a raw [g] | sigma raw [MPa] | stopped | steps | time [s] |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|",
    ]
    for r in deviations(data["rows"]):
        def d(k):
            v = r[f"d_{k}"]
            return f"{100 * v:+.2f}%" + ("*" if abs(v) > GOALS[k] else "")

        L.append(
            f"| {r['case']} | {r['level']} | {r['variant']} | {r['z_max_m']:.3f} | {d('z_max_m')} | {r['a_max_g']:.3f} | "
            f"{d('a_max_g')} | {r['sigma_max_mpa']:.1f} | {d('sigma_max_mpa')} | {r['a_max_raw_g']:.2f} | "
            f"{r['sigma_max_raw_mpa']:.0f} | {r['stopped']} | {r['num_steps']} | {r['wall_s']:.0f} |"
        )  # fmt: skip
    _report.write_lines(path, L)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--levels", nargs="*", default=["ale"], choices=["ale", "full"])
    p.add_argument("--cases", nargs="*", default=["design", "iva"], choices=["design", "iva"])
    p.add_argument("--variants", nargs="*", default=[v for v in VARIANTS if v not in DIAGNOSTIC_VARIANTS], choices=VARIANTS)
    p.add_argument("--beta", type=float, default=None, help="cable damping [s] (default: the calibrated value)")
    p.add_argument("--design-t-end", type=float, default=1.0)
    p.add_argument("--iva-t-end", type=float, default=1.2)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", help="report folder (default experiments/results)")
    p.add_argument("--buffer", nargs=2, type=float, metavar=("M_W_KG", "F_F_N"),
                   help="the design case with this counterweight mass [kg] and brake force [N] instead of Table 1's")
    p.add_argument("--tag", default="", help="suffix of the results' file names (e.g. _buffer_900)")
    p.add_argument("--hook-contact", choices=["capsule", "node"], default=DEFAULT_HOOK_CONTACT,
                   help="the ALE cables' hook model (node, the default: the hook as a sliding node; results tagged _node)")
    p.add_argument("--mesh", nargs=2, type=int, metavar=("SPAN", "FINE"),
                   help="the study's default mesh: span elements and fine ones (default: the scenes')")
    args = p.parse_args()
    global MESH
    if args.mesh is not None:
        check_positive("--mesh", np.asarray(args.mesh))
        MESH = tuple(args.mesh)
    enable_x64()
    stem = STEM + args.tag + ("_node" if args.hook_contact == "node" else "")
    buffer = None
    if args.buffer is not None:
        check_finite("--buffer", np.asarray(args.buffer))
        check_positive("--buffer", np.asarray(args.buffer))
        buffer = BufferDevice(counterweight_mass_kg=args.buffer[0], brake_force_N=args.buffer[1])
    if args.quick:
        args.levels, args.cases, args.variants = ["ale"], ["design"], ["default", "save_4"]
        args.design_t_end = 0.1
    beta = C.CALIBRATED_CABLE_DAMPING_S if args.beta is None else args.beta
    out = _report.output_dir(args.out, args.quick)
    old = out / f"{stem}.json"
    rows = []
    if old.exists():
        prev = json.loads(old.read_text())
        if prev.get("beta_s") == beta and prev.get("buffer") == args.buffer:
            # rows written before each row named its mesh ran the record's one default mesh
            rows = [r for r in prev.get("rows", [])
                    if r.get("default_mesh", prev.get("default_mesh")) == list(level_mesh(r["level"]))]  # fmt: skip
    data = _report.start(precision=_report.precision())
    data["beta_s"] = beta
    data["default_mesh"] = list(MESH) if MESH is not None else {lv: list(level_mesh(lv)) for lv in ("ale", "full")}
    data["buffer"] = args.buffer
    data["hook_contact"] = args.hook_contact
    data["rows"] = rows
    done = {(r["case"], r["level"], r["variant"]) for r in rows}
    iva_kwargs = iva_passive_kwargs() if "iva" in args.cases else {}
    for case in args.cases:
        t_end = args.design_t_end if case == "design" else args.iva_t_end
        for level in args.levels:
            for variant in args.variants:
                if (case, level, variant) in done:
                    continue
                row = one_run(case, level, variant, beta, t_end, iva_kwargs, buffer, args.hook_contact)
                rows.append(row)
                print(json.dumps({k: row[k] for k in ("case", "level", "variant", *KEYS, "stopped", "num_steps", "wall_s")}), flush=True)
                _report.save(data, out, stem)
                write_md(data, out / f"{stem}.md")
    _report.finish(data, out, stem, write_md)


if __name__ == "__main__":
    main()
