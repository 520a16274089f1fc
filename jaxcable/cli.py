"""The ``jaxcable`` command line. Each subcommand builds a scene from the same objects the Python API
uses, runs it in float64, and prints a short report or one JSON object (``--json``).

    jaxcable throw [--angle DEG] [--segment-length M] [--plot PATH] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys


def _throw(args) -> int:
    import numpy as np

    from . import enable_x64, simulate
    from .scenes.line_throwing import line_throwing_scene, report

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
        from .plotting import plot_flight

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
    from .simulate import SOLVERS

    parser = argparse.ArgumentParser(prog="jaxcable", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("throw", help="fly the line-throwing rocket once (calibrated defaults)")
    t.add_argument("--angle", type=_angle, default=30.0, help="launch elevation [deg] (default 30)")
    t.add_argument("--segment-length", type=_positive("--segment-length"), default=1.0, help="rope segment length [m] (default 1)")
    t.add_argument("--rope-length", type=_positive("--rope-length"), default=800.0, help="rope in the box [m] (default 800)")
    t.add_argument("--pullout", choices=["none", "constant", "momentum_flux"], default=None, help="pull-out force model (default: calibrated)")
    t.add_argument("--drag-form", choices=["standard", "per_axis"], default="standard", help="drag law (default standard)")
    t.add_argument("--solver", choices=sorted(SOLVERS), default="dopri5", help="diffrax solver (default dopri5)")
    t.add_argument("--rtol", type=_positive("--rtol"), default=1e-5, help="relative = absolute tolerance (default 1e-5: range within 0.01%% of a 1e-9 reference)")
    t.add_argument("--t-max", type=_positive("--t-max"), default=40.0, help="longest flight simulated [s]")
    t.add_argument("--plot", metavar="PATH", help="write a PNG of trajectory, speed and rope shapes")
    t.add_argument("--json", action="store_true", help="print one JSON object")
    t.set_defaults(func=_throw)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
