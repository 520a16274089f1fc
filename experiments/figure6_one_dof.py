"""Fig 6 of the arresting-cable paper (section II.B) and the Table 1 design against eq. (15).

The rigid-cable 1-DOF model (:mod:`jaxcable.arresting.one_dof`):

(1) Fig 6: the peak deceleration ``|z_bar''|_max`` (eq. 20) and the peak leg tension ``T_bar_max``
    (eq. 23) over the stroke against the counterweight group ``m_t_bar``, at the friction group
    ``F_t_bar`` that stops the rocket at z_m = 10 m (eq. 19), with the bounds of eqs. (21) and (24)
    found by bisection on the curves (``m_t_bar_bounds``; the paper reads 1.55 and 10.2 off the
    plot). Each point is :func:`~jaxcable.arresting.one_dof.stroke_peaks`, vmapped over m_t_bar.
(2) Table 1 against eq. (15): the paper's design (m_t_bar = 2, eq. 19: ``paper_design()``) and
    Table 1's printed buffer (m_w = 0.92 t, F_f = 3.13e5 N, which is m_t_bar = 1.325) landed by
    :func:`~jaxcable.arresting.one_dof.simulate_one_dof`: z_max, a_max (units of 9.80 m/s^2), the
    load factor and sigma_max, and each design's groups (m_t_bar, F_t_bar).

Writes ``figure6_one_dof.{json,md,png}`` (machine, JAX version, precision) into
``experiments/results/``. Usage:
    python experiments/figure6_one_dof.py              # a few seconds
    python experiments/figure6_one_dof.py --out DIR
"""

from __future__ import annotations

import argparse

import _report
import jax
import jax.numpy as jnp

import jaxcable
from jaxcable.arresting.one_dof import (
    PAPER_ALPHA,
    PAPER_L0,
    PAPER_M_T_BAR,
    PAPER_ROCKET_MASS,
    PAPER_V0,
    DesignCriteria,
    OneDofParams,
    allowed_tension_bar,
    friction_group_for_stop,
    m_t_bar_bounds,
    paper_design,
    params_groups,
    simulate_one_dof,
    stroke_peaks,
    v0_bar,
)

STEM = "figure6_one_dof"
TABLE1_M_W = 920.0
"""Table 1's counterweight, one of four [kg]."""
TABLE1_F_F = 3.13e5
"""Table 1's brake force, one of four [N]."""


def table1_design(g=9.81) -> OneDofParams:
    """Table 1 as printed: m_w = 0.92 t, F_f = 3.13e5 N (m_t_bar = 1.325, not 2; see the module
    docstring of :mod:`jaxcable.arresting.one_dof`); the rest as :func:`paper_design`."""
    return OneDofParams(
        m_r=PAPER_ROCKET_MASS,
        v0=PAPER_V0,
        l_0=PAPER_L0,
        alpha=PAPER_ALPHA,
        m_w=TABLE1_M_W,
        F_f=TABLE1_F_F,
        g=g,
        cable_radius=0.02,
    )


def fig6_curves(m_t_bars, F_t_bar, v0_bar_value, n_theta: int = 2001):
    """Fig 6: ``|z_bar''|_max`` and ``T_bar_max`` for each m_t_bar; shapes (n,) -> (n,), (n,)."""
    peaks = jax.vmap(stroke_peaks, in_axes=(0, None, None, None))
    return peaks(jnp.asarray(m_t_bars, float), jnp.asarray(F_t_bar, float), jnp.asarray(v0_bar_value, float), n_theta)


def fig6_data(params: OneDofParams | None = None, criteria: DesignCriteria | None = None, m_t_bars=None) -> dict:
    """The curves and bounds of Fig 6: F_t_bar fixed by eq. (19) from ``criteria.z_m``; v0_bar and
    T_bar_m from ``params`` (default: ``paper_design()``)."""
    params = paper_design() if params is None else params
    criteria = DesignCriteria() if criteria is None else criteria
    m_t_bars = jnp.linspace(0.0, 16.0, 321) if m_t_bars is None else jnp.asarray(m_t_bars)
    vb = v0_bar(params.v0, params.l_0, params.g)
    F_t_bar = friction_group_for_stop(vb, criteria.z_m / params.l_0)
    T_m_bar = allowed_tension_bar(criteria.sigma_m, params.cable_radius, params.m_r, params.g)
    acc, ten = fig6_curves(m_t_bars, F_t_bar, vb)
    lower, upper = m_t_bar_bounds(F_t_bar, vb, criteria.a_m_bar, T_m_bar)
    return dict(
        m_t_bar=[float(x) for x in m_t_bars], accel_max_bar=[float(x) for x in acc],
        tension_max_bar=[float(x) for x in ten], v0_bar=float(vb), F_t_bar=float(F_t_bar),
        a_m_bar=float(criteria.a_m_bar), T_m_bar=float(T_m_bar), lower=float(lower), upper=float(upper),
    )  # fmt: skip


