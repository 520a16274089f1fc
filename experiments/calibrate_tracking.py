"""Calibrate the tracking phase's unprinted values (motor bandwidth, rocket cross-flow drag and
normal-force slope) to what the paper shows of the tracking phase, with optax through the simulator.

The objective (``jaxcable.arresting.tracking_calibration``): QMC cases' tracking error at t_c / 2
within eqs 4-6's design, every case captured, QMC cases' captured states inside Table 8; plus a
small pull toward the values before calibration. Fitted on the deviated case of section IV.A and
``--n`` Halton cases (seed 1) per scenario, adam then L-BFGS; checked on ``--check-n`` other Halton
cases (seed 0, the sweeps' seed) and the deviated case, before (attitude held, b = 1 /s, C_n = 0.8,
C_N = 2) and after (free rocket, the adopted values), with each output's sensitivity (forward mode)
to each parameter; one gradient of the objective against central differences. ``--sweep`` adds
the two-phase QMC sweep of the defaults (``run_qmc_sweep``, rigid level, passive phase included).

Writes experiments/results/calibrate_tracking.{json,md,png}.

    python experiments/calibrate_tracking.py --sweep                # ~40 min on 2 busy cores
    python experiments/calibrate_tracking.py --n 2 --check-n 4 --adam-steps 2 --lbfgs-evaluations 2 --out /tmp/ct
"""

from __future__ import annotations

import argparse
import time

import jax.numpy as jnp
import numpy as np
from _report import finish, header, output_dir, save, start, write_lines

import jaxcable
from jaxcable.arresting import tracking_calibration as tc
from jaxcable.arresting.uncertainty import SCENARIOS, scenario_ranges

STEM = "calibrate_tracking"
TABLE8 = {k: scenario_ranges("I", "passive")[k][1] for k in ("x_m", "vx_m_s", "theta_x_deg", "omega_x_deg_s")}


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=8, help="Halton cases per scenario in the fit (seed 1), besides the deviated case")
    p.add_argument("--check-n", type=int, default=16, help="Halton cases per scenario in the check (seed 0)")
    p.add_argument("--adam-steps", type=int, default=15)
    p.add_argument("--lbfgs-evaluations", type=int, default=25)
    p.add_argument("--learning-rate", type=float, default=0.3)
    p.add_argument("--prior-weight", type=float, default=0.02)
    p.add_argument("--sweep", action="store_true", help="also run the two-phase QMC sweep of the defaults (run_qmc_sweep)")
    p.add_argument("--sweep-n", type=int, default=None, help="cases per scenario of that sweep (default: --check-n; the paper runs 100)")
    p.add_argument("--out", help="report folder (default experiments/results)")
    return p.parse_args(argv)


def summary(obs: dict, qmc: np.ndarray) -> dict:
    """Per scenario: the QMC cases' error at t_c / 2 and captured states, and every case's capture."""
    q = np.asarray(qmc, bool)
    lateral = np.maximum(np.abs(obs["vx_m_s"]), np.abs(obs["vy_m_s"]))
    tilt = np.maximum(np.abs(obs["theta_x_deg"]), np.abs(obs["theta_y_deg"]))
    rate = np.maximum(np.abs(obs["omega_x_deg_s"]), np.abs(obs["omega_y_deg_s"]))
    pos = np.maximum(np.abs(obs["x_m"]), np.abs(obs["y_m"]))
    return dict(
        n_qmc=int(q.sum()),
        qmc_captured=int(np.sum(obs["captured"][q])),
        qmc_error_half_tc_max_m=float(obs["tracking_error_m"][q].max()),
        qmc_error_half_tc_mean_m=float(obs["tracking_error_m"][q].mean()),
        qmc_within_tolerance=int(np.sum(obs["tracking_error_m"][q] <= obs["tracking_tolerance_m"][q])),
        qmc_margin_min_m=float(obs["capture_margin_m"][q].min()),
        qmc_lateral_speed_max_m_s=float(lateral[q].max()),
        qmc_tilt_component_max_deg=float(tilt[q].max()),
        qmc_rate_component_max_deg_s=float(rate[q].max()),
        qmc_position_component_max_m=float(pos[q].max()),
        deviated=dict(
            captured=bool(obs["captured"][~q].all()) if (~q).any() else None,
            margin_m=float(obs["capture_margin_m"][~q][0]) if (~q).any() else None,
            error_half_tc_m=float(obs["tracking_error_m"][~q][0]) if (~q).any() else None,
            lateral_speed_m_s=float(lateral[~q][0]) if (~q).any() else None,
        ),
    )


