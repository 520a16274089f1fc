"""One passive-deceleration landing at any fidelity level: run it, report the shared outputs.

:func:`run_landing` is the entry point the command line (``jaxcable land``) and the experiments use.
The ``1dof`` level runs :func:`jaxcable.arresting.one_dof.simulate_one_dof` (vertical central
landing only); the other levels build :func:`passive_landing_scene` and integrate it with
:func:`jaxcable.core.simulate`. Default solver settings per level are in ``LEVEL_DEFAULTS`` with the
measurement behind each (``experiments/bench_land.py``).
"""

from __future__ import annotations

import dataclasses

import diffrax
import equinox as eqx
import jax
import numpy as np

from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import RosenbrockW
from jaxcable.core.simulate import check_solver_arguments, simulate
from jaxcable.core.validation import check_bool, check_choice, check_instance
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing_rocket import rigid_landing_rocket
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.one_dof import OneDofParams, simulate_one_dof
from jaxcable.arresting.passive import (
    DEFAULT_CABLE_DAMPING_S,
    FIDELITY_LEVELS,
    G_CRITERIA,
    SAVE_SPACING_S,
    LandingCriteria,
    check_t_end,
    criteria_met,
    filtered_maxima,
    hook_contact_at,
    landing_outputs,
    passive_landing_scene,
)

__all__ = ["LEVEL_DEFAULTS", "LEVEL_STEP_CONTROL", "STIFF_DAMPING_S", "STIFF_LEVEL_DEFAULTS", "level_solver_settings", "CRITERIA_KEYS", "REPORT_KEYS", "LandingRun", "report_landing", "run_landing", "unmet_conditions"]

LEVEL_DEFAULTS = {
    # level: (solver, rtol, atol, max_steps). Chosen from the work-precision study
    # (docs/work_precision.md; reference Dopri8 1e-10): every level's step is held by stability,
    # not accuracy, so tightening costs little. rigid at 1e-6: 2e-7 error for 1.2x the cost of 1e-4;
    # ale/full at 1e-5: 5e-5 / 1e-6 error, at the a_max rounding sensitivity (2e-5), 1e-6 costs
    # 1.18x more. Implicit Kvaerno3/5 are 100-1000x slower on these scenes.
    # ale/full use Bosh3 at 1e-4 (docs/notes/contact_slip.md). Their steps are set by stability (the fine elements'
    # axial modes, the contact's stick creep), where a 3-stage solver covers more time per
    # evaluation than Tsit5's 6, except after the rocket stops, where they are set by accuracy.
    # Against Tsit5 at 1e-7, every output (z_max, a_max, sigma_max, stop time) is within 2.4e-4 of
    # the reference (the design case and the two-phase case of IV.A; the energy budget within 2e-5).
    # That is 20-200x below the mesh's 4-5% and the friction regularisation's 1.25%. Full design
    # case 20.4 -> 5.5 s, two-phase full 16.2 -> 6.4 s (docs/notes/contact_slip.md). Pass rtol/atol for tighter runs, and for stiffened
    # variants: with 1000x stiffer, damped (beta 1e-2 s) cables, 1e-4 errs by 2.0% in sigma_max
    # (1e-5: 0.2%; tests/arresting/test_passive.py, the full level's 1-DOF limit).
    # ale/full: these settings serve only the capsule contact below STIFF_DAMPING_S; with the hook
    # as a sliding node (the default) the levels run STIFF_LEVEL_DEFAULTS at every damping.
    "rigid": ("tsit5", 1e-6, 1e-6, 200_000),
    "ale": ("bosh3", 1e-4, 1e-4, 400_000),
    "full": ("bosh3", 1e-4, 1e-4, 400_000),
}

