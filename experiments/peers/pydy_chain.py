"""Peer comparison: an n-link planar pendulum chain in PyDy / sympy.physics.mechanics
``KanesMethod`` (integrated with scipy) against jaxcable's finite-segment rope (line-throwing paper,
section 3: the Kane chain of rigid links with point masses at their far ends), without payout.

The physical case (the same in both codes)
------------------------------------------
A chain of ``n`` rigid massless links of length ``l = L / n`` (``L`` = 10 m), each carrying a point
mass ``rho l`` (``rho`` = 0.4 kg/m) at its far end, hinged at a fixed pin, under gravity
``g`` = 9.81 m/s^2; no drag, no thrust, no payout, no ground. At t = 0 it is straight, at rest,
pointing from the pin down at ``DROP_ANGLE_DEG`` = 30 deg below the horizontal (its tip at the
origin, the pin at ``L (cos 30, sin 30)``), and released. The tip whips through the bottom of the
swing (the fastest, most sensitive part of the motion) within ``T_END`` = 2 s.

* PyDy side: the chain is derived from scratch with ``KanesMethod`` (coordinates ``theta_1..n`` from
  +Y as in the paper's eq 6, speeds ``omega_j = theta_j'``, point velocities from the symbolic time
  derivative of the positions, not from jaxcable's formulas), turned into a numerical right-hand side
  by ``pydy.codegen.ode_function_generators.generate_ode_function`` (``lambdify`` back end: the
  Cython back end needs Cython, not installed here; mass matrix solved numerically with numpy), and
  integrated with ``scipy.integrate.solve_ivp(method="DOP853")``.
* jaxcable side: the public scene :class:`jaxcable.throw.scene.LineThrowingScene` with
  only the :class:`~jaxcable.throw.forces.Gravity` force (no ``Thrust``/``AeroDrag``/pull-out/``Ground``
  component), a rope whose deployed length equals its capacity (every link full: no payout, no
  tail), the launch angle set to the drop angle so that the scene's own initial state is the
  straight chain above, and :func:`jaxcable.core.simulate` with ``dopri8``.

What the public API cannot express: a *pinned* top. Node 0 of the chain is always the rocket, a
free point mass. We emulate the pin with a rocket of ``PIN_MASS_KG`` = 1e30 kg whose weight is
cancelled by a two-line force component (``PinWeightCancel`` below); the rope then moves it by
``|T| / 1e30 ~ 1e-29 m/s^2``, far below any tolerance. A ``pinned`` option for node 0 (a
prescribed anchor) would make this exact; see README.md beside this script.

Measured: the tip position and every link angle at 41 matching times, max difference over time; both
codes at the same ``rtol = atol`` (the integration tolerance), plus the PyDy run repeated 100x tighter
to show the integration error of each code separately. Wall time: jaxcable after compile (second call
of the jitted solve); PyDy's symbolic derivation + code generation separately from its integration.

Writes ``experiments/results/peers_pydy.{json,md,png}`` (``--quick``: ``experiments/out/``).
Usage::

    pip install -e ".[peers]"
    python experiments/peers/pydy_chain.py            # n = 3, 5, 10, 20, 40 (PyDy budget per n)
    python experiments/peers/pydy_chain.py --quick    # n = 3, 5 only, looser tolerance
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: the report helper
import _report  # noqa: E402
TOTAL_LENGTH_M = 10.0
LINEAR_DENSITY_KG_PER_M = 0.4
G_MPS2 = 9.81
DROP_ANGLE_DEG = 30.0
T_END = 2.0
N_SAVE = 41
PIN_MASS_KG = 1e30


# ----------------------------------------------------------------------------- jaxcable side
def jaxcable_chain_scene(n: int):
    """The pendulum chain as a jaxcable line-throwing scene (see the module docstring)."""
    import jax.numpy as jnp

    from jaxcable.throw.rocket import PointRocket
    from jaxcable.throw.forces import AbstractForce, Gravity
    from jaxcable.components.rope import make_rope
    from jaxcable.throw.scene import Launch, LineThrowingScene

    class PinWeightCancel(AbstractForce):
        """Cancels gravity on node 0 (with a 1e30 kg 'rocket': a pinned top)."""

        def node_forces(self, t, kin, scene):
            return jnp.zeros_like(kin.velocities).at[0, 1].set(kin.masses[0] * G_MPS2)

    seg = TOTAL_LENGTH_M / n
    rope = make_rope(
        segment_length_m=seg,
        rope_length_m=TOTAL_LENGTH_M,
        linear_density_kg_per_m=LINEAR_DENSITY_KG_PER_M,
        drag_coefficient=0.0,
    )
    assert rope.capacity == n, (rope.capacity, n)
    rocket = PointRocket(
        mass_kg=jnp.asarray(PIN_MASS_KG),
        propellant_mass_kg=jnp.asarray(0.0),
        total_impulse_Ns=jnp.asarray(0.0),
        burn_time_s=jnp.asarray(1e3),
        diameter_m=jnp.asarray(0.1),
        drag_coefficient=jnp.asarray(0.0),
    )
    # deployed = capacity * l: every link full. payout_geometry computes floor(S / l); guard against
    # rounding making that n - 1 (the last link would then be welded to the one before it).
    launch = Launch(angle_rad=jnp.asarray(math.radians(DROP_ANGLE_DEG)), rail_length_m=jnp.asarray(rope.length_m))
    scene = LineThrowingScene(
        rocket=rocket, rope=rope, launch=launch, forces=(Gravity(g_mps2=G_MPS2), PinWeightCancel())
    )
    kin = scene.kinematics(0.0, scene.initial_state())
    assert int(kin.n_full) == n and int(kin.n_free) == n, "chain is not fully deployed"
    return scene


def run_jaxcable(n: int, tol: float, ts: np.ndarray):
    """Node positions (n_save, n+1, 2) on ``ts``, compile time and run time [s] of jaxcable."""
    import jax

    import jaxcable

    scene = jaxcable_chain_scene(n)

    def solve():
        res = jaxcable.simulate(
            scene, T_END, solver="dopri8", rtol=tol, atol=tol, snapshot_ts=ts, save_ts=ts[-1:], max_steps=1_000_000
        )
        jax.block_until_ready(res.snapshots)
        return res

    t0 = time.perf_counter()
    solve()
    first = time.perf_counter() - t0
    runs = []
    for _ in range(3):
        t0 = time.perf_counter()
        res = solve()
        runs.append(time.perf_counter() - t0)
    run = min(runs)
    return {
        "positions": np.asarray(res.snapshots),
        "compile_s": first - run,
        "run_s": run,
        "steps": int(res.num_steps),
        "status": res.status_message,
    }


# ----------------------------------------------------------------------------- PyDy side
def derive_pydy(n: int):
    """KanesMethod equations of the pinned n-link chain and PyDy's numerical right-hand side.

    Returns ``(rhs, constants)`` with ``rhs(x, t, p)`` for ``x = [theta_1..n, omega_1..n]``.
    """
    import sympy as sm
    import sympy.physics.mechanics as me
    from pydy.codegen.ode_function_generators import generate_ode_function

    q = me.dynamicsymbols(f"theta1:{n + 1}")
    u = me.dynamicsymbols(f"omega1:{n + 1}")
    length, mass, g = sm.symbols("l m g")
    N = me.ReferenceFrame("N")
    pin = me.Point("pin")
    pin.set_vel(N, 0)
    particles, loads = [], []
    previous = pin
    for j in range(n):
        # eq 6 of the line-throwing paper: r_j = r_{j-1} - l (sin theta_j, cos theta_j)
        point = previous.locatenew(f"P{j + 1}", -length * (sm.sin(q[j]) * N.x + sm.cos(q[j]) * N.y))
        point.set_vel(N, point.pos_from(pin).dt(N))  # symbolic time derivative (in q')
        particles.append(me.Particle(f"m{j + 1}", point, mass))
        loads.append((point, -mass * g * N.y))
        previous = point
    kd = [qj.diff() - uj for qj, uj in zip(q, u)]
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(particles, loads)
    constants = [length, mass, g]
    rhs = generate_ode_function(
        km.forcing,
        q,
        u,
        constants,
        mass_matrix=km.mass_matrix,
        coordinate_derivatives=sm.Matrix(u),
        generator="lambdify",
        linear_sys_solver="numpy",
    )
    return rhs, constants


def pydy_positions(theta: np.ndarray, n: int) -> np.ndarray:
    """Node positions (n_save, n+1, 2) from link angles (n_save, n), pin first."""
    seg = TOTAL_LENGTH_M / n
    a = math.radians(DROP_ANGLE_DEG)
    pin = TOTAL_LENGTH_M * np.array([math.cos(a), math.sin(a)])
    steps = -seg * np.stack([np.sin(theta), np.cos(theta)], -1)
    nodes = pin + np.cumsum(steps, axis=1)
    return np.concatenate([np.broadcast_to(pin, (theta.shape[0], 1, 2)), nodes], axis=1)


def run_pydy(n: int, tol: float, ts: np.ndarray, rhs=None):
    """Integrate the PyDy chain with DOP853; returns positions, angles, timings."""
    from scipy.integrate import solve_ivp

    derive_s = 0.0
    if rhs is None:
        t0 = time.perf_counter()
        rhs, _ = derive_pydy(n)
        derive_s = time.perf_counter() - t0
    seg = TOTAL_LENGTH_M / n
    p = np.array([seg, LINEAR_DENSITY_KG_PER_M * seg, G_MPS2])
    theta0 = np.full(n, math.pi / 2 - math.radians(DROP_ANGLE_DEG))
    x0 = np.concatenate([theta0, np.zeros(n)])
    t0 = time.perf_counter()
    # PyDy's generated function returns the same output buffer on every call: copy it, or
    # solve_ivp's stored Runge-Kutta stages are overwritten (found here: no convergence at all).
    sol = solve_ivp(lambda t, x: np.array(rhs(x, t, p)), (0.0, T_END), x0, method="DOP853", t_eval=ts, rtol=tol, atol=tol)
    run = time.perf_counter() - t0
    if not sol.success:
        raise RuntimeError(f"PyDy n={n}: solve_ivp failed: {sol.message}")
    theta = sol.y[:n].T
    return {
        "positions": pydy_positions(theta, n),
        "theta": theta,
        "derive_s": derive_s,
        "run_s": run,
        "rhs_evals": int(sol.nfev),
        "rhs": rhs,
    }


def link_angles(positions: np.ndarray) -> np.ndarray:
    """Link angles from +Y (eq 6) of node positions (..., n+1, 2): u = r_{j-1} - r_j = l (sin, cos)."""
    d = positions[..., :-1, :] - positions[..., 1:, :]
    return np.arctan2(d[..., 0], d[..., 1])


def wrapped(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a))


def compare(n: int, tol: float, ts: np.ndarray, budget_s: float) -> dict:
    jc = run_jaxcable(n, tol, ts)
    py = run_pydy(n, tol, ts)
    py_ref = run_pydy(n, tol * 1e-2, ts, rhs=py["rhs"])
    tip = lambda r: r[:, -1, :]
    diff = lambda a, b: float(np.max(np.linalg.norm(tip(a) - tip(b), axis=-1)))
    ang = lambda a, b: float(np.max(np.abs(wrapped(link_angles(a) - link_angles(b)))))
    row = {
        "n": n,
        "tol": tol,
        "tip_diff_jaxcable_vs_pydy_m": diff(jc["positions"], py["positions"]),
        "angle_diff_jaxcable_vs_pydy_rad": ang(jc["positions"], py["positions"]),
        "tip_err_jaxcable_vs_pydy_tight_m": diff(jc["positions"], py_ref["positions"]),
        "tip_err_pydy_vs_pydy_tight_m": diff(py["positions"], py_ref["positions"]),
        "pin_drift_jaxcable_m": float(np.max(np.abs(jc["positions"][:, 0, :] - jc["positions"][0, 0, :]))),
        # chord speed between saved times (a lower bound of the peak speed)
        "max_tip_speed_mps": float(np.max(np.linalg.norm(np.diff(tip(py_ref["positions"]), axis=0), axis=-1) / np.diff(ts))),
        "jaxcable_compile_s": jc["compile_s"],
        "jaxcable_run_s": jc["run_s"],
        "jaxcable_steps": jc["steps"],
        "jaxcable_status": jc["status"],
        "pydy_derive_codegen_s": py["derive_s"],
        "pydy_run_s": py["run_s"],
        "pydy_rhs_evals": py["rhs_evals"],
        "speed_ratio_pydy_over_jaxcable": py["run_s"] / jc["run_s"],
        "over_budget": py["derive_s"] + py["run_s"] > budget_s,
    }
    row["_traj"] = {"jaxcable": jc["positions"], "pydy": py["positions"]}
    return row


# ----------------------------------------------------------------------------- reporting
def write_outputs(rows, args, out_dir: Path, data: dict):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    ts = np.linspace(0.0, T_END, N_SAVE)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for row in rows:
        jc, py = row["_traj"]["jaxcable"], row["_traj"]["pydy"]
        (line,) = axes[0].plot(py[:, -1, 0], py[:, -1, 1], "-", lw=1, label=f"PyDy n={row['n']}")
        axes[0].plot(jc[:, -1, 0], jc[:, -1, 1], "o", ms=3, mfc="none", color=line.get_color())
        err = np.linalg.norm(jc[:, -1] - py[:, -1], axis=-1)
        axes[1].semilogy(ts, np.maximum(err, 1e-17), color=line.get_color(), label=f"n={row['n']}")
    last = rows[-1]["_traj"]
    for k in range(0, N_SAVE, 10):
        axes[0].plot(last["pydy"][k, :, 0], last["pydy"][k, :, 1], "-", color="0.7", lw=0.6)
    axes[0].set(xlabel="x [m]", ylabel="y [m]", title="tip path: PyDy (line), jaxcable (circles)")
    axes[0].set_aspect("equal")
    axes[0].legend(fontsize=7)
    axes[1].axhline(args.tol, color="k", ls=":", lw=0.8, label="rtol = atol")
    axes[1].set(xlabel="t [s]", ylabel="|tip jaxcable - tip PyDy| [m]", title="tip difference")
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    stem = "peers_pydy_quick" if args.quick else "peers_pydy"
    fig.savefig(out_dir / f"{stem}.png", dpi=120)
    plt.close(fig)

    clean = [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows]
    case = {
        "total_length_m": TOTAL_LENGTH_M,
        "linear_density_kg_per_m": LINEAR_DENSITY_KG_PER_M,
        "g_mps2": G_MPS2,
        "drop_angle_deg": DROP_ANGLE_DEG,
        "t_end_s": T_END,
        "n_save": N_SAVE,
        "pin_mass_kg": PIN_MASS_KG,
        "solvers": "jaxcable: diffrax Dopri8 (PID); PyDy: scipy solve_ivp DOP853; both rtol = atol = tol",
    }
    data.update(case=case, rows=clean, load_end=_report.load_average())
    _report.save(data, out_dir, stem)
    lines = [
        "# Peers: PyDy (sympy KanesMethod) vs jaxcable segment chain",
        "",
        *_report.header(data),
        "",
        f"Pinned {n_desc(rows)}-link chain, L = {TOTAL_LENGTH_M} m, rho = {LINEAR_DENSITY_KG_PER_M} kg/m, released "
        f"straight from rest {DROP_ANGLE_DEG} deg below horizontal, t = 0..{T_END} s, {N_SAVE} matching times. "
        f"Both integrators at rtol = atol = {args.tol:g}; *PyDy tight* = PyDy at {args.tol * 1e-2:g}. "
        "jaxcable time: after compile (best of 3). PyDy time: solve_ivp only; derivation + codegen separately.",
        "",
        "| n | tip diff jc-PyDy [m] | angle diff [rad] | tip err jc [m] | tip err PyDy [m] | max tip speed [m/s] "
        "| jc steps | jc run [s] | jc compile [s] | PyDy rhs evals | PyDy run [s] | PyDy derive+codegen [s] | PyDy/jc |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in clean:
        lines.append(
            f"| {r['n']} | {r['tip_diff_jaxcable_vs_pydy_m']:.2e} | {r['angle_diff_jaxcable_vs_pydy_rad']:.2e} "
            f"| {r['tip_err_jaxcable_vs_pydy_tight_m']:.2e} | {r['tip_err_pydy_vs_pydy_tight_m']:.2e} "
            f"| {r['max_tip_speed_mps']:.1f} | {r['jaxcable_steps']} | {r['jaxcable_run_s']:.3f} "
            f"| {r['jaxcable_compile_s']:.1f} | {r['pydy_rhs_evals']} | {r['pydy_run_s']:.2f} "
            f"| {r['pydy_derive_codegen_s']:.1f} | {r['speed_ratio_pydy_over_jaxcable']:.0f}x |"
        )
    lines += [
        "",
        "*tip err jc / PyDy*: each code at `tol` against PyDy at `tol/100` (its own integration error). "
        "The jc-PyDy difference is at the level of these integration errors: the two codes solve the same equations.",
        f"jaxcable's pin (a {PIN_MASS_KG:g} kg rocket with its weight cancelled) moved at most "
        f"{max(r['pin_drift_jaxcable_m'] for r in clean):.1e} m.",
    ]
    skipped = [r["n"] for r in clean if r["over_budget"]]
    if skipped:
        lines.append(f"PyDy exceeded the {args.budget:g} s budget at n = {skipped}; larger n were not tried.")
    _report.write_lines(out_dir / f"{stem}.md", lines)
    print("\n".join(lines))


def n_desc(rows):
    return "/".join(str(r["n"]) for r in rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="n = 3, 5 at tol 1e-8; results to experiments/out/")
    ap.add_argument("--n", type=int, nargs="*", default=None, help="chain sizes (default 3 5 10 20 40)")
    ap.add_argument("--tol", type=float, default=None, help="rtol = atol of both integrators (default 1e-10)")
    ap.add_argument(
        "--budget", type=float, default=300.0, help="PyDy seconds (derivation + integration) per n; stop after"
    )
    args = ap.parse_args(argv)
    if args.n is None:
        args.n = [3, 5] if args.quick else [3, 5, 10, 20, 40]
    if args.tol is None:
        args.tol = 1e-8 if args.quick else 1e-10

    import jaxcable

    jaxcable.enable_x64()
    data = _report.start()
    ts = np.linspace(0.0, T_END, N_SAVE)
    rows = []
    for n in args.n:
        print(f"n = {n} ...", flush=True)
        row = compare(n, args.tol, ts, args.budget)
        rows.append(row)
        print({k: v for k, v in row.items() if not k.startswith("_")}, flush=True)
        if row["over_budget"]:
            break
    write_outputs(rows, args, _report.output_dir(quick=args.quick), data)


if __name__ == "__main__":
    sys.exit(main())
