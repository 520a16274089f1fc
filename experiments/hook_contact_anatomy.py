"""Why the deviated case's sigma_max does not converge with the mesh: the hook's contact forces on the
cable, decomposed (not a test).

Section IV.A's deviated case (scenario I's tracking phase to capture, then the passive phase, ale
level, calibrated cable damping) peaks in cable stress early, near t = 0.14 s, on the cable that the
off-centre capture loads most, and that peak scatters with the length of the fine elements (771,
846, 809 MPa at 0.375, 0.19, 0.094 m; ``experiments/results/convergence_landing.md``). This script
integrates the case to 0.2 s per mesh variant and, at a few instants around the peak, takes the most
loaded cable apart:

* the span elements a hook touches, the normal force summed over their (capsule, element) pairs and
  its part along each element's axis; the friction force and its part along the axis, against the
  Coulomb bound ``mu_s N``;
* the tensions of the two legs (the elements next to the touched ones), their ratio, the total wrap
  angle round the hook (between elements three beyond the touched ones), the largest kink at one
  node inside the contact, and the capstan bound ``exp(mu_s theta)`` that a rope sliding over a round
  hook cannot exceed (Euler-Eytelwein; the cable's inertia aside).

A leg ratio above the capstan bound is tension that neither friction nor the cable's mass
explains: the discrete cable's contact forces act perpendicular to each straight element, so where
two elements meet at a kink on the hook, the share of the normal force that one element receives
pushes along the other (``F sin(alpha)`` at a kink of ``alpha``), which the continuum, whose normal is
perpendicular to one tangent, never does.

``--hook-contact node`` takes apart the hook as a sliding node instead (``AleCables``,
``hook_contact="node"``): the ring's load, the friction on the material sliding through the node and
the two legs' tensions at the node against the capstan bound of the wrap there (the node's own bend
and the wrap between the elements three beyond it); writes ``hook_contact_anatomy_node.{json,md}``.

Writes ``hook_contact_anatomy.{json,md}``. Usage (about 10 min on 2 cores):

    python experiments/hook_contact_anatomy.py
    python experiments/hook_contact_anatomy.py --hook-contact node
    python experiments/hook_contact_anatomy.py --variants default --times 0.14 --out experiments/out
"""

from __future__ import annotations

import argparse
import dataclasses

import _report
import jax
import jax.numpy as jnp
import numpy as np
from convergence_landing import iva_passive_kwargs, variant_kwargs

from jaxcable.arresting import calibration as C
from jaxcable.arresting.cable_sets import _capsules
from jaxcable.arresting.landing import level_solver_settings
from jaxcable.arresting.passive import PassiveLandingScene, passive_landing_scene
from jaxcable.components.contact import capsule_contact
from jaxcable.core import simulate
from jaxcable.core.config import enable_x64

STEM = "hook_contact_anatomy"
MESH = {"default": "0.375 m (32 span elements, 16 fine)", "fine_x2": "0.19 m (48, 32)", "fine_x4": "0.094 m (80, 64)"}


class _WholeStateScene(PassiveLandingScene):
    """The passive scene whose snapshots are the whole state (its own keeps node positions only)."""

    def snapshot(self, t, state):
        return state


def run_variant(variant, times, t_end, iva_kwargs, level="ale", hook_contact="capsule"):
    beta = C.CALIBRATED_CABLE_DAMPING_S
    kw = dict(cable_damping_s=beta, hook_contact=hook_contact, **variant_kwargs(variant, level, beta), **iva_kwargs)
    scene = passive_landing_scene(level, t_end_s=t_end, **kw)
    scene = _WholeStateScene(**{f.name: getattr(scene, f.name) for f in dataclasses.fields(scene)})
    solver, rtol, atol, steps = level_solver_settings(level, beta)
    res = simulate(scene, t_end, solver=solver, rtol=rtol, atol=atol, max_steps=steps, snapshot_ts=jnp.asarray(times))
    return scene, res


