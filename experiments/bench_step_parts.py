"""Where a W-method step's time goes at the ale and full levels: the cost per step of each part of
:class:`jaxcable.core.rosenbrock.RosenbrockW` inside diffrax's loop, by taking parts away.

From the design case's state at 0.05 s after capture (hooks in the cables, beta = 1e-5 s), each
variant takes ``--steps`` constant steps of ``--dt`` seconds in one compiled ``diffeqsolve`` (no
saves but the last, no event, no error control, so every variant does the same number of steps and
the difference between two variants is the cost of what one adds):

* ``bosh3``: the explicit default (3 vector-field evaluations per step, first same as last);
* ``rosw, J = 0``: the W-method's 4 evaluations per step and its loop, every solve ``x = b / beta``;
* ``rosw, J every step, linearisation only``: the same, with the linearisation computed every step
  and kept alive (a zero multiple of its sum enters ``beta``) but neither factored nor solved with;
* ``rosw, J every step, linearisation and factorisation``: the same, factored every step as well;
* ``rosw, no coupling``: the cables' blocks and hinges relinearised every step, factored, 4
  structured solves, the cable rows' columns on the rocket left out;
* ``rosw``: the same with the hook coupling (what ``simulate(solver="rosw")`` runs), the
  linearisation every step (``jacobian_every=1``, which batched sweeps do) and every 2 steps
  (the default for single runs); and every 2 steps with the contact of all ``contact_tangent_pairs``
  in ``J`` instead of the ``stiff_contact_pairs`` deepest (:class:`AleCables`); and every 2 steps
  with one block-tridiagonal sweep over each cable's internal nodes instead of its spans side by
  side (``CableLinearisation.plan``, :func:`jaxcable.arresting.stiff.chain_plan`).

Variants run in rounds (:func:`_report.time_rounds`, the best of ``--repeats``), so a change of
the machine's load hits each alike. Writes ``bench_step_parts<tag>.json/.md``. Usage:

    python experiments/bench_step_parts.py                 # full level, ~4 min on 2 cores
    python experiments/bench_step_parts.py --level ale --tag _ale
    python experiments/bench_step_parts.py --hook-contact node --mesh 64 32 --tag _node64
    python experiments/bench_step_parts.py --hook-contact node --mesh 80 16 --batch 4 --steps 100 --tag _node80_batch4
    python experiments/bench_step_parts.py --hook-contact node --mesh 80 16 --only "every 2 steps" --tag _node80_sweeps
"""

from __future__ import annotations

import argparse

import _report

T_START_S = 0.05
"""Time after capture [s] of the state the steps start from (the hooks have picked the cables up)."""


def build(level, dt, steps, hook_contact="capsule", mesh=(32, 16), batch=1, only=()):
    import dataclasses

    import diffrax
    import equinox as eqx
    import jax

    from jaxcable.arresting.passive import passive_landing_scene
    from jaxcable.arresting.stiff import ExplicitLinearisation
    from jaxcable.core.rosenbrock import RosenbrockW
    from jaxcable.core.simulate import make_solver, simulate

    # default: the capsule contact on 32 span elements (the records' model; its contact pairs' pick is measured here)
    scene = passive_landing_scene(
        level, t_end_s=T_START_S, cable_damping_s=1e-5, hook_contact=hook_contact, n_span_elements=mesh[0], n_fine=mesh[1]
    )
    y0 = simulate(scene, T_START_S, solver="rosw", rtol=1e-5, atol=1e-5).final_state
    term = diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y))

    # the contact of every pair the vector field's JVP differentiates in J (contact_tangent_pairs),
    # not only the stiff_contact_pairs deepest
    every = scene.cables.contact_tangent_pairs
    every_pair = dataclasses.replace(scene, cables=dataclasses.replace(scene.cables, stiff_contact_pairs=None))

    def no_coupling(t, y):
        return scene.stiff_linearisation(t, y, hook_coupling=False)

    class Unused(eqx.Module):
        """A linearisation whose work is done but not used: ``factor`` returns ``x = b / beta``
        with a zero multiple of the sum of the linearisation (``factored``: of its factors) added
        to ``beta``, so that XLA keeps the computation (an unused result would be removed)."""

        lin: eqx.Module
        factored: bool = eqx.field(static=True)

        def factor(self, beta):
            kept = self.lin.factor(beta) if self.factored else self.lin
            total = sum(jax.numpy.sum(x) for x in jax.tree_util.tree_leaves(kept) if eqx.is_array(x))
            return ExplicitLinearisation().factor(beta + 0.0 * total)

    def one_sweep(t, y):  # the sweeps over all of a cable's internal nodes, not the spans side by side
        return dataclasses.replace(scene.stiff_linearisation(t, y), plan=None)

    def linearisation_only(t, y):
        return Unused(scene.stiff_linearisation(t, y), factored=False)

    def factorisation_only(t, y):
        return Unused(scene.stiff_linearisation(t, y), factored=True)

    solvers = {
        "bosh3": make_solver("bosh3"),
        "rosw, J = 0": RosenbrockW(linearise=lambda t, y: ExplicitLinearisation(), jacobian_every=1),
        "rosw, J every step, linearisation only": RosenbrockW(linearise=linearisation_only, jacobian_every=1),
        "rosw, J every step, linearisation and factorisation": RosenbrockW(linearise=factorisation_only, jacobian_every=1),
        "rosw, no coupling, J every step": RosenbrockW(linearise=no_coupling, jacobian_every=1),
        "rosw, J every step": RosenbrockW(linearise=scene.stiff_linearisation, jacobian_every=1),
        "rosw, J every 2 steps": RosenbrockW(linearise=scene.stiff_linearisation, jacobian_every=2),
        "rosw, J every 2 steps, one sweep over each cable's nodes": RosenbrockW(linearise=one_sweep, jacobian_every=2),
    }
    if only:
        solvers = {k: v for k, v in solvers.items() if k == "bosh3" or any(o in k for o in only)}
    if hook_contact == "capsule":  # the node has no contact pairs
        solvers[f"rosw, J every 2 steps, {every} pairs in J"] = RosenbrockW(linearise=every_pair.stiff_linearisation, jacobian_every=2)

    # a batch: the same state vmapped, as a sweep's cases step in lock-step
    y_start = y0 if batch == 1 else jax.tree_util.tree_map(lambda x: jax.numpy.stack([x] * batch), y0)

    def call(solver):
        def one(y):
            sol = diffrax.diffeqsolve(
                term, solver, T_START_S, T_START_S + steps * dt, dt, y, saveat=diffrax.SaveAt(t1=True),
                stepsize_controller=diffrax.ConstantStepSize(), max_steps=steps + 10, throw=False,
            )  # fmt: skip
            return sol.ys

        run = jax.jit(one if batch == 1 else jax.vmap(one))
        return lambda: run(y_start)

    return {name: call(s) for name, s in solvers.items()}


