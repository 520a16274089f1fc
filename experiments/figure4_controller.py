"""Fig 4 of the arresting-cable paper (section II.A) and the dead-time approximation error table.

(1) Fig 4: the closed tracking loop alone (``run_tracking_loop``), the paper's case tau = 0.1 s,
    sigma_r = 0.1 m, t_c = 10 s, a_p = 2 /s, initial error 17 m (a still rocket whose bottom is above
    the top plane at x = y = 17 m), with and without the saturation ramp kappa, with measurement
    noise (one fixed key) and without. Plots the displacement of slider 1 and the reel-out speed of
    active pulley 1.
(2) The error of each dead-time approximant (Pade orders 1-5, chains of 1-16 lags) against the exact
    delayed reference (``delayed_loop_reference``: RK4 with a history buffer, h = tau / 20), on the
    noise-free Fig 4 loop with and without kappa: max |d - d_ref| and max |v_p - v_ref| over
    [0, 10] s on the reference grid (every 5 ms), solver steps and run time (second call). The
    loop runs at rtol = atol = 1e-10; the integration error is reported next to the table (default
    order rerun at 1e-12) and the reference's own error (h halved).

Writes figure4_controller.json, .md and .png (machine, JAX version, precision). Usage:
    python experiments/figure4_controller.py            # ~2 min on 2 busy cores
    python experiments/figure4_controller.py --out DIR
"""

from __future__ import annotations

import argparse
import time

import _report
import jax
import jax.numpy as jnp
import numpy as np

import jaxcable
from jaxcable.arresting.control import (
    RocketPath,
    TrackingController,
    delayed_loop_reference,
    measurement_noise_track,
    run_tracking_loop,
)

STEM = "figure4_controller"
T1 = 10.0
TARGET = 17.0
TOL = 1e-10
T_C_HALF = 5.0  # t_c / 2 of the Fig 4 case
PADE_ORDERS = (1, 2, 3, 4, 5)
LAG_COUNTS = (1, 2, 4, 8, 16)


def figure4_rocket(target_m: float = TARGET) -> RocketPath:
    """Fig 4's constant target: a still, vertical rocket whose bottom is 20 m above the plane at
    x = y = ``target_m`` [m] (its length does not matter while the bottom is above the plane)."""
    return RocketPath(
        head_m=jnp.array([target_m, target_m, 60.0]), bottom_m=jnp.array([target_m, target_m, 20.0])
    )


def parse_args():
    p = argparse.ArgumentParser(description="Fig 4 controller and dead-time approximation errors")
    p.add_argument("--out", help="report folder (default experiments/results)")
    p.add_argument("--seed", type=int, default=0, help="noise key for the Fig 4 curves")
    return p.parse_args()


def timed_run(ctrl, save_ts, noise=None, tol=TOL):
    """(result, first-call seconds, second-call seconds)."""
    def once():
        res = run_tracking_loop(ctrl, figure4_rocket(TARGET), save_ts, noise=noise, rtol=tol, atol=tol)
        return jax.block_until_ready(res)

    t0 = time.perf_counter()
    once()
    t1 = time.perf_counter()
    res = once()
    t2 = time.perf_counter()
    assert int(res.status) == 0, f"solver status {int(res.status)}"
    return res, t1 - t0, t2 - t1


