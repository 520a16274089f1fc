"""Speed of the ALE landing levels before/after the vector-field rewrite (issues 3 and 6; not a test).

The ``ale`` and ``full`` levels of the passive-deceleration landing (arresting-cable paper, section
III) spend their time in the vector field: four ALE cables over pulleys, hook-cable contact on every
hook capsule x span element, and the rocket. This script measures the same cases with two versions
of the package side by side, each in its own worker process:

* ``before``: the working tree's ``jaxcable/`` with the three rewritten modules
  (``arresting/cables.py``, ``arresting/cable_sets.py``, ``arresting/contact.py``) taken from
  ``--baseline-rev`` (default: the commit before the rewrite), copied to a temporary directory;
* ``after``: the working tree as it is.

Sections (results are written after each one):

(1) ``evals``: one vector-field evaluation of the design case at each level, timed inside a jitted
    ``fori_loop`` of ``--evals`` evaluations with the scene as a jit *argument* (as in
    :func:`jaxcable.core.simulate`, so parameters are not folded into constants), best of ``--reps``;
    also ``cables.respond`` and ``rocket.derivative`` alone, the first call (trace + compile) of a
    single jitted evaluation and the number of kernels (fusions, dots, library calls) in its
    optimised HLO.
(2) ``equivalence``: the vector field of both versions at the same 31 states of a 0.3 s ``ale``
    landing (and ``full``): largest difference relative to the largest entry of each state group.
(3) ``landings``: ``run_landing`` to ``--t-short`` (0.3 s) and ``--t-long`` (1 s) for each version and
    level with the level defaults (Tsit5, rtol 1e-5): compile (first - second call), run (second
    call), steps, z_max, a_max, sigma_max; plus the ``after`` version with the capture speed changed
    by 1e-12 (relative): the spread that rounding alone causes in these outputs (a_max, the sampled
    maximum of an acceleration that rings at the cable modes, is the most sensitive).
(4) ``solvers`` (``--solvers``, after only): Tsit5, Dopri5, Kvaerno3, Kvaerno5 (dense Jacobian, LU)
    on the first ``--solver-t-end`` seconds of the design case and of the stiff case of issue 3
    (EA x 1000, cable damping 1e-2 s), each in its own process with ``--solver-timeout``; and the
    spectral radius of the vector field's Jacobian at both captures (which bounds an explicit step).

Writes ``experiments/results/bench_ale_speed.{json,md}`` (``--quick``: ``experiments/out/``). Usage:
    python experiments/bench_ale_speed.py              # ~25 min on 2 busy cores
    python experiments/bench_ale_speed.py --quick      # ~5 min: short landings, fewer evaluations
    python experiments/bench_ale_speed.py --solvers --sections solvers --keep   # add section (4)
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REWRITTEN = ("jaxcable/arresting/cables.py", "jaxcable/arresting/cable_sets.py", "jaxcable/arresting/contact.py")
BASELINE_REV = "08477e39b611199b16852d72b6264c86103a563f"
SECTIONS = ("evals", "equivalence", "landings", "solvers")
LEVELS = ("ale", "full")
COMPARED = ("z_max_m", "a_max_g", "sigma_max_mpa")


def parse_args(argv=None):
    p = argparse.ArgumentParser(description="ALE landing speed, before/after")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--sections", nargs="+", default=list(SECTIONS[:3]), choices=SECTIONS)
    p.add_argument("--solvers", action="store_true", help="also run section (4)")
    p.add_argument("--levels", nargs="+", default=list(LEVELS), choices=LEVELS)
    p.add_argument("--baseline-rev", default=BASELINE_REV)
    p.add_argument("--evals", type=int, default=2000)
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--rounds", type=int, default=3, help="evals: alternating before/after worker rounds")
    p.add_argument("--t-short", type=float, default=0.3)
    p.add_argument("--t-long", type=float, default=1.0)
    p.add_argument("--solver-t-end", type=float, default=0.001)
    p.add_argument("--solver-timeout", type=float, default=900.0)
    p.add_argument("--keep", action="store_true", help="keep sections of an existing json not redone")
    p.add_argument("--note", action="append", default=[])
    # internal: a worker process
    p.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--spec", default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.solvers and "solvers" not in args.sections:
        args.sections.append("solvers")
    if args.quick:
        args.evals, args.reps, args.rounds, args.t_long = 500, 3, 1, None
        args.t_short = 0.05
    return args


# ------------------------------------------------------------------------------------------------
# workers (run inside the version under test)
# ------------------------------------------------------------------------------------------------


def _enable():
    import jaxcable

    jaxcable.enable_x64()


def _timed_loop(fn, scene, y0, n):
    """A jitted function running ``fn(scene, y)`` n times in a fori_loop (state nudged each time so
    nothing is hoisted as loop-invariant except what depends on the scene's parameters alone)."""
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    def loop(scene, y):
        def body(i, carry):
            y, acc = carry
            out = fn(scene, y)
            total = sum(jnp.sum(leaf) for leaf in jax.tree_util.tree_leaves(out))
            return jax.tree_util.tree_map(lambda a: a + 1e-14 * total, y), acc + total

        return jax.lax.fori_loop(0, n, body, (y, jnp.zeros(())))[1]

    return eqx.filter_jit(loop)


def _hlo_kernels(text):
    """Kernel launches in an optimised HLO module: fusions, dots, library (custom) calls, copies."""
    import re

    counts = {}
    for op in ("fusion", "dot", "custom-call", "copy"):
        counts[op] = len(re.findall(rf"=\s*\S+\s+{op}\(", text))
    return counts


def worker_evals(spec):
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    _enable()
    from jaxcable.arresting.passive import passive_landing_scene

    out = {}
    for level in spec["levels"]:
        scene = passive_landing_scene(level, t_end_s=0.3)
        y0 = scene.initial_state()
        # 3 mm into the cables: every hook in contact (the state of most of a landing)
        y0 = eqx.tree_at(lambda y: y.rocket.r, y0, y0.rocket.r - jnp.array([0.0, 0.0, 0.003]))

        def respond(sc, y):
            return sc.cables.respond(y.cables, sc.hooks(y.rocket))[:2]

        def rocket(sc, y):
            forces = jnp.zeros((4, 3, 3)) + 1e3 * y.rocket.r[0, 2]
            return sc.rocket.derivative(y.rocket, sc.gravity, hook_forces_N=forces)

        pieces = {
            "vector_field": lambda sc, y: sc.vector_field(0.0, y),
            "cables_respond": respond,
            "rocket_derivative": rocket,
        }
        res = {}
        t0 = time.perf_counter()
        single = eqx.filter_jit(lambda sc, y: sc.vector_field(0.0, y))
        lowered = single.lower(scene, y0)
        compiled = lowered.compile()
        res["first_call_s"] = time.perf_counter() - t0
        res["hlo_kernels"] = _hlo_kernels(compiled.compiled.as_text())
        loops = {k: _timed_loop(f, scene, y0, spec["evals"]) for k, f in pieces.items()}
        for f in loops.values():
            jax.block_until_ready(f(scene, y0))
        best = {k: float("inf") for k in loops}
        best_cpu = {k: float("inf") for k in loops}
        for _ in range(spec["reps"]):  # interleaved, so load spikes hit every piece alike
            for k, f in loops.items():
                t0, c0 = time.perf_counter(), time.process_time()
                jax.block_until_ready(f(scene, y0))
                best[k] = min(best[k], time.perf_counter() - t0)
                best_cpu[k] = min(best_cpu[k], time.process_time() - c0)
        res["us_per_eval"] = {k: 1e6 * v / spec["evals"] for k, v in best.items()}
        res["cpu_us_per_eval"] = {k: 1e6 * v / spec["evals"] for k, v in best_cpu.items()}
        res["load_1min"] = round(os.getloadavg()[0], 2)
        out[level] = res
    return out


def worker_states(spec):
    """Full states along a 0.3 s landing of each level (after version), flattened, to a .npz."""
    import diffrax
    import equinox as eqx
    import jax.numpy as jnp
    import numpy as np
    from jax.flatten_util import ravel_pytree

    _enable()
    from jaxcable.arresting.passive import passive_landing_scene

    arrays = {}
    for level in spec["levels"]:
        scene = passive_landing_scene(level, t_end_s=0.3)
        ts = jnp.linspace(0.0, 0.3, 31)

        @eqx.filter_jit
        def solve(scene):
            term = diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y))
            ctrl = diffrax.PIDController(rtol=1e-5, atol=1e-5)
            sol = diffrax.diffeqsolve(
                term, diffrax.Tsit5(), 0.0, 0.3, None, scene.initial_state(),
                saveat=diffrax.SaveAt(ts=ts), stepsize_controller=ctrl, max_steps=400_000,
            )
            return jax_vmap_ravel(sol.ys)

        arrays[level] = np.asarray(solve(scene))
    np.savez(spec["path"], **arrays)
    return {level: list(a.shape) for level, a in arrays.items()}