STIFF_DAMPING_S = {"ale": 5e-4, "full": 1e-3}
"""With the capsule hook contact (``hook_contact="capsule"``, a former default): the cable damping
beta [s] per level from which the ale and full levels run the W-method by default
(``STIFF_LEVEL_DEFAULTS``). With the hook as a sliding node (the scenes' default) they run it at
every beta: there Bosh3's step is 4-5e-6 s already at beta = 1e-5 s (the capsule's on 32 span
elements: 4e-5 s) and shrinks with beta like the capsule's, and on the design
case at beta = 1e-5 s on the default mesh Bosh3 took 69,643 steps for the first 0.3 s at the ale
level (5.8x the time of rosw at 1e-5, 10x that of the level's default rtol 3e-5) and had covered
0.50 s in 100,000 steps at the full level (about 6x the time of rosw at 1e-5 for the whole second at
its pace); ``experiments/bench_stiff.py --default-model``, ``experiments/results/bench_stiff_{ale,full_1s}_default.md``,
docs/stiff_integrator.md. The measurements of the capsule's crossover: Explicit steps shrink with beta (stability: ``dt <= (2/omega)(sqrt(1 +
zeta^2) - zeta)``, ``zeta = beta omega / 2``); the W-method treats the cables' elasticity and
damping, the contact on the cable nodes and the hooks' hinges implicitly
(:mod:`jaxcable.arresting.stiff`), so its steps are set by accuracy. Measured on the design case,
first 0.2 s (``experiments/bench_stiff.py``, docs/stiff_integrator.md; 2-core AMD EPYC, JAX 0.10.2
CPU, float64), Bosh3 at 1e-4 against rosw at 1e-5 (steps):

* ale: beta 1e-5 s 0.64 s (2053) / 4.4 s (5663); 1e-4 s 1.03 s (3549) / 4.2 s (5554); 1e-3 s
  11.6 s (40895) / 4.5 s (5838); 1e-2 s 115 s (407278) / 5.3 s (6747);
* full: beta 1e-5 s 0.94 s (2035) / 18.3 s (9958); 1e-3 s 16.5 s (40900) / 17.9 s (9916); 1e-2 s
  see docs/stiff_integrator.md.

Bosh3's steps grow about linearly with beta, the W-method's stay near 6000 (ale) and 10000 (full)
per 0.2 s with the hooks held fixed in its ``J``, so they cross near 5e-4 s (ale) and 1e-3 s (full).
With the cable rows' columns on the rocket in ``J`` (:class:`.stiff.HookCoupling`) the W-method takes
2,809 / 2,382 steps (ale, beta 1e-5 / 1e-2 s; 3.8 / 2.9 s) and 2,676 / 2,255 (full; 8.6 / 9.2 s),
against Bosh3's 0.87 / 117 s (ale) and 1.2 / 214 s (full), measured side by side under load 2-4
(``experiments/results/bench_stiff_coupling.md``): the crossover stays between 1e-4 and 1e-3 s."""

STIFF_LEVEL_DEFAULTS = {
    # level: (solver, rtol, atol, max_steps) when cable_damping_s >= STIFF_DAMPING_S. rtol 1e-5:
    # with the hooks in J, rosw at 1e-4 errs by 2-4e-4 in the criteria and up to 3e-4 in the energy
    # budget (full), at 1e-5 by 2e-6 to 5e-5 and 1.5e-6 to 2.7e-5 (the budget goal: 1e-4;
    # the reference: rosw at 1e-7; experiments/results/bench_stiff_coupling.md).
    # ale at 3e-5, on its own mesh (passive.LEVEL_CABLE_MESH: 80 span elements, 16 fine): the design
    # case (1 s) and IV.A's (1.2 s) read every criterion within 3e-4 of rtol 1e-6 and close the
    # energy budget to 8.1e-6 / 1.8e-6, in 0.69x / 0.73x the steps of 1e-5; at 1e-4 within 1.3e-3,
    # budget 3.9e-5 / 8.2e-6, 0.45x / 0.55x the steps: too near the budget's check for a default
    # (experiments/convergence_landing.py --levels ale --variants rtol_x3 rtol_x10 --tag _ale80;
    # docs/arresting_validation.md, "The ale level's own mesh"). full at 3e-5 by the same rule, on its
    # mesh (80 span elements, 16 fine): the design case (1 s) and IV.A's (1.2 s) read every criterion
    # within 2.8e-4 / 3e-5 of rtol 1e-6 and close the energy budget to 2.2e-5 / 7.2e-6, in 0.68x /
    # 0.72x the steps of 1e-5 (5,990 / 9,045); at 1e-4 within 6.4e-4, budget 8.6e-5 on the design
    # case, near the check (experiments/convergence_landing.py --levels full --variants default
    # rtol_x3 rtol_x10 --tag _full80; docs/arresting_validation.md, "Convergence").
    "ale": ("rosw", 3e-5, 3e-5, 400_000),
    "full": ("rosw", 3e-5, 3e-5, 400_000),
}


