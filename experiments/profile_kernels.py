"""Where a design call's time goes, kernel by kernel (a diagnostic, not a benchmark of record).

Compiles one call of the design objective (``forward``, forward-mode ``fm`` or ``reverse``
gradient) at a level, runs it once under ``jax.profiler.trace`` and sums the time of every XLA
CPU kernel ("thunk") in the trace, then lists the costliest ones with their output shape, whether
XLA made them a library ("ynn") fusion, and the source operation they come from (from the
optimised HLO's metadata).

Read the shares with care: the profiler caps a trace at about a million events (the first part of
the solve is covered; the per-call times stand), profiling slows the run, and XLA's CPU runtime
runs independent kernels on both cores at once, so a kernel's time is not all on the critical
path (session 12: removing a 67 us sort of the ale contact's derivative did not change the wall
time). Confirm any change with a timed comparison (``bench_xla_flags.py``, ``bench_design.py``).

This is how the ale level's slow-coordinate blocks were found (session 12: two library fusions
took most of the ALE vector field: ``CableSubsystem.accelerations`` in ``jaxcable.arresting.cables``).

    python experiments/profile_kernels.py --level ale --call fm          # ~1 min
    python experiments/profile_kernels.py --level rigid --n 32 --call fm --chunk 32

Writes ``experiments/results/profile_kernels_{level}_{call}.{json,md}``.
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import re
import tempfile

import _report


def kernel_table(compiled, args, top: int):
    """Run ``compiled(*args)`` once under the profiler; the ``top`` costliest kernels and totals."""
    import jax

    info = {}
    for line in compiled.as_text().splitlines():
        m = re.match(r"\s*%([\w.\-]+) = (\S+) ", line)
        if m:
            op = re.search(r'op_name="([^"]+)"', line)
            info[m.group(1)] = dict(
                shape=m.group(2).rstrip(",")[:40],
                library_fusion="__ynn_fusion" in line,
                source="/".join(op.group(1).split("/")[-3:]) if op else "",
            )
    jax.block_until_ready(compiled(*args))
    with tempfile.TemporaryDirectory() as d:
        with jax.profiler.trace(d, create_perfetto_trace=True):
            jax.block_until_ready(compiled(*args))
        (path,) = glob.glob(f"{d}/**/perfetto_trace.json.gz", recursive=True)
        with gzip.open(path) as f:
            trace = json.load(f)
    events = trace["traceEvents"] if isinstance(trace, dict) else trace
    total, calls = collections.Counter(), collections.Counter()
    for e in events:
        name = e.get("name", "")
        if e.get("ph") == "X" and name in info:  # the kernels; not the runtime's or Python's spans
            total[name] += e.get("dur", 0.0)
            calls[name] += 1
    all_us = sum(total.values())
    rows = [
        dict(kernel=k, share=v / all_us, us_per_call=v / calls[k], calls=calls[k], **info[k])
        for k, v in total.most_common(top)
    ]  # fmt: skip
    library = sum(v for k, v in total.items() if info[k]["library_fusion"]) / all_us
    return dict(rows=rows, kernel_ms=all_us / 1e3, events=len(events), library_share=library)


def write_md(data, path):
    lines = [f"# Kernel profile: {data['level']} level, {data['call']} call", "", *_report.header(data), "",
             f"Design objective over m_w and F_f at the paper's design, n = {data['n']}, t_end {data['t_end_s']} s, "
             f"chunk {data['chunk']}. One profiled call after a warm-up: {data['kernel_ms']:.0f} ms in kernels over "
             f"{data['events']} trace events (the profiler keeps about a million). Library (ynn) fusions: "
             f"{100 * data['library_share']:.1f}% of the kernel time. Kernels run concurrently on the cores: "
             "a share is not a share of the wall time (module docstring).", "",
             "| share | us per call | calls | kernel | output | library | source |", "|---:|---:|---:|---|---|---|---|"]  # fmt: skip
    for r in data["rows"]:
        lines.append(f"| {100 * r['share']:.1f}% | {r['us_per_call']:.1f} | {r['calls']} | {r['kernel']} | "
                     f"`{r['shape']}` | {'yes' if r['library_fusion'] else ''} | {r['source']} |")  # fmt: skip
    path.write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", choices=["rigid", "ale", "full"], default="ale")
    ap.add_argument("--call", choices=["forward", "fm", "reverse"], default="fm")
    ap.add_argument("--n", type=int, default=None, help="cases (default: 32 at rigid, 1 at ale/full)")
    ap.add_argument("--t-end", type=float, default=None, help="simulated time [s] (default 1.2 rigid, 0.1 ale/full)")
    ap.add_argument("--chunk", default="auto", help="DesignProblem.chunk: auto, none or a number")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()

    import jax

    import jaxcable
    from jaxcable.arresting.design import design_problem, objective_and_grad, objective_value, paper_start

    jaxcable.enable_x64()
    n = args.n or (32 if args.level == "rigid" else 1)
    t_end = args.t_end or (1.2 if args.level == "rigid" else 0.1)
    chunk = None if args.chunk == "none" else (args.chunk if args.chunk == "auto" else int(args.chunk))
    gradient = dict(fm="forward", reverse="reverse").get(args.call, "forward")
    pr = design_problem("m_w,F_f", n=n, fidelity=args.level, t_end_s=t_end, chunk=chunk, gradient=gradient)
    u0 = pr.space.to_unconstrained(paper_start(pr))
    fn = objective_value if args.call == "forward" else objective_and_grad
    compiled = jax.jit(lambda u: fn(pr, u)).lower(u0).compile()
    data = _report.start(level=args.level, call=args.call, n=n, t_end_s=t_end, chunk=args.chunk)
    data.update(kernel_table(compiled, (u0,), args.top))
    _report.finish(data, _report.output_dir(args.out), f"profile_kernels_{args.level}_{args.call}", write_md)


if __name__ == "__main__":
    main()
