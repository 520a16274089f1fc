"""Trace a method once per structure inside a solve: a cached, inlined ``jax.jit``.

diffrax and the W-method call a scene's vector field at several places of one program (the
stages, the first-same-as-last evaluation, the step after a jump, the event), and diffrax traces
its step more than once, so a vector field, a probe, a linearisation or a structured solve called
plainly is traced at every place. :func:`traced_once` calls it through ``jax.jit(..., inline=True)``:
JAX caches the trace by the arguments' structure and shapes and inlines its equations into the
enclosing program, so the compiled program is the same as a plain call's. On the full level's
design case (0.3 s, 2-core Intel Xeon, JAX 0.10.2 CPU, float64) tracing took 8 s instead of
27 s and the whole cached first call 25.5 s instead of 53.6 s, the same steps and outputs to every
digit (``docs/sweeps.md``, "Start-up"). Inlined rather than a nested call: with the vector field
a nested ``jit`` call, a program that also held a dense LU (the tests' reference of the W-method's
step) failed at run time with "No registered implementation for untyped custom call to
lapack_dgetrf_ffi" (JAX 0.10.2 CPU; not reduced to a smaller case).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["traced_once"]


def traced_once(method, scene, *args):
    """``method(scene, *args)``, traced once per structure and shapes of its arguments (arrays
    traced, everything else static and hashed) and inlined into the enclosing program. ``method``
    must return arrays (a PyTree of them, static fields of modules allowed). A number among
    ``args`` (a time given as a Python or NumPy scalar) is passed as a weakly typed array, so it
    is traced, not a static value that would trace again for every value; bools stay static (a
    switch). Called outside a trace (no argument a tracer), it is a plain call."""
    args = tuple(jnp.asarray(a) if _is_number(a) else a for a in args)
    dynamic, static = eqx.partition((scene, args), eqx.is_array)
    if not any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(dynamic)):
        return method(scene, *args)  # outside a trace: run as before, nothing to compile
    return _inline_call(method, _Static(static), dynamic)


def _is_number(a) -> bool:
    return isinstance(a, (int, float, np.number)) and not isinstance(a, (bool, np.bool_))


class _Static:
    """The non-array part of a call's arguments as a static argument of ``jax.jit`` (hashed by
    its tree structure and leaves, as ``equinox.filter_jit`` hashes them)."""

    def __init__(self, tree):
        self.tree = tree
        self._key = jax.tree_util.tree_flatten(tree)

    def __hash__(self):
        leaves, treedef = self._key
        return hash((treedef, tuple(leaves)))

    def __eq__(self, other):
        return isinstance(other, _Static) and self._key == other._key


def _call(method, static, dynamic):
    scene, args = eqx.combine(dynamic, static.tree)
    return method(scene, *args)


# inline: the trace is cached, and its equations are inlined into the enclosing program (no
# nested call in the compiled program)
_inline_call = jax.jit(_call, static_argnums=(0, 1), inline=True)
