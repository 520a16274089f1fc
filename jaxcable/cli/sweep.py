"""quasi-Monte Carlo robustness sweep of the arresting-cable landing (paper section IV)

``jaxcable sweep``: run (or resume) :func:`jaxcable.arresting.sweep.run_qmc_sweep` and report its
summary (Tables 6, 7, 9; Table 5 for two-phase sweeps), optionally with the plots of Figs 15-21
(:mod:`jaxcable.arresting.sweep_plots`). Exit status 0 when every case ran (whatever the success
rate), 1 when some failed numerically, 2 on bad arguments.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import jax
import numpy as np

from jaxcable.arresting.passive import DEFAULT_CABLE_DAMPING_S
from jaxcable.arresting.screening import MEASURED_BANDS, run_confirmation
from jaxcable.arresting.sweep import CRITERIA, SWEEP_FIDELITIES, qmc_case_fn, run_qmc_sweep, summarize_sweep, summary_markdown
from jaxcable.arresting.sweep_plots import plot_histories, plot_landing_plane, plot_tracking
from jaxcable.arresting.uncertainty import PHASES, SCENARIOS, halton_samples, scenario_settings
from jaxcable.cli.report import Report, cable_damping, emit, positive
from jaxcable.core.config import enable_x64, use_cpu_devices
from jaxcable.core.simulate import SOLVERS
from jaxcable.studies.sweep import run_histories

__all__ = ["DESCRIPTION", "HELP", "add_arguments", "configure_devices", "run", "sweep_main"]

HELP = "quasi-Monte Carlo robustness sweep"
DESCRIPTION = __doc__.split("\n\n")[0]


def positive_int(flag: str):
    """Argument type: an integer > 0, refused naming ``flag`` (exit status 2)."""

    def parse(text: str) -> int:
        value = int(text)
        if value <= 0:
            raise argparse.ArgumentTypeError(f"{flag} must be a positive integer, got {text}")
        return value

    return parse


def auto_or_positive_int(flag: str):
    """Argument type: ``auto`` or an integer > 0, refused naming ``flag`` (exit status 2)."""

    def parse(text: str):
        return "auto" if text == "auto" else positive_int(flag)(text)

    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``jaxcable sweep``."""
    p = parser
    p.add_argument("--scenario", choices=SCENARIOS, default="I", help="wind scenario of Table 4 (default I)")
    p.add_argument("--n", type=positive_int("--n"), default=100, help="number of Halton cases (default 100, as the paper)")
    p.add_argument("--phase", choices=PHASES, default="passive", help="passive: from capture (Table 8 states); full: two-phase, tracking from the terminal-guidance point (Table 3 states), capture, passive phase at --fidelity")
    p.add_argument(
        "--fidelity",
        choices=SWEEP_FIDELITIES,
        default="rigid",
        help="model level (default rigid, for cost: ~0.1 s per 2 s case once compiled, ale ~1 min)",
    )
    p.add_argument("--out", default="sweep.csv", help="CSV of one row per case; resumed if it exists (default sweep.csv)")
    p.add_argument("--seed", type=int, default=0, help="Halton scrambling seed (default 0)")
    p.add_argument(
        "--batch-size",
        type=auto_or_positive_int("--batch-size"),
        default="auto",
        help="cases per compiled call (default auto: 32 at the rigid level; at ale and full 1 per device on a CPU, 24 on a GPU; "
        "at ale and full, 1 per device streams the cases: each device solves its next case alone as it finishes one)",
    )
    p.add_argument("--t-end", type=positive("--t-end"), default=2.0, help="time simulated after capture [s] (default 2)")
    p.add_argument("--solver", choices=sorted(SOLVERS), default=None, help="diffrax solver (default per level)")
    p.add_argument("--rtol", type=positive("--rtol"), default=None,
                   help="relative = absolute tolerance (default per level; --phase full: the passive phase at ale and full)")
    p.add_argument("--max-steps", type=positive_int("--max-steps"), default=None, help="solver step budget per case (default per level)")
    p.add_argument("--cable-damping", type=cable_damping(), default=DEFAULT_CABLE_DAMPING_S, help=f"cables' stiffness-proportional damping beta [s] (default {DEFAULT_CABLE_DAMPING_S:g} = 'calibrated', fitted to the paper's section III.F, docs/arresting_validation.md; the paper prints none, a_max depends on it: 1e-5 leaves the cables' mode ringing)")
    p.add_argument("--hook-contact", choices=["capsule", "node"], default=None, help="how a hook holds its cable (--fidelity ale, full): node (default), the hook as a sliding node of its cable, or capsule, the Hertz/Coulomb contact of the hook's capsules with every span element (docs/arresting_validation.md)")
    p.add_argument("--span-elements", type=positive_int("--span-elements"), default=None, help="ALE elements per arresting span (--fidelity ale, full; default: the level's, 80 at both)")
    p.add_argument("--fine-elements", type=positive_int("--fine-elements"), default=None, help="of those, fine elements next to each hook (--fidelity ale, full; default: the level's, 16 at both); --hook-contact capsule --span-elements 32 --fine-elements 16 resumes the sweeps recorded before the node became the default")
    p.add_argument("--rocket-bodies", type=positive_int("--rocket-bodies"), default=None, metavar="N", help="rigid bodies of the flexible rocket (--fidelity full; default 5). 1: a rigid rocket with the sprung hinged hooks, within 0.6%% of 5 bodies in every criterion on the design case, the deviated case and 4 section IV cases, in 0.71-0.86x the time (docs/arresting_validation.md)")
    p.add_argument(
        "--confirm",
        metavar="SCREENED_CSV",
        help="rerun, with this command's settings, the cases of a finished screening sweep (e.g. one at --rtol 1e-4 "
        "--t-end 1.2) whose criteria lie within --band of a limit, that failed, or that had not stopped; the rows go to "
        "--out, the screened table with them in place to OUT_merged.csv, and the summary is of the merged table",
    )
    p.add_argument("--band", type=positive("--band"), nargs="+", default=None, metavar="BAND",
                   help="with --confirm: relative distance from a limit inside which a screened verdict is rerun: one number for "
                   "every criterion or three, for z_max, a_max and sigma_max (default: the band measured for the screen's --rtol: "
                   + "; ".join(f"{t:g}: {' '.join(f'{v:g}' for v in b.values())}" for t, b in MEASURED_BANDS.items())
                   + "; a screen at another tolerance needs --band)")
    p.add_argument("--plot", metavar="PREFIX", help="write PREFIX_plane.png (Fig 21), PREFIX_histories.png (Figs 18-20) and, with --phase full, PREFIX_tracking.png (Figs 15-17)")
    p.add_argument("--plot-cases", type=positive_int("--plot-cases"), default=32, help="cases in the histories and tracking plots (default 32)")
    p.add_argument("--process-index", type=int, default=None, help="this host's index in a multi-host sweep (default: jax.process_index())")
    p.add_argument("--process-count", type=int, default=None, help="hosts in a multi-host sweep (default: jax.process_count())")
    p.add_argument(
        "--distributed",
        action="store_true",
        help="call jax.distributed.initialize() first (multi-host; arguments auto-detected on Slurm, Open MPI, TPU)",
    )
    p.add_argument(
        "--coordinator",
        metavar="HOST:PORT",
        help="with --distributed off a managed cluster: the coordinator address (with --process-index/--process-count)",
    )
    p.add_argument(
        "--cpu-devices",
        type=auto_or_positive_int("--cpu-devices"),
        default="auto",
        help="on a CPU host: JAX devices to split the cases of each batch over, one per core (default auto: one per "
        "core this process may use; 1: one device, one core). Ignored when XLA_FLAGS sets a device count and when "
        "jaxcable.cli.main(argv) is called from Python (there: jaxcable.core.config.use_cpu_devices)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true", help="print one JSON object (the summary)")


