"""Plots people would rather look at than read (matplotlib, Agg backend; PNG files)."""

from __future__ import annotations

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_flight(result, path, title="line-throwing rocket"):
    """Trajectory with rope shapes, speed and rope pull of one flight (a :class:`Result`)."""
    plt = _plt()
    ts = np.asarray(result.ts)
    tf = float(result.t_final)
    ok = ts <= tf
    p = result.probes
    pos = np.asarray(p.position)[ok]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    ax = axes[0]
    ax.plot(pos[:, 0], pos[:, 1], "k-", lw=1.5, label="rocket")
    for ts_, shape in zip(np.asarray(result.snapshot_ts), np.asarray(result.snapshots)):
        if np.isfinite(ts_) and ts_ <= tf:
            ax.plot(shape[:, 0], shape[:, 1], lw=0.8, label=f"rope at {ts_:g} s")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title)
    ax.legend(fontsize=7)
    ax.set_aspect("auto")
    axes[1].plot(ts[ok], np.asarray(p.speed)[ok])
    axes[1].set_xlabel("t [s]")
    axes[1].set_ylabel("rocket speed [m/s]")
    axes[1].grid(alpha=0.3)
    axes[2].plot(ts[ok], np.asarray(p.rope_pull)[ok] / 1e3)
    axes[2].set_xlabel("t [s]")
    axes[2].set_ylabel("rope pull on rocket [kN]")
    axes[2].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
