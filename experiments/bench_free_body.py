"""The rigid rocket's Newton-Euler path against the general Kane path, side by side (not a test).

``jaxcable.components.multibody.accelerations`` sends a system without hinges (the rigid and ale levels'
rocket: one body, hooks welded) through Newton-Euler body by body, ``m v_dot = F``,
``J omega_dot = tau - omega x J omega``, instead of the general Kane path (partial velocities by
``jacfwd``, the 6 x 6 mass matrix and its Cholesky solve). The two give the same accelerations and
tangents to round-off (``tests/arresting/test_multibody.py``). This script measures what the
shortcut buys on the rigid design objective (``m_w``, ``F_f``, the paper's design, t_end 1.2 s):
the forward call, the forward-mode gradient and the reverse-mode gradient at each batch size, both
paths compiled ahead of time in one process (for the Kane path ``multibody._free_body_accelerations``
is replaced by ``multibody._kane_accelerations`` while the calls are traced), then timed in turn,
round by round (best of ``--repeats``).

Writes ``experiments/results/bench_free_body.{json,md}``. Usage:
    python experiments/bench_free_body.py                      # ~6 min on 2 cores
    python experiments/bench_free_body.py --n 4 --repeats 1 --out experiments/out
"""

from __future__ import annotations

import argparse

import _report
import jax
import numpy as np

import jaxcable
from jaxcable.components import multibody
from jaxcable.arresting.design import design_problem, objective_and_grad, objective_value, paper_start

PATHS = {"kane": multibody._kane_accelerations, "newton_euler": multibody._free_body_accelerations}


def compiled_calls(n, t_end):
    """Each path's three calls (forward, forward mode, reverse mode), compiled ahead of time."""
    base = design_problem("m_w,F_f", n=n, t_end_s=t_end)
    fm = design_problem("m_w,F_f", n=n, t_end_s=t_end, gradient="forward")
    rev = design_problem("m_w,F_f", n=n, t_end_s=t_end, gradient="reverse")
    u0 = base.space.to_unconstrained(paper_start(base))
    calls = {}
    for path, hinge_free in PATHS.items():
        multibody._free_body_accelerations = hinge_free  # looked up when accelerations is traced
        jax.clear_caches()
        for name, fn, pr in (("forward", objective_value, base), ("forward_mode", objective_and_grad, fm),
                             ("reverse_mode", objective_and_grad, rev)):  # fmt: skip
            compiled = fn.lower(pr, u0).compile()
            calls[f"{path}/{name}"] = (lambda c, p_: (lambda: c(p_, u0)))(compiled, pr)
    multibody._free_body_accelerations = PATHS["newton_euler"]
    return calls


def measure(n, t_end, repeats):
    calls = compiled_calls(n, t_end)
    outs, _, best = _report.time_rounds(calls, repeats)
    row = dict(n=n, seconds=best)
    for path in PATHS:
        fwd = best[f"{path}/forward"]
        row[f"{path}_ratio"] = {k: best[f"{path}/{k}"] / fwd for k in ("forward_mode", "reverse_mode")}
        row[f"{path}_steps"] = int(np.max(outs[f"{path}/forward"][1]["num_steps"]))
    row["speed_up"] = {k: best[f"kane/{k}"] / best[f"newton_euler/{k}"] for k in ("forward", "forward_mode", "reverse_mode")}
    j = {p: float(outs[f"{p}/forward"][0]) for p in PATHS}
    g = {p: np.asarray(outs[f"{p}/forward_mode"][1]) for p in PATHS}
    row["objective"] = j
    row["objective_rel_diff"] = abs(j["kane"] - j["newton_euler"]) / abs(j["kane"])
    row["grad_rel_diff"] = float(np.max(np.abs(g["kane"] - g["newton_euler"]) / np.abs(g["kane"])))
    print(f"n {n}: " + ", ".join(f"{k} {v:.3f} s" for k, v in best.items()), flush=True)
    return row


def write_md(data, path):
    lines = ["# Newton-Euler path against the Kane path (rigid design objective)", "", *_report.header(data), "",
             f"Rigid level, m_w and F_f at the paper's design, t_end {data['t_end']} s, Table 8 captures (seed 0), "
             "chunks 'auto'. Best of the rounds; ratio = gradient / forward call of the same path; speed-up = Kane / "
             "Newton-Euler.", "",
             "| n | path | steps | forward [s] | forward mode [s] (ratio) | reverse mode [s] (ratio) |",
             "|---:|---|---:|---:|---:|---:|"]  # fmt: skip
    for r in data["rows"]:
        for p in PATHS:
            s, q = r["seconds"], r[f"{p}_ratio"]
            lines.append(f"| {r['n']} | {p} | {r[f'{p}_steps']} | {s[f'{p}/forward']:.3f} | "
                         f"{s[f'{p}/forward_mode']:.3f} ({q['forward_mode']:.2f}x) | "
                         f"{s[f'{p}/reverse_mode']:.3f} ({q['reverse_mode']:.2f}x) |")  # fmt: skip
    lines += ["", "| n | speed-up forward | forward mode | reverse mode | objective rel. diff | gradient rel. diff |",
              "|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in data["rows"]:
        u = r["speed_up"]
        lines.append(f"| {r['n']} | {u['forward']:.2f}x | {u['forward_mode']:.2f}x | {u['reverse_mode']:.2f}x | "
                     f"{r['objective_rel_diff']:.1e} | {r['grad_rel_diff']:.1e} |")  # fmt: skip
    lines += ["", "The two paths round differently, which shifts the adaptive steps: the objective and the "
              "gradient differ at that level, not by the physics."]  # fmt: skip
    path.write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32, 64])
    ap.add_argument("--t-end", type=float, default=1.2)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    jaxcable.enable_x64()
    out = _report.output_dir(args.out)
    data = _report.start(t_end=args.t_end)
    data["rows"] = [measure(n, args.t_end, args.repeats) for n in args.n]
    _report.finish(data, out, "bench_free_body", write_md)


if __name__ == "__main__":
    main()