def gradient_check(space, cases, u, prior_weight, h=1e-3):
    """dJ/du by forward mode against central differences (same compiled objective)."""
    j, g, _ = tc.tracking_objective(space, u, cases, prior_weight, gradient=True)
    fd = []
    for i in range(space.size):
        e = jnp.zeros(space.size).at[i].set(h)
        jp = float(tc.tracking_objective(space, u + e, cases, prior_weight, gradient=True)[0])
        jm = float(tc.tracking_objective(space, u - e, cases, prior_weight, gradient=True)[0])
        fd.append((jp - jm) / (2 * h))
    g = np.asarray(g)
    return dict(u=np.asarray(u).tolist(), x=np.asarray(space.to_physical(u)).tolist(), objective=float(j),
                forward=g.tolist(), central=fd, h=h,
                max_relative_difference=float(np.max(np.abs(g - fd)) / np.max(np.abs(fd))))  # fmt: skip


def main(argv=None):
    args = parse_args(argv)
    jaxcable.enable_x64()
    out = output_dir(args.out)
    data = start(args=vars(args), bounds=tc.PARAMETER_BOUNDS, prior=tc.PRIOR_VALUES,
                 required_margin_m=tc.REQUIRED_MARGIN_M, residual_scales=tc.RESIDUAL_SCALES,
                 loop_sensitivity_peak_at_upper_bound={s: tc.loop_sensitivity_peak(tc.PARAMETER_BOUNDS["motor_bandwidth_per_s"][1], a, 0.1)
                                                       for s, a in (("I", 2.0), ("II", 5.0), ("III", 6.0))},
                 design_relative_error={s: float(tc.design_relative_error(a, t)) for s, a, t in (("I", 2, 10), ("II", 5, 6), ("III", 6, 5))})  # fmt: skip
    fit_cases = [tc.calibration_cases(s, args.n, seed=1) for s in SCENARIOS]
    check_cases = {s: tc.calibration_cases(s, args.check_n, seed=0) for s in SCENARIOS}
    t0 = time.perf_counter()

    # -- before: the previous defaults (attitude held) and the free rocket with the same values ----
    data["before"] = {}
    for label, hold in (("held_prior", True), ("free_prior", False)):
        data["before"][label] = {}
        for s, c in check_cases.items():
            obs = tc.evaluate(tc.PRIOR_VALUES, c, attitude_hold=hold)
            data["before"][label][s] = summary(obs, np.asarray(c.qmc))
            print(label, s, data["before"][label][s], f"{time.perf_counter() - t0:.0f} s", flush=True)
        save(data, out, STEM)

    # -- the gradient at the start against central differences ------------------------------------
    space = tc.calibration_space()
    lo, hi = np.asarray(space.lower), np.asarray(space.upper)
    x0 = np.clip([tc.PRIOR_VALUES[n] for n in space.names], lo + 0.05 * (hi - lo), hi - 0.05 * (hi - lo))
    data["gradient_check"] = gradient_check(space, fit_cases, space.to_unconstrained(jnp.asarray(x0)), args.prior_weight)
    print("gradient check", data["gradient_check"], flush=True)

    # -- the fit: adam, then L-BFGS from adam's best ---------------------------------------------
    def progress(i, j, x, aux):
        print(f"  {i:3d}  J {j:.5g}  misfit {aux['misfit']:.4g}  prior {aux['prior']:.3g}  x {np.round(x, 4).tolist()}"
              f"  {time.perf_counter() - t0:.0f} s", flush=True)  # fmt: skip

    fits = []
    adam = tc.fit_tracking(fit_cases, method="adam", steps=args.adam_steps, learning_rate=args.learning_rate,
                           prior_weight=args.prior_weight, callback=progress)  # fmt: skip
    fits.append(adam)
    lbfgs = tc.fit_tracking(fit_cases, method="lbfgs", steps=args.lbfgs_evaluations, x0=adam.best,
                            prior_weight=args.prior_weight, callback=progress)  # fmt: skip
    fits.append(lbfgs)
    best = min(fits, key=lambda f: f.objective)
    data["fit"] = dict(
        names=list(best.names), best=best.best, objective=best.objective,
        histories=[f.history.as_json() for f in fits],
        worst_residuals={s: dict(zip(tc.RESIDUAL_NAMES, np.max(r, axis=0).tolist())) for s, r in best.residuals.items()},
    )  # fmt: skip
    print("fit", best.best, best.objective, flush=True)
    save(data, out, STEM)

    # -- after: the adopted (rounded) values, free rocket; sensitivities --------------------------
    adopted = dict(tc.CALIBRATED_VALUES)
    data["adopted"] = adopted
    j_adopted, aux = tc.tracking_objective(space, None, fit_cases, args.prior_weight, x=[adopted[n] for n in space.names])
    data["adopted_objective"] = dict(
        objective=float(j_adopted), misfit=aux["misfit"], prior=aux["prior"],
        worst_residuals={s: dict(zip(tc.RESIDUAL_NAMES, np.max(r, axis=0).tolist())) for s, r in aux["residuals"].items()},
    )  # fmt: skip
    values = dict(adopted, rocket_axial_drag_coefficient=0.8, cable_normal_drag_coefficient=1.2)
    data["after"], data["sensitivities"] = {}, {}
    for s, c in check_cases.items():
        sens = tc.observable_sensitivities(values, c)
        q = np.asarray(c.qmc)
        obs = sens["observables"]
        data["after"][s] = summary(obs, q)
        jac = sens["jacobian"]
        lateral = np.maximum(np.abs(obs["vx_m_s"]), np.abs(obs["vy_m_s"]))
        picks = dict(  # output index, the case that decides the summary (QMC cases)
            qmc_worst_error=(0, int(np.flatnonzero(q)[np.argmax(obs["tracking_error_m"][q])])),
            qmc_smallest_margin=(1, int(np.flatnonzero(q)[np.argmin(obs["smooth_capture_margin_m"][q])])),
            qmc_largest_lateral_speed=(2, int(np.flatnonzero(q)[np.argmax(lateral[q])])),
        )
        data["sensitivities"][s] = {
            "per_unit": {k: dict(zip(sens["names"], jac[i, o].tolist())) for k, (o, i) in picks.items()},
            "mean_over_qmc": {name: dict(zip(sens["names"], jac[q, o].mean(axis=0).tolist()))
                              for o, name in enumerate(sens["output_names"])},
        }  # fmt: skip
        print("after", s, data["after"][s], f"{time.perf_counter() - t0:.0f} s", flush=True)
        save(data, out, STEM)

    if args.sweep:
        data["sweep"] = run_sweeps(args.sweep_n or args.check_n)
    finish(data, out, STEM, write_md)
    plot(data, out / f"{STEM}.png")


