"""Figures 3-7 of the line-throwing rocket paper (Lu et al., Mechanika 22(6) 2016, section 4.2).

Flies the calibrated line-throwing scene at launch angles 25, 35, 45, 55 and 65 deg (one
``jax.vmap`` over the launch angle, ``with_angle`` inside the mapped function; ``--loop`` flies them
one after another instead) and writes, in the output folder:

    fig3_trajectories.png          rocket trajectories
    fig4_speed.png                 rocket speed vs time
    fig5_trajectory_angle.png      trajectory angle atan2(vy, vx) vs time
    fig6_rope_shapes_45deg.png     rope node positions at several instants, 45 deg, with the trajectory
    fig7_acceleration_45deg.png    rocket acceleration along its velocity vs time, 45 deg
    fig3_7_summary.csv             one row per angle (header comments: machine, JAX, precision, settings)
    fig3_7_run.json                the same numbers plus the run's settings and wall times

Usage:
    python experiments/figures_throw.py                      # 1 m segments (the paper's), experiments/results/
    python experiments/figures_throw.py --quick              # 5 m segments, experiments/out/figures_quick/
    python experiments/figures_throw.py --segment-length 2 --out /tmp/figs

``--quick`` writes to ``experiments/out/figures_quick/`` (git-ignored) unless ``--out`` is given, so a
quick check never overwrites the committed full-resolution figures.
"""

from __future__ import annotations

import argparse
import csv
import time

import _report
import jax
import jax.numpy as jnp
import numpy as np

import jaxcable
from jaxcable.throw import line_throwing_scene, with_angle

ANGLES_DEG = (25.0, 35.0, 45.0, 55.0, 65.0)
# Instants of the rope shapes in Fig 6 [s]; those after ground impact are dropped (the solver saves inf).
SNAPSHOT_TS = (0.25, 0.43, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 12.0)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--segment-length", type=float, default=1.0, help="rope segment length [m] (paper: 1 m)")
    p.add_argument("--quick", action="store_true", help="5 m segments, output to experiments/out/figures_quick/")
    p.add_argument("--angles", type=float, nargs="+", default=list(ANGLES_DEG), help="launch angles [deg]")
    p.add_argument("--rope-length", type=float, default=800.0, help="rope in the box [m]")
    p.add_argument("--t1", type=float, default=40.0, help="end time if the rocket has not landed [s]")
    p.add_argument("--solver", default="dopri5")
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--atol", type=float, default=1e-6)
    p.add_argument("--loop", action="store_true", help="fly the angles one by one instead of jax.vmap")
    p.add_argument("--out", default=None, help="output folder (default: experiments/results, or out/ with --quick)")
    return p.parse_args()


def fly(scene, angle_rad, *, t1, solver, rtol, atol, snapshot_ts):
    return jaxcable.simulate(
        with_angle(scene, angle_rad), t1, solver=solver, rtol=rtol, atol=atol, snapshot_ts=snapshot_ts
    )


def fly_all(scene, angles_rad, use_vmap, **kw):
    """All flights as one batched :class:`jaxcable.Result` (leading axis = angle) and wall times."""

    def one(sc, a):
        return fly(sc, a, **kw)

    if use_vmap:
        batched = jax.jit(jax.vmap(one, in_axes=(None, 0)))
        t0 = time.perf_counter()
        compiled = batched.lower(scene, angles_rad).compile()
        t_compile = time.perf_counter() - t0
        t0 = time.perf_counter()
        res = jax.block_until_ready(compiled(scene, angles_rad))
        return res, {"compile_s": t_compile, "run_s": time.perf_counter() - t0}
    t0 = time.perf_counter()
    runs = [jax.block_until_ready(one(scene, a)) for a in angles_rad]
    res = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *runs)
    return res, {"compile_and_run_s": time.perf_counter() - t0}


def flight(res, i):
    """Plain numpy time histories of flight ``i``, ending at the impact point."""
    ts = np.asarray(res.ts[i])
    tf = float(res.t_final[i])
    ok = ts <= tf
    p = res.probes
    end_pos = np.asarray(res.final_state.r0[i])
    end_vel = np.asarray(res.final_state.v0[i])
    pos = np.vstack([np.asarray(p.position[i])[ok], end_pos])
    vel = np.vstack([np.asarray(p.velocity[i])[ok], end_vel])
    t = np.append(ts[ok], tf)
    speed = np.hypot(vel[:, 0], vel[:, 1])
    # The trajectory angle and the acceleration along the velocity are undefined while the rocket is
    # at rest (t = 0, where the probes report 0): leave those samples out of Figs 5 and 7.
    moving = speed > 1e-9
    snap_t = np.asarray(res.snapshot_ts[i])
    keep = np.isfinite(snap_t) & (snap_t <= tf)
    return {
        "t": t,
        "position": pos,
        "speed": speed,
        "t_moving": t[moving],
        "trajectory_angle_deg": np.degrees(np.arctan2(vel[moving, 1], vel[moving, 0])),
        "t_probe": ts[ok][moving[:-1]],
        "acceleration": np.asarray(p.acceleration[i])[ok][moving[:-1]],
        "snapshot_ts": snap_t[keep],
        "snapshots": np.asarray(res.snapshots[i])[keep],
        "t_final": tf,
    }


