"""Start-up of the command line with JAX's persistent compilation cache (not a test).

Each command runs twice in fresh processes sharing one compilation-cache folder that is empty before
the first run (``JAXCABLE_CACHE_DIR`` set to a new folder per command): *first* = trace + lower +
compile everything and write the compiled programs, *second* = trace + lower again and read the
programs back. Timed: the wall time of each process, from the parent. Counted inside each process
(``jax.monitoring`` listeners, printed at exit): the programs JAX looked up in the cache, the ones it
found (hits) and wrote, and the seconds spent tracing to jaxprs, lowering to StableHLO and in XLA's
backend compile. A program compiled in the second run although the first run compiled it too was
not written (JAX writes no program holding a host callback) or got a different key (its HLO
changed between processes). Every command prints ``--json``, compared between the two runs.

Writes ``bench_startup.json`` and ``bench_startup.md`` (machine, JAX version, precision, load
averages) into ``experiments/results`` (or ``--out``). Usage:
    python experiments/bench_startup.py                      # every command (~15-25 min on 2 busy cores)
    python experiments/bench_startup.py --commands throw land_1dof --out /tmp/startup
    python experiments/bench_startup.py --diagnose          # also the DIAGNOSES variants
    python experiments/bench_startup.py --rewrite --note "..."   # the .md again from the .json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _report import finish, header, output_dir, start

COMMANDS = {
    "import": ["--import-only"],
    "throw": ["throw", "--json"],
    "land_1dof": ["land", "--fidelity", "1dof", "--json"],
    "land_rigid": ["land", "--fidelity", "rigid", "--json"],
    "land_ale": ["land", "--fidelity", "ale", "--json"],
    "land_full": ["land", "--fidelity", "full", "--json"],
    "land_two_phase_rigid": ["land", "--phase", "full", "--fidelity", "rigid", "--json"],
    "sweep_8": ["sweep", "--n", "8", "--no-progress", "--json", "--out", "{tmp}/sweep.csv"],
    "design_8x3": ["design", "--n", "8", "--steps", "3", "--json"],
}
"""Name -> argv of ``jaxcable`` (``import``: only ``import jaxcable.cli``, the floor of every
command); ``{tmp}`` is a fresh folder per run (a sweep resumes from its CSV)."""

DIAGNOSES = {"throw": {"EQX_ON_ERROR": "nan"}, "land_rigid": {"EQX_ON_ERROR": "nan"}}
"""With ``--diagnose``: these commands again with these environment variables, as ``NAME+diag``.
``EQX_ON_ERROR=nan`` makes equinox's runtime checks (``eqx.error_if``, used by diffrax) substitute
NaN instead of raising through a host callback, so JAX can write the programs holding them: it
measures what the cache would give without those callbacks; the command line does not set it."""

VOLATILE_KEYS = ("wall_s", "out")
"""Keys of a command's JSON left out when the two runs' outputs are compared: the design's wall time,
the sweep's CSV path (a fresh folder per run)."""

# The child process: jaxcable's own main, with listeners counting JAX's compilation events and the
# seconds of each program's XLA compile (or read-back), and a log handler noting the programs JAX
# declined to write because they hold a host callback; all printed to stderr at exit as one line
# that the parent picks out.
_CHILD = r"""
import atexit, collections, json, logging, sys
import jax.monitoring as monitoring
counts, seconds, programs, unwritten = collections.Counter(), collections.Counter(), collections.Counter(), set()
def on_duration(event, s, **kw):
    seconds[event] += s
    if event == "/jax/core/compile/backend_compile_duration":
        programs[kw.get("fun_name", "?")] += s
monitoring.register_event_listener(lambda event, **kw: counts.update([event]))
monitoring.register_event_duration_secs_listener(on_duration)
class Unwritten(logging.Handler):
    def emit(self, record):
        message = record.getMessage()
        if "because it uses host callbacks" in message:
            unwritten.add(message.split("'")[1])
log = logging.getLogger("jax._src.compiler")
log.setLevel(logging.DEBUG)
log.propagate = False
log.addHandler(Unwritten())
atexit.register(lambda: print("BENCH_STARTUP " + json.dumps(dict(
    counts=counts, seconds=seconds, programs=programs.most_common(4), unwritten=sorted(unwritten))), file=sys.stderr))
if sys.argv[1:] == ["--import-only"]:
    import jaxcable.cli
    sys.exit(0)
from jaxcable.cli import main
sys.exit(main(sys.argv[1:]))
"""