def jax_vmap_ravel(tree):
    import jax
    from jax.flatten_util import ravel_pytree

    return jax.vmap(lambda y: ravel_pytree(y)[0])(tree)


def worker_vf_at_states(spec):
    """The vector field of this version at the saved states (flattened), to a .npz; and the sizes
    of the state groups (leaf names) to compare them by."""
    import equinox as eqx
    import jax
    import jax.numpy as jnp
    import numpy as np
    from jax.flatten_util import ravel_pytree

    _enable()
    from jaxcable.arresting.passive import passive_landing_scene

    states = np.load(spec["states"])
    out, groups = {}, {}
    for level in spec["levels"]:
        scene = passive_landing_scene(level, t_end_s=0.3)
        flat0, unravel = ravel_pytree(scene.initial_state())
        if flat0.shape[0] != states[level].shape[1]:
            raise ValueError(f"state sizes differ: {flat0.shape[0]} vs {states[level].shape[1]}")
        f = eqx.filter_jit(lambda sc, ys: jax.vmap(lambda y: ravel_pytree(sc.vector_field(0.0, unravel(y)))[0])(ys))
        out[level] = np.asarray(f(scene, jnp.asarray(states[level])))
        leaves = jax.tree_util.tree_leaves_with_path(scene.initial_state())
        groups[level] = [(jax.tree_util.keystr(p), int(np.size(v))) for p, v in leaves]
    np.savez(spec["path"], **out)
    return groups