def summary_rows(res, angles_deg):
    rows = []
    for i, a in enumerate(angles_deg):
        o = {k: np.asarray(v[i]) for k, v in res.outputs.items()}
        rows.append(
            {
                "angle_deg": float(a),
                "range_m": float(o["range_m"]),
                "max_speed_mps": float(o["max_speed_mps"]),
                "flight_time_s": float(o["flight_time_s"]),
                "max_height_m": float(o["max_height_m"]),
                "impact_speed_mps": float(o["impact_speed_mps"]),
                "deployed_rope_m": float(o["deployed_rope_m"]),
                "n_segments": int(o["n_segments"]),
                "speed_at_1_2_3_4_s_mps": [float(v) for v in o["speed_at_1_2_3_4_s_mps"]],
                "num_steps": int(res.num_steps[i]),
                "num_rejected": int(res.num_rejected[i]),
                "status": jaxcable.status_message(res.status[i]),
            }
        )
    return rows


CSV_COLUMNS = [
    "angle_deg",
    "range_m",
    "max_speed_mps",
    "flight_time_s",
    "max_height_m",
    "impact_speed_mps",
    "deployed_rope_m",
    "n_segments",
    "num_steps",
    "status",
]


def write_csv(path, rows, header_lines):
    with open(path, "w", newline="") as f:
        for line in header_lines:
            f.write(f"# {line}\n")
        w = csv.DictWriter(f, fieldnames=CSV_COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4f}" if isinstance(v, float) else v) for k, v in r.items()})


def make_figures(flights, angles_deg, out, subtitle, burn_time_s):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = plt.cm.viridis(np.linspace(0.0, 0.9, len(angles_deg)))
    label = lambda a: f"{a:g}°"
    paths = {}

    def save(fig, name):
        fig.tight_layout()
        fig.savefig(out / name, dpi=120)
        plt.close(fig)
        paths[name] = out / name

    # Fig 3: trajectories.
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for a, fl, c in zip(angles_deg, flights, colors):
        ax.plot(fl["position"][:, 0], fl["position"][:, 1], color=c, label=label(a))
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"Fig. 3 trajectories ({subtitle})")
    ax.grid(alpha=0.3)
    ax.legend(title="launch angle")
    save(fig, "fig3_trajectories.png")

    # Fig 4: speed.
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for a, fl, c in zip(angles_deg, flights, colors):
        ax.plot(fl["t"], fl["speed"], color=c, label=label(a))
    ax.set(xlabel="t [s]", ylabel="rocket speed [m/s]", title=f"Fig. 4 speed ({subtitle})")
    ax.grid(alpha=0.3)
    ax.legend(title="launch angle")
    save(fig, "fig4_speed.png")

    # Fig 5: trajectory angle.
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for a, fl, c in zip(angles_deg, flights, colors):
        ax.plot(fl["t_moving"], fl["trajectory_angle_deg"], color=c, label=label(a))
        ax.plot(0.0, a, "o", color=c, ms=4)  # the launch direction
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set(
        xlabel="t [s]",
        ylabel="trajectory angle atan2(vy, vx) [deg]",
        title=f"Fig. 5 trajectory angle ({subtitle}; dots: launch angle)",
    )
    ax.grid(alpha=0.3)
    ax.legend(title="launch angle")
    save(fig, "fig5_trajectory_angle.png")

    # Figs 6 and 7 at 45 deg (or the listed angle closest to it).
    i45 = int(np.argmin(np.abs(np.asarray(angles_deg) - 45.0)))
    a45 = angles_deg[i45]
    fl = flights[i45]
    fig, ax = plt.subplots(figsize=(8.5, 4.8))
    ax.plot(fl["position"][:, 0], fl["position"][:, 1], "k--", lw=1.0, label="rocket trajectory")
    shade = plt.cm.plasma(np.linspace(0.0, 0.85, max(len(fl["snapshot_ts"]), 1)))
    for ts_, shape, c in zip(fl["snapshot_ts"], fl["snapshots"], shade):
        ax.plot(shape[:, 0], shape[:, 1], color=c, lw=1.2, label=f"rope at {ts_:g} s")
        ax.plot(shape[0, 0], shape[0, 1], "o", color=c, ms=4)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"Fig. 6 rope shapes at {a45:g}° ({subtitle})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    save(fig, f"fig6_rope_shapes_{a45:g}deg.png")

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax.plot(fl["t_probe"], fl["acceleration"], "k-")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.axvline(burn_time_s, color="tab:red", ls=":", lw=1.0, label=f"burn-out {burn_time_s:g} s")
    ax.set(
        xlabel="t [s]",
        ylabel="acceleration along velocity [m/s²]",
        title=f"Fig. 7 rocket acceleration at {a45:g}° ({subtitle})",
    )
    ax.grid(alpha=0.3)
    ax.legend()
    save(fig, f"fig7_acceleration_{a45:g}deg.png")
    return paths


