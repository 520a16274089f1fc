r"""The resumable sweep runner: one case function over many cases, batched, sharded, written to CSV.

System-agnostic (systems register their case functions by name, :mod:`jaxcable.studies.registry`;
the arresting-cable QMC sweep of paper section IV is :mod:`jaxcable.arresting.sweep`).

How a sweep is built (physics stays single-case, STYLE.md 3):

* A **case function** (:class:`AbstractCaseFunction`) maps one case's parameters to its scalar
  outputs, ``case_fn(params: dict[str, scalar]) -> dict[str, scalar]``, ``status_code`` (the
  diffrax result code) among them. It is an ``eqx.Module`` (its array fields are parameters too).
* :func:`run_sweep` lifts it with ``jax.vmap`` over chunks of ``batch_size`` cases; each chunk is
  sharded over the local devices (:mod:`jaxcable.studies.sharding`: a 1-D ``Mesh``, the chunk
  padded to a multiple of the device count, ``jax.shard_map`` so each device integrates its own
  cases in its own ``while`` loop; one call per device from its own thread for a case function
  that cannot run under ``shard_map``).
* Rows are appended to a tidy CSV as each chunk finishes (whole lines, flush, fsync) with a sidecar
  JSON holding the sweep's identity; a restarted sweep drops a trailing partial line, skips the cases
  already written, and refuses to resume when its arguments differ. A case whose solver did not
  succeed, or whose outputs are not finite (except those the case function allows,
  :attr:`AbstractCaseFunction.allowed_nonfinite`), is a row with ``failed=True`` and its solver status.
* Multi-host sweeps: each process runs its strided share (:func:`process_indices`) into its own
  file; :func:`merge_sweep_csvs` joins them.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import numpy as np

from jaxcable.core.config import enable_x64
from jaxcable.core.provenance import __version__
from jaxcable.core.simulate import status_message
from jaxcable.core.validation import check_positive
from jaxcable.studies.sharding import device_mesh, evaluate, round_up
from jaxcable.studies.sharding import stream as stream_cases

__all__ = [
    "AbstractCaseFunction",
    "merge_sweep_csvs",
    "process_indices",
    "read_sidecar",
    "read_sweep_csv",
    "run_histories",
    "run_sweep",
    "sidecar_path",
    "update_sidecar",
]

_OK_STATUS = tuple(int(r._value) for r in (diffrax.RESULTS.successful, diffrax.RESULTS.event_occurred))


# ------------------------------------------------------------------------------------------------
# Case functions
# ------------------------------------------------------------------------------------------------


class AbstractCaseFunction(eqx.Module):
    """One case: ``__call__(params) -> dict`` of scalar outputs (``status_code`` and ``num_steps``
    among them); optionally ``histories(params) -> dict`` of time histories for plots.

    A case function whose set-up needs concrete numbers (e.g. a mesh built with NumPy) splits into
    ``build(params) -> case`` (host, concrete scalars) and ``solve(case)`` /
    ``solve_histories(case)`` (traced), and says so with ``host_build = True``: the sweep then builds
    every case of a chunk on the host, stacks them (their static structure must agree) and vmaps
    ``solve`` over the stack. ``__call__`` stays the single-case entry point either way."""

    @property
    def host_build(self) -> bool:
        return False

    @property
    def per_device_loops(self) -> bool:
        """On several devices: True runs each device's share under ``shard_map`` (its own solver
        loop); False (a solve that does not trace under ``shard_map``) one call per device on its
        share, each from its own thread."""
        return True

    @property
    def column_order(self) -> tuple[str, ...]:
        """Outputs written first in the CSV, in this order (the others follow alphabetically, then
        ``status_code`` and ``num_steps``)."""
        return ()

    @property
    def allowed_nonfinite(self) -> dict[str, str]:
        """Outputs that may be non-finite without marking the case failed, each with the boolean
        output that explains it (the case fails only while that flag is True)."""
        return {}

    def __call__(self, params: dict) -> dict:
        raise NotImplementedError

    def histories(self, params: dict) -> dict:
        raise NotImplementedError(f"{type(self).__name__} keeps no time histories")

    def describe(self) -> dict:
        """JSON-able identity of the case function (stored with a sweep; resume checks it)."""
        leaves = jax.tree_util.tree_leaves_with_path(self)
        return {
            "type": type(self).__name__,
            **{jax.tree_util.keystr(p): np.asarray(v).tolist() for p, v in leaves},
        }



# ------------------------------------------------------------------------------------------------
# CSV rows, sidecar, resume
# ------------------------------------------------------------------------------------------------


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "True" if v else "False"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))  # shortest repr that round-trips a float64 exactly


def _parse(text: str):
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def sidecar_path(out_csv) -> Path:
    """The sidecar of a sweep CSV: ``out_csv + ".json"`` (the sweep's identity)."""
    return Path(str(out_csv) + ".json")


def read_sidecar(out_csv) -> dict | None:
    """The sidecar's contents, or ``None`` when the CSV or its sidecar does not exist."""
    side = sidecar_path(out_csv)
    if not (Path(out_csv).exists() and side.exists()):
        return None
    return json.loads(side.read_text())


def update_sidecar(out_csv, **fields) -> None:
    """Set ``fields`` in an existing sidecar (atomically: written aside, then renamed)."""
    side = sidecar_path(out_csv)
    meta = json.loads(side.read_text())
    meta.update(fields)
    tmp = Path(str(side) + ".tmp")
    tmp.write_text(json.dumps(meta, indent=1))
    os.replace(tmp, side)


def _read_rows(path: Path, repair: bool) -> tuple[list[str] | None, list[list[str]]]:
    """Header and complete rows of a sweep CSV. With ``repair``, a trailing partial line (a chunk
    cut by a kill) is truncated off the file."""
    if not path.exists():
        return None, []
    data = path.read_bytes()
    end = data.rfind(b"\n") + 1
    if end < len(data) and repair:
        with open(path, "r+b") as f:
            f.truncate(end)
            f.flush()
            os.fsync(f.fileno())
    lines = data[:end].decode().splitlines()
    if not lines:
        return None, []
    return lines[0].split(","), [line.split(",") for line in lines[1:] if line]


def _append_lines(path: Path, lines: list[str]):
    """Append whole lines and make them durable before the next chunk starts: a kill can cut
    only the last, unfinished write, which the next start truncates."""
    with open(path, "a", encoding="utf-8") as f:
        f.write("".join(line + "\n" for line in lines))
        f.flush()
        os.fsync(f.fileno())


def read_sweep_csv(path) -> dict:
    """A sweep CSV as columns ``{name: np.ndarray}`` sorted by case (complete lines only; a case
    written twice, which a sweep never does, keeps its first row)."""
    header, rows = _read_rows(Path(path), repair=False)
    if header is None:
        raise ValueError(f"{path}: not a sweep CSV (empty)")
    seen, kept = set(), []
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"{path}: a row has {len(row)} fields, the header {len(header)}")
        case = int(row[0])
        if case not in seen:
            seen.add(case)
            kept.append([_parse(x) for x in row])
    kept.sort(key=lambda r: r[0])
    cols = {}
    for j, name in enumerate(header):
        vals = [r[j] for r in kept]
        cols[name] = np.asarray(vals, dtype=object if name == "solver_status" else None)
        if name == "solver_status":
            cols[name] = cols[name].astype(str)
    if not kept:
        cols = {name: np.zeros(0) for name in header}
    return cols