def worker_landings(spec):
    import equinox as eqx
    import numpy as np

    _enable()
    import jaxcable
    from jaxcable.arresting.landing import run_landing
    from jaxcable.arresting.layout import CaptureState
    from jaxcable.core.provenance import machine_info

    results = {}
    for level in spec["levels"]:
        for t_end in spec["t_ends"]:
            key = f"{level}@{t_end:g}"
            load0 = os.getloadavg()[0]
            t0 = time.perf_counter()
            first = run_landing(level, t_end_s=t_end)
            t1, c1 = time.perf_counter(), time.process_time()
            second = run_landing(level, t_end_s=t_end)
            t2, c2 = time.perf_counter(), time.process_time()
            row = dict(
                first_s=t1 - t0,
                run_s=t2 - t1,
                run_cpu_s=c2 - c1,
                compile_s=(t1 - t0) - (t2 - t1),
                steps=int(second.outputs["num_steps"]),
                rejected=int(second.result.num_rejected),
                status=second.outputs["solver_status"],
                load_1min=[round(load0, 2), round(os.getloadavg()[0], 2)],
                **{k: float(second.outputs[k]) for k in COMPARED + ("energy_budget_error",)},
            )
            if spec.get("perturb"):
                cap = CaptureState(vz_m_s=-20.0 * (1.0 + 1e-12))
                t3 = time.perf_counter()
                pert = run_landing(level, capture=cap, t_end_s=t_end)
                row["perturbed_run_s"] = time.perf_counter() - t3
                row["perturbed"] = {k: float(pert.outputs[k]) for k in COMPARED}
                row["perturbed_steps"] = int(pert.outputs["num_steps"])
            results[key] = row
            _write_json(spec["path"], dict(results=results, machine=machine_info()))
    return dict(results=results, machine=machine_info())


