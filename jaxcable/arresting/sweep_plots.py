"""Plots of the arresting-cable QMC sweep (paper section IV): Figs 15-17 (trajectories and tracking
errors of a two-phase sweep), Figs 18-20 (passive-phase histories), Fig 21 (criteria over the landing
plane). Each writes a PNG with matplotlib (Agg) and returns its path; lengths in m, times in s,
accelerations in g, stresses in MPa."""

from __future__ import annotations

import numpy as np

from jaxcable.arresting.passive import LandingCriteria
from jaxcable.arresting.sweep import CAPTURED_PREFIX, CRITERIA

__all__ = ["plot_histories", "plot_landing_plane", "plot_tracking"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_landing_plane(table: dict, path, title: str = "", criteria: LandingCriteria = LandingCriteria()):
    """Like Fig 21: (a) capture positions with lateral-velocity (red) and inclination (green) arrows;
    (b-d) z_max, a_max, sigma_max over the landing plane (x, y coloured by the criterion; failed
    cases as black crosses, cases whose hooks missed the cables ringed in red). The capture state is
    the sweep's input in a passive sweep and the state at capture (``captured_*`` columns) in a
    two-phase sweep."""
    plt = _plt()
    pre = CAPTURED_PREFIX if CAPTURED_PREFIX + "x_m" in table else ""
    col = lambda name: np.asarray(table[pre + name], float)  # noqa: E731
    x, y = col("x_m"), col("y_m")
    failed = np.asarray(table["failed"], bool)
    missed = ~np.asarray(table["captured"], bool) & ~failed
    fig, axes = plt.subplots(2, 2, figsize=(11, 9.5))
    ax = axes[0, 0]
    ax.scatter(x, y, s=10, c="k")
    ax.quiver(x, y, col("vx_m_s"), col("vy_m_s"), color="r", angles="xy", scale_units="xy", scale=0.5, width=0.003, label="v_xy (1 m/s = 2 m)")
    ax.quiver(x, y, col("theta_y_deg"), -col("theta_x_deg"), color="g", angles="xy", scale_units="xy", scale=4.0, width=0.003, label="tilt direction (4 deg = 1 m)")
    ax.set_title("a) states at capture", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    for ax, letter, (name, _, _, limit_field, unit) in zip(axes.flat[1:], "bcd", CRITERIA):
        v = np.asarray(table[name], float)
        sc = ax.scatter(x[~failed], y[~failed], c=v[~failed], s=30, cmap="viridis")
        if failed.any():
            ax.scatter(x[failed], y[failed], marker="x", c="k", s=30, label="failed")
        if missed.any():
            ax.scatter(x[missed], y[missed], s=90, facecolors="none", edgecolors="r", label="hooks missed")
        if failed.any() or missed.any():
            ax.legend(fontsize=7)
        fig.colorbar(sc, ax=ax, label=f"{name} [{unit}] (limit {getattr(criteria, limit_field):g})")
        ax.set_title(f"{letter}) {name}", fontsize=10)
    for ax in axes.flat:
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal", adjustable="datalim")
    fig.suptitle(title or "criteria over the landing plane", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


def plot_histories(histories: dict, path, title: str = "", criteria: LandingCriteria = LandingCriteria()):
    """Like Figs 18-20: drop, acceleration and max cable stress against time, one line per case."""
    plt = _plt()
    ts = np.asarray(histories["ts"])
    fig, axes = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    panels = (
        ("drop_m", "buffering distance [m]", criteria.z_max_m),
        ("acceleration_g", "acceleration [g]", criteria.a_max_g),
        ("stress_max_mpa", "max cable stress [MPa]", criteria.sigma_max_mpa),
    )
    for ax, (key, label, limit) in zip(axes, panels):
        for t, v in zip(ts, np.asarray(histories[key])):
            ax.plot(t, v, lw=0.6, alpha=0.7)
        ax.axhline(limit, color="r", ls=":", lw=1)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("time since capture [s]")
    fig.suptitle(title or f"{ts.shape[0]} cases", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)


def plot_tracking(histories: dict, path, title: str = "", tracking_time_s: float | None = None, tolerance_m: float = 1.0):
    """Like Figs 15-17 (two-phase sweeps, :meth:`TwoPhaseCaseFunction.histories`): (a) the
    trajectories of O from the terminal-guidance point (black) to capture (red; open red ring: the
    hooks missed the cables), (b) the tracking error |frame centre - measured target| against
    time, one line per case, with ``t_c / 2`` (when given) and the tracking tolerance."""
    plt = _plt()
    ts = np.asarray(histories["tracking_ts"], float)
    pos = np.asarray(histories["o_position_m"], float)
    cap = np.asarray(histories["captured_position_m"], float)
    captured = np.asarray(histories["captured"], bool)
    err = np.asarray(histories["tracking_error_m"], float)
    fig = plt.figure(figsize=(13, 5.8))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    for p in pos:
        ok = np.isfinite(p[:, 0])
        ax.plot(p[ok, 0], p[ok, 1], p[ok, 2], lw=0.6, alpha=0.6)
    ax.scatter(pos[:, 0, 0], pos[:, 0, 1], pos[:, 0, 2], c="k", s=8, label="terminal-guidance point")
    ax.scatter(cap[captured, 0], cap[captured, 1], cap[captured, 2], c="r", s=8, label="captured")
    if (~captured).any():
        ax.scatter(cap[~captured, 0], cap[~captured, 1], cap[~captured, 2], s=40, facecolors="none", edgecolors="r", label="hooks missed")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title("a) trajectories of O to the capture plane", fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    ax = fig.add_subplot(1, 2, 2)
    for t, e in zip(ts, err):
        ok = np.isfinite(t) & (e > 0)
        ax.plot(t[ok], e[ok], lw=0.6, alpha=0.7)
    ax.set_yscale("log")
    if tracking_time_s is not None:
        ax.axvline(0.5 * tracking_time_s, color="k", ls="--", lw=1, label="t_c / 2")
    ax.axhline(tolerance_m, color="r", ls=":", lw=1, label=f"tracking tolerance {tolerance_m:g} m")
    ax.set_xlabel("time since terminal guidance [s]")
    ax.set_ylabel("tracking error |frame centre - target| [m]")
    ax.set_title("b) tracking errors", fontsize=10)
    ax.legend(fontsize=7)
    fig.suptitle(title or f"{ts.shape[0]} cases", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)
