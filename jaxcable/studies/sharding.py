"""Batching and device sharding of single-case functions: one chunk of cases over the local devices.

A *case function* here is any ``eqx.Module`` with ``__call__(params) -> dict`` of scalar outputs
(params: ``{name: scalar}``), optionally ``histories(params) -> dict``, and the two flags of
:class:`jaxcable.studies.sweep.AbstractCaseFunction`:

* ``host_build``: the case is built on the host (``build(params)``, concrete numbers, e.g. a mesh
  made with NumPy) and only ``solve(case)`` / ``solve_histories(case)`` is traced; the built cases
  of a chunk are stacked (:func:`stack_cases`) and the solve is vmapped over the stack;
* ``per_device_loops``: on several devices, True runs each device's share under ``jax.shard_map``
  (its own ``while`` loop, no cross-device step synchronisation); False (a solve that does not trace
  under ``shard_map``) one vmapped call per device on its slice, each from its own thread.

:func:`evaluate` runs one chunk, padded to a fixed size (one compilation per chunk shape), and
returns NumPy arrays. The mesh is 1-D over the local devices with the case axis :data:`AXIS`.
:func:`stream` runs host-built cases one at a time per device, with no chunks: each device's thread
builds its next case while the others solve, and no device waits for another's slower case.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import equinox as eqx
import jax
import numpy as np

__all__ = ["AXIS", "device_mesh", "evaluate", "on_mesh", "per_device", "round_up", "stack_cases", "stream"]

AXIS = "cases"
"""Name of the mesh axis the cases are sharded along."""

_SOLVE_METHOD = {"__call__": "solve", "histories": "solve_histories"}
"""The traced method of a host-built case function, per single-case method."""


def device_mesh(devices=None) -> jax.sharding.Mesh:
    """A 1-D mesh over ``devices`` (default: the local devices), axis :data:`AXIS`."""
    devices = jax.local_devices() if devices is None else list(devices)
    return jax.sharding.Mesh(np.asarray(devices), (AXIS,))


def round_up(a: int, b: int) -> int:
    """The smallest multiple of ``b`` not below ``a``."""
    return -(-a // b) * b


def _sharded_impl(case_fn, batch, mesh, method):
    # shard_map (not a plain sharded vmap): each device runs its own vmapped while-loop, so a
    # device stops when its own cases finish, with no cross-device reduction per step.
    # check_vma=False: diffrax's while-loop carries mix device-varying values (the cases) with
    # replicated ones (constants), which the varying-axes type check rejects; the body has no
    # collectives, so there is nothing for the check to protect.
    P = jax.sharding.PartitionSpec
    if mesh.devices.size == 1:
        return jax.vmap(getattr(case_fn, method))(batch)
    fn_dynamic, fn_static = eqx.partition(case_fn, eqx.is_array)
    batch_dynamic, batch_static = eqx.partition(batch, eqx.is_array)

    def local(fn_dynamic, batch_dynamic):
        fn = eqx.combine(fn_dynamic, fn_static)
        return jax.vmap(getattr(fn, method))(eqx.combine(batch_dynamic, batch_static))

    return jax.shard_map(local, mesh=mesh, in_specs=(P(), P(AXIS)), out_specs=P(AXIS), check_vma=False)(
        fn_dynamic, batch_dynamic
    )


# One compiled function per (case function structure, mesh, method, chunk shape): module level so
# that repeated sweeps (tests, extensions, resumes in one process) reuse the compiled code.
_sharded = eqx.filter_jit(_sharded_impl)


def stack_cases(cases: list):
    """Stack single-case PyTrees along a new leading axis (NumPy arrays); their non-array parts must
    agree (``ValueError`` otherwise)."""
    statics = [eqx.partition(c, eqx.is_array)[1] for c in cases]
    if any(s != statics[0] for s in statics[1:]):
        raise ValueError("the cases of a chunk were built with different static structures; cannot batch them")
    return jax.tree_util.tree_map(lambda *xs: np.stack([np.asarray(x) for x in xs]) if eqx.is_array(xs[0]) else xs[0], *cases)


def evaluate(case_fn, params: dict, mesh, size: int, method: str = "__call__") -> dict:
    """Run ``case_fn`` (``method``: ``"__call__"`` or ``"histories"``) on the cases of ``params``
    (``{name: (k,)}``, k <= size) padded to ``size`` (a multiple of the mesh size) by repeating the
    first case; returns ``{output: np.ndarray (k, ...)}``."""
    k = len(next(iter(params.values())))
    pad = size - k
    padded = {name: np.concatenate([v, np.repeat(v[:1], pad)]) if pad else v for name, v in params.items()}
    if case_fn.host_build:
        batch = stack_cases([case_fn.build({n: v[j] for n, v in padded.items()}) for j in range(size)])
        method = _SOLVE_METHOD[method]
    else:
        batch = padded
    if mesh.devices.size > 1 and not case_fn.per_device_loops:
        out = per_device(case_fn, batch, list(mesh.devices.flat), method)
    else:
        out = on_mesh(case_fn, batch, mesh, method)
    return {name: np.asarray(v)[:k] for name, v in out.items()}


def on_mesh(case_fn, batch, mesh, method) -> dict:
    """The batch placed along the mesh's case axis and run (vmapped, under ``shard_map`` on several
    devices); returns the outputs as JAX arrays (size, ...)."""
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec(AXIS))
    batch = jax.tree_util.tree_map(lambda x: jax.device_put(x, sharding) if eqx.is_array(x) else x, batch)
    return _sharded(case_fn, batch, mesh, method)


def per_device(case_fn, batch, devices, method) -> dict:
    """One vmapped call per device on its equal slice of the batch, each from its own thread, so
    each device steps its own cases in its own ``while`` loop, concurrently. For case functions that
    cannot run under ``shard_map`` (``per_device_loops`` False): one call over the batch sharded
    across the devices makes XLA partition the loop, whose step-size control then waits for every
    device at every step (measured slower than one device). Threads, not asynchronous dispatch: a
    call of these solves returns only when it has finished (measured: two calls dispatched in turn
    took the sum of their times, from two threads the time of one). One compilation per device."""
    size = len(jax.tree_util.tree_leaves(eqx.filter(batch, eqx.is_array))[0])
    per = size // len(devices)

    def run(d):
        part = jax.tree_util.tree_map(lambda x: x[d * per : (d + 1) * per] if eqx.is_array(x) else x, batch)
        return {name: np.asarray(v) for name, v in on_mesh(case_fn, part, device_mesh([devices[d]]), method).items()}

    with ThreadPoolExecutor(len(devices)) as pool:
        outs = list(pool.map(run, range(len(devices))))
    return {name: np.concatenate([o[name] for o in outs]) for name in outs[0]}


# One compiled single-case solve per (case function structure, device): see :func:`stream`.
_solve_one = eqx.filter_jit(lambda case_fn, case: case_fn.solve(case))


def stream(case_fn, params: dict, indices, devices, on_case) -> None:
    """Run the host-built cases ``indices`` of ``params`` (``{name: (n,)}``) one at a time on each of
    ``devices``, and call ``on_case(index, outputs)`` (``{name: np.ndarray (1,)}``) as each finishes,
    in the order they finish, one call at a time (a lock serialises them).

    Each device has a thread that takes the next case, builds it (``case_fn.build``, its compiled
    parts on that device), and solves it alone (``case_fn.solve``, not ``vmap``-ped). Against chunks of one case a device (:func:`evaluate`) no
    device waits for the other's slower case at a chunk's end, and a case's build on the host
    overlaps the other devices' solves. The first exception a case raises stops every thread after
    its current case and is raised here."""
    lock = threading.Lock()
    todo = [int(i) for i in indices][::-1]  # taken from the end: in index order
    failures = []

    def work(device):
        with jax.default_device(device):
            while True:
                with lock:
                    if failures or not todo:
                        return
                    i = todo.pop()
                try:
                    case = case_fn.build({name: v[i] for name, v in params.items()})
                    case = jax.tree_util.tree_map(lambda x: jax.device_put(x, device) if eqx.is_array(x) else x, case)
                    out = {name: np.asarray(v)[None] for name, v in _solve_one(case_fn, case).items()}
                    with lock:
                        on_case(i, out)
                except BaseException as e:  # noqa: BLE001 (re-raised by the caller's thread)
                    with lock:
                        failures.append(e)
                    return

    threads = [threading.Thread(target=work, args=(d,), daemon=True) for d in devices]
    for t in threads:
        t.start()
    for t in threads:
        while t.is_alive():
            t.join(0.5)  # a timed join keeps the main thread responsive to Ctrl-C
    if failures:
        raise failures[0]
