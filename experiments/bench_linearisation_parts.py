"""Where the W-method's linearisation spends its time at the full level, part by part, for the hook
as a sliding node on 64 span elements (the default) and 32, and the capsule contact on 32.

From the design case's state 0.05 s after capture (beta = 1e-5 s), each part is called ``--calls``
times inside one compiled ``fori_loop``, the state perturbed by ``i * 1e-14`` at each pass so that
nothing is hoisted out of the loop; reported: the best of 3 loops, per call. Parts: one evaluation
of the vector field; the whole ``stiff_linearisation``; the cables' blocks (``AleCables.stiff_blocks``:
element Jacobians, contact pairs for the capsule, the node's ring, the assembly, the masses); the
node's eight JVPs (``_node_jacobians``, inside the blocks); the hooks' hinge rows; the hook
coupling's construction and one stage's JVP. The parts overlap (the blocks are inside the whole),
and the shared kinematics are recomputed by each part here.

Writes ``bench_linearisation_parts.{json,md}``. Usage::

    python experiments/bench_linearisation_parts.py      # ~5 min on 2 cores
"""

from __future__ import annotations

import argparse
import time

import _report

MODELS = (("node", 64, 32), ("node", 32, 16), ("capsule", 32, 16))
T0 = 0.05


def parts(scene):
    from jaxcable.arresting.passive import _rocket_rows
    from jaxcable.arresting.stiff import HookCoupling

    def kin_pick(y):
        hooks = scene.hooks(y.rocket)
        kin = scene.cables.kinematics(y.cables)
        return hooks, kin, scene.cables.contact_pairs_picked(kin, hooks, stiff=True)

    def blocks(y):
        hooks, kin, picked = kin_pick(y)
        return scene.cables.stiff_blocks(y.cables, hooks, T0, kin=kin, picked=picked)

    def hinge(y):
        _, kin, picked = kin_pick(y)
        return scene._hinge_jacobian(T0, y, kin, picked)

    def coupling(y):
        return HookCoupling.at(scene.cables, scene.rocket, y.cables, y.rocket, rows=_rocket_rows).forces_jvp(y.rocket)

    out = {
        "vector field": lambda y: scene.vector_field(T0, y),
        "linearisation (all)": lambda y: scene.stiff_linearisation(T0, y),
        "cables' blocks": blocks,
        "hinge rows": hinge,
        "coupling + one stage": coupling,
    }
    if scene.cables.hook_contact == "node":
        out["node's JVPs (in the blocks)"] = lambda y: scene.cables._node_jacobians(y.cables, scene.hooks(y.rocket))
    return out


def time_part(fn, y0, calls):
    import jax
    import jax.numpy as jnp

    def floats(tree):
        return [x for x in jax.tree_util.tree_leaves(tree) if hasattr(x, "dtype") and jnp.issubdtype(x.dtype, jnp.floating)]

    @jax.jit
    def loop(y0):
        def body(i, acc):
            y = jax.tree_util.tree_map(lambda x: x + i * 1e-14 if jnp.issubdtype(x.dtype, jnp.floating) else x, y0)
            return acc + 1e-30 * sum(jnp.sum(x) for x in floats(fn(y)))

        return jax.lax.fori_loop(0, calls, body, 0.0)

    loop(y0).block_until_ready()
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        loop(y0).block_until_ready()
        best = min(best, (time.perf_counter() - t) / calls)
    return best


def write_md(data, path):
    L = ["# The W-method's linearisation, part by part (full level)", "", *_report.header(data), ""]
    L += [
        (
            f"Design case, state {T0} s after capture, beta = 1e-5 s; per call, the best of 3 compiled loops of "
            f"{data['calls']} calls. The parts overlap (the blocks are inside the whole linearisation)."
        ),
        "",
        "| part | " + " | ".join(data["models"]) + " |",
        "|---|" + "---:|" * len(data["models"]),
    ]
    names = list(dict.fromkeys(k for m in data["models"] for k in data["us"][m]))
    for k in names:
        L.append(f"| {k} | " + " | ".join(f"{data['us'][m][k]:.0f} us" if k in data["us"][m] else "-" for m in data["models"]) + " |")
    _report.write_lines(path, L)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--calls", type=int, default=200)
    p.add_argument("--out", default=None)
    args = p.parse_args()

    from jaxcable.arresting.passive import passive_landing_scene
    from jaxcable.core.config import enable_x64
    from jaxcable.core.simulate import simulate

    enable_x64()
    data = _report.start(precision=_report.precision(), calls=args.calls, models=[], us={})
    out = _report.output_dir(args.out)
    for hook, n_span, n_fine in MODELS:
        name = f"{hook}, {n_span} elements"
        scene = passive_landing_scene("full", t_end_s=T0, cable_damping_s=1e-5, hook_contact=hook, n_span_elements=n_span, n_fine=n_fine)
        y0 = simulate(scene, T0, solver="rosw", rtol=1e-5, atol=1e-5).final_state
        data["models"].append(name)
        data["us"][name] = {k: 1e6 * time_part(fn, y0, args.calls) for k, fn in parts(scene).items()}
        print(name, {k: round(v) for k, v in data["us"][name].items()}, flush=True)
        _report.finish(data, out, "bench_linearisation_parts", write_md)


if __name__ == "__main__":
    main()