def decompose(scene, state, t, cable):
    """The contact on ``cable``'s span at ``state``: one row of the report."""
    cab = scene.cables
    law = cab.contact
    area = float(scene.cables_area())
    kin = cab.kinematics(state.cables)
    hooks = scene.hooks(state.rocket)
    r1, r2, a1, a2 = (np.asarray(x) for x in cab._span_ends(kin))
    caps_p, caps_v = _capsules(hooks)
    tension = np.asarray(jax.vmap(lambda sub, k: sub.element_tensions(k))(cab.subsystems, kin))[cable]
    lo, hi = cab.span_slice
    tension = tension[lo:hi]
    axis = (r2 - r1)[cable]
    axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    n_nodes = r1.shape[1] + 1
    node_normal = np.zeros((n_nodes, 3))  # the contact's normal forces lumped on the span's nodes [N]
    node_friction = np.zeros((n_nodes, 3))
    normal_sum = friction_sum = 0.0
    touched = set()
    for h in range(4):
        for k in range(2):
            for e in range(r1.shape[1]):
                c = capsule_contact(law, caps_p[h, k, 0], caps_p[h, k, 1], cab.hook_radius_m, caps_v[h, k, 0],
                                     caps_v[h, k, 1], r1[cable, e], r2[cable, e], cab.cable_radius_m, a1[cable, e],
                                     a2[cable, e])  # fmt: skip
                if float(c.penetration) <= 0.0:
                    continue
                touched.add(e)
                w = float(c.w)
                fn = float(c.normal_force) * np.asarray(c.normal)
                fr = np.asarray(c.friction)
                node_normal[e] += (1.0 - w) * fn
                node_normal[e + 1] += w * fn
                node_friction[e] += (1.0 - w) * fr
                node_friction[e + 1] += w * fr
                normal_sum += float(c.normal_force)
                friction_sum += float(np.linalg.norm(fr))
    # the cable's tangent at each node: the bisector of its elements' axes (one axis at the span's ends)
    tangent = np.concatenate([axis[:1], axis[:-1] + axis[1:], axis[-1:]])
    tangent = tangent / np.linalg.norm(tangent, axis=1, keepdims=True)
    normal_axial = float(np.sum(node_normal * tangent))
    friction_axial = float(np.sum(node_friction * tangent))
    e0, e1 = min(touched), max(touched)
    n_el = len(tension)

    def angle(a, b):
        a, b = max(a, 0), min(b, n_el - 1)
        return float(np.arccos(np.clip(axis[a] @ axis[b], -1.0, 1.0)))

    legs = tension[max(e0 - 1, 0)], tension[min(e1 + 1, n_el - 1)]
    wrap = angle(e0 - 3, e1 + 3)
    kink = max(angle(e, e + 1) for e in range(e0 - 1, e1 + 1))
    mu_s = float(law.mu_s)
    low, high = float(min(legs)), float(max(legs))
    signed = float(legs[1] - legs[0])  # the leg after the contact minus the leg before it [N]
    return {
        "t_s": float(t), "touched": sorted(touched), "normal_kN": normal_sum / 1e3, "normal_along_kN": normal_axial / 1e3,
        "friction_kN": friction_sum / 1e3, "friction_bound_kN": mu_s * normal_sum / 1e3,
        "friction_along_kN": friction_axial / 1e3, "leg_difference_kN": signed / 1e3, "leg_low_mpa": low / area / 1e6, "leg_high_mpa": high / area / 1e6,
        "leg_ratio": high / low, "span_max_mpa": float(tension.max()) / area / 1e6, "wrap_rad": wrap, "kink_rad": kink,
        "capstan": float(np.exp(mu_s * wrap)),
    }  # fmt: skip


def decompose_node(scene, state, t, cable):
    """The hook node of ``cable`` at ``state`` (``hook_contact="node"``): one row of the report."""
    cab = scene.cables
    mu_s = float(cab.contact.mu_s)
    area = float(scene.cables_area())
    kin = cab.kinematics(state.cables)
    hooks = scene.hooks(state.rocket)
    node = cab._node_slots()[0]
    Q = cab._node_contact(kin, hooks)[0]  # on the slow coordinates: s_h's friction, the node's ring + friction
    tension = np.asarray(jax.vmap(lambda sub, k: sub.element_tensions(k))(cab.subsystems, kin))[cable]
    lo, hi = cab.span_slice
    r = np.asarray(kin.r[cable])
    axis = np.diff(r, axis=0)
    axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)

    def angle(a, b):
        a, b = max(a, lo), min(b, hi - 1)
        return float(np.arccos(np.clip(axis[a] @ axis[b], -1.0, 1.0)))

    legs = tension[node - 1], tension[node]
    low, high = float(min(legs)), float(max(legs))
    bend, wrap = angle(node - 1, node), angle(node - 3, node + 2)
    s_slot = cab._node_slots()[1]
    return {
        "t_s": float(t), "ring_kN": float(np.linalg.norm(np.asarray(Q)[cable, 5:8])) / 1e3,
        "friction_s_kN": float(np.asarray(Q)[cable, s_slot]) / 1e3,
        "leg_difference_kN": float(legs[1] - legs[0]) / 1e3, "leg_low_mpa": low / area / 1e6, "leg_high_mpa": high / area / 1e6,
        "leg_ratio": high / low, "span_max_mpa": float(tension[lo:hi].max()) / area / 1e6, "bend_rad": bend, "wrap_rad": wrap,
        "capstan": float(np.exp(mu_s * max(bend, wrap))),
    }  # fmt: skip


def _write_table(data, path, title, text, head, cells):
    """The report: ``title``, the run's header, ``text``, then one table row per row of ``data``
    (``cells(row, mark)``, ``mark`` = "*" where the legs' ratio exceeds the capstan bound)."""
    L = [f"# {title}", "", *_report.header(data), "", text, "", head, "|" + "|".join(
        "---" if c.strip() in ("fine elements", "touched", "legs [MPa]", "wrap, kink [rad]", "bend, wrap [rad]") else "---:"
        for c in head.strip("|").split("|")) + "|"]  # fmt: skip
    for r in data["rows"]:
        L.append(f"| {MESH.get(r['variant'], r['variant'])} | {r['t_s']:.3f} | " + cells(r, "*" if r["leg_ratio"] > r["capstan"] else "") + " |")
    _report.write_lines(path, L)