def worker_solver(spec):
    """One solver on one case: steps and wall time of the first (compile + run) and second call.
    The first call's figures are written before the second call starts, so a timeout keeps them."""
    import jax

    _enable()
    from jaxcable import simulate
    from jaxcable.arresting.layout import ArrestingLayout
    from jaxcable.arresting.passive import passive_landing_scene

    kwargs = {}
    if spec["case"] == "stiff":
        kwargs = dict(layout=ArrestingLayout(EA_N=2.64e11), cable_damping_s=1e-2)
    scene = passive_landing_scene(spec["level"], t_end_s=spec["t_end"], **kwargs)
    row = {}
    for call in ("first", "run"):
        t0 = time.perf_counter()
        res = simulate(scene, spec["t_end"], solver=spec["solver"], rtol=1e-5, atol=1e-5, max_steps=400_000)
        jax.block_until_ready(res.outputs)
        row[f"{call}_s"] = time.perf_counter() - t0
        row.update(
            steps=int(res.num_steps), rejected=int(res.num_rejected), status=res.status_message,
            **{k: float(res.outputs[k]) for k in COMPARED + ("energy_budget_error",)},
        )
        _write_json(spec["out"], row)
    return row


def worker_spectrum(spec):
    """Largest |eigenvalue| of the vector field's Jacobian at the capture state (design and stiff)."""
    import equinox as eqx
    import jax
    import numpy as np
    from jax.flatten_util import ravel_pytree

    _enable()
    from jaxcable.arresting.layout import ArrestingLayout
    from jaxcable.arresting.passive import passive_landing_scene

    out = {}
    for case, kwargs in (("design", {}), ("stiff", dict(layout=ArrestingLayout(EA_N=2.64e11), cable_damping_s=1e-2))):
        scene = passive_landing_scene(spec["level"], t_end_s=0.3, **kwargs)
        flat, unravel = ravel_pytree(scene.initial_state())
        t0 = time.perf_counter()
        J = eqx.filter_jit(lambda sc, x: jax.jacfwd(lambda z: ravel_pytree(sc.vector_field(0.0, unravel(z)))[0])(x))(
            scene, flat
        )
        J = np.asarray(J)
        t_jac = time.perf_counter() - t0
        lam = np.linalg.eigvals(J)
        i = int(np.argmax(np.abs(lam)))
        out[case] = dict(
            n_states=int(flat.shape[0]),
            spectral_radius=float(np.abs(lam[i])),
            eigenvalue=[float(lam[i].real), float(lam[i].imag)],
            most_negative_real=float(np.min(lam.real)),
            jacobian_first_call_s=t_jac,
        )
    return out


WORKERS = dict(
    evals=worker_evals,
    states=worker_states,
    vf_at_states=worker_vf_at_states,
    landings=worker_landings,
    solver=worker_solver,
    spectrum=worker_spectrum,
)


# ------------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------------


def _write_json(path, data):
    Path(path).write_text(json.dumps(data, indent=1, default=float))


def baseline_tree(rev, dest):
    """The working tree's package with the rewritten modules from ``rev``: the 'before' version."""
    shutil.copytree(ROOT / "jaxcable", Path(dest) / "jaxcable", ignore=shutil.ignore_patterns("__pycache__"))
    for rel in REWRITTEN:
        text = subprocess.run(
            ["git", "-C", str(ROOT), "show", f"{rev}:{rel}"], capture_output=True, text=True, check=True
        ).stdout
        (Path(dest) / rel).write_text(text)
    return dest


