"""``jaxcable land``: one landing of the arresting-cable system. ``--phase passive`` (default) starts
at capture and runs the passive deceleration (:func:`jaxcable.arresting.landing.run_landing`, the
design case by default); ``--phase full`` starts at the terminal-guidance point and runs tracking,
capture and the passive phase (:func:`jaxcable.arresting.two_phase.run_two_phase`, a deviated
terminal state by default). Reported: the criteria z_max, a_max, sigma_max (a_max and sigma_max after
the SAE J211 CFC 60 filter, the unfiltered maxima beside them), whether the rocket stopped and the
solve succeeded (a landing meets the criteria only if both hold), and, for the passive phase alone,
the energy budget."""

from __future__ import annotations

import argparse

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import plot_landing, report_landing, run_landing
from jaxcable.arresting.layout import CaptureState
from jaxcable.arresting.passive import DEFAULT_CABLE_DAMPING_S
from jaxcable.arresting.two_phase import plot_two_phase, report_two_phase, run_two_phase
from jaxcable.cli.report import Report, cable_damping, positive
from jaxcable.core.simulate import SOLVERS

DESCRIPTION = " ".join(__doc__.split("\n\n")[0].split())
HELP = "one landing: passive deceleration (default: design case) or, with --phase full, tracking + capture + deceleration"

DEVIATED = dict(x=13.0, y=13.0, vx=0.5, vy=0.5, vz=None, theta_x=5.0, theta_y=5.0, theta_z=25.0,
                omega_x=0.1, omega_y=0.1, omega_z=0.1)  # fmt: skip
"""Defaults of the state flags with ``--phase full``: a deviated terminal-guidance state (vz: -h/t_c)."""
DESIGN = dict(x=0.0, y=0.0, vx=0.0, vy=0.0, vz=-20.0, theta_x=0.0, theta_y=0.0, theta_z=0.0,
              omega_x=0.0, omega_y=0.0, omega_z=0.0)  # fmt: skip
"""Defaults of the state flags with ``--phase passive``: the design case, a central vertical capture."""