def plot_fig6(path, fig6: dict):
    """Write Fig 6 (|z_bar''|_max and T_bar_max versus m_t_bar) as a PNG at ``path`` (the Agg canvas
    directly: no pyplot state). Returns ``path``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.0, 4.0), dpi=150)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot(fig6["m_t_bar"], fig6["accel_max_bar"], "r-", label=r"$|\bar z''|_{\max}$ (eq. 20)")
    ax.plot(fig6["m_t_bar"], fig6["tension_max_bar"], "b--", label=r"$\bar T_{\max}$ (eq. 23)")
    ax.axhline(fig6["a_m_bar"], color="r", lw=0.7, ls=":")
    ax.axhline(fig6["T_m_bar"], color="b", lw=0.7, ls=":")
    ax.axvline(fig6["lower"], color="k", lw=0.7, ls=":")
    ax.axvline(fig6["upper"], color="k", lw=0.7, ls=":")
    ax.axvline(PAPER_M_T_BAR, color="0.5", lw=0.7)
    ax.set_xlabel(r"$\bar m_t$")
    ax.set_ylabel("dimensionless peak")
    ax.set_title(
        rf"$\bar F_t$ = {fig6['F_t_bar']:.3f}; bounds {fig6['lower']:.3f} $\leq \bar m_t \leq$ {fig6['upper']:.3f}",
        fontsize=9,
    )
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    return path


def land(params: OneDofParams) -> dict:
    """One design landed by the 1-DOF model: its groups and criteria."""
    m_t_bar, F_t_bar, _ = params_groups(params)
    sol = simulate_one_dof(params)
    return dict(
        m_w_kg=float(params.m_w), F_f_N=float(params.F_f), m_t_bar=float(m_t_bar), F_t_bar=float(F_t_bar),
        z_max_m=float(sol.z_max), a_max_g=float(sol.a_max), load_factor_max=float(sol.load_factor_max),
        sigma_max_mpa=float(sol.sigma_max), t_stop_s=float(sol.t_stop), stopped=bool(sol.stopped),
        energy_error=float(sol.energy_error),
    )  # fmt: skip


def write_md(data, path):
    f6 = data["fig6"]
    lines = [
        "# Fig 6 and Table 1 of the arresting-cable paper (rigid-cable 1-DOF model, section II.B)",
        "",
        *_report.header(data),
        "",
        "## Fig 6",
        "",
        f"v0_bar = {f6['v0_bar']:.4f}, F_t_bar = {f6['F_t_bar']:.4f} (eq. 19, stop at 10 m), a_m_bar = "
        f"{f6['a_m_bar']:g}, T_m_bar = {f6['T_m_bar']:.4f} (800 MPa on a 20 mm cable). Bounds on m_t_bar by "
        "bisection on the curves:",
        "",
        "| bound | ours | paper |",
        "|---|---:|---:|",
        f"| eq. 21 (deceleration), lower | {f6['lower']:.4f} | 1.55 |",
        f"| eq. 24 (tension), upper | {f6['upper']:.4f} | 10.2 |",
        "",
        f"Plot: `{STEM}.png`.",
        "",
        "## Table 1 against eq. (15)",
        "",
        "| design | m_w [kg] | F_f [N] | m_t_bar | F_t_bar | z_max [m] | a_max [g] | load factor | sigma_max [MPa] | stop [s] |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, r in data["designs"].items():
        lines.append(
            f"| {name} | {r['m_w_kg']:.1f} | {r['F_f_N']:.4g} | {r['m_t_bar']:.4f} | {r['F_t_bar']:.4f} | {r['z_max_m']:.3f} | "
            f"{r['a_max_g']:.3f} | {r['load_factor_max']:.3f} | {r['sigma_max_mpa']:.1f} | {r['t_stop_s']:.3f} |"
        )
    lines += [
        "",
        "a_max and the load factor in units of 9.80 m/s^2 (the paper's success criteria); the dynamics use g = 9.81. "
        "Table 1's counterweight is m_t_bar = 1.325, below the eq. 21 bound: it exceeds a_m_bar = 4 (5 g load).",
    ]
    _report.write_lines(path, lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", help="report folder (default experiments/results)")
    args = p.parse_args(argv)
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start(precision=_report.precision())
    data["fig6"] = fig6_data()
    data["designs"] = {"eq. 15, m_t_bar = 2 (paper_design)": land(paper_design()), "Table 1": land(table1_design())}
    data["plot"] = plot_fig6(out / f"{STEM}.png", data["fig6"]).name
    _report.finish(data, out, STEM, write_md)


if __name__ == "__main__":
    main()
