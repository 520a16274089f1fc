"""Where the centred capture's acceleration peak comes from, component by component (not a test).

At the full level the design case (centre, vertical, 20 m/s) with eq 19's counterweight peaks
about 1 g above the rigid level (``experiments/design_full_check.py``). The levels differ in two
components: the cables (massless elastic at ``rigid``; ALE elements with mass, over pulleys, with
hook contact at ``ale`` and ``full``) and the rocket (rigid with welded hooks at ``rigid`` and
``ale``; flexible with sprung hooks at ``full``). This script swaps them one at a time, then varies
the one that matters:

* the ladder: ``rigid``; ``full`` with massless cables (the flexible rocket and sprung hooks alone);
  ``ale`` (the cables with mass alone); ``full`` (both);
* at the ``ale`` level: the cables' mass per length x 0.1 and x 0.3 (Table 1: 9.8 kg/m), the cable
  Rayleigh damping beta x 3 (above the calibration's bound: the fundamental mode's damping ratio
  then exceeds 0.1), and the mesh x 2 (64 span elements, 32 fine), which checks that the peak is
  converged and not an artefact of the mesh.

Per run: z_max, a_max (CFC 60, the criterion), the raw a_max, sigma_max, the time of a_max, the RMS
of the difference ``a_z - a_z(rigid)`` over the stroke (0.02 s to the stop) and its strongest
frequencies. Each ``--buffers`` entry runs the ladder; the variants run for the first only.

An estimate that owes nothing to the ALE model: the capture strikes each arresting span at its
middle and sends a transverse kink along both legs (25 m from the hook to the slider pulleys) at
``c = sqrt(T / rhoA)``; it returns to the hook when ``int_0^t c dt`` reaches twice the leg length
(first return) and four times (second). The column "kink returns" evaluates this with the rigid
level's tension history ``T = sigma pi r^2`` (uniform, quasi-static; at least the pre-tension) and
the run's ``rhoA``.

Writes ``peak_anatomy.{json,md,png}``. Usage (about 15 min on 2 cores):

    python experiments/peak_anatomy.py
    python experiments/peak_anatomy.py --quick        # ladder only, eq 19, 0.6 s; experiments/out/
"""

from __future__ import annotations

import argparse
import time

import _report
import numpy as np

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.layout import ArrestingLayout, kink_return_times
from jaxcable.arresting.one_dof import paper_design
from jaxcable.arresting.passive import DEFAULT_CABLE_DAMPING_S
from jaxcable.core.config import enable_x64

STEM = "peak_anatomy"
G = 9.81

BUFFERS = {
    # eq 19's counterweight (m_t_bar = 2) with Table 1's brake, as paper_start / design_full_check use it
    "eq19": lambda: BufferDevice(counterweight_mass_kg=paper_design().m_w),
    "table1": lambda: BufferDevice(),
}

LADDER = (
    ("rigid", "rigid", {}),
    ("full, massless cables", "full", {"cable_model": "massless"}),
    ("ale", "ale", {}),
    ("full", "full", {}),
)


def variants():
    rho = ArrestingLayout().rhoA_kg_per_m
    return (
        ("ale, rhoA x 0.1", "ale", {"layout": ArrestingLayout(rhoA_kg_per_m=0.1 * rho)}),
        ("ale, rhoA x 0.3", "ale", {"layout": ArrestingLayout(rhoA_kg_per_m=0.3 * rho)}),
        ("ale, beta x 3", "ale", {"cable_damping_s": 3.0 * DEFAULT_CABLE_DAMPING_S}),
        ("ale, mesh x 2", "ale", {"n_span_elements": 64, "n_fine": 32}),
    )


def spectrum_peaks(ts, x, k=4, f_min_hz=8.0):
    """The ``k`` strongest local maxima above ``f_min_hz`` of the Hann-windowed spectrum of ``x``
    (uniform samples ``ts``): [(frequency [Hz], relative amplitude)]."""
    x = (x - x.mean()) * np.hanning(len(x))
    n = 1 << int(np.ceil(np.log2(4 * len(x))))
    F = np.abs(np.fft.rfft(x, n))
    fr = np.fft.rfftfreq(n, ts[1] - ts[0])
    peaks = [i for i in range(1, len(F) - 1) if F[i] > F[i - 1] and F[i] >= F[i + 1] and fr[i] > f_min_hz]
    peaks = sorted(peaks, key=lambda i: -F[i])[:k]
    top = max(F[i] for i in peaks) if peaks else 1.0
    return [(float(fr[i]), float(F[i] / top)) for i in sorted(peaks)]


def kink_returns(rigid, rhoA_kg_per_m):
    """The kink's first and second return to the hook [s] with the rigid level's histories and the
    run's ``rhoA`` (:func:`jaxcable.arresting.layout.kink_return_times`; module docstring)."""
    layout = ArrestingLayout(rhoA_kg_per_m=rhoA_kg_per_m)
    return kink_return_times(layout, rigid["_ts"], rigid["_sigma_pa"], rigid["_drop_m"])