def level_solver_settings(fidelity: str, cable_damping_s=None, hook_contact: str | None = None):
    """``(solver, rtol, atol, max_steps)`` of a level: ``STIFF_LEVEL_DEFAULTS`` for the ale and
    full levels with the hook as a sliding node (``hook_contact`` None, the default, or ``"node"``)
    at any damping, and with the capsule contact (``"capsule"``) from cable damping
    ``cable_damping_s >= STIFF_DAMPING_S[level]`` [s]; else ``LEVEL_DEFAULTS``. ``None`` is the scenes' default damping (:data:`.passive.DEFAULT_CABLE_DAMPING_S`,
    calibrated: the W-method at ale and full). A traced damping (a design, a vmapped batch) takes
    the W-method at ale and full too: it runs at any beta, where an explicit solver would stall
    at its stability limit on stiffly damped cables."""
    if fidelity not in STIFF_LEVEL_DEFAULTS:
        return LEVEL_DEFAULTS[fidelity]
    if hook_contact_at(hook_contact, "ale") != "capsule":
        return STIFF_LEVEL_DEFAULTS[fidelity]
    if isinstance(cable_damping_s, jax.core.Tracer):
        return STIFF_LEVEL_DEFAULTS[fidelity]
    beta = np.asarray(DEFAULT_CABLE_DAMPING_S if cable_damping_s is None else cable_damping_s)
    if beta.size and float(np.min(beta)) >= STIFF_DAMPING_S[fidelity]:
        return STIFF_LEVEL_DEFAULTS[fidelity]
    return LEVEL_DEFAULTS[fidelity]


def batched_solver(solver):
    """The solver for a ``vmap``-ped batch of cases: ``"rosw"`` becomes ``RosenbrockW`` with its
    linearisation at every step (``jacobian_every=1``), any other solver is returned as given.
    Under ``vmap`` the W-method's choice between a fresh and a kept ``J`` is a select that computes
    both, so a batch pays the linearisation at every step anyway and gains only the fewer rejected
    steps of a fresh ``J``: 4 ale design cases vmapped (beta 4e-3 to 2e-2 s, 0.1 s, rtol 1e-5; 2-core
    CPU, float64) 16.1 s at ``jacobian_every`` 2 (the single runs' default), 12.1 s at 1 (1,526-1,709
    steps, 41-54 rejected, against 1,634-2,023 and 184-432)."""
    return RosenbrockW(jacobian_every=1) if isinstance(solver, str) and solver == "rosw" else solver


LEVEL_STEP_CONTROL = {
    # level: (pcoeff, icoeff) of the PID step-size controller. ale/full run at the solver's stability
    # limit (the fine elements' axial modes), where the classic I controller rejects ~25% of the
    # steps; a PI controller (0.4, 0.3) rejects ~5%: 1 s full design case 23.9k -> 19.9k attempted
    # steps, run 25.8 -> 21.1 s, outputs equal to 2e-5 (docs/work_precision.md, "Defaults: what the data say").
    "rigid": (0.0, 1.0),
    "ale": (0.4, 0.3),
    "full": (0.4, 0.3),
}


@dataclasses.dataclass
class LandingRun:
    """Outputs of one landing: ``outputs`` (dict of floats/bools), histories ``ts`` [s] and
    ``probes`` (dict of arrays), the fidelity level and the solver's report."""

    fidelity: str
    outputs: dict
    ts: np.ndarray
    probes: dict
    solver_status: str
    num_steps: int
    result: object = None
    criteria: LandingCriteria = dataclasses.field(default_factory=LandingCriteria)


