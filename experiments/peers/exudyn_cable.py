"""Peer comparison: a cable pinned at both ends, dropped from straight under gravity, in
Exudyn (PyPI ``exudyn``: 2D ANCF cable elements, ``ObjectANCFCable2D``) against jaxcable's ALE cable
(arresting-cable paper, section III.B.1, eqs 26-31; :mod:`jaxcable.components.ale`, every material
coordinate fixed: a Lagrangian cable of linear elements with consistent mass).

The physical case (the same in both codes)
------------------------------------------
A cable of unstretched length ``L0`` = 10 m, ``EA`` = 1e5 N, ``rho A`` = 1 kg/m, pinned at two
level points exactly ``L0`` apart: at t = 0 it is straight, unstretched and at rest, and gravity
(9.81 m/s^2) is switched on. It drops, stretches (the sag is set by the stretch alone: ~0.36 m) and
swings back: a strongly nonlinear case (zero tension, hence zero transverse stiffness, at the start).
No damping.

1. *Drop* (``T_END`` = 0.5 s: one fall and most of the rebound): middle-node path, both codes with
   an adaptive explicit Runge-Kutta pair at rtol = atol = 1e-8 (Exudyn: its DOPRI5; jaxcable:
   diffrax Tsit5), saved at the times Exudyn's sensor recorded.
2. *Statics*: the hanging cable. Exudyn: ``SolveStatic`` with load stepping; jaxcable: Newton on the
   free nodal positions of :func:`jaxcable.components.ale.assemble`'s force. Both against Irvine's elastic
   catenary (span = L0: all sag comes from stretch).

Modelling differences (not error): Exudyn's element is a cubic Hermite (position + slope) ANCF cable
with a bending stiffness (we give it a negligible ``EI`` = 1e-2 N m^2: zero makes its statics
singular at the straight start); jaxcable's is a linear two-node element (no bending), Green strain
(Exudyn's axial strain is ``|r'| - 1``). With 20 elements both are O(h^2)-accurate in different ways,
so they agree to discretisation accuracy, not to the integration tolerance.

Writes ``experiments/results/peers_exudyn.{json,md,png}`` (``--quick``: ``experiments/out/``).
Usage::

    pip install -e ".[peers]"
    python experiments/peers/exudyn_cable.py            # 20 elements
    python experiments/peers/exudyn_cable.py --quick    # 10 elements, 0.25 s
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: the report helper
import _report  # noqa: E402
EA_N = 1e5
RHOA_KG_PER_M = 1.0
LENGTH_M = 10.0
EI_NM2 = 1e-2
G_MPS2 = 9.81
TOL = 1e-8


# ----------------------------------------------------------------------------- Exudyn
def _exudyn_system(n_el: int):
    import exudyn as exu
    from exudyn.beams import GenerateStraightLineANCFCable2D
    from exudyn.utilities import Cable2D

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    template = Cable2D(
        physicsMassPerLength=RHOA_KG_PER_M,
        physicsBendingStiffness=EI_NM2,
        physicsAxialStiffness=EA_N,
        useReducedOrderIntegration=0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        nodes = GenerateStraightLineANCFCable2D(
            mbs,
            [0.0, 0.0, 0.0],
            [LENGTH_M, 0.0, 0.0],
            n_el,
            template,
            massProportionalLoad=[0.0, -G_MPS2, 0.0],
            fixedConstraintsNode0=[1, 1, 0, 0],  # pinned: positions fixed, slope free
            fixedConstraintsNode1=[1, 1, 0, 0],
        )[0]
    return SC, mbs, nodes


def _settings(exu, t_end=None):
    ss = exu.SimulationSettings()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        ss.solutionSettings.writeSolutionToFile = False
        ss.timeIntegration.verboseMode = 0
        ss.staticSolver.verboseMode = 0
        if t_end is not None:
            ss.timeIntegration.endTime = t_end
            ss.timeIntegration.numberOfSteps = int(round(t_end / 1e-3))  # initial/maximum step 1 ms
            ss.timeIntegration.automaticStepSize = True
            ss.timeIntegration.absoluteTolerance = TOL
            ss.timeIntegration.relativeTolerance = TOL
            ss.solutionSettings.sensorsWritePeriod = 0.005
    return ss


def run_exudyn_drop(n_el: int, t_end: float):
    import exudyn as exu
    from exudyn.utilities import SensorNode

    SC, mbs, nodes = _exudyn_system(n_el)
    mid = nodes[n_el // 2]
    sensor = mbs.AddSensor(SensorNode(nodeNumber=mid, storeInternal=True, outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    ss = _settings(exu, t_end)
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, ss, solverType=exu.DynamicSolverType.DOPRI5)
    run_s = time.perf_counter() - t0
    data = np.asarray(mbs.GetSensorStoredData(sensor))
    final = np.array([mbs.GetNodeOutput(n, exu.OutputVariableType.Position)[:2] for n in nodes])
    steps = int(mbs.sys["dynamicSolver"].it.currentStepIndex) if "dynamicSolver" in mbs.sys else None
    return {"t": data[:, 0], "mid": data[:, 1:3], "final": final, "run_s": run_s, "steps": steps}


def run_exudyn_static(n_el: int):
    """Exudyn's static solution, trying load-stepping strategies in turn (see the comment)."""
    import exudyn as exu

    # From the straight, tension-free start the transverse stiffness is only the tiny EI, so Newton
    # must follow the sag as gravity is ramped up. Measured here: with 10 elements, 50 linear load
    # steps fail ("STATIC SOLVER FAILED") and 200 geometric ones converge; with 20 elements, 200
    # and 1000 geometric steps fail and 200 linear adaptive steps converge. We try both.
    strategies = [
        {"numberOfLoadSteps": 200, "loadStepGeometric": False, "adaptiveStep": True},
        {"numberOfLoadSteps": 200, "loadStepGeometric": True, "adaptiveStep": False},
    ]
    failures = []
    for strategy in strategies:
        SC, mbs, nodes = _exudyn_system(n_el)
        mbs.Assemble()
        ss = _settings(exu)
        for key, value in strategy.items():
            setattr(ss.staticSolver, key, value)
        ss.staticSolver.newton.relativeTolerance = 1e-10
        ss.staticSolver.newton.maxIterations = 50
        t0 = time.perf_counter()
        try:
            ok = exu.SolveStatic(mbs, ss)
        except Exception as err:  # exudyn raises SolverError("SolveStatic terminated due to errors")
            failures.append(f"{strategy}: {err}")
            continue
        run_s = time.perf_counter() - t0
        pos = np.array([mbs.GetNodeOutput(n, exu.OutputVariableType.Position)[:2] for n in nodes])
        return {"pos": pos, "ok": bool(ok), "run_s": run_s, "strategy": strategy, "failures": failures}
    raise RuntimeError("Exudyn SolveStatic failed with every strategy: " + "; ".join(failures))