def merge_sweep_csvs(paths: Sequence, out) -> dict:
    """Merge the CSVs of one sweep run on several hosts (same columns) into ``out``, one row per case,
    sorted; returns the merged columns."""
    header, merged = None, {}
    for p in paths:
        h, rows = _read_rows(Path(p), repair=False)
        if h is None:
            continue
        if header is not None and h != header:
            raise ValueError(f"{p}: columns differ from {paths[0]}")
        header = h
        for row in rows:
            merged.setdefault(int(row[0]), row)
    if header is None:
        raise ValueError("no rows to merge")
    tmp = Path(str(out) + ".tmp")
    tmp.write_text(",".join(header) + "\n" + "".join(",".join(merged[i]) + "\n" for i in sorted(merged)))
    os.replace(tmp, out)
    return read_sweep_csv(out)


def _status_text(code: int) -> str:

    return status_message(code).replace(",", ";").replace("\n", " ")


def _failed(outputs: dict, i: int, allowed_nonfinite: dict) -> bool:
    if int(outputs["status_code"][i]) not in _OK_STATUS:
        return True
    for name, v in outputs.items():
        x = v[i]
        if np.issubdtype(np.asarray(x).dtype, np.floating) and not np.isfinite(x):
            flag = allowed_nonfinite.get(name)
            if flag is None or bool(outputs[flag][i]):
                return True
    return False