def run_landing(
    fidelity: str = "full",
    capture: CaptureState | None = None,
    layout: ArrestingLayout | None = None,
    buffer: BufferDevice | None = None,
    *,
    t_end_s: float = 2.0,
    solver: str | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    max_steps: int | None = None,
    criteria: LandingCriteria = LandingCriteria(),
    progress: bool = False,
    **scene_kwargs,
) -> LandingRun:
    """Run one passive-deceleration case (default: the design case, Table 1) and report it.

    ``progress`` shows a progress bar of simulated time (the ale and full levels take 5-10 s per
    simulated second on a 2-core CPU after compiling).
    The run returns NumPy arrays and is not differentiated, so it integrates with diffrax's plain
    while loop (``diffrax.ForwardMode()``), not the checkpointed loop that reverse-mode AD needs
    (measured: 0-4% less time on the full level, within the timing noise). Differentiable runs:
    :func:`jaxcable.core.simulate` on :func:`passive_landing_scene`."""
    enable_x64()
    check_choice("fidelity", fidelity, FIDELITY_LEVELS)
    check_instance("capture", capture, CaptureState, allow_none=True)
    check_instance("layout", layout, ArrestingLayout, allow_none=True)
    check_instance("buffer", buffer, BufferDevice, allow_none=True)
    check_instance("criteria", criteria, LandingCriteria)
    check_t_end("t_end_s", t_end_s)
    check_solver_arguments(solver=solver, rtol=rtol, atol=atol, max_steps=max_steps)
    check_bool("progress", progress)
    capture = CaptureState() if capture is None else capture
    layout = ArrestingLayout() if layout is None else layout
    buffer = BufferDevice() if buffer is None else buffer
    if fidelity == "1dof":
        return _run_one_dof(capture, layout, buffer, t_end_s, criteria)

    scene = passive_landing_scene(fidelity, capture, layout, buffer, t_end_s=t_end_s, **scene_kwargs)
    d_solver, d_rtol, d_atol, d_steps = level_solver_settings(
        fidelity, scene_kwargs.get("cable_damping_s"), scene_kwargs.get("hook_contact")
    )
    pcoeff, icoeff = LEVEL_STEP_CONTROL[fidelity]
    result = simulate(
        scene,
        t_end_s,
        solver=solver or d_solver,
        rtol=rtol or d_rtol,
        atol=atol or (rtol or d_atol),
        max_steps=max_steps or d_steps,
        progress=progress,
        adjoint=diffrax.ForwardMode(),
        pcoeff=pcoeff,
        icoeff=icoeff,
    )
    outputs = result.outputs
    if criteria != LandingCriteria():  # the scene summarises with the default criteria
        outputs = _landing_outputs_jit(result.ts, result.probes, result.status, criteria)
    out = {k: np.asarray(v).item() for k, v in outputs.items() if k != "status"}
    out["solver_status"] = result.status_message
    out["num_steps"] = int(result.num_steps)
    probes = {k: np.asarray(v) for k, v in result.probes.items() if k != "energy"}
    probes["energy"] = {k: np.asarray(v) for k, v in result.probes["energy"].items()}
    out["energy_budget_J"] = _budget_at_end(np.asarray(result.ts), probes["energy"])
    return LandingRun(
        fidelity, out, np.asarray(result.ts), probes, result.status_message, out["num_steps"], result, criteria
    )


_landing_outputs_jit = eqx.filter_jit(landing_outputs)


def _budget_at_end(ts, energy):
    last = int(np.max(np.nonzero(np.isfinite(ts))[0]))
    return {k: float(v[last] - v[0]) for k, v in energy.items()}