def _start_distributed(args) -> None:
    try:
        if args.coordinator:
            jax.distributed.initialize(args.coordinator, num_processes=args.process_count, process_id=args.process_index)
        else:
            jax.distributed.initialize()
    except RuntimeError as err:
        # jax.distributed must start before JAX creates its backends: importing jaxcable does not
        # (tests/test_cpu_devices.py), a JAX operation run earlier in the same process does.
        raise ValueError(
            f"jax.distributed.initialize() failed: {err}\n"
            "Run each host with --process-index I --process-count N instead (the same slices, "
            "without jax.distributed)."
        ) from err


def run(args: argparse.Namespace) -> Report:
    """Run (or resume) the sweep of ``args``: the summary (data), its markdown (text); ``ok`` False
    when some case failed numerically."""
    enable_x64()
    if args.distributed:
        _start_distributed(args)
    p_index = jax.process_index() if args.process_index is None else args.process_index
    p_count = jax.process_count() if args.process_count is None else args.process_count
    out = args.out
    if args.confirm and p_count > 1:
        raise ValueError(f"--confirm runs on one process (merge the screened sweep's files first), got process_count = {p_count}")
    if p_count > 1:
        # one file per process (hosts may share a file system): results.p0of4.csv, ...
        path = Path(out)
        out = str(path.with_name(f"{path.stem}.p{p_index}of{p_count}{path.suffix}"))
    case_kwargs = dict(
        t_end_s=args.t_end, solver=args.solver, rtol=args.rtol, max_steps=args.max_steps, cable_damping_s=args.cable_damping,
        hook_contact=args.hook_contact, n_span_elements=args.span_elements, n_fine=args.fine_elements,
        n_rocket_bodies=args.rocket_bodies,
    )
    sweep_kwargs = {
        "phase": args.phase,
        "fidelity": args.fidelity,
        "out": out,
        "seed": args.seed,
        "batch_size": args.batch_size,
        "process_index": p_index,
        "process_count": p_count,
        "progress": not (args.no_progress or args.json),
        **case_kwargs,
    }
    confirmation = None
    if args.confirm:
        band = None if args.band is None else _band(args.band)
        confirmation = run_confirmation(args.confirm, args.scenario, args.n, band=band, **sweep_kwargs)
        band = confirmation["band"]
        table = confirmation["merged"]
    else:
        table = run_qmc_sweep(args.scenario, args.n, **sweep_kwargs)
    summary = summarize_sweep(table)
    summary.update(
        scenario=args.scenario,
        phase=args.phase,
        fidelity=args.fidelity,
        seed=args.seed,
        out=out,
        process_index=p_index,
        process_count=p_count,
        devices=len(jax.local_devices()),
    )
    summary["wind_applied"] = True
    title = f"scenario {args.scenario}, {args.phase} phase, fidelity {args.fidelity}"
    if confirmation is not None:
        summary["confirmation"] = {
            "screened": args.confirm, "band": band, "cases": confirmation["cases"].tolist(),
            "turned": confirmation["turned"], "merged_csv": confirmation["merged_csv"],
        }  # fmt: skip
        title += f", {args.confirm} with {len(confirmation['cases'])} cases confirmed"
    if args.plot:
        summary["plots"] = [plot_landing_plane(table, f"{args.plot}_plane.png", f"{title}, {summary['n_cases']} cases")]
        # the histories are recomputed for the first --plot-cases cases, from the sweep's own case function
        case_fn = qmc_case_fn(args.scenario, args.phase, args.fidelity, args.seed, **case_kwargs)
        samples = halton_samples(args.n, args.scenario, args.phase, args.seed)
        k = min(args.plot_cases, len(table["case"]))
        hist = run_histories(case_fn, samples, np.asarray(table["case"][:k], int))
        if args.phase == "full":
            t_c = scenario_settings(args.scenario)["t_c_s"]
            summary["plots"].append(plot_tracking(hist, f"{args.plot}_tracking.png", f"{title}: tracking phase, first {k} cases", t_c))
        summary["plots"].append(plot_histories(hist, f"{args.plot}_histories.png", f"{title}: passive phase, first {k} cases"))
    lines = [summary_markdown(summary, title), f"rows in {out}"]
    if confirmation is not None:
        cases = ", ".join(map(str, confirmation["cases"].tolist())) or "none"
        turned = ", ".join(map(str, confirmation["turned"])) or "none"
        lines.append(f"confirmed {len(confirmation['cases'])} cases within {_band_text(band)} of a limit (or failed, or not stopped): {cases}; verdicts turned: {turned}")
        lines.append(f"merged table in {confirmation['merged_csv']}")
    lines += [f"plot written to {path}" for path in summary.get("plots", [])]
    return Report(summary, "\n".join(lines), ok=not summary["n_failed"])