def process_indices(n: int, process_index: int = 0, process_count: int = 1) -> np.ndarray:
    """Case indices of one process of a multi-host sweep: ``process_index``, ``+ process_count``, ...
    (strided, so growing ``n`` keeps every earlier case on the same process)."""
    if not 0 <= process_index < process_count:
        raise ValueError(f"process_index must be in [0, {process_count}), got {process_index}")
    return np.arange(process_index, n, process_count)


def run_sweep(
    case_fn: AbstractCaseFunction,
    samples: dict,
    out_csv,
    *,
    indices=None,
    batch_size: int = 32,
    identity: dict | None = None,
    devices=None,
    progress: bool = True,
    on_chunk: Callable[[np.ndarray], None] | None = None,
    stream: bool = True,
) -> dict:
    """Run ``case_fn`` on the cases ``indices`` (default all) of ``samples`` ({name: (n,)}), append
    one CSV row per case to ``out_csv`` as each chunk finishes, and return all the file's rows as
    columns (:func:`read_sweep_csv`).

    Resumes: cases already in ``out_csv`` are skipped; the sidecar ``out_csv + ".json"`` stores
    ``identity`` (plus the case function's description and the input names) and a restart with a
    different one raises ``ValueError``. ``batch_size`` (cases per compiled call, padded up to a
    multiple of the device count), ``devices`` and ``progress`` change results only through
    roundoff and may differ on resume.

    A host-built case function (``host_build``) at one case a device (``batch_size`` equal to the
    device count) is streamed (:func:`jaxcable.studies.sharding.stream`): each device takes the next
    case as it finishes one, solves it alone (``solve``, not vmapped), and its row is written then, so rows
    come in the order the cases finish (:func:`read_sweep_csv` sorts them). ``stream=False`` runs
    them in chunks like any other case function (``experiments/bench_sweep_stream.py`` compares
    the two).
    ``on_chunk(case_indices)`` is called after each chunk (a streamed case: each case) is durable
    (logging, tests).
    """

    enable_x64()
    check_positive("batch_size", batch_size)
    names = list(samples)
    arrays = {k: np.asarray(samples[k], dtype=float) for k in names}
    n = len(arrays[names[0]])
    indices = np.arange(n) if indices is None else np.asarray(indices, dtype=int)
    if indices.size and (indices.min() < 0 or indices.max() >= n):
        raise ValueError(f"indices must be in [0, {n}), got {indices.min()}..{indices.max()}")
    mesh = device_mesh(devices)
    n_dev = mesh.devices.size
    out_csv = Path(out_csv)
    side = sidecar_path(out_csv)
    meta = dict(identity=identity or {}, case_fn=case_fn.describe(), inputs=names)
    header, done = _check_resume(out_csv, side, meta, arrays, names)
    if header is None:
        # a new sweep (or one killed before its first chunk): sidecar first, then an empty CSV;
        # the header goes in with the first chunk, once the case function's outputs are known
        out_csv.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(str(side) + ".tmp")
        tmp.write_text(json.dumps(dict(meta, jaxcable=__version__), indent=1))
        os.replace(tmp, side)
        out_csv.write_text("")
    todo = np.array([i for i in indices if int(i) not in done], dtype=int)
    # one chunk shape per sweep (one compilation): the last chunk is padded up to it
    size = round_up(min(batch_size, max(len(todo), 1)), n_dev)
    bar = _progress_bar(len(indices), len(indices) - len(todo), progress)

    def write(idx, outputs):
        nonlocal header
        if "status_code" not in outputs:
            raise ValueError("a case function must return 'status_code' (the solver's result code)")
        out_keys = _ordered(outputs, case_fn.column_order)
        columns = ["case", *names, *out_keys, "solver_status", "failed"]
        lines = []
        if header is None:
            header = columns
            lines.append(",".join(columns))
        elif header != columns:
            raise ValueError(f"{out_csv}: its columns differ from this case function's outputs; refusing to resume")
        for j, case in enumerate(idx):
            failed = _failed(outputs, j, case_fn.allowed_nonfinite)
            row = [_fmt(int(case))] + [_fmt(arrays[k][case]) for k in names]
            row += [_fmt(outputs[k][j]) for k in out_keys]
            row += [_status_text(int(outputs["status_code"][j])), _fmt(failed)]
            lines.append(",".join(row))
        _append_lines(out_csv, lines)
        if bar is not None:
            bar.update(len(idx))
        if on_chunk is not None:
            on_chunk(idx)

    if stream and case_fn.host_build and size == n_dev:
        # one case a device: stream the cases (no chunks; builds overlap the other devices' solves)
        stream_cases(case_fn, arrays, todo, list(mesh.devices.flat), lambda i, out: write(np.array([i]), out))
    else:
        for start in range(0, len(todo), size):
            idx = todo[start : start + size]
            write(idx, evaluate(case_fn, {k: arrays[k][idx] for k in names}, mesh, size))
    if bar is not None:
        bar.close()
    return read_sweep_csv(out_csv)


