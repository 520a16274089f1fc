"""XLA's CPU library ("YNN") fusions on and off, on the rigid design objective (not a test).

XLA's CPU compiler hands some small multiply-reduce patterns (the 3 x 3 rotations of the point
kinematics and their tangents) to a library fusion (``kind=kCustom``, "ynn_fusion" in the optimised
HLO). At the rigid level's array sizes these calls cost more than XLA's own loop code: measured in
``experiments/bench_gradient_cost.py``'s loop over the vector field (32 cases), the value and two
tangents take ~48 us with them and ~30 us with ``XLA_FLAGS=--xla_cpu_experimental_ynn_fusion_type=``
(none). This script measures what that does to the design objective (``m_w``, ``F_f``, the paper's
design, t_end 1.2 s): the forward call (chunks of 32), forward mode with chunks of 16 (the CPU auto
size) and of 32, and reverse mode. ``XLA_FLAGS`` is read when JAX starts its CPU client, so each
setting runs in its own process; the settings alternate, ``--rounds`` processes each, best kept.

``--ale`` measures the ale level instead (one design case, 0.1 s, forward call and forward mode;
written to ``bench_xla_flags_ale.{json,md}``).

Writes ``experiments/results/bench_xla_flags.{json,md}``. Usage:
    python experiments/bench_xla_flags.py                    # ~10 min on 2 cores
    python experiments/bench_xla_flags.py --ale              # ~5 min
    python experiments/bench_xla_flags.py --n 8 --rounds 1 --out experiments/out
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import _report

SETTINGS = {"default": "", "ynn_off": "--xla_cpu_experimental_ynn_fusion_type="}


def child(n, repeats, ale=False):
    import jax

    import jaxcable
    from jaxcable.arresting.design import design_problem, objective_and_grad, objective_value, paper_start

    jaxcable.enable_x64()
    level = dict(fidelity="ale", t_end_s=0.1) if ale else dict(t_end_s=1.2)
    base = design_problem("m_w,F_f", n=n, chunk=32, **level)
    u0 = base.space.to_unconstrained(paper_start(base))
    calls = {"forward": lambda: objective_value(base, u0)}
    modes = (("forward_mode_32", dict(gradient="forward", chunk=32)),)
    if not ale:
        modes = (("forward_mode_16", dict(gradient="forward", chunk=16)), *modes,
                 ("reverse_mode", dict(gradient="reverse", chunk=32)))  # fmt: skip
    for label, kw in modes:
        pr = design_problem("m_w,F_f", n=n, **level, **kw)
        calls[label] = (lambda p_: (lambda: objective_and_grad(p_, u0)))(pr)
    outs, first, best = _report.time_rounds(calls, repeats)
    grad = [float(g) for g in outs["forward_mode_32"][1]]
    print(json.dumps(dict(best=best, first=first, grad=grad, objective=float(outs["forward"][0]),
                          float64=bool(jax.config.jax_enable_x64))))


def write_md_ale(data, path):
    lines = ["# XLA CPU library fusions on and off (ale design objective)", "", *_report.header(data), "",
             "ale level, design case (n = 1), m_w and F_f at the paper's design, 0.1 s. Each setting in its own "
             f"process, {data['rounds']} alternating processes per setting, best kept.", "",
             "| setting | forward [s] | forward mode [s] | ratio | compile forward / FM [s] |", "|---|---:|---:|---:|---|"]
    for r in data["rows"]:
        b, f = r["best"], r["first"]
        lines.append(f"| {r['setting']} | {b['forward']:.3f} | {b['forward_mode_32']:.3f} | "
                     f"{b['forward_mode_32'] / b['forward']:.2f}x | {f['forward'] - b['forward']:.1f} / "
                     f"{f['forward_mode_32'] - b['forward_mode_32']:.1f} |")  # fmt: skip
    path.write_text("\n".join(lines) + "\n")


def write_md(data, path):
    lines = ["# XLA CPU library fusions on and off (rigid design objective)", "", *_report.header(data), "",
             f"m_w and F_f at the paper's design, t_end 1.2 s, Table 8 captures (seed 0). Each setting in its own "
             f"process, {data['rounds']} alternating processes per setting, {data['repeats']} rounds inside each; best "
             "kept. ratio = the call / the forward call of the same setting; compile = first call - best "
             "(first process).", "",
             "| n | setting | forward [s] | forward mode, chunks of 16 [s] (ratio) | chunks of 32 [s] (ratio) | "
             "reverse mode [s] (ratio) | compile forward / FM 32 / reverse [s] |",
             "|---:|---|---:|---:|---:|---:|---|"]  # fmt: skip
    for r in data["rows"]:
        b, f = r["best"], r["first"]
        fw = b["forward"]
        comp = " / ".join(f"{f[k] - b[k]:.1f}" for k in ("forward", "forward_mode_32", "reverse_mode"))
        lines.append(f"| {r['n']} | {r['setting']} | {fw:.3f} | {b['forward_mode_16']:.3f} ({b['forward_mode_16'] / fw:.2f}x) | "
                     f"{b['forward_mode_32']:.3f} ({b['forward_mode_32'] / fw:.2f}x) | "
                     f"{b['reverse_mode']:.3f} ({b['reverse_mode'] / fw:.2f}x) | {comp} |")  # fmt: skip
    lines += ["", "| n | speed-up with ynn off: forward | forward mode 16 | forward mode 32 | reverse | gradient rel. diff |",
              "|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for n in sorted({r["n"] for r in data["rows"]}):
        d, o = (next(r for r in data["rows"] if r["n"] == n and r["setting"] == s) for s in SETTINGS)
        g = max(abs(a - b) / abs(a) for a, b in zip(d["grad"], o["grad"]))
        lines.append(f"| {n} | " + " | ".join(f"{d['best'][k] / o['best'][k]:.2f}x" for k in
                     ("forward", "forward_mode_16", "forward_mode_32", "reverse_mode")) + f" | {g:.1e} |")  # fmt: skip
    path.write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[32, 64])
    ap.add_argument("--rounds", type=int, default=2, help="processes per setting and n")
    ap.add_argument("--repeats", type=int, default=3, help="timing rounds inside each process")
    ap.add_argument("--out", default=None)
    ap.add_argument("--ale", action="store_true", help="the ale level (n = 1, 0.1 s) instead")
    ap.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        child(args.child, args.repeats, args.ale)
        return
    if args.ale:
        args.n = [1]
    out = _report.output_dir(args.out)
    data = _report.start(rounds=args.rounds, repeats=args.repeats)
    rows, precisions = {}, set()
    for n in args.n:
        for _ in range(args.rounds):
            for setting, flags in SETTINGS.items():
                env = dict(os.environ, XLA_FLAGS=(os.environ.get("XLA_FLAGS", "") + " " + flags).strip())
                cmd = [sys.executable, __file__, "--child", str(n), "--repeats", str(args.repeats)]
                cmd += ["--ale"] if args.ale else []
                res = subprocess.run(cmd,
                                     env=env, capture_output=True, text=True, check=True)  # fmt: skip
                got = json.loads(res.stdout.strip().splitlines()[-1])
                precisions.add(got["float64"])
                new = dict(n=n, setting=setting, best=got["best"], first=got["first"], grad=got["grad"])
                row = rows.setdefault((n, setting), new)
                row["best"] = {k: min(v, got["best"][k]) for k, v in row["best"].items()}
                print(f"n {n} {setting}: " + ", ".join(f"{k} {v:.3f} s" for k, v in got["best"].items()), flush=True)
    data["rows"] = list(rows.values())
    # The timed calls run in the children, which enable float64; the parent's own setting (read by
    # _report.start) says nothing about them.
    (data["machine"]["float64"],) = precisions
    if args.ale:
        _report.finish(data, out, "bench_xla_flags_ale", write_md_ale)
    else:
        _report.finish(data, out, "bench_xla_flags", write_md)


if __name__ == "__main__":
    main()
