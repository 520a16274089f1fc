"""Calibrate the cables' Rayleigh damping beta (eq 31, no value printed) to the paper's section III.F.

The objective (:mod:`jaxcable.arresting.calibration`): the RMS distance, scaled by the 1-DOF peaks, of
the design case's drop, CFC 60 acceleration, CFC 60 stress and counterweight rise from the analytical
1-DOF solution (Figs 11b-e: the paper's model "oscillates around" it and "agrees closely").

1. The rocket-cable-counterweight mode's frequency, from the ringing of the rigid level at beta = 1e-5 s
   (the spectrum of the acceleration minus its 0.1 s running mean): sets the upper bound of beta
   (``zeta_1 <= 0.10``).
2. The objective on a grid of beta at the rigid level (one compiled, vmapped solve).
3. The fit: optax Adam on the bounded log beta, gradients by reverse mode through the rigid level.
4. The sensitivities of z_max, a_max, sigma_max to ln beta at the fit (forward mode), checked by
   central differences.
5. The check at the ale level (``--levels ale full`` adds full): the objective and the criteria at the
   fitted beta and at the explicit default 1e-5 s, with the W-method.
6. ``--hook-damper``: Table 1's hook damper c_h = 4e5 N s/m (a suspected misprint) against 4e3 and
   4e4 at the full level, by the same objective.

Writes ``calibrate_damping.{json,md,png}`` (machine, JAX version, float64). Usage::

    python experiments/calibrate_damping.py                         # rigid fit + ale check, ~10 min on 2 cores
    python experiments/calibrate_damping.py --levels ale full --hook-damper   # + full, ~40 min
    python experiments/calibrate_damping.py --quick                 # fit only, 5 steps
"""

from __future__ import annotations

import argparse
import time

import _report
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.config import enable_x64
from jaxcable.arresting import calibration as C
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.landing_rocket import LandingRocketParams

STEM = "calibrate_damping"
KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa")


def ringing_frequency(ts, acc_z, window):
    """Dominant circular frequency [rad/s] of ``acc_z`` minus its 0.1 s running mean, over ``window``."""
    a = np.asarray(acc_z)[window]
    dt = float(ts[1] - ts[0])
    n_avg = int(round(0.1 / dt)) | 1
    x = a - np.convolve(a, np.ones(n_avg) / n_avg, "same")
    x = x[n_avg // 2 : -(n_avg // 2)]
    f = np.fft.rfftfreq(len(x), dt)
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x))))
    k = 3 + int(np.argmax(spec[3:]))
    # parabolic refinement of the peak
    y0, y1, y2 = np.log(spec[k - 1 : k + 2])
    shift = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    return 2 * np.pi * (f[k] + shift * (f[1] - f[0]))


def level_check(level, beta, ref_j, **scene_kwargs):
    t0 = time.perf_counter()
    run = run_landing(level, t_end_s=1.0, cable_damping_s=beta, **scene_kwargs)
    wall = time.perf_counter() - t0
    total, per = C.landing_misfit(run, ref_j)
    o = run.outputs
    return dict(
        level=level, beta_s=beta, objective=total, per_channel=per,
        **{k: float(o[k]) for k in KEYS}, stopped=bool(o["stopped"]), solver_status=str(o["solver_status"]),
        num_steps=int(o["num_steps"]), energy_budget_error=float(o["energy_budget_error"]), wall_s=wall,
        histories={k: v.tolist() for k, v in C.channels_of(run).items()},
    )  # fmt: skip