def run_sweeps(n):
    """The two-phase QMC sweep of the defaults (rigid level, passive phase included): captures."""
    import tempfile
    from pathlib import Path

    from jaxcable.arresting.sweep import run_qmc_sweep

    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for s in SCENARIOS:
            t = run_qmc_sweep(s, n, phase="full", out=Path(tmp) / f"{s}.csv", seed=0, progress=False)
            err = np.asarray(t["tracking_error_m"], float)
            v = np.maximum(np.abs(np.asarray(t["captured_vx_m_s"], float)), np.abs(np.asarray(t["captured_vy_m_s"], float)))
            res[s] = dict(n=n, captured=int(np.sum(np.asarray(t["captured"], bool))), error_half_tc_max_m=float(err.max()),
                          margin_min_m=float(np.min(np.asarray(t["capture_margin_m"], float))),
                          lateral_speed_max_m_s=float(v.max()), stopped=int(np.sum(np.asarray(t["stopped"], bool))))  # fmt: skip
            print("sweep", s, res[s], flush=True)
    return res


def _row(label, s, d):
    dev = d["deviated"]
    return (f"| {label} | {s} | {d['qmc_captured']}/{d['n_qmc']} | {d['qmc_error_half_tc_max_m']:.2f} | "
            f"{d['qmc_within_tolerance']}/{d['n_qmc']} | {d['qmc_margin_min_m']:.2f} | {d['qmc_lateral_speed_max_m_s']:.2f} | "
            f"{d['qmc_tilt_component_max_deg']:.1f} | {d['qmc_rate_component_max_deg_s']:.2f} | {d['qmc_position_component_max_m']:.1f} | "
            f"{dev['margin_m']:.2f} | {dev['error_half_tc_m']:.2f} |")  # fmt: skip


