"""The ``jaxcable`` command line. Each subcommand builds a scene from the same objects the Python API
uses, runs it in float64, and prints a short report or one JSON object (``--json``).

    jaxcable throw [--angle DEG] [--segment-length M] [--plot PATH] [--json]
    jaxcable land  [--fidelity 1dof|rigid|ale|full] [--x M --y M --vz M/S ...] [--plot PATH] [--json]
    jaxcable land  --phase full [--scenario I|II|III] [the 15 uncertain parameters] [--json]
    jaxcable sweep --scenario I --n 100 [--phase passive|full] [--fidelity ...] --out results.csv
    jaxcable design [--vars m_w,F_f,a_p] [--n 64] [--steps 50] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys


def _throw(args) -> int:
    import numpy as np

    from jaxcable.core import enable_x64, simulate
    from jaxcable.throw.scene import line_throwing_scene, report

    enable_x64()
    try:
        scene = line_throwing_scene(
            angle_deg=args.angle,
            segment_length_m=args.segment_length,
            rope_length_m=args.rope_length,
            pullout=args.pullout,
            drag_form=args.drag_form,
        )
        result = simulate(scene, args.t_max, solver=args.solver, rtol=args.rtol, atol=args.rtol)
    except ValueError as err:
        print(f"jaxcable throw: error: {err}", file=sys.stderr)
        return 2
    out = report(result.outputs, result.status_message)
    out["angle_deg"] = args.angle
    out["segment_length_m"] = args.segment_length
    out["num_steps"] = int(result.num_steps)
    if args.plot:
        from jaxcable.throw.plotting import plot_flight

        plot_flight(result, args.plot, title=f"line-throwing rocket, {args.angle:g} deg")
        out["plot"] = args.plot
    if args.json:
        print(json.dumps(out))
    else:
        v = out["speed_at_1_2_3_4_s_mps"]
        print(f"line-throwing rocket, launch angle {args.angle:g} deg, segments {args.segment_length:g} m")
        print(f"  range            {out['range_m']:8.1f} m")
        print(f"  max speed        {out['max_speed_mps']:8.1f} m/s")
        print(f"  flight time      {out['flight_time_s']:8.2f} s")
        print("  speed at 1-4 s   " + ", ".join(f"{x:.1f}" for x in v) + " m/s")
        print(f"  max height       {out['max_height_m']:8.1f} m")
        print(f"  impact speed     {out['impact_speed_mps']:8.1f} m/s")
        print(f"  rope deployed    {out['deployed_rope_m']:8.1f} m in {out['n_segments']} segments")
        print(f"  solver           {out['solver_status']} ({out['num_steps']} steps)")
        if args.plot:
            print(f"  plot written to  {args.plot}")
    ok = out["solver_status"] in ("successful", "event_occurred") and bool(np.isfinite(out["range_m"]))
    return 0 if ok else 1


_DEVIATED = dict(x=13.0, y=13.0, vx=0.5, vy=0.5, vz=None, theta_x=5.0, theta_y=5.0, theta_z=25.0,
                 omega_x=0.1, omega_y=0.1, omega_z=0.1)  # fmt: skip
_DESIGN = dict(x=0.0, y=0.0, vx=0.0, vy=0.0, vz=-20.0, theta_x=0.0, theta_y=0.0, theta_z=0.0,
               omega_x=0.0, omega_y=0.0, omega_z=0.0)  # fmt: skip


def _buffer_from_args(args):
    """The buffer devices of ``jaxcable land``: m_w, F_f and the optional brake profile (ValueError
    naming the flag on bad input)."""
    from jaxcable.arresting.buffer import BufferDevice

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


def _land(args) -> int:
    defaults = _DEVIATED if args.phase == "full" else _DESIGN
    for k, v in defaults.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    if args.phase == "full":
        return _land_two_phase(args)
    from jaxcable.arresting.landing import plot_landing, report_landing, run_landing
    from jaxcable.arresting.layout import CaptureState

    try:
        capture = CaptureState(
            x_m=args.x,
            y_m=args.y,
            vx_m_s=args.vx,
            vy_m_s=args.vy,
            vz_m_s=args.vz,
            theta_x_deg=args.theta_x,
            theta_y_deg=args.theta_y,
            theta_z_deg=args.theta_z,
            omega_x_deg_s=args.omega_x,
            omega_y_deg_s=args.omega_y,
            omega_z_deg_s=args.omega_z,
        )
        buffer = _buffer_from_args(args)
        run = run_landing(
            args.fidelity,
            capture,
            buffer=buffer,
            t_end_s=args.t_end,
            solver=args.solver,
            rtol=args.rtol,
            progress=args.fidelity in ("ale", "full") and not args.json,
            **({} if args.fidelity == "1dof" else dict(cable_damping_s=args.cable_damping)),
            **(dict(n_span_elements=args.span_elements, n_fine=args.fine_elements) if args.fidelity in ("ale", "full") else {}),
        )
    except ValueError as err:
        print(f"jaxcable land: error: {err}", file=sys.stderr)
        return 2
    out = report_landing(run)
    if args.plot:
        plot_landing(run, args.plot)
        out["plot"] = args.plot
    if args.json:
        print(json.dumps(out))
    else:
        yes = {True: "yes", False: "NO"}
        print(f"passive deceleration, fidelity {run.fidelity}")
        print(f"  z_max        {out['z_max_m']:8.3f} m     (< 10 m: {yes[out['z_ok']]})")
        print(f"  a_max        {out['a_max_g']:8.3f} g     (< 5 g: {yes[out['a_ok']]}; g = 9.80 m/s^2)")
        print(f"  sigma_max    {out['sigma_max_mpa']:8.1f} MPa   (< 800 MPa: {yes[out['sigma_ok']]})")
        st = out["stop_time_s"]
        print(f"  stop time    {st:8.3f} s" if st is not None else "  stop time    not stopped")
        print(f"  criteria met {yes[out['criteria_met']]}")
        print("  energy budget, change since capture [kJ]:")
        for k, v in out["energy_budget_J"].items():
            print(f"    {k:28s} {v / 1e3:10.1f}")
        print(f"  budget closes to {out['energy_budget_error']:.2e} of the input energy")
        print(f"  solver       {out['solver_status']} ({out['num_steps']} steps)")
        if args.plot:
            print(f"  plot written to {args.plot}")
    ok = out["solver_status"] in ("successful", "event_occurred")
    return 0 if ok else 1


def _land_two_phase(args) -> int:
    from jaxcable.arresting.layout import CaptureState
    from jaxcable.arresting.two_phase import plot_two_phase, report_two_phase, run_two_phase

    if args.fidelity == "1dof":
        print("jaxcable land: error: --phase full needs --fidelity rigid, ale or full", file=sys.stderr)
        return 2
    if (args.span_elements, args.fine_elements) != (16, 8):
        print("jaxcable land: error: --span-elements/--fine-elements apply to --phase passive only", file=sys.stderr)
        return 2
    try:
        terminal = CaptureState(
            x_m=args.x, y_m=args.y, vx_m_s=args.vx, vy_m_s=args.vy,
            theta_x_deg=args.theta_x, theta_y_deg=args.theta_y, theta_z_deg=args.theta_z,
            omega_x_deg_s=args.omega_x, omega_y_deg_s=args.omega_y, omega_z_deg_s=args.omega_z,
        )  # fmt: skip
        buffer = _buffer_from_args(args)
        run = run_two_phase(
            terminal,
            scenario=args.scenario,
            fidelity=args.fidelity,
            buffer=buffer,
            passive_t_end_s=args.t_end,
            gain_per_s=args.gain,
            motor_delay_s=args.motor_delay,
            noise_rms_m=args.noise_rms,
            wind_speed_m_s=args.wind_speed,
            wind_angle_deg=args.wind_angle,
            gust_intensity=args.gust_intensity,
            seed=args.seed,
            cable_damping_s=args.cable_damping,
        )
    except ValueError as err:
        print(f"jaxcable land: error: {err}", file=sys.stderr)
        return 2
    out = report_two_phase(run)
    if args.plot:
        plot_two_phase(run, args.plot)
        out["plot"] = args.plot
    if args.json:
        print(json.dumps(out))
    else:
        yes = {True: "yes", False: "NO"}
        c = out["captured_state"]
        print(f"two-phase landing, scenario {args.scenario}, passive fidelity {args.fidelity}")
        print(f"  captured          {yes[out['captured']]} at t = {out['capture_time_s']:.3f} s "
              f"(smallest hook margin {out['capture_margin_m']:.3f} m)")  # fmt: skip
        print(f"  tracking error    {out['tracking_error_m']:.3f} m at t_c/2, "
              f"{out['tracking_error_at_capture_m']:.3f} m at capture")  # fmt: skip
        print(f"  captured state    x {c['x_m']:.2f} m, y {c['y_m']:.2f} m, v ({c['vx_m_s']:.2f}, {c['vy_m_s']:.2f}, "
              f"{c['vz_m_s']:.2f}) m/s, theta ({c['theta_x_deg']:.2f}, {c['theta_y_deg']:.2f}, {c['theta_z_deg']:.2f}) deg")  # fmt: skip
        print(f"  z_max        {out['z_max_m']:8.3f} m     (< 10 m: {yes[out['z_ok']]})")
        print(f"  a_max        {out['a_max_g']:8.3f} g     (< 5 g: {yes[out['a_ok']]}; g = 9.80 m/s^2)")
        print(f"  sigma_max    {out['sigma_max_mpa']:8.1f} MPa   (< 800 MPa: {yes[out['sigma_ok']]})")
        print(f"  landed (all criteria) {yes[out['landed']]}")
        print(f"  solver       tracking {out['tracking_solver_status']} ({out['tracking_steps']} steps), "
              f"passive {out['solver_status']} ({out['num_steps']} steps)")  # fmt: skip
        if args.plot:
            print(f"  plot written to {args.plot}")
    ok = out["solver_status"] in ("successful", "event_occurred")
    return 0 if ok else 1


def _sweep(args) -> int:
    from jaxcable.studies.sweep import sweep_main

    return sweep_main(args.rest)


def _design(args) -> int:
    from jaxcable.arresting.design import design_main

    return design_main(args.rest)


def _bench(args) -> int:
    from jaxcable.studies.bench import bench_main

    return bench_main(args.rest)


def _angle(text):
    value = float(text)
    if not 0.0 < value < 90.0:
        raise argparse.ArgumentTypeError(f"--angle must be in (0, 90) deg, got {text}")
    return value


def _positive(name):
    def parse(text):
        value = float(text)
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{name} must be positive, got {text}")
        return value

    return parse


def build_parser() -> argparse.ArgumentParser:
    from jaxcable.arresting.passive import DEFAULT_CABLE_DAMPING_S
    from jaxcable.core.simulate import SOLVERS

    parser = argparse.ArgumentParser(prog="jaxcable", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("throw", help="fly the line-throwing rocket once (calibrated defaults)")
    t.add_argument("--angle", type=_angle, default=30.0, help="launch elevation [deg] (default 30)")
    t.add_argument("--segment-length", type=_positive("--segment-length"), default=1.0, help="rope segment length [m] (default 1)")
    t.add_argument("--rope-length", type=_positive("--rope-length"), default=800.0, help="rope in the box [m] (default 800)")
    t.add_argument("--pullout", choices=["none", "constant", "momentum_flux"], default=None, help="pull-out force model (default: calibrated)")
    t.add_argument("--drag-form", choices=["standard", "per_axis"], default="standard", help="drag law (default standard)")
    # defaults from the work-precision study (docs/work_precision.md): at 1 m segments Tsit5 at 1e-4
    # has a time-integration error <= 3.8e-5 in range, max speed and flight time (below the 1 m
    # segments' own discretisation error) with 10.0k vector-field evaluations, against 16.3k for
    # Dopri5 at 1e-5 (the previous default)
    t.add_argument("--solver", choices=sorted(SOLVERS), default="tsit5", help="diffrax solver (default tsit5)")
    t.add_argument("--rtol", type=_positive("--rtol"), default=1e-4, help="relative = absolute tolerance (default 1e-4: range, max speed, flight time within 4e-5 of a Dopri8 1e-10 reference)")
    t.add_argument("--t-max", type=_positive("--t-max"), default=40.0, help="longest flight simulated [s]")
    t.add_argument("--plot", metavar="PATH", help="write a PNG of trajectory, speed and rope shapes")
    t.add_argument("--json", action="store_true", help="print one JSON object")
    t.set_defaults(func=_throw)

    la = sub.add_parser(
        "land",
        help="one landing: passive deceleration (default: design case) or, with --phase full, tracking + capture + deceleration",
    )
    la.add_argument("--phase", choices=["passive", "full"], default="passive",
                    help="passive: start captured (issue 3 scene); full: from the terminal-guidance state (default passive)")  # fmt: skip
    la.add_argument("--fidelity", choices=["1dof", "rigid", "ale", "full"], default="full", help="model level of the passive phase (default full)")
    la.add_argument("--scenario", choices=["I", "II", "III"], default="I", help="Table 4 scenario (h, t_c, a_p, max wind) for --phase full (default I)")
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
        d_pas, d_full = _DESIGN[name], _DEVIATED[name]
        la.add_argument(flag, type=float, default=None,
                        help=f"{what} [{unit}] (default {d_pas:g}; --phase full: {d_full if d_full is not None else '-h/t_c'})")  # fmt: skip
    la.add_argument("--wind-angle", type=float, default=90.0, help="theta_w, direction the wind blows from, clockwise from north (+y) [deg] (--phase full; default 90)")
    la.add_argument("--wind-speed", type=float, default=None, help="v_ws, steady wind [m/s] (--phase full; default: the scenario's maximum)")
    la.add_argument("--gust-intensity", type=float, default=0.1, help="lambda_wg, gust RMS / steady wind [-] (--phase full; default 0.1)")
    la.add_argument("--motor-delay", type=float, default=0.1, help="tau, motor dead time [s] (--phase full; default 0.1)")
    la.add_argument("--noise-rms", type=float, default=0.1, help="sigma_r, measurement noise RMS [m] (--phase full; default 0.1)")
    la.add_argument("--gain", type=float, default=None, help="a_p, PD gain [1/s] (--phase full; default: the scenario's)")
    la.add_argument("--seed", type=int, default=0, help="seed of the measurement noise and the gust (--phase full; default 0)")
    la.add_argument("--counterweight-mass", type=float, default=920.0, help="m_w, one counterweight [kg] (Table 1: 920)")
    la.add_argument("--brake-force", type=float, default=3.13e5, help="F_f, one brake [N] (Table 1: 3.13e5)")
    la.add_argument("--brake-profile", default=None, help="factors phi_0,...,phi_K-1 of the brake force along the counterweight rise, F_f(w) = F_f phi(w), at K equally spaced knots over [0, --brake-profile-travel] (e.g. a design of `jaxcable design --vars m_w,profile:8`); default: constant brake")
    la.add_argument("--brake-profile-travel", type=float, default=6.0, help="counterweight rise of the profile's last knot [m] (default 6)")
    la.add_argument("--cable-damping", type=float, default=DEFAULT_CABLE_DAMPING_S, help=f"cables' stiffness-proportional damping beta [s] (levels rigid, ale, full; default {DEFAULT_CABLE_DAMPING_S:g}: the paper gives none, a_max depends on it; ale/full: a larger beta shortens the explicit step)")
    la.add_argument("--span-elements", type=int, default=16, help="ALE elements per arresting span (levels ale, full; default 16)")
    la.add_argument("--fine-elements", type=int, default=8, help="of those, equal fine elements over +-3 m around the hook (levels ale, full; default 8 = 0.75 m; 4 = 1.5 m halves the run time and moves sigma_max by 1-6%%: docs/arresting_design.md)")
    la.add_argument("--t-end", type=_positive("--t-end"), default=2.0, help="time simulated after capture [s] (default 2)")
    la.add_argument("--solver", choices=sorted(SOLVERS), default=None, help="diffrax solver (default per level)")
    la.add_argument("--rtol", type=_positive("--rtol"), default=None, help="relative = absolute tolerance (default per level)")
    la.add_argument("--plot", metavar="PATH", help="write a PNG like the paper's Fig 11")
    la.add_argument("--json", action="store_true", help="print one JSON object")
    la.set_defaults(func=_land)

    sw = sub.add_parser("sweep", help="quasi-Monte Carlo robustness sweep (see jaxcable sweep --help)", add_help=False)
    sw.add_argument("rest", nargs=argparse.REMAINDER)
    sw.set_defaults(func=_sweep)
    de = sub.add_parser("design", help="gradient-based design optimisation (see jaxcable design --help)", add_help=False)
    de.add_argument("rest", nargs=argparse.REMAINDER)
    de.set_defaults(func=_design)
    be = sub.add_parser("bench", help="short speed-against-error benchmark on this machine (see jaxcable bench --help)", add_help=False)
    be.add_argument("rest", nargs=argparse.REMAINDER)
    be.set_defaults(func=_bench)
    return parser


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # sweep/design/bench parse their own flags (argparse's REMAINDER does not take a rest starting with "--")
    if argv[:1] == ["sweep"]:
        from jaxcable.studies.sweep import sweep_main

        return sweep_main(argv[1:])
    if argv[:1] == ["design"]:
        from jaxcable.arresting.design import design_main

        return design_main(argv[1:])
    if argv[:1] == ["bench"]:
        from jaxcable.studies.bench import bench_main

        return bench_main(argv[1:])
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