_EVENTS = {
    "lookups": "/jax/compilation_cache/compile_requests_use_cache",
    "hits": "/jax/compilation_cache/cache_hits",
    "written": "/jax/compilation_cache/cache_misses",
}
_SECONDS = {
    "trace_s": "/jax/core/compile/jaxpr_trace_duration",
    "lower_s": "/jax/core/compile/jaxpr_to_mlir_module_duration",
    "backend_compile_s": "/jax/core/compile/backend_compile_duration",
}


def _strip(data):
    if isinstance(data, dict):
        return {k: _strip(v) for k, v in data.items() if k not in VOLATILE_KEYS}
    if isinstance(data, list):
        return [_strip(v) for v in data]
    return data


def _cache_files(folder: Path) -> dict:
    files = [p for p in folder.iterdir() if p.is_file()] if folder.exists() else []
    return {"entries": len(files), "bytes": sum(p.stat().st_size for p in files)}


def run_once(argv: list, cache: Path, timeout_s: float, env_extra: dict | None = None) -> dict:
    """One process of ``jaxcable ARGV`` with ``cache`` as its cache folder: wall time, exit status,
    JAX's compilation counts and seconds, the JSON it printed."""
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if k != "JAXCABLE_NO_CACHE"}
        env["JAXCABLE_CACHE_DIR"] = str(cache)
        env.update(env_extra or {})
        cmd = [sys.executable, "-c", _CHILD, *[a.format(tmp=tmp) for a in argv]]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env, check=False)
        wall = time.perf_counter() - t0
    stats = next((json.loads(line.split(" ", 1)[1]) for line in proc.stderr.splitlines() if line.startswith("BENCH_STARTUP ")),
                 {"counts": {}, "seconds": {}, "programs": [], "unwritten": []})  # fmt: skip
    row = {"wall_s": wall, "returncode": proc.returncode}
    row.update({k: int(stats["counts"].get(e, 0)) for k, e in _EVENTS.items()})
    row.update({k: float(stats["seconds"].get(e, 0.0)) for k, e in _SECONDS.items()})
    row["compiled"] = row["lookups"] - row["hits"]
    row["slowest_programs_s"] = stats["programs"]
    row["unwritten_host_callbacks"] = stats["unwritten"]
    if argv == COMMANDS["import"]:
        row["output"] = {} if proc.returncode == 0 else None
    else:
        try:
            row["output"] = json.loads(proc.stdout)
        except json.JSONDecodeError:
            row["output"] = None
    if row["output"] is None:
        row["stderr_tail"] = proc.stderr[-2000:]
    return row


def bench_command(argv: list, timeout_s: float, env_extra: dict | None = None) -> dict:
    """``jaxcable ARGV`` twice with one cache folder, empty before the first run."""
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(tmp) / "cache"
        first = run_once(argv, cache, timeout_s, env_extra)
        after_first = _cache_files(cache)
        second = run_once(argv, cache, timeout_s, env_extra)
        after_second = _cache_files(cache)
    output = first.pop("output")
    same = output is not None and _strip(output) == _strip(second.pop("output"))
    return {
        "argv": argv, "env": env_extra or {}, "output": output, "first": first, "second": second, "cache_after_first": after_first,
        "cache_after_second": after_second, "same_output": same, "speedup": first["wall_s"] / second["wall_s"],
    }  # fmt: skip