def run_worker(task, spec, version, trees, timeout=None):
    """Run a worker in a fresh process on one version; returns its JSON result (or an error)."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        spec_path = f.name
        out_path = spec_path.replace(".json", ".out.json")
        json.dump(dict(spec, out=out_path), f)
    env = dict(os.environ)
    env["PYTHONPATH"] = str(trees[version]) + os.pathsep + env.get("PYTHONPATH", "")
    env.setdefault("PYTHONWARNINGS", "ignore")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", task, "--spec", spec_path]
    t0 = time.perf_counter()
    try:
        try:
            proc = subprocess.run(
                cmd, env=env, capture_output=True, text=True, timeout=timeout, cwd=tempfile.gettempdir()
            )
        except subprocess.TimeoutExpired:
            partial = json.loads(Path(out_path).read_text()) if Path(out_path).exists() else {}
            return dict(error=f"timed out after {timeout:.0f} s", wall_s=time.perf_counter() - t0, **partial)
        if proc.returncode != 0 or not Path(out_path).exists():
            return dict(error=proc.stderr[-2000:], wall_s=time.perf_counter() - t0)
        result = json.loads(Path(out_path).read_text())
        result["_process_wall_s"] = time.perf_counter() - t0
        return result
    finally:
        for path in (spec_path, out_path):
            Path(path).unlink(missing_ok=True)


def worker_main(args):
    spec = json.loads(Path(args.spec).read_text())
    import jaxcable

    result = WORKERS[args.worker](spec)
    result = result if isinstance(result, dict) else {"value": result}
    # which jaxcable the worker imported (the working tree or a 'before' copy), relative to the repo
    result["_jaxcable_file"] = os.path.relpath(jaxcable.__file__, ROOT)
    _write_json(args.spec.replace(".json", ".out.json"), result)


def compare_states(before_path, after_path, groups):
    """Per level and state group: max |before - after| / max |after| over the saved states."""
    import numpy as np

    a, b = np.load(after_path), np.load(before_path)
    out = {}
    for level in a.files:
        x, y = a[level], b[level]
        rows, start = {}, 0
        for name, size in groups[level]:
            xa, ya = x[:, start : start + size], y[:, start : start + size]
            start += size
            scale = float(np.max(np.abs(xa))) if xa.size else 0.0
            if scale == 0.0:
                continue
            rows[name] = dict(max_abs=scale, max_rel_diff=float(np.max(np.abs(xa - ya)) / scale))
        out[level] = rows
    return out


def main(args):
    import jaxcable
    from jaxcable.core.provenance import machine_info

    jaxcable.enable_x64()  # the workers run in float64; record it here too

    out_dir = ROOT / ("experiments/out" if args.quick else "experiments/results")
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path = out_dir / ("bench_ale_speed_quick.json" if args.quick else "bench_ale_speed.json")
    data = json.loads(json_path.read_text()) if (args.keep and json_path.exists()) else {}
    data["machine"] = machine_info()
    data["run"] = dict(
        started=time.strftime("%Y-%m-%d %H:%M:%S"),
        argv=sys.argv[1:],
        baseline_rev=args.baseline_rev,
        rewritten=list(REWRITTEN),
        levels=args.levels,
        evals=args.evals,
        reps=args.reps,
        rounds=args.rounds,
        t_short=args.t_short,
        t_long=args.t_long,
        notes=args.note,
    )
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench_ale_speed_") as tmp:
        trees = {"after": ROOT, "before": baseline_tree(args.baseline_rev, Path(tmp) / "before")}
        if "evals" in args.sections:
            # rounds alternate the versions, so a change of the machine's load hits both alike
            spec = dict(levels=args.levels, evals=args.evals, reps=args.reps)
            rounds = {"before": [], "after": []}
            for i in range(args.rounds):
                for v in (("before", "after") if i % 2 == 0 else ("after", "before")):
                    rounds[v].append(run_worker("evals", spec, v, trees))
                data["evals"] = {v: _best_of_rounds(r) for v, r in rounds.items()}
                _save(data, json_path)
        if "equivalence" in args.sections:
            states = str(Path(tmp) / "states.npz")
            info = run_worker("states", dict(levels=args.levels, path=states), "after", trees)
            paths = {v: str(Path(tmp) / f"vf_{v}.npz") for v in ("before", "after")}
            groups = {
                v: run_worker("vf_at_states", dict(levels=args.levels, states=states, path=paths[v]), v, trees)
                for v in ("before", "after")
            }
            if any("error" in g for g in groups.values()) or "error" in info:
                data["equivalence"] = dict(error=[info, groups])
            else:
                data["equivalence"] = compare_states(paths["before"], paths["after"], groups["after"])
            _save(data, json_path)
        if "landings" in args.sections:
            t_ends = [args.t_short] + ([args.t_long] if args.t_long else [])
            data["landings"] = {"before": {"results": {}}, "after": {"results": {}}}
            for t_end in t_ends:
                for level in args.levels:  # one case at a time, both versions back to back
                    for v in ("before", "after"):
                        spec = dict(levels=[level], t_ends=[t_end], perturb=(v == "after"),
                                    path=str(Path(tmp) / f"land_{v}.json"))
                        res = run_worker("landings", spec, v, trees)
                        key = f"{level}@{t_end:g}"
                        data["landings"][v]["results"][key] = res.get("results", {}).get(key, dict(error=res.get("error")))
                        _save(data, json_path)
        if "solvers" in args.sections:
            rows = {}
            for case in ("design", "stiff"):
                for solver in ("tsit5", "dopri5", "kvaerno3", "kvaerno5"):
                    if case == "stiff" and solver in ("tsit5", "dopri5"):
                        continue  # explicit: see the spectral radius below
                    spec = dict(level="ale", case=case, solver=solver, t_end=args.solver_t_end)
                    rows[f"{case}/{solver}"] = run_worker("solver", spec, "after", trees, timeout=args.solver_timeout)
                    data["solvers"] = dict(t_end=args.solver_t_end, timeout_s=args.solver_timeout, rows=rows)
                    _save(data, json_path)
            data["solvers"]["spectrum"] = run_worker("spectrum", dict(level="ale"), "after", trees)
            _save(data, json_path)
    data["run"]["wall_s"] = time.perf_counter() - t_start
    _save(data, json_path)


def _best_of_rounds(rounds):
    """Per level: the fastest of the rounds' timings (each already the best of its reps)."""
    ok = [r for r in rounds if "error" not in r]
    if not ok:
        return rounds[-1]
    out = {}
    for level in (k for k in ok[0] if not k.startswith("_")):
        rows = [r[level] for r in ok]
        best = dict(rows[0])
        for key in ("us_per_eval", "cpu_us_per_eval"):
            best[key] = {p: min(r[key][p] for r in rows) for p in rows[0][key]}
        best["first_call_s"] = min(r["first_call_s"] for r in rows)
        best["load_1min"] = [r["load_1min"] for r in rows]
        best["rounds"] = len(rows)
        out[level] = best
    return out