def _run_one_dof(capture, layout, buffer, t_end_s, criteria):
    lateral = {
        k: float(getattr(capture, k))
        for k in ("x_m", "y_m", "vx_m_s", "vy_m_s", "theta_x_deg", "theta_y_deg", "omega_x_deg_s", "omega_y_deg_s")
        if float(getattr(capture, k)) != 0.0
    }
    if lateral:
        raise ValueError(
            f"fidelity '1dof' models the vertical central landing only; got nonzero {lateral}: "
            "use --fidelity rigid, ale or full"
        )

    params = OneDofParams(
        m_r=rigid_landing_rocket(hinged_hooks=False).total_mass_kg,  # same mass as the other levels
        v0=-float(capture.vz_m_s),
        l_0=layout.half_span_m,
        alpha=buffer.transfer_rate,
        m_w=buffer.counterweight_mass_kg,
        F_f=buffer.brake_force_N,
        cable_radius=layout.cable_radius_m,
    )
    # at least one sample per SAVE_SPACING_S up to the stop (the criteria's filter needs <= 1 ms)
    sol = simulate_one_dof(params, t1=t_end_s, n_save=round(t_end_s / SAVE_SPACING_S) + 1)
    ts, probes = _one_dof_record(sol, params, t_end_s)
    # before capture: the same acceleration (free fall: the 1-DOF z'' starts at g), cables unloaded
    before = dict(acceleration_m_s2=probes["acceleration_m_s2"][0], stress_max_pa=0.0)
    maxima = {k: float(v) for k, v in filtered_maxima(ts, probes, criteria.filter_cfc_hz, before).items()}
    z_max = float(sol.z_max)
    # the raw maxima: the 1-DOF model's own, refined by a parabola through the largest samples
    out = dict(
        z_max_m=z_max,
        a_max_g=maxima["a_max_g"],
        sigma_max_mpa=maxima["sigma_max_mpa"],
        a_max_raw_g=float(sol.a_max),
        sigma_max_raw_mpa=float(sol.sigma_max),
        stop_time_s=float(sol.t_stop) if bool(sol.stopped) else float("nan"),
        # simulate_one_dof raises when its solve fails (diffrax's throw=True)
        solve_ok=True,
        stopped=bool(sol.stopped),
        z_ok=z_max < criteria.z_max_m,
        a_ok=maxima["a_max_g"] < criteria.a_max_g,
        sigma_ok=maxima["sigma_max_mpa"] < criteria.sigma_max_mpa,
        energy_budget_error=float(sol.energy_error),
        solver_status="successful",
        num_steps=0,
    )
    out["criteria_met"] = bool(criteria_met(out))
    last = -1
    out["energy_budget_J"] = dict(
        rocket_kinetic=float(0.5 * params.m_r * (sol.velocity[last] ** 2 - sol.velocity[0] ** 2)),
        rocket_gravitational=-float(sol.rocket_potential[last]),
        counterweight=float(sol.counterweight_potential[last]),
        dissipated_brakes_damping=float(sol.friction_work[last]),
    )
    probes = {k: np.asarray(v) for k, v in probes.items()}
    return LandingRun("1dof", out, np.asarray(ts), probes, "successful", 0, sol, criteria)


def _one_dof_record(sol, params, t_end_s):
    """The 1-DOF landing as a record over ``[0, t_end_s]`` on the solution's uniform grid (spacing
    ``t_stop / (n_save - 1)``), like the scenes' saved histories: ``ts`` [s] and the probes
    ``drop_m``, ``velocity_m_s`` (n, 3), ``acceleration_m_s2`` (n, 3), ``stress_max_pa``,
    ``counterweight_rise_m`` (n, 4).

    After the stop the rocket rests at z_max on rigid cables: acceleration 0, and each of the 8
    legs holds ``m_r g / (8 sin theta_s)``. The rigid-cable deceleration drops to zero at the stop, and
    the criteria's filter must see that drop as it sees it in the elastic-cable levels (a stiff
    cable's stop, a few ms long, is where the filtered a_max exceeds the raw one). Valid while
    the brakes hold the counterweights, ``|2 T_s / alpha - m_w g| <= F_f`` (Table 1's buffer: 55 kN
    against 9 kN +- 313 kN); otherwise the record ends at the stop (the model says nothing after it)."""
    n = sol.t.shape[0]
    t = np.asarray(sol.t)
    zeros = np.zeros(n)
    rec = dict(
        drop_m=np.asarray(sol.z),
        velocity_m_s=np.stack([zeros, zeros, -np.asarray(sol.velocity)], 1),
        acceleration_m_s2=np.stack([zeros, zeros, -np.asarray(sol.acceleration)], 1),
        stress_max_pa=np.asarray(sol.stress),
        counterweight_rise_m=np.repeat(np.asarray(sol.w)[:, None], 4, 1),
    )
    dt = t[1] - t[0]
    z_s, l_0, g = float(sol.z_max), float(params.l_0), float(params.g)
    sin_s = z_s / np.hypot(l_0, z_s)
    hold = float(params.m_r) * g / (8.0 * sin_s) if sin_s > 0 else np.inf
    brakes_hold = abs(2.0 * hold / float(params.alpha) - float(params.m_w) * g) <= float(params.F_f)
    extra = int(np.floor((t_end_s - t[-1]) / dt + 1e-9)) if bool(sol.stopped) and brakes_hold else 0
    if extra <= 0:
        return t, rec
    after = dict(
        drop_m=np.full(extra, z_s),
        velocity_m_s=np.zeros((extra, 3)),
        acceleration_m_s2=np.zeros((extra, 3)),
        stress_max_pa=np.full(extra, hold / float(params.cable_area)),
        counterweight_rise_m=np.repeat(rec["counterweight_rise_m"][-1:], extra, 0),
    )
    ts = np.concatenate([t, t[-1] + dt * np.arange(1, extra + 1)])
    return ts, {k: np.concatenate([rec[k], after[k]]) for k in rec}