def write_md(data, path):
    L = ["# Calibration of the cables' Rayleigh damping to section III.F", "", *_report.header(data), ""]
    L += [
        f"Mode of the rocket-cable-counterweight system (rigid level, beta = 1e-5 s): omega_1 = "
        f"{data['omega_1_rad_s']:.1f} rad/s ({data['omega_1_rad_s'] / 2 / np.pi:.2f} Hz). Bounds of beta: "
        f"{data['bounds_s'][0]:g} - {data['bounds_s'][1]:.3g} s (zeta_1 <= {data['zeta_max']:g}).",
        "",
        "## The objective against beta (rigid level)",
        "",
        "| beta [s] | J | drop | acceleration | stress | counterweight |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for row in data["scan"]:
        p = row["per_channel"]
        L.append(f"| {row['beta_s']:.3g} | {row['objective']:.4f} | {p['drop_m']:.4f} | {p['acceleration_g']:.4f} | {p['stress_mpa']:.4f} | {p['counterweight_rise_m']:.4f} |")
    fit = data["fit"]
    L += [
        "",
        "## The fit (optax Adam, rigid level)",
        "",
        f"From beta = {fit['history'][0][0]:.3g} s, {len(fit['history'])} iterations: beta = **{fit['beta_s']:.4g} s**, "
        f"J = {fit['objective']:.4f}, at bound: {fit['at_bound'] or 'no'}. "
        f"Criteria there: z_max {fit['outputs']['z_max_m']:.3f} m, a_max {fit['outputs']['a_max_g']:.3f} g, "
        f"sigma_max {fit['outputs']['sigma_max_mpa']:.1f} MPa.",
        "",
        "Sensitivity at the fit, d output / d ln beta (forward mode; central difference over ln beta +- 0.05 in brackets):",
        "",
        "| output | d / d ln beta | central difference |",
        "|---|---:|---:|",
    ]
    for k in KEYS:
        L.append(f"| {k} | {fit['sensitivity'][k]:.4g} | {data['sensitivity_fd'][k]:.4g} |")
    L += ["", "## At the other levels (1 s design case, default solver settings)", "",
          "| level | beta [s] | J | drop | accel. | stress | counterw. | z_max [m] | a_max [g] | sigma_max [MPa] | steps | time [s] |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for row in data["levels"]:
        p = row["per_channel"]
        L.append(
            f"| {row['level']}{row.get('label', '')} | {row['beta_s']:.3g} | {row['objective']:.4f} | {p['drop_m']:.4f} | {p['acceleration_g']:.4f} | "
            f"{p['stress_mpa']:.4f} | {p['counterweight_rise_m']:.4f} | {row['z_max_m']:.3f} | {row['a_max_g']:.3f} | "
            f"{row['sigma_max_mpa']:.1f} | {row['num_steps']} | {row['wall_s']:.0f} |"
        )  # fmt: skip
    o = data["one_dof"]
    L += ["", f"1-DOF (analytical): z_max {o['z_max_m']:.3f} m, a_max {o['a_max_g']:.3f} g, sigma_max {o['sigma_max_mpa']:.1f} MPa, stop {o['stop_time_s']:.3f} s."]
    _report.write_lines(path, L)


def plot(data, ref, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 5, figsize=(20, 3.6))
    b = [r["beta_s"] for r in data["scan"]]
    ax[0].loglog(b, [r["objective"] for r in data["scan"]], "o-")
    for x in data["bounds_s"]:
        ax[0].axvline(x, color="grey", ls=":")
    ax[0].plot(data["fit"]["beta_s"], data["fit"]["objective"], "r*", ms=12, label="fit")
    ax[0].set(xlabel="beta [s]", ylabel="J (rigid level)", title="objective; bounds dotted")
    ax[0].legend()
    labels = dict(drop_m="drop [m]", acceleration_g="acceleration, CFC 60 [g]", stress_mpa="stress, CFC 60 [MPa]", counterweight_rise_m="counterweight rise [m]")
    for i, k in enumerate(C.CHANNELS):
        a = ax[i + 1]
        a.plot(ref["ts"], ref[k], "k-", lw=2, label="1-DOF (analytical)")
        for row in data["levels"]:
            a.plot(ref["ts"], row["histories"][k], "--", lw=1, label=f"{row['level']}{row.get('label', '')}, beta {row['beta_s']:.2g} s")
        a.axvline(ref["t_stop_s"], color="grey", ls=":")
        a.set(xlabel="t [s]", title=labels[k])
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--levels", nargs="*", default=["ale"], choices=["ale", "full"], help="levels checked at the fit")
    p.add_argument("--steps", type=int, default=20, help="optax iterations")
    p.add_argument("--hook-damper", action="store_true", help="check Table 1's c_h at the full level")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", help="report folder (default experiments/results)")
    args = p.parse_args()
    enable_x64()
    out = _report.output_dir(args.out, args.quick)
    data = _report.start(precision=_report.precision())
    ref = C.one_dof_reference(1.0)
    ref_j = {k: (jnp.asarray(v) if isinstance(v, np.ndarray) else v) for k, v in ref.items()}
    one = run_landing("1dof", t_end_s=1.0).outputs
    data["one_dof"] = {k: float(one[k]) for k in (*KEYS, "stop_time_s")}

    run = C._scene_fn("rigid", 1.0, dict(solver="tsit5", rtol=1e-6, atol=1e-6, max_steps=200_000), {})

    @jax.jit
    def scan_one(beta):
        r = run(beta)
        total, per = C.history_misfit(r.ts, r.probes, ref_j)
        return total, per, r.probes["acceleration_m_s2"][:, 2]

    betas = np.geomspace(1e-5, 5e-2, 4 if args.quick else 15)
    scan = []
    for beta in betas:
        total, per, acc_z = scan_one(beta)
        scan.append(dict(beta_s=float(beta), objective=float(total), per_channel={k: float(v) for k, v in per.items()}))
        if beta == betas[0]:
            data["omega_1_rad_s"] = float(ringing_frequency(ref["ts"], acc_z, ref["window"]))
        print(f"beta {beta:.3g} s: J = {float(total):.4f}", flush=True)
    data["scan"] = scan
    data["zeta_max"] = C.ZETA_MAX
    bounds = C.beta_bounds_s(C.ZETA_MAX, data["omega_1_rad_s"])
    data["bounds_s"] = list(bounds)
    _report.save(data, out, STEM)

    t0 = time.perf_counter()
    fit = C.fit_cable_damping("rigid", bounds_s=bounds, steps=5 if args.quick else args.steps, progress=True)
    data["fit"] = dict(beta_s=fit.beta_s, objective=fit.objective, at_bound=fit.at_bound, history=fit.history,
                       per_channel=fit.per_channel, outputs=fit.outputs, sensitivity=fit.sensitivity,
                       wall_s=time.perf_counter() - t0)  # fmt: skip
    print(f"fit: beta = {fit.beta_s:.4g} s, J = {fit.objective:.4f}, at bound: {fit.at_bound or 'no'}", flush=True)

    @jax.jit
    def outs(lb):
        o = run(jnp.exp(lb)).outputs
        return jnp.stack([o[k] for k in KEYS])

    h = 0.05
    lb = np.log(fit.beta_s)
    fd = (np.asarray(outs(lb + h)) - np.asarray(outs(lb - h))) / (2 * h)
    data["sensitivity_fd"] = dict(zip(KEYS, map(float, fd)))
    _report.save(data, out, STEM)

    rows = []
    if not args.quick:
        for level in args.levels:
            for beta in (fit.beta_s, 1e-5):
                rows.append(level_check(level, beta, ref_j))
                print(level, beta, {k: rows[-1][k] for k in ("objective", *KEYS, "wall_s")}, flush=True)
                data["levels"] = rows
                _report.save(data, out, STEM)
        if args.hook_damper:
            for c_h in (4e3, 4e4):
                row = level_check("full", fit.beta_s, ref_j, rocket_params=LandingRocketParams(hook_damping_N_s_per_m=c_h))
                row["label"] = f" c_h {c_h:g}"
                rows.append(row)
                print("full c_h", c_h, {k: row[k] for k in ("objective", *KEYS, "wall_s")}, flush=True)
                data["levels"] = rows
                _report.save(data, out, STEM)
    data["levels"] = rows
    plot(data, ref, out / f"{STEM}.png")
    _report.finish(data, out, STEM, write_md)


if __name__ == "__main__":
    main()