def one_run(label, level, kw, buffer, t_end):
    t0 = time.perf_counter()
    run = run_landing(level, buffer=buffer, t_end_s=t_end, **kw)
    o = run.outputs
    ts = np.asarray(run.ts)
    finite = np.isfinite(ts)
    a_z = np.asarray(run.probes["acceleration_m_s2"])[finite, 2] / G
    return {
        "label": label, "level": level, "z_max_m": o["z_max_m"], "a_max_g": o["a_max_g"], "a_max_raw_g": o["a_max_raw_g"],
        "sigma_max_mpa": o["sigma_max_mpa"], "t_a_max_s": float(ts[finite][np.argmax(a_z)]),
        "stopped": bool(o["stopped"]), "stop_time_s": o.get("stop_time_s"), "steps": run.num_steps,
        "status": run.solver_status, "wall_s": time.perf_counter() - t0,
        "_ts": ts[finite], "_a_z": a_z, "_sigma_pa": np.asarray(run.probes["stress_max_pa"])[finite],
        "_drop_m": np.asarray(run.probes["drop_m"])[finite],
        "rhoA_kg_per_m": float(kw.get("layout", ArrestingLayout()).rhoA_kg_per_m),
    }  # fmt: skip


def compare_with_rigid(row, rigid):
    """RMS of ``a_z - a_z(rigid)`` over the stroke (0.02 s to the rigid level's stop) and its
    strongest frequencies."""
    ts, a = row["_ts"], row["_a_z"]
    n = min(len(ts), len(rigid["_ts"]))
    stop = rigid["stop_time_s"] if rigid["stop_time_s"] == rigid["stop_time_s"] else ts[n - 1]
    m = (ts[:n] >= 0.02) & (ts[:n] <= stop)
    d = a[:n][m] - rigid["_a_z"][:n][m]
    row["rms_vs_rigid_g"] = float(np.sqrt(np.mean(d**2)))
    row["kink_returns_s"] = kink_returns(rigid, row["rhoA_kg_per_m"]) if row["level"] != "rigid" and "massless" not in row["label"] else []
    row["peaks_vs_rigid_hz"] = spectrum_peaks(ts[:n][m], d) if m.sum() > 16 else []


def write_md(data, path):
    lines = ["# Where the centred capture's acceleration peak comes from", "", *_report.header(data), ""]
    lines += [
        f"Design case (centre, vertical, 20 m/s), {data['t_end_s']:g} s, each level's default solver and mesh,",
        (f"cable damping beta = {data['beta_s']:g} s (calibrated) unless the row says otherwise. a_max: CFC 60 "
        "(the criterion); the difference to the rigid level is taken on a_z over the stroke."),
        "",
    ]
    for name, rows in data["buffers"].items():
        lines += [(f"## Buffer {name}: m_w = {data['buffer_values'][name][0]:.1f} kg, F_f = "
                  f"{data['buffer_values'][name][1]:.4g} N"), "",
                  ("| run | z_max [m] | a_max [g] | a raw [g] | at t [s] | sigma_max [MPa] | RMS a_z - rigid [g] | "
                  "strongest frequencies of the difference [Hz] | kink returns [s] | steps | time [s] |"),
                  "|---|---:|---:|---:|---:|---:|---:|---|---|---:|---:|"]  # fmt: skip
        for r in rows:
            peaks = ", ".join(f"{f:.0f}" for f, _ in r.get("peaks_vs_rigid_hz", []))
            rms = f"{r['rms_vs_rigid_g']:.2f}" if "rms_vs_rigid_g" in r else ""
            kinks = ", ".join(f"{t:.3f}" for t in r.get("kink_returns_s", []))
            lines.append(
                f"| {r['label']} | {r['z_max_m']:.3f} | {r['a_max_g']:.2f} | {r['a_max_raw_g']:.2f} | "
                f"{r['t_a_max_s']:.3f} | {r['sigma_max_mpa']:.1f} | {rms} | {peaks} | {kinks} | {r['steps']} | "
                f"{r['wall_s']:.0f} |"
            )
        lines.append("")
    lines += [f"![a_z histories]({STEM}.png)"]
    _report.write_lines(path, lines)


def plot(data, histories, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(histories)
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 3.2 * len(names)), squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        for label, ts, a in histories[name]:
            ax.plot(ts, a, lw=1.0, label=label)
        ax.set_ylabel("a_z [g]")
        ax.set_title(f"design case, buffer {name}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--buffers", nargs="+", default=list(BUFFERS), choices=list(BUFFERS))
    p.add_argument("--t-end", type=float, default=1.0, help="simulated time [s] (default 1.0)")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", default=None)
    args = p.parse_args()
    if args.quick:
        args.buffers, args.t_end = ["eq19"], 0.6
    enable_x64()  # before the report records the precision (run_landing enables it too)
    out = _report.output_dir(args.out, args.quick)
    data = _report.start(t_end_s=args.t_end, beta_s=float(DEFAULT_CABLE_DAMPING_S), buffers={}, buffer_values={})
    histories = {}
    for i, name in enumerate(args.buffers):
        buffer = BUFFERS[name]()
        data["buffer_values"][name] = (float(buffer.counterweight_mass_kg), float(buffer.brake_force_N))
        runs = list(LADDER) + (list(variants()) if i == 0 and not args.quick else [])
        rows, histories[name] = [], []
        for label, level, kw in runs:
            row = one_run(label, level, kw, buffer, args.t_end)
            if rows:
                compare_with_rigid(row, rows[0])
            rows.append(row)
            if label in {lbl: 0 for lbl, _, _ in LADDER}:
                histories[name].append((label, row["_ts"], row["_a_z"]))
            data["buffers"][name] = [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows]
            print(name, data["buffers"][name][-1], flush=True)
            _report.save(data, out, STEM)
    plot(data, histories, out / f"{STEM}.png")
    _report.finish(data, out, STEM, write_md)


if __name__ == "__main__":
    main()