def write_md(data, path):
    lines = [
        f"# Cost per step of the W-method's parts ({data['level']} level)",
        "",
        *_report.header(data),
        "",
        (
            f"Design case, hook model {data.get('hook_contact', 'capsule')} on {data.get('mesh', [32, 16])[0]} span elements "
            f"({data.get('mesh', [32, 16])[1]} fine), from its state {T_START_S} s after capture, beta = 1e-5 s, {data['steps']} constant "
            f"steps of {data['dt_s']:g} s in one compiled `diffeqsolve` (no saves, no event), best of "
            f"{data['repeats']} rounds"
            + (f"; {data['batch']} copies of the state vmapped, times per case:" if data.get("batch", 1) > 1 else ":")
        ),
        "",
        "| variant | per step | against bosh3 | added by this row |",
        "|---|---:|---:|---:|",
    ]
    rows = data["per_step_us"]
    base = rows["bosh3"]
    prev = None
    for name, us in rows.items():
        added = "" if prev is None else f"{us - prev:+.0f} us"
        lines.append(f"| {name} | {us:.0f} us | {us / base:.2f} | {added} |")
        prev = us
    return _report.write_lines(path, lines)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--level", choices=("ale", "full"), default="full")
    p.add_argument("--steps", type=int, default=300)
    p.add_argument("--dt", type=float, default=2e-6, help="constant step [s] (below every solver's stability limit)")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--tag", default="")
    p.add_argument("--hook-contact", choices=("capsule", "node"), default="capsule", help="the hook model (default capsule: the records')")
    p.add_argument("--mesh", nargs=2, type=int, default=[32, 16], metavar=("SPAN", "FINE"), help="span elements and fine ones (default 32 16)")
    p.add_argument("--batch", type=int, default=1, help="cases vmapped (the state repeated), as a sweep's batch; times per case (default 1)")
    p.add_argument("--only", nargs="+", default=[], metavar="TEXT", help="run bosh3 and the variants whose names contain any TEXT (default: all)")
    p.add_argument("--out", default=None)
    args = p.parse_args()

    from jaxcable.core.config import enable_x64

    enable_x64()
    data = _report.start(level=args.level, steps=args.steps, dt_s=args.dt, repeats=args.repeats, hook_contact=args.hook_contact, mesh=args.mesh, batch=args.batch)
    calls = build(args.level, args.dt, args.steps, args.hook_contact, tuple(args.mesh), args.batch, tuple(args.only))
    _, first, best = _report.time_rounds(calls, args.repeats)
    data["per_step_us"] = {k: 1e6 * best[k] / args.steps / args.batch for k in calls}
    data["first_call_s"] = first
    for k, us in data["per_step_us"].items():
        print(f"{k:34s} {us:8.0f} us/step")
    _report.finish(data, _report.output_dir(args.out), "bench_step_parts" + args.tag, write_md)


if __name__ == "__main__":
    main()