def _band(values: list[float]):
    """``--band``'s one number (every criterion) or three (z_max, a_max, sigma_max) as
    :func:`jaxcable.arresting.screening.cases_to_confirm` takes them."""
    if len(values) == 1:
        return values[0]
    if len(values) == 3:
        return dict(zip((c[0] for c in CRITERIA), values))
    raise ValueError(f"--band takes one number (every criterion) or three (z_max, a_max, sigma_max), got {len(values)}: {values}")


def _band_text(band) -> str:
    if isinstance(band, dict):
        return " / ".join(f"{v:g}" for v in band.values()) + " (z / a / sigma)"
    return f"{band:g}"


def sweep_main(argv: list[str] | None = None) -> int:
    """``jaxcable sweep`` on its own: parse ``argv``, run, print (exit status as :func:`run`'s report)."""
    parser = argparse.ArgumentParser(prog="jaxcable sweep", description=DESCRIPTION)
    add_arguments(parser)
    args = parser.parse_args(argv)
    if argv is None:
        configure_devices(args)
    return emit("sweep", run, args)


def configure_devices(args: argparse.Namespace) -> None:
    """The process's CPU devices from ``--cpu-devices`` (:func:`jaxcable.core.config.use_cpu_devices`).
    Called by a command line of its own process (``jaxcable sweep``) before the first JAX operation;
    not by ``main(argv)`` called from Python, whose process may have chosen its devices already."""
    use_cpu_devices(args.cpu_devices)