def figure4_curves(seed):
    save_ts = jnp.linspace(0.0, T1, 1001)
    base = TrackingController()
    noise = measurement_noise_track(jax.random.PRNGKey(seed), base, T1)
    curves, summary = {"t_s": np.asarray(save_ts).tolist()}, {}
    for ramp in (True, False):
        for noisy in (True, False):
            name = f"{'with' if ramp else 'without'}_kappa_{'noise' if noisy else 'no_noise'}"
            ctrl = TrackingController(ramp=ramp)
            res, _, run_s = timed_run(ctrl, save_ts, noise if noisy else None, tol=1e-8)
            d = np.asarray(res.slider_m[:, 0])
            v = np.asarray(res.reelout_m_s[:, 0])
            target = np.asarray(res.target_m[:, 0])
            # 1e-5 m (m/s) resolution in the json: far below the noise and the approximation errors
            pairs = (("d_m", d), ("v_p_m_s", v), ("target_m", target))
            curves[name] = {k: np.round(x, 5).tolist() for k, x in pairs}
            err = TARGET - d
            t = np.asarray(save_ts)
            late = t >= 0.8 * T1
            within = np.nonzero(np.abs(err) > 0.1)[0]
            summary[name] = {
                "peak_reelout_m_s": float(np.max(np.abs(v))),
                "time_of_peak_s": float(t[np.argmax(np.abs(v))]),
                "peak_displacement_m": float(np.max(d)),
                "error_at_t_c_half_m": float(err[np.argmin(np.abs(t - T_C_HALF))]),
                "rms_error_last_2s_m": float(np.sqrt(np.mean(err[late] ** 2))),
                "last_time_error_above_0.1m_s": float(t[within[-1]]) if within.size else 0.0,
                # the exact delay keeps v_p = 0 for t < tau; an approximant's output rings there
                "min_max_v_p_before_tau_m_s": [float(np.min(v[t < 0.1])), float(np.max(v[t < 0.1]))],
                "accepted_steps": int(res.num_steps),
                "rejected_steps": int(res.num_rejected),
                "run_s": run_s,
            }
            print(name, summary[name])
    return curves, summary


def error_table():
    rows = []
    refs = {}
    for ramp in (True, False):
        ctrl = TrackingController(ramp=ramp)
        ts, d_ref, v_ref = delayed_loop_reference(ctrl, TARGET, T1, steps_per_delay=20)
        ts2, d_ref2, v_ref2 = delayed_loop_reference(ctrl, TARGET, T1, steps_per_delay=40)
        refs[ramp] = {
            "grid_step_s": float(ts[1] - ts[0]),
            "self_error_d_m": float(np.max(np.abs(d_ref2[::2] - d_ref))),
            "self_error_v_p_m_s": float(np.max(np.abs(v_ref2[::2] - v_ref))),
            "peak_v_p_m_s": float(np.max(np.abs(v_ref))),
        }
        save_ts = jnp.asarray(ts)
        for model, orders in (("pade", PADE_ORDERS), ("lags", LAG_COUNTS)):
            for n in orders:
                c = TrackingController(ramp=ramp, delay_model=model, delay_order=n)
                res, first_s, run_s = timed_run(c, save_ts)
                row = {
                    "kappa": ramp,
                    "model": model,
                    "order": n,
                    "max_err_d_m": float(np.max(np.abs(np.asarray(res.slider_m[:, 0]) - d_ref))),
                    "max_err_v_p_m_s": float(np.max(np.abs(np.asarray(res.reelout_m_s[:, 0]) - v_ref))),
                    "accepted_steps": int(res.num_steps),
                    "rejected_steps": int(res.num_rejected),
                    "first_call_s": first_s,
                    "run_s": run_s,
                }
                rows.append(row)
                print(row)
        # the integration error of the table's runs: default order at 1e-10 against 1e-12
        c = TrackingController(ramp=ramp)
        a, _, _ = timed_run(c, save_ts, tol=TOL)
        b, _, _ = timed_run(c, save_ts, tol=1e-12)
        refs[ramp]["integration_error_d_m"] = float(jnp.max(jnp.abs(a.slider_m - b.slider_m)))
        refs[ramp]["integration_error_v_p_m_s"] = float(jnp.max(jnp.abs(a.reelout_m_s - b.reelout_m_s)))
        # no delay model at all (tau dropped): the error an approximant has to beat
        c0 = TrackingController(ramp=ramp, motor_delay_s=0.0)
        r0, _, _ = timed_run(c0, save_ts)
        refs[ramp]["no_delay_err_d_m"] = float(np.max(np.abs(np.asarray(r0.slider_m[:, 0]) - d_ref)))
        refs[ramp]["no_delay_err_v_p_m_s"] = float(np.max(np.abs(np.asarray(r0.reelout_m_s[:, 0]) - v_ref)))
    return rows, {("with_kappa" if k else "without_kappa"): v for k, v in refs.items()}


