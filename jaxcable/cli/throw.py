"""``jaxcable throw``: one flight of the line-throwing rocket with the calibrated defaults (the
scene of :func:`jaxcable.throw.scene.line_throwing_scene`), reported as range, speeds, heights and
the rope deployed."""

from __future__ import annotations

import argparse

import numpy as np

from jaxcable.cli.report import Report, in_open_interval, non_negative, positive
from jaxcable.core.config import enable_x64
from jaxcable.core.simulate import SOLVERS, simulate
from jaxcable.throw.plotting import plot_flight
from jaxcable.throw.scene import THROW_STEP_CONTROL, line_throwing_scene, report

DESCRIPTION = " ".join(__doc__.split("\n\n")[0].split())
HELP = "fly the line-throwing rocket once (calibrated defaults)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``jaxcable throw``."""
    p = parser
    p.add_argument("--angle", type=in_open_interval("--angle", 0.0, 90.0, " deg"), default=30.0, help="launch elevation [deg] (default 30)")
    p.add_argument("--segment-length", type=positive("--segment-length"), default=1.0, help="rope segment length [m] (default 1)")
    p.add_argument("--rope-length", type=positive("--rope-length"), default=800.0, help="rope in the box [m] (default 800)")
    p.add_argument("--pullout", choices=["none", "constant", "momentum_flux"], default=None, help="pull-out force model (default: calibrated)")
    p.add_argument("--drag-form", choices=["standard", "per_axis"], default="standard", help="drag law (default standard)")
    # defaults from the work-precision study (docs/work_precision.md): at 1 m segments Tsit5 at 1e-4
    # has a time-integration error <= 3.8e-5 in range, max speed and flight time (below the 1 m
    # segments' own discretisation error) with 10.0k vector-field evaluations, against 16.3k for
    # Dopri5 at 1e-5
    p.add_argument("--solver", choices=sorted(SOLVERS), default="tsit5", help="diffrax solver (default tsit5)")
    p.add_argument("--rtol", type=positive("--rtol"), default=1e-4, help="relative = absolute tolerance (default 1e-4: range, max speed, flight time within 4e-5 of a Dopri8 1e-10 reference)")
    # the PI step-size controller; its measurement: THROW_STEP_CONTROL's docstring
    p.add_argument("--pcoeff", type=non_negative("--pcoeff"), default=THROW_STEP_CONTROL[0],
                   help=f"proportional coefficient of the PID step-size controller (default {THROW_STEP_CONTROL[0]:g}: PI)")  # fmt: skip
    p.add_argument("--icoeff", type=positive("--icoeff"), default=THROW_STEP_CONTROL[1],
                   help=f"integral coefficient of the PID step-size controller (default {THROW_STEP_CONTROL[1]:g}; "
                   "--pcoeff 0 --icoeff 1: diffrax's I controller)")  # fmt: skip
    p.add_argument("--no-windows", action="store_true",
                   help="evaluate every link of the box at every step instead of the smallest window of "
                   "64, 128, 256, 512 links holding the deployed rope (same results to rounding; at 1 m segments "
                   "the first call compiles in 0.66x the time, the flight runs 1.6x longer)")  # fmt: skip
    p.add_argument("--t-max", type=positive("--t-max"), default=40.0, help="longest flight simulated [s]")
    p.add_argument("--plot", metavar="PATH", help="write a PNG of trajectory, speed and rope shapes")
    p.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> Report:
    """Fly once; ValueError (naming the flag or field) on bad input."""
    enable_x64()
    scene = line_throwing_scene(
        angle_deg=args.angle,
        segment_length_m=args.segment_length,
        rope_length_m=args.rope_length,
        pullout=args.pullout,
        drag_form=args.drag_form,
        window_links=() if args.no_windows else None,
    )
    result = simulate(scene, args.t_max, solver=args.solver, rtol=args.rtol, atol=args.rtol,
                      pcoeff=args.pcoeff, icoeff=args.icoeff)  # fmt: skip
    out = report(result.outputs, result.status_message)
    out["angle_deg"] = args.angle
    out["segment_length_m"] = args.segment_length
    out["num_steps"] = int(result.num_steps)
    if args.plot:
        plot_flight(result, args.plot, title=f"line-throwing rocket, {args.angle:g} deg")
        out["plot"] = args.plot
    v = out["speed_at_1_2_3_4_s_mps"]
    lines = [
        f"line-throwing rocket, launch angle {args.angle:g} deg, segments {args.segment_length:g} m",
        f"  range            {out['range_m']:8.1f} m",
        f"  max speed        {out['max_speed_mps']:8.1f} m/s",
        f"  flight time      {out['flight_time_s']:8.2f} s",
        "  speed at 1-4 s   " + ", ".join(f"{x:.1f}" for x in v) + " m/s",
        f"  max height       {out['max_height_m']:8.1f} m",
        f"  impact speed     {out['impact_speed_mps']:8.1f} m/s",
        f"  rope deployed    {out['deployed_rope_m']:8.1f} m in {out['n_segments']} segments",
        f"  solver           {out['solver_status']} ({out['num_steps']} steps)",
    ]
    if args.plot:
        lines.append(f"  plot written to  {args.plot}")
    ok = out["solver_status"] in ("successful", "event_occurred") and bool(np.isfinite(out["range_m"]))
    return Report(data=out, text="\n".join(lines), ok=ok)
