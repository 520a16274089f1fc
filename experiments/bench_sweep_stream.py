"""A streamed sweep against chunks of one case a device, at the full level on a CPU (not a test).

Section IV's two-phase cases at the screening settings (``--rtol 1e-4 --t-end 1.2
--rocket-bodies 1``) on two CPU devices (one per core). The first ``--warm`` cases are run once by
each arm (compiling its programs: the streamed arm solves one case unbatched, the chunked arm a
vmapped chunk of one); then each round copies that file and runs the cases ``warm .. n - 1`` with
the arms alternating, so a change of the machine's load hits both alike. Times are of the whole
``run_qmc_sweep`` call (host builds, CSV writes included; programs already compiled in the
process). Also: each arm's steps, and the largest relative difference of the criteria between the
arms. Writes ``bench_sweep_stream.{json,md}``. Usage:

    python experiments/bench_sweep_stream.py                 # 20 cases, 2 rounds: ~25 min on 2 cores
    python experiments/bench_sweep_stream.py --n 8 --rounds 1 --out experiments/out
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import _report


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", default="I", choices=("I", "II", "III"))
    p.add_argument("--n", type=int, default=22, help="cases in all (default 22)")
    p.add_argument("--warm", type=int, default=2, help="cases each arm runs first, to compile (default 2)")
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--out", default=str(Path(__file__).parent / "results"))
    args = p.parse_args()

    from jaxcable.core.config import use_cpu_devices

    use_cpu_devices(2)
    import numpy as np

    from jaxcable.arresting.sweep import run_qmc_sweep
    from jaxcable.core.config import enable_x64
    from jaxcable.studies.sweep import read_sweep_csv, sidecar_path

    enable_x64()  # as the sweep does: the report's machine line states the precision
    report = _report.start(scenario=args.scenario)
    settings = {"phase": "full", "fidelity": "full", "rtol": 1e-4, "t_end_s": 1.2, "n_rocket_bodies": 1, "progress": False}
    tmp = Path(tempfile.mkdtemp())
    arms = {"streamed": True, "chunks of one case a device": False}
    seeds, compile_s = {}, {}
    for name, stream in arms.items():
        out = tmp / f"warm_{stream}.csv"
        t = time.perf_counter()
        run_qmc_sweep(args.scenario, args.warm, out=out, stream=stream, **settings)
        compile_s[name] = time.perf_counter() - t
        seeds[name] = out
    times = {name: [] for name in arms}
    tables = {}
    for r in range(args.rounds):
        for name, stream in arms.items():
            out = tmp / f"round{r}_{stream}.csv"
            shutil.copy(seeds[name], out)
            shutil.copy(sidecar_path(seeds[name]), sidecar_path(out))
            t = time.perf_counter()
            run_qmc_sweep(args.scenario, args.n, out=out, stream=stream, **settings)
            times[name].append(time.perf_counter() - t)
            tables[name] = read_sweep_csv(out)
            print(f"round {r}, {name}: {times[name][-1]:.1f} s", flush=True)
    a, b = (tables[name] for name in arms)
    rest = slice(args.warm, args.n)
    steps = {name: int(np.sum(tables[name]["num_steps"][rest])) for name in arms}
    st = a["num_steps"][rest].astype(float)
    pairs = st[: len(st) // 2 * 2].reshape(-1, 2)
    diffs = {k: float(np.max(np.abs(b[k] / a[k] - 1.0))) for k in ("z_max_m", "a_max_g", "sigma_max_mpa")}
    data = dict(
        report, load_end=_report.load_average(), wall_s=time.perf_counter() - report["_t0"],
        cases=args.n - args.warm, settings=settings,
        first_call_s=compile_s, times_s=times, steps=steps,
        chunk_wait_by_steps=float(pairs.max(axis=1).sum() / (pairs.sum() / 2.0)) if pairs.size else None,
        criteria_rel_diff=diffs,
        ratio_best=min(times["streamed"]) / min(times["chunks of one case a device"]),
        ratio_mean=float(np.mean(times["streamed"]) / np.mean(times["chunks of one case a device"])),
    )  # fmt: skip
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    _report.write_json(out_dir / "bench_sweep_stream.json", data)
    lines = [
        "# A streamed sweep against chunks of one case a device",
        "",
        *_report.header(data),
        "",
        f"Section IV scenario {args.scenario}, cases {args.warm}-{args.n - 1}, full level at the screening settings",
        "(rtol 1e-4, 1.2 s, rigid rocket), two CPU devices; whole `run_qmc_sweep` calls, compiled.",
        "",
        "| arm | times [s] | steps |",
        "|---|---|---:|",
        *[f"| {name} | {', '.join(f'{t:.1f}' for t in times[name])} | {steps[name]:,} |" for name in arms],
        "",
        f"Streamed over chunked: {data['ratio_mean']:.3f}x (means), {data['ratio_best']:.3f}x (best of each).",
        f"The chunks' wait for their slower case, by the steps: {data['chunk_wait_by_steps']:.3f}x.",
        "Largest relative difference of the criteria between the arms: "
        + ", ".join(f"{k} {v:.1e}" for k, v in diffs.items()) + ".",
        f"First calls (compiling, {args.warm} cases): " + ", ".join(f"{k} {v:.0f} s" for k, v in compile_s.items()) + ".",
    ]
    (out_dir / "bench_sweep_stream.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