_YES = {True: "yes", False: "NO"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``jaxcable land``."""
    p = parser
    p.add_argument("--phase", choices=["passive", "full"], default="passive",
                   help="passive: start captured (the passive-deceleration scene); full: from the terminal-guidance state (default passive)")  # fmt: skip
    p.add_argument("--fidelity", choices=["1dof", "rigid", "ale", "full"], default="full", help="model level of the passive phase (default full)")
    p.add_argument("--scenario", choices=["I", "II", "III"], default="I", help="Table 4 scenario (h, t_c, a_p, max wind) for --phase full (default I)")
    for flag, unit, what in (
        ("--x", "m", "position of the hook-plane centre O (passive: at capture; full: at the terminal-guidance point)"),
        ("--y", "m", "position of O"),
        ("--vx", "m/s", "velocity of O"),
        ("--vy", "m/s", "velocity of O"),
        ("--vz", "m/s", "vertical velocity of O, z up (passive only; full: -h/t_c)"),
        ("--theta-x", "deg", "rotation vector component (inclination)"),
        ("--theta-y", "deg", "rotation vector component (inclination)"),
        ("--theta-z", "deg", "rotation vector component (roll), |theta_z| < 45"),
        ("--omega-x", "deg/s", "angular velocity"),
        ("--omega-y", "deg/s", "angular velocity"),
        ("--omega-z", "deg/s", "angular velocity"),
    ):
        name = flag[2:].replace("-", "_")
        d_pas, d_full = DESIGN[name], DEVIATED[name]
        p.add_argument(flag, type=float, default=None,
                       help=f"{what} [{unit}] (default {d_pas:g}; --phase full: {d_full if d_full is not None else '-h/t_c'})")  # fmt: skip
    p.add_argument("--wind-angle", type=float, default=90.0, help="theta_w, direction the wind blows from, clockwise from north (+y) [deg] (--phase full; default 90)")
    p.add_argument("--wind-speed", type=float, default=None, help="v_ws, steady wind [m/s] (--phase full; default: the scenario's maximum)")
    p.add_argument("--gust-intensity", type=float, default=0.1, help="lambda_wg, gust RMS / steady wind [-] (--phase full; default 0.1)")
    p.add_argument("--motor-delay", type=float, default=0.1, help="tau, motor dead time [s] (--phase full; default 0.1)")
    p.add_argument("--noise-rms", type=float, default=0.1, help="sigma_r, measurement noise RMS [m] (--phase full; default 0.1)")
    p.add_argument("--gain", type=float, default=None, help="a_p, PD gain [1/s] (--phase full; default: the scenario's)")
    p.add_argument("--seed", type=int, default=0, help="seed of the measurement noise and the gust (--phase full; default 0)")
    p.add_argument("--counterweight-mass", type=float, default=920.0, help="m_w, one counterweight [kg] (Table 1: 920)")
    p.add_argument("--brake-force", type=float, default=3.13e5, help="F_f, one brake [N] (Table 1: 3.13e5)")
    p.add_argument("--brake-profile", default=None, help="factors phi_0,...,phi_K-1 of the brake force along the counterweight rise, F_f(w) = F_f phi(w), at K equally spaced knots over [0, --brake-profile-travel] (e.g. a design of `jaxcable design --vars m_w,profile:8`); default: constant brake")
    p.add_argument("--brake-profile-travel", type=float, default=6.0, help="counterweight rise of the profile's last knot [m] (default 6)")
    p.add_argument("--cable-damping", type=cable_damping(), default=DEFAULT_CABLE_DAMPING_S, help=f"cables' stiffness-proportional damping beta [s] (levels rigid, ale, full; default {DEFAULT_CABLE_DAMPING_S:g} = 'calibrated', fitted to the paper's section III.F, docs/arresting_validation.md; the paper prints none, a_max depends on it: 1e-5 leaves the cables' mode ringing; ale/full run the W-method rosw at any damping, its steps free of the explicit stability limit)")
    p.add_argument("--span-elements", type=int, default=None, help="ALE elements per arresting span (levels ale, full; default: the level's, 80 at both: with the hook as a node the criteria of the design case and the deviated case are within 0.2%% (full) and 1.2%% (ale) of twice as many elements, docs/arresting_validation.md)")
    p.add_argument("--fine-elements", type=int, default=None, help="of those, equal fine elements over +-3 m next to the hook (levels ale, full; default: the level's, 16 = 0.375 m at both)")
    p.add_argument("--hook-contact", choices=["capsule", "node"], default=None, help="how a hook holds its cable (levels ale, full): node (default), the hook as a sliding node of its cable, or capsule, the Hertz/Coulomb contact of the hook's capsules with every span element (pushes the cable along itself where it kinks over the hook: the deviated case's sigma_max does not converge with the mesh; docs/arresting_validation.md)")
    p.add_argument("--rocket-bodies", type=int, default=None, metavar="N", help="rigid bodies of the flexible rocket (level full; default 5). 1: a rigid rocket with the sprung hinged hooks, a cheaper model: on the design case, the deviated case and 4 section IV cases z_max within 0.04%%, a_max within 0.6%%, sigma_max within 0.3%% of 5 bodies, in 0.71-0.86x the time (docs/arresting_validation.md)")
    p.add_argument("--t-end", type=positive("--t-end"), default=2.0, help="time simulated after capture [s] (default 2)")
    p.add_argument("--solver", choices=sorted(SOLVERS), default=None, help="diffrax solver (default per level)")
    p.add_argument("--rtol", type=positive("--rtol"), default=None, help="relative = absolute tolerance (default per level)")
    p.add_argument("--plot", metavar="PATH", help="write a PNG like the paper's Fig 11")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> Report:
    """One landing; ValueError (naming the flag or field) on bad input."""
    defaults = DEVIATED if args.phase == "full" else DESIGN
    for k, v in defaults.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    return _two_phase(args) if args.phase == "full" else _passive(args)


def _buffer(args: argparse.Namespace) -> BufferDevice:
    """The buffer devices: m_w, F_f and the optional brake profile (ValueError naming the flag)."""
    profile = None
    if args.brake_profile:
        try:
            profile = [float(v) for v in args.brake_profile.split(",") if v.strip()]
        except ValueError:
            raise ValueError(f"--brake-profile must be comma-separated numbers, got {args.brake_profile!r}") from None
        if args.fidelity == "1dof":
            raise ValueError("--brake-profile needs --fidelity rigid, ale or full (the 1-DOF model has a constant brake)")
    return BufferDevice(
        counterweight_mass_kg=args.counterweight_mass, brake_force_N=args.brake_force, brake_profile=profile,
        brake_profile_travel_m=args.brake_profile_travel,
    )  # fmt: skip


def _criteria_lines(out: dict) -> list[str]:
    cfc = f"CFC {out['filter_cfc_hz']:g}"
    return [
        f"  z_max        {_num(out['z_max_m'], '8.3f')} m     (< 10 m: {_YES[out['z_ok']]})",
        f"  a_max        {_num(out['a_max_g'], '8.3f')} g     (< 5 g: {_YES[out['a_ok']]}; {cfc}, raw "
        f"{_num(out['a_max_raw_g'], '.3f')} g; g = 9.80 m/s^2)",
        f"  sigma_max    {_num(out['sigma_max_mpa'], '8.1f')} MPa   (< 800 MPa: {_YES[out['sigma_ok']]}; {cfc}, raw "
        f"{_num(out['sigma_max_raw_mpa'], '.1f')} MPa)",
    ]


def _num(value, fmt: str) -> str:
    return "nan" if value is None else format(value, fmt)


def _verdict(met: bool, unmet: list[str]) -> str:
    """``yes``, or ``NO`` with the reasons (``not stopped within t_end``, ``solver: ...``)."""
    return _YES[met] if met or not unmet else f"NO ({'; '.join(unmet)})"


def _cable_options(args: argparse.Namespace) -> dict:
    """The passive scene's cable mesh, hook model and rocket bodies from the flags (only those
    given; ValueError naming the flag where the level has no such part)."""
    options = {}
    if args.fidelity in ("ale", "full"):
        given = {"n_span_elements": args.span_elements, "n_fine": args.fine_elements, "hook_contact": args.hook_contact}
        options.update({k: v for k, v in given.items() if v is not None})
    else:
        for flag, value in (("--span-elements", args.span_elements), ("--fine-elements", args.fine_elements), ("--hook-contact", args.hook_contact)):
            if value is not None and not (flag == "--hook-contact" and value == "capsule"):
                raise ValueError(f"{flag} {value} needs --fidelity ale or full (the {args.fidelity} level has no cable nodes)")
    if args.rocket_bodies is not None:
        if args.fidelity != "full":
            raise ValueError(f"--rocket-bodies {args.rocket_bodies} needs --fidelity full (the {args.fidelity} level's rocket is one rigid body)")
        options["n_rocket_bodies"] = args.rocket_bodies
    return options


def _passive(args: argparse.Namespace) -> Report:
    capture = CaptureState(
        x_m=args.x, y_m=args.y, vx_m_s=args.vx, vy_m_s=args.vy, vz_m_s=args.vz,
        theta_x_deg=args.theta_x, theta_y_deg=args.theta_y, theta_z_deg=args.theta_z,
        omega_x_deg_s=args.omega_x, omega_y_deg_s=args.omega_y, omega_z_deg_s=args.omega_z,
    )  # fmt: skip
    level_options = {} if args.fidelity == "1dof" else dict(cable_damping_s=args.cable_damping)
    level_options.update(_cable_options(args))
    landing = run_landing(
        args.fidelity,
        capture,
        buffer=_buffer(args),
        t_end_s=args.t_end,
        solver=args.solver,
        rtol=args.rtol,
        progress=args.fidelity in ("ale", "full") and not args.json,
        **level_options,
    )
    out = report_landing(landing)
    if args.plot:
        plot_landing(landing, args.plot)
        out["plot"] = args.plot
    st = out["stop_time_s"]
    lines = [
        f"passive deceleration, fidelity {landing.fidelity}",
        *_criteria_lines(out),
        f"  stop time    {st:8.3f} s" if st is not None else f"  stop time    not stopped within t_end = {args.t_end:g} s",
        f"  criteria met {_verdict(out['criteria_met'], out['unmet'])}",
        "  energy budget, change since capture [kJ]:",
        *(f"    {k:28s} {v / 1e3:10.1f}" for k, v in out["energy_budget_J"].items()),
        f"  budget closes to {out['energy_budget_error']:.2e} of the input energy",
        f"  solver       {out['solver_status']} ({out['num_steps']} steps)",
    ]
    if args.plot:
        lines.append(f"  plot written to {args.plot}")
    return Report(data=out, text="\n".join(lines), ok=out["solver_status"] in ("successful", "event_occurred"))


def _two_phase(args: argparse.Namespace) -> Report:
    if args.fidelity == "1dof":
        raise ValueError("--phase full needs --fidelity rigid, ale or full")
    terminal = CaptureState(
        x_m=args.x, y_m=args.y, vx_m_s=args.vx, vy_m_s=args.vy,
        theta_x_deg=args.theta_x, theta_y_deg=args.theta_y, theta_z_deg=args.theta_z,
        omega_x_deg_s=args.omega_x, omega_y_deg_s=args.omega_y, omega_z_deg_s=args.omega_z,
    )  # fmt: skip
    landing = run_two_phase(
        terminal,
        scenario=args.scenario,
        fidelity=args.fidelity,
        buffer=_buffer(args),
        passive_t_end_s=args.t_end,
        gain_per_s=args.gain,
        motor_delay_s=args.motor_delay,
        noise_rms_m=args.noise_rms,
        wind_speed_m_s=args.wind_speed,
        wind_angle_deg=args.wind_angle,
        gust_intensity=args.gust_intensity,
        seed=args.seed,
        cable_damping_s=args.cable_damping,
        passive_kwargs=_cable_options(args),
    )
    out = report_two_phase(landing)
    if args.plot:
        plot_two_phase(landing, args.plot)
        out["plot"] = args.plot
    c = out["captured_state"]
    lines = [
        f"two-phase landing, scenario {args.scenario}, passive fidelity {args.fidelity}",
        f"  captured          {_YES[out['captured']]} at t = {out['capture_time_s']:.3f} s "
        f"(smallest hook margin {out['capture_margin_m']:.3f} m)",
        f"  tracking error    {out['tracking_error_m']:.3f} m at t_c/2, "
        f"{out['tracking_error_at_capture_m']:.3f} m at capture",
        f"  captured state    x {c['x_m']:.2f} m, y {c['y_m']:.2f} m, v ({c['vx_m_s']:.2f}, {c['vy_m_s']:.2f}, "
        f"{c['vz_m_s']:.2f}) m/s, theta ({c['theta_x_deg']:.2f}, {c['theta_y_deg']:.2f}, {c['theta_z_deg']:.2f}) deg",
        *_criteria_lines(out),
        f"  stop time    {out['stop_time_s']:.3f} s after capture" if out["stop_time_s"] is not None
        else f"  stop time    not stopped within t_end = {args.t_end:g} s",
        f"  landed (all criteria) {_verdict(out['landed'], out['unmet'])}",
        f"  solver       tracking {out['tracking_solver_status']} ({out['tracking_steps']} steps), "
        f"passive {out['solver_status']} ({out['num_steps']} steps)",
    ]
    if args.plot:
        lines.append(f"  plot written to {args.plot}")
    return Report(data=out, text="\n".join(lines), ok=out["solver_status"] in ("successful", "event_occurred"))