def _progress_bar(total, initial, show):
    if not show:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, initial=initial, unit="case", desc="sweep", file=sys.stderr)


def _check_resume(out_csv: Path, side: Path, meta: dict, arrays: dict, names: list):
    """The CSV's header (``None`` if it has none yet) and the case indices already written; raises if
    the file belongs to a different sweep."""
    if not out_csv.exists():
        return None, set()
    if not side.exists():
        raise ValueError(
            f"{out_csv} exists without its sidecar {side.name}: not a sweep file (or its sidecar was "
            "deleted); move it away or choose another --out"
        )
    stored = json.loads(side.read_text())
    diffs = [
        f"{key}: stored {stored.get(key)!r}, now {meta[key]!r}"
        for key in meta
        if _jsonable(stored.get(key)) != _jsonable(meta[key])
    ]
    if diffs:
        raise ValueError(
            f"{out_csv} holds a different sweep; refusing to resume (use another --out, or delete "
            "the file and its sidecar to start again). Differences: " + "; ".join(diffs)
        )
    header, rows = _read_rows(out_csv, repair=True)
    if header is None:
        return None, set()
    if header[: 1 + len(names)] != ["case", *names]:
        raise ValueError(f"{out_csv}: its input columns differ from this sweep's; refusing to resume")
    done = set()
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"{out_csv}: a complete line has {len(row)} fields, the header {len(header)}")
        case = int(row[0])
        if case >= len(arrays[names[0]]):
            continue
        # the inputs written must be this sweep's inputs (guards against a changed sampler)
        written = np.array([float(x) for x in row[1 : 1 + len(names)]])
        expected = np.array([arrays[k][case] for k in names])
        if not np.array_equal(written, expected):
            raise ValueError(f"{out_csv}: the inputs of case {case} differ from this sweep's samples; refusing to resume")
        done.add(case)
    return header, done


def _ordered(outputs: dict, column_order) -> list:
    """Output columns: the case function's ``column_order``, then the rest alphabetically, with the
    solver's code and step count last."""
    last = ("status_code", "num_steps")
    first = [k for k in column_order if k in outputs]
    rest = sorted(k for k in outputs if k not in first and k not in last)
    return first + rest + [k for k in last if k in outputs]


def _jsonable(x):
    return json.loads(json.dumps(x))


def run_histories(case_fn: AbstractCaseFunction, samples: dict, indices, *, devices=None) -> dict:
    """Time histories (``case_fn.histories``) of the cases ``indices`` in one batch: {name: (k, n_save)}."""

    enable_x64()
    indices = np.asarray(indices, dtype=int)
    mesh = device_mesh(devices)
    params = {k: np.asarray(v, dtype=float)[indices] for k, v in samples.items()}
    size = round_up(max(len(indices), 1), mesh.devices.size)
    return evaluate(case_fn, params, mesh, size, method="histories")