def write_md(data, path):
    summary, rows, refs = data["figure4_summary"], data["delay_error_table"], data["reference"]
    default = next(r for r in rows if r["kappa"] and r["model"] == "pade" and r["order"] == 2)
    ring = summary["without_kappa_no_noise"]["min_max_v_p_before_tau_m_s"]
    c = TrackingController()
    lines = [
        "# Fig 4: active-tracking controller, and the dead-time approximation error",
        "",
        *_report.header(data),
        "",
        f"Case (section II.A): tau = {float(c.motor_delay_s):g} s, sigma_r = {float(c.noise_rms_m):g} m, "
        f"t_c = {float(c.tracking_time_s):g} s, a_p = {float(c.gain_per_s):g} /s, initial error {TARGET:g} m, PD law "
        f"(derivative gain {float(c.derivative_gain):g}), motor bandwidth {float(c.motor_bandwidth_per_s):g} /s, "
        f"Delta t = {float(c.sample_period_s):g} s, Pade order {c.delay_order} (the defaults).",
        "",
        "## Fig 4 (slider 1 / pulley 1)",
        "",
        "| run | peak v_p [m/s] | at t [s] | peak d [m] | e(t_c / 2) [m] | RMS error t >= 8 s [m] | last t with abs(e) > 0.1 m [s] | steps (rejected) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, s in summary.items():
        lines.append(
            f"| {name} | {s['peak_reelout_m_s']:.3f} | {s['time_of_peak_s']:.2f} | {s['peak_displacement_m']:.3f} | "
            f"{s['error_at_t_c_half_m']:.3f} | {s['rms_error_last_2s_m']:.4f} | {s['last_time_error_above_0.1m_s']:.2f} | "
            f"{s['accepted_steps']} ({s['rejected_steps']}) |"
        )
    lines += [
        "",
        "Reading: the ramp halves the peak reel-out speed (the paper's claim for Fig 4) at the price of a later "
        "convergence. Eq 11 (a_p = 20 / t_c) promises abs(e) <= e^-5 x 17 m = 0.11 m at t_c / 2 = 5 s for the P law "
        "without motor lag; with the paper's PD law, the 1 s motor lag and tau = 0.1 s the noise-free error at 5 s is "
        f"{summary['with_kappa_no_noise']['error_at_t_c_half_m']:.2f} m and d peaks at "
        f"{summary['with_kappa_no_noise']['peak_displacement_m']:.2f} m: eq 9 is a design estimate, not the loop's response.",
        "",
        "## Dead-time approximants against the exact delay (noise-free Fig 4 loop)",
        "",
        "Max error over [0, 10] s on the reference grid; loop integrated at rtol = atol = 1e-10.",
        "",
    ]
    for key, r in refs.items():
        lines.append(
            f"* {key}: reference grid {r['grid_step_s']:g} s, its own error (h halved) {r['self_error_d_m']:.1e} m / "
            f"{r['self_error_v_p_m_s']:.1e} m/s; integration error of the table's runs {r['integration_error_d_m']:.1e} m / "
            f"{r['integration_error_v_p_m_s']:.1e} m/s; peak v_p {r['peak_v_p_m_s']:.2f} m/s; "
            f"dropping tau altogether errs {r['no_delay_err_d_m']:.2e} m / {r['no_delay_err_v_p_m_s']:.2e} m/s."
        )
    lines += [
        "",
        "| kappa | approximant | states/channel | max abs(d - d_ref) [m] | max abs(v_p - v_ref) [m/s] | steps (rejected) | run [ms] |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        label = f"Pade {r['order']}" if r["model"] == "pade" else f"{r['order']} lags"
        lines.append(
            f"| {'yes' if r['kappa'] else 'no'} | {label} | {r['order']} | {r['max_err_d_m']:.2e} | "
            f"{r['max_err_v_p_m_s']:.2e} | {r['accepted_steps']} ({r['rejected_steps']}) | {1e3 * r['run_s']:.1f} |"
        )
    lines += [
        "",
        f"Reading: with kappa every Pade order is far below the 0.1 m noise; order 2 (the default) errs "
        f"{default['max_err_d_m']:.1e} m and {default['max_err_v_p_m_s']:.1e} m/s. Without kappa the command "
        f"has a kink at t = 0 (v_smooth jumps to a_p e = 34 m/s), which no rational approximant reproduces; "
        f"the v_p error then falls slowly with the order (Pade 2 rings during the dead time: v_p between "
        f"{ring[0]:.2f} and {ring[1]:.2f} m/s for t < tau, where the exact delay keeps it at 0). "
        f"A chain of n lags converges like 1/n and is coarser than Pade order 1 even at n = {max(LAG_COUNTS)}.",
        "",
    ]
    _report.write_lines(path, lines)


def plot(path, curves, rows):
    import matplotlib.pyplot as plt

    t = np.asarray(curves["t_s"])
    fig, axes = plt.subplots(1, 3, figsize=(16, 6.0))
    styles = {
        "with_kappa_noise": ("C0", "-", "with kappa (noise)"),
        "without_kappa_noise": ("C3", "-", "without kappa (noise)"),
        "with_kappa_no_noise": ("k", "--", "with kappa, no noise"),
        "without_kappa_no_noise": ("0.5", "--", "without kappa, no noise"),
    }
    for name, (color, ls, label) in styles.items():
        c = curves[name]
        axes[0].plot(t, c["d_m"], color=color, ls=ls, lw=1.2 if ls == "-" else 0.9, label=label)
        axes[1].plot(t, c["v_p_m_s"], color=color, ls=ls, lw=1.2 if ls == "-" else 0.9, label=label)
    axes[0].axhline(TARGET, color="0.7", lw=0.8)
    axes[0].set(xlabel="t [s]", ylabel="displacement of slider 1, d [m]", title="a) displacement of slider 1")
    axes[1].set(xlabel="t [s]", ylabel="reel-out speed of pulley 1, v_p [m/s]",
                title="b) reel-out speed of pulley 1")
    axes[0].legend(fontsize=8)
    for kappa, marker in ((True, "o"), (False, "s")):
        for model, color in (("pade", "C0"), ("lags", "C2")):
            sel = [r for r in rows if r["kappa"] == kappa and r["model"] == model]
            n = [r["order"] for r in sel]
            lab = f"{'Pade' if model == 'pade' else 'lag chain'}, {'with' if kappa else 'without'} kappa"
            axes[2].loglog(n, [r["max_err_d_m"] for r in sel], marker=marker, color=color,
                           ls="-" if kappa else ":", label=f"d, {lab}")
            axes[2].loglog(n, [r["max_err_v_p_m_s"] for r in sel], marker=marker, color=color, mfc="none",
                           ls="-" if kappa else ":", alpha=0.6, label=f"v_p, {lab}")
    axes[2].set(xlabel="states per channel (order)", ylabel="max error vs exact delay [m], [m/s]",
                title="c) dead-time approximation error (Fig 4, no noise)")
    axes[2].legend(fontsize=7, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.14))
    fig.suptitle("Active tracking (arresting-cable paper, Fig 4): tau = 0.1 s, sigma_r = 0.1 m, t_c = 10 s, "
                 "a_p = 2 /s, e(0) = 17 m", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)


def main():
    args = parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    result = _report.start()
    curves, summary = figure4_curves(args.seed)
    rows, refs = error_table()
    result |= {
        "case": {
            **{k: float(v) for k, v in vars(TrackingController()).items() if hasattr(v, "shape")},
            "delay_order": TrackingController().delay_order,
            "target_m": TARGET,
            "noise_seed": args.seed,
        },
        "figure4_summary": summary,
        "delay_error_table": rows,
        "reference": refs,
        "figure4_curves": curves,
    }
    plot(out / f"{STEM}.png", curves, rows)
    _report.finish(result, out, STEM, write_md)


if __name__ == "__main__":
    main()