def report_landing(run: LandingRun) -> dict:
    """The JSON-able summary of a run (``jaxcable land --json``)."""
    o = run.outputs
    out = {k: o[k] for k in REPORT_KEYS}
    for k, v in list(out.items()):
        if isinstance(v, (np.bool_, bool)):
            out[k] = bool(v)
        elif isinstance(v, float) and not np.isfinite(v):
            out[k] = None
    out["fidelity"] = run.fidelity
    out["energy_budget_J"] = o["energy_budget_J"]
    out["g_unit_m_s2"] = G_CRITERIA
    out["filter_cfc_hz"] = run.criteria.filter_cfc_hz
    out["unmet"] = unmet_conditions(out)
    return out


CRITERIA_KEYS = (
    "z_max_m",
    "a_max_g",
    "sigma_max_mpa",
    "a_max_raw_g",
    "sigma_max_raw_mpa",
    "stop_time_s",
    "criteria_met",
    "solve_ok",
    "stopped",
    "z_ok",
    "a_ok",
    "sigma_ok",
    "energy_budget_error",
)
"""The passive phase's outputs in every landing report (``jaxcable land``, one and two phases)."""

REPORT_KEYS = (*CRITERIA_KEYS, "solver_status", "num_steps")
"""The keys of :func:`report_landing` taken from a run's outputs (``jaxcable land --json``)."""


def unmet_conditions(out: dict) -> list[str]:
    """Why a landing's outputs ``out`` (with ``solve_ok``, ``stopped``, ``z_ok``, ``a_ok``,
    ``sigma_ok`` and ``solver_status``) do not meet the criteria, in words; empty when they do."""
    why = []
    if not out["solve_ok"]:
        why.append(f"solver: {out['solver_status']}")
    if not out["stopped"]:
        why.append("not stopped within t_end")
    why += [f"{name} over the limit" for name, flag in (("z_max", "z_ok"), ("a_max", "a_ok"), ("sigma_max", "sigma_ok")) if not out[flag]]
    return why


def plot_landing(run: LandingRun, path: str):
    """A PNG like the paper's Fig 11: drop, velocity, acceleration, cable stress, counterweight."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ts = run.ts
    ok = np.isfinite(ts)
    p = run.probes
    fig, ax = plt.subplots(5, 1, figsize=(7, 11), sharex=True)
    ax[0].plot(ts[ok], p["drop_m"][ok])
    ax[0].set_ylabel("drop z [m]")
    ax[0].axhline(10.0, color="r", ls=":", lw=1)
    ax[1].plot(ts[ok], -p["velocity_m_s"][ok, 2])
    ax[1].set_ylabel("descent speed [m/s]")
    ax[2].plot(ts[ok], -p["acceleration_m_s2"][ok, 2] / G_CRITERIA)
    ax[2].set_ylabel("deceleration [g]")
    ax[2].axhline(-5.0, color="r", ls=":", lw=1)
    ax[3].plot(ts[ok], p["stress_max_pa"][ok] / 1e6)
    ax[3].axhline(800.0, color="r", ls=":", lw=1)
    ax[3].set_ylabel("max cable stress [MPa]")
    ax[4].plot(ts[ok], p["counterweight_rise_m"][ok])
    ax[4].set_ylabel("counterweight rise [m]")
    ax[4].set_xlabel("time since capture [s]")
    o = run.outputs
    fig.suptitle(
        f"passive deceleration, fidelity {run.fidelity}: z_max {o['z_max_m']:.2f} m, "
        f"a_max {o['a_max_g']:.2f} g, sigma_max {o['sigma_max_mpa']:.0f} MPa",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
