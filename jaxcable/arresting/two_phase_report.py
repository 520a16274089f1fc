"""Reports of a two-phase landing (:func:`jaxcable.arresting.two_phase.run_two_phase`): the JSON
summary of ``jaxcable land --phase full --json`` and a PNG like the paper's Figs 13-14 (arresting-cable
paper, section IV.A). Re-exported by :mod:`jaxcable.arresting.two_phase`.

``landed`` is the two-phase success: captured, tracking error at capture within tolerance, and the
passive phase's ``criteria_met`` (solve succeeded, stopped, z_max, a_max and sigma_max within limits,
a_max and sigma_max after the CFC 60 filter); ``unmet`` lists in words what kept a run from it.
"""

from __future__ import annotations

import numpy as np

from jaxcable.arresting.landing import CRITERIA_KEYS, unmet_conditions
from jaxcable.arresting.passive import G_CRITERIA
from jaxcable.core.simulate import status_message

__all__ = ["plot_two_phase", "report_two_phase"]


def report_two_phase(run) -> dict:
    """The JSON-able summary of a two-phase run ``run``, a
    :class:`~jaxcable.arresting.two_phase.TwoPhaseRun` (``jaxcable land --phase full --json``)."""
    o = run.outputs
    out = {
        k: o[k]
        for k in (
            "captured",
            "landed",
            "capture_margin_m",
            "capture_margins_m",
            "tracking_error_m",
            "tracking_error_at_capture_m",
            "capture_time_s",
            "captured_state",
            "frame_centre_at_capture_m",
            "tracking_ok",
            *CRITERIA_KEYS,
        )
    }
    for k, v in list(out.items()):
        if isinstance(v, float) and not np.isfinite(v):
            out[k] = None
    out["criteria_met"] = bool(o["criteria_met"]) and bool(o["captured"])
    out["passive_criteria_met"] = bool(o["criteria_met"])
    out["tracking_solver_status"] = status_message(o["tracking_status"])
    out["tracking_steps"] = int(o["tracking_steps"])
    out["solver_status"] = status_message(o["passive_status"])
    out["num_steps"] = int(o["passive_steps"])
    out["filter_cfc_hz"] = float(run.criteria.filter_cfc_hz)
    out["fidelity"] = run.fidelity
    out["scenario"] = run.scenario
    out["phase"] = "full"
    why = [] if o["captured"] else ["not captured"]
    why += [] if o["tracking_ok"] else ["tracking error at capture over the tolerance"]
    out["unmet"] = why + unmet_conditions(dict(o, solver_status=out["solver_status"]))
    return out


def plot_two_phase(run, path: str):
    """A PNG at ``path`` like the paper's Figs 13-14 of ``run`` (a
    :class:`~jaxcable.arresting.two_phase.TwoPhaseRun`): tracking error, frame centre and target,
    reel-out speeds, then the passive phase's drop, acceleration, cable stress and hook contact forces."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr, pa = run.tracking, run.passive
    ts = np.asarray(tr.ts)
    ok = np.isfinite(ts)
    p = {k: np.asarray(v) for k, v in tr.probes.items()}
    tp = np.asarray(pa.ts)
    okp = np.isfinite(tp)
    q = {k: np.asarray(v) for k, v in pa.probes.items() if k != "energy"}
    t_cap = run.outputs["capture_time_s"]
    fig, ax = plt.subplots(4, 2, figsize=(11, 11))
    ax = ax.ravel()
    ax[0].plot(ts[ok], p["tracking_error_m"][ok], label="|frame centre - measured target|")
    ax[0].plot(ts[ok], p["true_tracking_error_m"][ok], "--", label="|frame centre - true target|")
    ax[0].set_yscale("log")
    ax[0].set_ylabel("tracking error [m]")
    ax[0].legend(fontsize=7)
    for i, lab in enumerate("xy"):
        ax[1].plot(ts[ok], p["frame_centre_xy_m"][ok, i], label=f"frame centre {lab}")
        ax[1].plot(ts[ok], p["target_xy_m"][ok, i], ":", label=f"target {lab}")
    ax[1].set_ylabel("position [m]")
    ax[1].legend(fontsize=7)
    ax[2].plot(ts[ok], p["reelout_speed_m_s"][ok])
    ax[2].set_ylabel("reel-out speed v_p [m/s]")
    ax[3].plot(ts[ok], p["throat_height_m"][ok])
    ax[3].set_ylabel("hook throat height [m]")
    for a in ax[:4]:
        a.set_xlabel("time since terminal guidance [s]")
    ax[4].plot(tp[okp] + t_cap, q["drop_m"][okp])
    ax[4].axhline(10.0, color="r", ls=":", lw=1)
    ax[4].set_ylabel("drop z [m]")
    ax[5].plot(tp[okp] + t_cap, np.linalg.norm(q["acceleration_m_s2"][okp], axis=1) / G_CRITERIA)
    ax[5].axhline(5.0, color="r", ls=":", lw=1)
    ax[5].set_ylabel("|acceleration| [g]")
    ax[6].plot(tp[okp] + t_cap, q["stress_max_pa"][okp] / 1e6)
    ax[6].axhline(800.0, color="r", ls=":", lw=1)
    ax[6].set_ylabel("max cable stress [MPa]")
    ax[7].plot(tp[okp] + t_cap, q["hook_normal_force_N"][okp] / 1e3)
    ax[7].set_ylabel("hook-cable force [kN]")
    for a in ax[4:]:
        a.set_xlabel("time [s]")
    o = run.outputs
    fig.suptitle(
        f"two-phase landing, scenario {run.scenario}, passive fidelity {run.fidelity}: captured {o['captured']}, "
        f"z_max {o['z_max_m']:.2f} m, a_max {o['a_max_g']:.2f} g, sigma_max {o['sigma_max_mpa']:.0f} MPa",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
