"""Shared plumbing of the experiment scripts' reports (imported by the scripts beside it; a
script run as ``python experiments/NAME.py`` has this folder on its import path).

A report is a dict ``data`` started by :func:`start` (machine, load average, date, the command),
filled by the script, and finished by :func:`finish`, which adds the load at the end and the wall
time and writes ``STEM.json`` and the script's markdown ``STEM.md`` into the output folder."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from jaxcable.provenance import machine_info

ROOT = Path(__file__).resolve().parent.parent


def output_dir(out: str | None) -> Path:
    """``--out`` or ``experiments/results``, created."""
    path = Path(out) if out else ROOT / "experiments" / "results"
    path.mkdir(parents=True, exist_ok=True)
    return path


def start(**fields) -> dict:
    """A new report: machine, load average now, date, the command that ran, and ``fields``; the
    wall clock starts here."""
    info = machine_info()
    script = Path(sys.argv[0]).name
    return dict(
        machine=info, load_start=info["load_average_1_5_15_min"], date=time.strftime("%Y-%m-%d %H:%M:%S"),
        command=" ".join(["python", f"experiments/{script}", *sys.argv[1:]]), _t0=time.perf_counter(), **fields,
    )  # fmt: skip


def finish(data: dict, out: Path, stem: str, write_md) -> None:
    """Add the end load and the wall time, write ``stem``.json and ``write_md(data, stem.md)``."""
    data["load_end"] = machine_info()["load_average_1_5_15_min"]
    data["wall_s"] = time.perf_counter() - data.pop("_t0")
    (out / f"{stem}.json").write_text(json.dumps(data, indent=1, default=float))
    write_md(data, out / f"{stem}.md")
    print(f"wrote {out / f'{stem}.json'}, {out / f'{stem}.md'}")