# ----------------------------------------------------------------------------- jaxcable
def _cable_bits(n_el):
    import jax.numpy as jnp

    from jaxcable.components.ale import AleCable

    n = n_el + 1
    cable = AleCable(EA_N=EA_N, rhoA_kg_per_m=RHOA_KG_PER_M)
    s = jnp.linspace(0.0, LENGTH_M, n)
    gravity = jnp.array([0.0, 0.0, -G_MPS2])  # jaxcable is 3D: the cable hangs in the x-z plane
    return cable, s, gravity


def jaxcable_static(n_el: int):
    import jax.numpy as jnp

    from _jaxcable_statics import static_newton

    cable, s, gravity = _cable_bits(n_el)
    n = n_el + 1
    # start from a parabola deeper than the answer: every element starts stretched (in tension)
    x = np.asarray(s)
    guess = jnp.stack([s, jnp.zeros(n), jnp.asarray(-4 * 0.6 * x * (LENGTH_M - x) / LENGTH_M**2)], 1)
    t0 = time.perf_counter()
    r = static_newton(cable, s, gravity, guess, RHOA_KG_PER_M * G_MPS2 * LENGTH_M, max_iter=60)
    return {"pos": r[:, [0, 2]], "run_s": time.perf_counter() - t0}


def run_jaxcable_drop(n_el: int, ts: np.ndarray):
    import diffrax
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    from jaxcable.components.ale import AleState, ale_cable_vector_field

    cable, s, gravity = _cable_bits(n_el)
    n = n_el + 1
    fixed_r = jnp.zeros(n, bool).at[0].set(True).at[-1].set(True)
    fixed_s = jnp.ones(n, bool)
    y0 = AleState(r=jnp.stack([s, jnp.zeros(n), jnp.zeros(n)], 1), s=s, v=jnp.zeros((n, 3)), sdot=jnp.zeros(n))

    @eqx.filter_jit
    def solve(cable, y0):
        term = diffrax.ODETerm(lambda t, y, args: ale_cable_vector_field(args, y, fixed_r, fixed_s, gravity))
        sol = diffrax.diffeqsolve(
            term,
            diffrax.Tsit5(),
            0.0,
            float(ts[-1]),
            None,
            y0,
            args=cable,
            saveat=diffrax.SaveAt(ts=jnp.asarray(ts)),
            stepsize_controller=diffrax.PIDController(rtol=TOL, atol=TOL),
            max_steps=1_000_000,
        )
        return sol.ys.r, sol.stats["num_accepted_steps"], sol.result

    t0 = time.perf_counter()
    jax.block_until_ready(solve(cable, y0))
    first = time.perf_counter() - t0
    runs = []
    for _ in range(2):
        t0 = time.perf_counter()
        r, steps, result = solve(cable, y0)
        jax.block_until_ready(r)
        runs.append(time.perf_counter() - t0)
    assert result == diffrax.RESULTS.successful, result
    r = np.asarray(r)
    return {"mid": r[:, n_el // 2][:, [0, 2]], "final": r[-1][:, [0, 2]], "steps": int(steps), "run_s": min(runs),
            "compile_s": first - min(runs)}


# ----------------------------------------------------------------------------- main
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="10 elements, 0.25 s; results to experiments/out/")
    ap.add_argument("--elements", type=int, default=None)
    args = ap.parse_args(argv)
    n_el = args.elements or (10 if args.quick else 20)
    t_end = 0.25 if args.quick else 0.5

    import jaxcable

    jaxcable.enable_x64()
    data = _report.start()
    from importlib.metadata import version

    ex = run_exudyn_drop(n_el, t_end)
    ts = np.clip(ex["t"], 0.0, t_end)
    jc = run_jaxcable_drop(n_el, ts)
    ex_static = run_exudyn_static(n_el)
    jc_static = jaxcable_static(n_el)
    w = RHOA_KG_PER_M * G_MPS2
    from _jaxcable_statics import irvine

    sag_ref, H_ref = irvine(EA_N, w, LENGTH_M, LENGTH_M)
    mid = n_el // 2
    diff = np.linalg.norm(ex["mid"] - jc["mid"], axis=-1)
    drop = {
        "t_end_s": t_end,
        "n_times": len(ts),
        "max_mid_node_drop_m": float(-np.min(ex["mid"][:, 1])),
        "max_mid_node_diff_m": float(np.max(diff)),
        "max_mid_node_diff_rel_to_drop": float(np.max(diff) / -np.min(ex["mid"][:, 1])),
        "exudyn_run_s": ex["run_s"],
        "jaxcable_run_s": jc["run_s"],
        "jaxcable_compile_s": jc["compile_s"],
        "jaxcable_steps": jc["steps"],
        "speed_ratio_jaxcable_over_exudyn": jc["run_s"] / ex["run_s"],
    }
    static = {
        "irvine_sag_m": sag_ref,
        "irvine_H_N": H_ref,
        "exudyn_static_converged": ex_static["ok"],
        "exudyn_sag_m": float(-ex_static["pos"][mid, 1]),
        "jaxcable_sag_m": float(-jc_static["pos"][mid, 1]),
        "max_node_distance_m": float(np.max(np.linalg.norm(ex_static["pos"] - jc_static["pos"], axis=-1))),
        "exudyn_static_s": ex_static["run_s"],
        "exudyn_static_strategy": ex_static["strategy"],
        "exudyn_static_failed_strategies": ex_static["failures"],
        "jaxcable_newton_s": jc_static["run_s"],
    }
    static["exudyn_sag_rel_err"] = static["exudyn_sag_m"] / sag_ref - 1
    static["jaxcable_sag_rel_err"] = static["jaxcable_sag_m"] / sag_ref - 1
    case = {
        "EA_N": EA_N,
        "rhoA_kg_per_m": RHOA_KG_PER_M,
        "length_m": LENGTH_M,
        "span_m": LENGTH_M,
        "EI_exudyn_Nm2": EI_NM2,
        "elements": n_el,
        "g_mps2": G_MPS2,
        "exudyn": f"exudyn {version('exudyn')}, ObjectANCFCable2D, DOPRI5 rtol = atol = {TOL}",
        "jaxcable": f"ALE cable (s fixed), diffrax Tsit5 rtol = atol = {TOL}",
    }
    out_dir = _report.output_dir(quick=args.quick)
    stem = "peers_exudyn_quick" if args.quick else "peers_exudyn"
    data.update(case=case, drop=drop, static=static, load_end=_report.load_average())
    _report.save(data, out_dir, stem)
    _plot(out_dir / f"{stem}.png", ts, ex, jc, ex_static, jc_static, sag_ref)
    lines = [
        "# Peers: Exudyn ANCF cable vs jaxcable ALE cable (dropped from straight, pinned at both ends)",
        "",
        *_report.header(data),
        "",
        f"Case: L0 = span = {LENGTH_M} m, EA = {EA_N:g} N, rhoA = {RHOA_KG_PER_M} kg/m, {n_el} elements; "
        f"{case['exudyn']} (EI = {EI_NM2} N m^2); {case['jaxcable']}.",
        "",
        f"## Drop from straight, 0..{t_end} s",
        "",
        "| quantity | value |",
        "|---|---:|",
        f"| deepest middle-node position [m] | {drop['max_mid_node_drop_m']:.4f} |",
        f"| max middle-node distance Exudyn vs jaxcable [m] | {drop['max_mid_node_diff_m']:.2e} "
        f"({drop['max_mid_node_diff_rel_to_drop']:.1e} of the drop) |",
        f"| Exudyn run [s] | {ex['run_s']:.3f} |",
        f"| jaxcable run [s] ({jc['steps']} Tsit5 steps), compile [s] | {jc['run_s']:.3f}, {jc['compile_s']:.1f} |",
        f"| jaxcable / Exudyn wall time | {drop['speed_ratio_jaxcable_over_exudyn']:.2f} |",
        "",
        "## Statics (hanging cable)",
        "",
        "| | Exudyn | jaxcable | Irvine (analytic) |",
        "|---|---:|---:|---:|",
        f"| mid-node sag [m] | {static['exudyn_sag_m']:.6f} | {static['jaxcable_sag_m']:.6f} | {sag_ref:.6f} |",
        f"| rel. error vs Irvine | {static['exudyn_sag_rel_err']:+.2e} | {static['jaxcable_sag_rel_err']:+.2e} | |",
        f"| solve time [s] | {ex_static['run_s']:.3f} | {jc_static['run_s']:.3f} (Newton, incl. compile) | |",
        "",
        f"Largest distance between the two static shapes' nodes: {static['max_node_distance_m']:.2e} m. "
        f"Exudyn static solver converged: {ex_static['ok']} with {ex_static['strategy']} "
        f"(failed first: {len(ex_static['failures'])} strategies).",
        "",
        "Differences are discretisation (cubic ANCF with slopes vs linear elements; Exudyn's engineering vs "
        "jaxcable's Green strain; a tiny EI in Exudyn), not integration error: see the script's docstring.",
    ]
    _report.write_lines(out_dir / f"{stem}.md", lines)
    print("\n".join(lines))


def _plot(path, ts, ex, jc, ex_static, jc_static, sag_ref):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ax = axes[0]
    ax.plot(ts, ex["mid"][:, 1], "-", label="Exudyn (ANCF)")
    ax.plot(ts, jc["mid"][:, 1], "--", label="jaxcable (ALE)")
    ax.axhline(-sag_ref, color="k", ls=":", lw=0.8, label="static sag (Irvine)")
    ax.set(xlabel="t [s]", ylabel="middle node height [m]", title="drop from straight")
    ax.legend(fontsize=7)
    ax = axes[1]
    ax.plot(ex_static["pos"][:, 0], ex_static["pos"][:, 1], "o-", ms=3, label="Exudyn static")
    ax.plot(jc_static["pos"][:, 0], jc_static["pos"][:, 1], "x--", ms=4, label="jaxcable static")
    ax.plot(ex["final"][:, 0], ex["final"][:, 1], "-", lw=0.8, label="Exudyn at t_end")
    ax.plot(jc["final"][:, 0], jc["final"][:, 1], "--", lw=0.8, label="jaxcable at t_end")
    ax.set(xlabel="x [m]", ylabel="height [m]", title="shapes")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