def write_md(data, path):
    a = data["args"]
    lines = [f"# Calibration of the tracking phase ({', '.join(tc.CALIBRATION_PARAMETERS)})", ""]
    lines += header(data) + [""]
    lines += [
        (f"Fitted on the deviated case of section IV.A and {a['n']} Halton cases (seed 1) per scenario; checked on "
        f"{a['check_n']} other Halton cases (seed 0, the sweeps' seed) and the deviated case. Rigid rocket, tracking "
        "phase only (the phase switch's event included). Objective: squared hinges of the QMC cases' error at t_c / 2 "
        "above eqs 4-6's design (ideal motor) plus two RMS of the filtered noise, of every capture margin below "
        f"{tc.REQUIRED_MARGIN_M} m, and of the QMC cases' captured states outside Table 8; plus "
        f"{a['prior_weight']} x the squared distance (in bound widths) from the values before calibration."),
        "",
        "## Parameters",
        "",
        "| parameter | bounds | before | fitted | adopted |",
        "|---|---|---:|---:|---:|",
    ]
    for n in tc.CALIBRATION_PARAMETERS:
        lo, hi = data["bounds"][n]
        lines.append(f"| {n} | [{lo:g}, {hi:g}] | {data['prior'][n]:g} | {data['fit']['best'][n]:.4g} | {data['adopted'][n]:g} |")
    lines += [
        "",
        f"Objective: fitted {data['fit']['objective']:.4g}, adopted values {data['adopted_objective']['objective']:.4g} "
        f"(misfit {data['adopted_objective']['misfit']:.4g}, prior term {data['adopted_objective']['prior']:.4g}). "
        f"Loop sensitivity peak M_s at b = {data['bounds']['motor_bandwidth_per_s'][1]:g} /s, tau = 0.1 s: "
        + ", ".join(f"{s} {v:.2f}" for s, v in data["loop_sensitivity_peak_at_upper_bound"].items())
        + ". Design relative error at t_c / 2 (eqs 4-6, ideal motor): "
        + ", ".join(f"{s} {100 * v:.2f} %" for s, v in data["design_relative_error"].items())
        + ".",
        "",
        ("Gradient of the objective at the start (forward mode through the solves and the event time) against central "
        f"differences (h = {data['gradient_check']['h']:g} in the logistic coordinates): forward "
        f"{np.round(data['gradient_check']['forward'], 6).tolist()}, central {np.round(data['gradient_check']['central'], 6).tolist()}, "
        f"largest difference {data['gradient_check']['max_relative_difference']:.1e} of the largest component."),
        "",
        "## Before and after (check cases)",
        "",
        "QMC columns over the check's Halton cases; Table 8: |v| <= 2 m/s, |theta| <= 16 deg, |omega| <= 6 deg/s, |x|, |y| <= 17 m.",
        "",
        "| model | scenario | captured | error at t_c/2 max [m] | within design | min margin [m] | max abs v [m/s] | max abs theta [deg] | max abs omega [deg/s] | max abs x, y [m] | deviated: margin [m] | deviated: error at t_c/2 [m] |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    labels = dict(held_prior="before: attitude held, previous values", free_prior="free rocket, previous values")
    for key, label in labels.items():
        for s, d in data["before"][key].items():
            lines.append(_row(label, s, d))
    for s, d in data["after"].items():
        lines.append(_row("after: free rocket, adopted values", s, d))
    lines += ["", "## Sensitivities at the adopted values (forward mode)", ""]
    lines += [("Derivative of each output of the deciding QMC case (worst error, smallest soft margin, largest lateral "
               "speed) per unit of each parameter; the cables' coefficient carries no load in the tracking phase."), ""]
    names = list(next(iter(data["sensitivities"].values()))["per_unit"]["qmc_worst_error"])
    lines.append("| scenario | output | " + " | ".join(names) + " |")
    lines.append("|---|---|" + "---:|" * len(names))
    for s, sens in data["sensitivities"].items():
        for k, row in sens["per_unit"].items():
            lines.append(f"| {s} | {k} | " + " | ".join(f"{row[n]:.3g}" for n in names) + " |")
    if data.get("sweep"):
        lines += ["", "## Two-phase QMC sweep of the defaults (run_qmc_sweep, rigid level)", ""]
        lines += ["Halton cases of seed 0 (the first of them are the check's cases).", ""]
        lines += ["| scenario | cases | captured | min margin [m] | error at t_c/2 max [m] | max abs v [m/s] | stopped |",
                  "|---|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        for s, d in data["sweep"].items():
            lines.append(f"| {s} | {d['n']} | {d['captured']} | {d.get('margin_min_m', float('nan')):.3f} | {d['error_half_tc_max_m']:.2f} | "
                         f"{d['lateral_speed_max_m_s']:.2f} | {d['stopped']} |")  # fmt: skip
    write_lines(path, lines)


def plot(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(14, 4))
    offset = 0
    for h in data["fit"]["histories"]:
        j = np.asarray(h["objective"])
        ax[0].semilogy(offset + np.arange(len(j)), j, "o-", ms=3, label=h["method"])
        x = np.asarray(h["x"])
        for i, n in enumerate(h["names"]):
            lo, hi = data["bounds"][n]
            ax[1].plot(offset + np.arange(len(j)), (x[:, i] - lo) / (hi - lo), color=f"C{i}", ls=("-", "--", ":")[i % 3],
                       label=n if offset == 0 else None)  # fmt: skip
        offset += len(j)
    ax[0].set_xlabel("objective evaluation")
    ax[0].set_ylabel("objective J")
    ax[0].legend()
    ax[1].set_xlabel("objective evaluation")
    ax[1].set_ylabel("(x - lower) / (upper - lower)")
    ax[1].legend(fontsize=7)
    keys = [("held_prior", "before (held)"), ("free_prior", "free, previous"), (None, "after")]
    width = 0.25
    for k, (key, label) in enumerate(keys):
        src = data["after"] if key is None else data["before"][key]
        vals = [src[s]["qmc_error_half_tc_max_m"] for s in SCENARIOS]
        ax[2].bar(np.arange(3) + (k - 1) * width, vals, width, label=label)
    ax[2].set_xticks(range(3), SCENARIOS)
    ax[2].set_ylabel("QMC max tracking error at t_c / 2 [m]")
    ax[2].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