def write_md(data: dict, path: Path) -> None:
    lines = ["# Command-line start-up with the persistent compilation cache", "", *header(data), ""]
    lines += [
        "Each command ran twice, in fresh processes, with one cache folder that was empty before the first run. "
        "Wall = the process's wall time (import, trace, lower, XLA compile or read back, run, print). Trace / lower / "
        "XLA = seconds JAX spent tracing to jaxprs, lowering to StableHLO, and compiling with XLA or reading the "
        "compiled program back; looked up / hits / written = programs JAX looked up in the cache, found there, "
        "wrote there; entries, MB: the cache folder after the run. `same` = the two runs printed the same JSON "
        "(timing keys aside). `import` = `import jaxcable.cli` alone. `+diag` = with "
        + ", ".join(f"`{k}={v}`" for k, v in sorted({kv for env in DIAGNOSES.values() for kv in env.items()}))
        + " (see Notes).",
        "",
        "| command | run | wall [s] | trace [s] | lower [s] | XLA [s] | looked up | hits | written | entries | MB | same |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for name, r in data["commands"].items():
        if "error" in r:
            lines.append(f"| {name} | - | error: {r['error']} | | | | | | | | | |")
            continue
        for run in ("first", "second"):
            x, c = r[run], r[f"cache_after_{run}"]
            same = ("yes" if r["same_output"] else "NO") if run == "second" else ""
            lines.append(
                f"| {name if run == 'first' else ''} | {run} | {x['wall_s']:.1f} | {x['trace_s']:.1f} | {x['lower_s']:.1f} | "
                f"{x['backend_compile_s']:.1f} | {x['lookups']} | {x['hits']} | {x['written']} | {c['entries']} | "
                f"{c['bytes'] / 1e6:.1f} | {same} |"
            )
    lines += [
        "",
        "Per command: first / second wall time; the programs with the most XLA seconds in the second run (still "
        "compiled there, or read back); the programs JAX declined to write because they hold a host callback.",
        "",
        "| command | first / second | slowest XLA programs of the second run [s] | not written (host callback) |",
        "|---|---:|---|---|",
    ]
    for name, r in data["commands"].items():
        if "speedup" not in r:
            continue
        slow = ", ".join(f"`{n}` {t:.1f}" for n, t in r["second"]["slowest_programs_s"][:3])
        unwritten = ", ".join(f"`{n}`" for n in r["first"]["unwritten_host_callbacks"]) or "-"
        lines.append(f"| {name} | {r['speedup']:.2f} | {slow} | {unwritten} |")
    lines += ["", "Commands (`jaxcable ARGV`):", ""]
    lines += [f"* {n}: `{' '.join(r['argv'])}`" + (f" with {r['env']}" if r.get("env") else "") for n, r in data["commands"].items()]
    notes = list(data.get("notes", []))
    for name, r in data["commands"].items():
        if "speedup" in r and name != "import":
            second = r["second"]
            notes.append(
                f"{name}: the second run took {second['wall_s'] / r['first']['wall_s']:.0%} of the first; it compiled "
                f"{second['compiled']} of its {second['lookups']} programs again ({second['backend_compile_s']:.1f} s of XLA with "
                f"the read-backs) and traced + lowered for {second['trace_s'] + second['lower_s']:.1f} s, which no cache saves; "
                f"not written for a host callback: {', '.join(r['first']['unwritten_host_callbacks']) or 'none'}."
            )
    if notes:
        lines += ["", "## Notes", "", *[f"* {n}" for n in notes]]
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--commands", nargs="+", choices=list(COMMANDS), default=list(COMMANDS))
    p.add_argument("--diagnose", action="store_true", help="also the DIAGNOSES variants of the chosen commands")
    p.add_argument("--timeout", type=float, default=1800.0, help="seconds one process may take (default 1800)")
    p.add_argument("--out", default=None, help="output folder (default experiments/results)")
    p.add_argument("--note", action="append", default=[], help="a line for the report's notes (repeatable)")
    p.add_argument("--rewrite", action="store_true", help="rewrite bench_startup.md from bench_startup.json, adding the --note lines")
    args = p.parse_args()
    if args.rewrite:
        out = output_dir(args.out)
        data = json.loads((out / "bench_startup.json").read_text())
        data["notes"] = data.get("notes", []) + args.note
        (out / "bench_startup.json").write_text(json.dumps(data, indent=1, default=float))
        write_md(data, out / "bench_startup.md")
        print(f"rewrote {out / 'bench_startup.md'}")
        return
    import jax

    jax.config.update("jax_enable_x64", True)  # the commands run in float64; machine_info records it
    out = output_dir(args.out)
    data = start(commands={}, notes=args.note)
    runs = [(name, COMMANDS[name], None) for name in args.commands]
    if args.diagnose:
        runs += [(f"{name}+diag", COMMANDS[name], env) for name, env in DIAGNOSES.items() if name in args.commands]
    for name, argv, env in runs:
        print(f"{name} ...", flush=True)
        try:
            data["commands"][name] = r = bench_command(argv, args.timeout, env)
            print(f"  first {r['first']['wall_s']:.1f} s, second {r['second']['wall_s']:.1f} s, same output {r['same_output']}",
                  flush=True)  # fmt: skip
        except subprocess.TimeoutExpired as err:
            data["commands"][name] = {"argv": argv, "env": env or {}, "error": f"timed out after {err.timeout:.0f} s"}
    finish(data, out, "bench_startup", write_md)


if __name__ == "__main__":
    main()