def _save(data, json_path):
    _write_json(json_path, data)
    json_path.with_suffix(".md").write_text(render_md(data))


def _fmt(x, spec=".3g"):
    return "-" if x is None else format(x, spec)


def render_md(data):
    m = data["machine"]
    run = data["run"]
    lines = [
        "# ALE landing levels: speed before/after the vector-field rewrite",
        "",
        f"Machine: {m['processor']} ({m['machine']}, {m['cpu_count']} logical CPUs), {m['platform']}.  ",
        f"JAX {m['jax']} on {m['jax_backend']}, float64 = {m['float64']}, jaxcable {m['jaxcable']}.  ",
        f"Load average at the start: {m['load_average_1_5_15_min']} (shared machine: wall-clock times are noisy).  ",
        f"Run {run['started']}, {_fmt(run.get('wall_s'), '.0f')} s. Generated by `experiments/bench_ale_speed.py "
        f"{' '.join(run['argv'])}`.  ",
        f"*before* = the working tree with `{'`, `'.join(run['rewritten'])}` from `{run['baseline_rev'][:10]}`; "
        "*after* = the working tree. Each version runs in its own process.",
        "",
    ]
    ev = data.get("evals")
    if ev:
        lines += [
            "## 1. One vector-field evaluation (design case, every hook in contact)",
            "",
            f"Per version: {run.get('rounds', 1)} worker processes (rounds alternate the versions), each timing a "
            f"jitted `fori_loop` of {run['evals']} evaluations {run['reps']} times, scene passed as a jit argument; "
            "the fastest wall time (and, separately, the smallest process CPU time: XLA may use both cores) per "
            "evaluation. *first call* = trace + compile of one jitted evaluation; *kernels* = fusions + dots + "
            "library calls + copies in its optimised HLO.",
            "",
            "| level | version | vector field [us] | (CPU [us]) | cables.respond [us] | rocket [us] | first call [s] "
            "| kernels | load (1 min) |",
            "|---|---|---:|---:|---:|---:|---:|---:|---|",
        ]
        levels = sorted({lv for v in ev.values() if "error" not in v for lv in v if not lv.startswith("_")})
        for level in levels:
            for v in ("before", "after"):
                r = ev[v].get(level) if "error" not in ev[v] else None
                if r is None:
                    lines.append(f"| {level} | {v} | error | | | | | | |")
                    continue
                us, cpu = r["us_per_eval"], r.get("cpu_us_per_eval", {})
                kern = sum(r["hlo_kernels"].values())
                lines.append(
                    f"| {level} | {v} | {us['vector_field']:.1f} | {_fmt(cpu.get('vector_field'), '.1f')} | "
                    f"{us['cables_respond']:.1f} | {us['rocket_derivative']:.1f} | {r['first_call_s']:.1f} | {kern} | "
                    f"{r.get('load_1min', '-')} |"
                )
            if "error" not in ev["before"] and "error" not in ev["after"] and level in ev["before"]:
                b_, a_ = ev["before"][level], ev["after"][level]
                ratio = b_["us_per_eval"]["vector_field"] / a_["us_per_eval"]["vector_field"]
                cpu_b, cpu_a = b_.get("cpu_us_per_eval", {}), a_.get("cpu_us_per_eval", {})
                ratio_cpu = f"{cpu_b['vector_field'] / cpu_a['vector_field']:.2f}x" if cpu_a and cpu_b else "-"
                lines.append(f"| {level} | speed-up | {ratio:.2f}x | {ratio_cpu} | | | | | |")
        lines.append("")
    eq = data.get("equivalence")
    if eq:
        lines += [
            "## 2. Same physics: vector field of both versions at the same states",
            "",
            "31 states of a 0.3 s landing (after version, Tsit5 rtol 1e-5); per state group, the largest "
            "|before - after| over all states divided by the largest |after| of that group.",
            "",
            "| level | state group | max abs (after) | max rel difference |",
            "|---|---|---:|---:|",
        ]
        if "error" in eq:
            lines.append(f"| error | {str(eq['error'])[:200]} | | |")
        else:
            for level, rows in eq.items():
                for name, r in rows.items():
                    lines.append(f"| {level} | `{name}` | {r['max_abs']:.3g} | {r['max_rel_diff']:.1e} |")
        lines.append("")
    la = data.get("landings")
    if la:
        lines += [
            "## 3. Landings (`run_landing`, level defaults: Tsit5, rtol = atol = 1e-5)",
            "",
            "*run* = second identical call (what a compiled landing costs), *compile* = first - second call. "
            "The last column of the *after* rows is the run with the capture speed changed by 1e-12 "
            "(relative): its differences from the unperturbed run are what rounding alone does to the outputs.",
            "",
            "| case | version | run [s] | (CPU [s]) | compile [s] | steps (rejected) | z_max [m] | a_max [g] "
            "| sigma_max [MPa] | energy err | load | perturbed: dz, da, dsigma (rel) |",
            "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|",
        ]
        keys = []
        for v in ("before", "after"):
            for k in la.get(v, {}).get("results", {}):
                if k not in keys:
                    keys.append(k)
        for key in keys:
            rows = {v: la.get(v, {}).get("results", {}).get(key) for v in ("before", "after")}
            for v, r in rows.items():
                if r is None or "error" in r:
                    lines.append(f"| {key} | {v} | {'error' if r else '-'} | | | | | | | | | |")
                    continue
                pert = "-"
                if "perturbed" in r:
                    pert = ", ".join(f"{(r['perturbed'][k] - r[k]) / abs(r[k]):.1e}" for k in COMPARED)
                lines.append(
                    f"| {key} | {v} | {r['run_s']:.2f} | {_fmt(r.get('run_cpu_s'), '.2f')} | {r['compile_s']:.1f} | "
                    f"{r['steps']} ({r['rejected']}) | {r['z_max_m']:.6f} | {r['a_max_g']:.5f} | "
                    f"{r['sigma_max_mpa']:.4f} | {r['energy_budget_error']:.1e} | {r['load_1min']} | {pert} |"
                )
            rb, ra = rows["before"], rows["after"]
            if rb and ra and "error" not in rb and "error" not in ra:
                diffs = ", ".join(f"{(ra[k] - rb[k]) / abs(rb[k]):.1e}" for k in COMPARED)
                cpu = f"{rb['run_cpu_s'] / ra['run_cpu_s']:.2f}x" if "run_cpu_s" in ra else "-"
                lines.append(
                    f"| {key} | after vs before | {rb['run_s'] / ra['run_s']:.2f}x faster | {cpu} | | | "
                    f"rel. differences (z, a, sigma): {diffs} | | | | | |"
                )
        lines.append("")
    so = data.get("solvers")
    if so:
        lines += [
            f"## 4. Solvers (after version, ale level, first {so['t_end']} s, rtol = atol = 1e-5)",
            "",
            f"Each in its own process (timeout {so['timeout_s']:.0f} s); *run* = second call. Stiff case: "
            "`ArrestingLayout(EA_N=2.64e11)`, `cable_damping_s=1e-2` (issue 3's 1-DOF limit).",
            "",
            "| case/solver | run [s] | first [s] | steps (rejected) | run per simulated ms [s] | status | z_max | a_max | sigma_max |",
            "|---|---:|---:|---:|---:|---|---:|---:|---:|",
        ]
        for key, r in so["rows"].items():
            if "first_s" not in r:
                lines.append(f"| {key} | {r.get('error', 'error').splitlines()[-1][:80]} | | | | | | | |")
                continue
            run_time = r.get("run_s")
            per_ms = "-" if run_time is None else f"{run_time / (1e3 * so['t_end']):.2f}"
            status = r["status"] if "error" not in r else f"{r['status']}; 2nd call {r['error']}"
            lines.append(
                f"| {key} | {_fmt(run_time, '.2f')} | {r['first_s']:.1f} | {r['steps']} ({r['rejected']}) | {per_ms} | "
                f"{status} | {r['z_max_m']:.5f} | {r['a_max_g']:.4f} | {r['sigma_max_mpa']:.2f} |"
            )
        sp = so.get("spectrum")
        if sp and "error" not in sp:
            lines += ["", "| capture | states | spectral radius [1/s] | eigenvalue | most negative real part [1/s] | Jacobian first call [s] |",
                      "|---|---:|---:|---|---:|---:|"]
            for case in ("design", "stiff"):
                r = sp[case]
                lines.append(
                    f"| {case} | {r['n_states']} | {r['spectral_radius']:.3g} | {r['eigenvalue'][0]:.3g} {r['eigenvalue'][1]:+.3g}i | "
                    f"{r['most_negative_real']:.3g} | {r['jacobian_first_call_s']:.1f} |"
                )
        lines.append("")
    if run.get("notes"):
        lines += ["## Notes", ""] + [f"* {n}" for n in run["notes"]] + [""]
    return "\n".join(lines)


if __name__ == "__main__":
    cli = parse_args()
    if cli.worker:
        worker_main(cli)
    else:
        try:
            main(cli)
        except Exception:  # keep what was written; show the error
            traceback.print_exc()
            sys.exit(1)