def write_md_node(data, path):
    _write_table(
        data, path, "The hook node of the most loaded cable of the deviated case",
        "Section IV.A's deviated case, scenario I, ale level, calibrated cable damping, hooks as sliding nodes, "
        f"integrated to {data['t_end_s']:g} s; cable {data['cable']}. Per instant: the ring's load on the node "
        "(with the friction's reaction), the friction's force on the node's material coordinate, the two "
        "elements' tensions at the node and their ratio, the bend at the node, the wrap between the elements "
        "three beyond it, and the capstan bound exp(mu_s theta) of the larger. A ratio above the bound is marked *.",
        "| fine elements | t [s] | ring [kN] | friction on s [kN] | leg difference [kN] | legs [MPa] | ratio | capstan | bend, wrap [rad] | span max [MPa] |",
        lambda r, mark: (
            f"{r['ring_kN']:.0f} | {r['friction_s_kN']:+.1f} | {r['leg_difference_kN']:+.1f} | "
            f"{r['leg_low_mpa']:.0f} / {r['leg_high_mpa']:.0f} | {r['leg_ratio']:.3f}{mark} | {r['capstan']:.3f} | "
            f"{r['bend_rad']:.2f}, {r['wrap_rad']:.2f} | {r['span_max_mpa']:.0f}"
        ),
    )  # fmt: skip


def write_md(data, path):
    _write_table(
        data, path, "The hook's contact forces on the most loaded cable of the deviated case",
        "Section IV.A's deviated case, scenario I, ale level, calibrated cable damping, integrated to "
        f"{data['t_end_s']:g} s; cable {data['cable']} (the most loaded). Per instant: the span elements a hook "
        "touches; the normal force summed over their pairs, and its part along the cable: the pairs' forces "
        "lumped on the elements' end nodes as the model applies them, projected on each node's tangent (the "
        "bisector of its two elements) and summed (zero for a continuum, whose contact normal is "
        "perpendicular to its tangent); the friction, its Coulomb bound mu_s N, and its part along the cable "
        "the same way; the difference of the two legs' tensions (the leg after the contact minus the one "
        "before, in the span's direction), their tensions and ratio, the wrap angle, the largest kink at "
        "one node of the contact, and the capstan bound exp(mu_s theta). A ratio above the bound is "
        "marked *.",
        "| fine elements | t [s] | touched | N [kN] | N along [kN] | friction [kN] (mu_s N) | friction along [kN] | leg difference [kN] | legs [MPa] | ratio | capstan | wrap, kink [rad] | span max [MPa] |",
        lambda r, mark: (
            f"{','.join(map(str, r['touched']))} | {r['normal_kN']:.0f} | {r['normal_along_kN']:+.0f} | "
            f"{r['friction_kN']:.0f} ({r['friction_bound_kN']:.0f}) | {r['friction_along_kN']:+.0f} | "
            f"{r['leg_difference_kN']:+.0f} | {r['leg_low_mpa']:.0f} / {r['leg_high_mpa']:.0f} | {r['leg_ratio']:.3f}{mark} | "
            f"{r['capstan']:.3f} | {r['wrap_rad']:.2f}, {r['kink_rad']:.2f} | {r['span_max_mpa']:.0f}"
        ),
    )  # fmt: skip


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--variants", nargs="+", default=["default", "fine_x2", "fine_x4"], choices=sorted(MESH))
    p.add_argument("--times", nargs="+", type=float, default=[0.10, 0.12, 0.13, 0.14, 0.15, 0.16],
                   help="instants [s] (default around the stress peak)")
    p.add_argument("--t-end", type=float, default=0.2, help="simulated time [s] (default 0.2)")
    p.add_argument("--cable", type=int, default=0, help="cable taken apart (default 0, the most loaded)")
    p.add_argument("--out", default=None)
    p.add_argument("--hook-contact", choices=["capsule", "node"], default="capsule",
                   help="the hook model taken apart (default capsule; node: the hook as a sliding node)")
    args = p.parse_args()
    enable_x64()
    out = _report.output_dir(args.out)
    node = args.hook_contact == "node"
    stem = STEM + ("_node" if node else "")
    data = _report.start(precision=_report.precision(), t_end_s=args.t_end, cable=args.cable, rows=[])
    iva = iva_passive_kwargs()
    for variant in args.variants:
        scene, res = run_variant(variant, args.times, args.t_end, iva, hook_contact=args.hook_contact)
        for j, t in enumerate(np.asarray(res.snapshot_ts)):
            state = jax.tree_util.tree_map(lambda x, j=j: x[j], res.snapshots)
            row = dict(variant=variant, **(decompose_node if node else decompose)(scene, state, t, args.cable))
            data["rows"].append(row)
            print(row, flush=True)
        _report.save(data, out, stem)
    _report.finish(data, out, stem, write_md_node if node else write_md)


if __name__ == "__main__":
    main()
