"""A batch of single-case computations as one vmap, or as ``lax.map`` over vmapped chunks.

Physics handles one case; a batch is ``jax.vmap`` over the cases. On the CPU a vmapped adaptive
solve's cost per case grows with the batch beyond a few tens of cases (the batch runs in lockstep and
its vectors outgrow the caches), so a large batch runs faster as a ``lax.map`` over chunks:
:func:`chunked_vmap` does that, and :func:`chunk_size` resolves ``"auto"`` to the measured sizes of
``AUTO_CHUNK`` on the CPU (the whole batch elsewhere).
"""

from __future__ import annotations

import diffrax
import jax
import jax.numpy as jnp

__all__ = ["AUTO_CHUNK", "chunk_size", "chunked_vmap"]

AUTO_CHUNK = {"forward": 32, "forward_mode": 16, "reverse_mode": 32}
"""Cases per vmapped call of ``chunk="auto"`` on the CPU, for a forward evaluation, a forward-mode
gradient (``diffrax.ForwardMode``) and a reverse-mode gradient. Measured on the arresting design's
rigid-level batch at n = 32 and 64 (``experiments/bench_design.py --sections chunk``): at n = 64
the forward call runs 1.28x, the forward-mode gradient 1.11x and reverse mode 1.17x faster than one
vmap. With XLA's CPU library fusions turned off (``XLA_FLAGS=--xla_cpu_experimental_ynn_fusion_type=``)
forward mode is faster over chunks of 32: pass ``chunk=32`` then."""


def chunk_size(chunk, adjoint) -> int | None:
    """Cases per vmapped call: ``chunk`` itself (a positive integer, or None for the whole batch),
    or for ``"auto"`` the CPU size of ``AUTO_CHUNK`` by ``adjoint`` (None: a forward evaluation;
    ``diffrax.ForwardMode``; any other adjoint: reverse mode), and the whole batch off the CPU."""
    if chunk != "auto":
        return chunk
    if jax.default_backend() != "cpu":
        return None
    if adjoint is None:
        return AUTO_CHUNK["forward"]
    return AUTO_CHUNK["forward_mode" if isinstance(adjoint, diffrax.ForwardMode) else "reverse_mode"]


def chunked_vmap(fn, inputs, n: int, chunk: int | None):
    """``jax.vmap(fn)(*inputs)`` over the leading axis n, run as ``lax.map`` over chunks of at most
    ``chunk`` cases when ``chunk < n``: as few chunks as that allows, of equal size, so that the
    padding (copies of the last case, outputs dropped) is less than one case per chunk (n = 20 in
    chunks of at most 16: two of 10, not 16 + 4 padded to 32). The chunks are compiled for another
    batch shape, so their vectorised round-off differs from one vmap's; an adaptive solve may then
    step differently, and the results agree to its integration tolerance."""
    if chunk is None or chunk >= n:
        return jax.vmap(fn)(*inputs)
    n_chunks = -(-n // chunk)
    chunk = -(-n // n_chunks)
    pad = n_chunks * chunk - n

    def split(v):
        v = jnp.concatenate([v, jnp.repeat(v[-1:], pad, axis=0)]) if pad else v
        return v.reshape((n_chunks, chunk) + v.shape[1:])

    out = jax.lax.map(lambda args: jax.vmap(fn)(*args), jax.tree_util.tree_map(split, inputs))
    return jax.tree_util.tree_map(lambda v: v.reshape((n_chunks * chunk,) + v.shape[2:])[:n], out)