def main():
    args = parse_args()
    jaxcable.enable_x64()
    seg = 5.0 if args.quick else args.segment_length
    out = _report.output_dir(args.out, quick=args.quick, sub="figures_quick")
    data = _report.start()
    angles_deg = [float(a) for a in args.angles]

    scene = line_throwing_scene(45.0, segment_length_m=seg, rope_length_m=args.rope_length)
    angles_rad = jnp.deg2rad(jnp.asarray(angles_deg))
    kw = dict(t1=args.t1, solver=args.solver, rtol=args.rtol, atol=args.atol, snapshot_ts=jnp.asarray(SNAPSHOT_TS))
    mode = "loop" if args.loop else "vmap"
    print(f"flying {len(angles_deg)} launch angles with {seg:g} m segments ({mode}, {args.solver}, rtol={args.rtol:g})", flush=True)
    t0 = time.perf_counter()
    try:
        res, timing = fly_all(scene, angles_rad, use_vmap=not args.loop, **kw)
    except Exception as e:  # vmap is the intended path; fall back rather than produce nothing
        if args.loop:
            raise
        print(f"jax.vmap over the launch angle failed ({type(e).__name__}: {e}); flying them in a loop", flush=True)
        mode = "loop (vmap failed)"
        res, timing = fly_all(scene, angles_rad, use_vmap=False, **kw)
    timing["total_s"] = time.perf_counter() - t0

    rows = summary_rows(res, angles_deg)
    flights = [flight(res, i) for i in range(len(angles_deg))]
    subtitle = f"{seg:g} m segments"
    burn_time = float(scene.rocket.burn_time_s)
    paths = make_figures(flights, angles_deg, out, subtitle, burn_time)

    settings = {
        "segment_length_m": seg,
        "rope_length_m": args.rope_length,
        "t1_s": args.t1,
        "solver": args.solver,
        "rtol": args.rtol,
        "atol": args.atol,
        "batching": mode,
        "quick": args.quick,
    }
    header = [
        "Lu et al. 2016 Figs 3-7: line-throwing rocket flights, calibrated defaults (jaxcable.throw.CALIBRATION)",
        ", ".join(f"{k}={v}" for k, v in settings.items()),
        _report.machine_line(data["machine"]),
        f"run {data['date']} by `{data['command']}`, load average at the start {data['load_start']}",
        ", ".join(f"{k}={v:.2f}" for k, v in timing.items()),
        "units: angle deg, lengths m, speeds m/s, time s",
    ]
    write_csv(out / "fig3_7_summary.csv", rows, header)
    data.update(settings=settings, wall_s=timing, flights=rows, load_end=_report.load_average())
    _report.write_json(out / "fig3_7_run.json", data)

    warn = [r for r in rows if r["status"] != "event_occurred"]
    ran_out = [r for r in rows if r["deployed_rope_m"] >= args.rope_length - seg]
    print(f"\n{'angle':>6} {'range':>8} {'v_max':>7} {'t_fl':>6} {'h_max':>7} {'v_imp':>7} {'rope':>7} {'steps':>6}  status")
    print(f"{'[deg]':>6} {'[m]':>8} {'[m/s]':>7} {'[s]':>6} {'[m]':>7} {'[m/s]':>7} {'[m]':>7}")
    for r in rows:
        print(
            f"{r['angle_deg']:6.1f} {r['range_m']:8.1f} {r['max_speed_mps']:7.1f} {r['flight_time_s']:6.2f} "
            f"{r['max_height_m']:7.1f} {r['impact_speed_mps']:7.1f} {r['deployed_rope_m']:7.1f} {r['num_steps']:6d}  {r['status']}"
        )
    best = max(rows, key=lambda r: r["range_m"])
    print(f"\nlongest range at {best['angle_deg']:g} deg ({best['range_m']:.1f} m)")
    print("wall time: " + ", ".join(f"{k} {v:.1f} s" for k, v in timing.items()) + f" ({mode})")
    if warn:
        print("WARNING: flights that did not end at ground impact: " + ", ".join(f"{r['angle_deg']:g} deg ({r['status']})" for r in warn))
    if ran_out:
        print("WARNING: the rope ran out at " + ", ".join(f"{r['angle_deg']:g} deg" for r in ran_out) + "; raise --rope-length")
    print(f"wrote {len(paths)} figures, fig3_7_summary.csv and fig3_7_run.json to {out}")


if __name__ == "__main__":
    main()
