r"""Explicit Runge-Kutta solvers for diffrax with the stages unrolled: for small states on a CPU.

Why. diffrax's explicit Runge-Kutta solvers run the stages of a step in a loop over the stage index
(``equinox.internal.while_loop``, which lets one implementation serve every tableau, implicit ones
and reverse-mode autodiff included) and form each stage's state as a dot product of the tableau row
with a stack of the previous stages. For a state of a few hundred numbers on a CPU the step is then
made of many tiny kernels and costs far more than the vector field: on the 20-segment line of
``experiments/peers/moordyn_line.py`` (126 state numbers, 2-core CPU, JAX 0.10.2, float64) the
lumped-mass vector field costs 0.7 us and a ``diffrax.Tsit5`` step 13.7 us (6 evaluations); with 64
cases in one state, a Tsit5 step costs ~160 us on a trivial vector field. Here the stages are written
out in Python at trace time (``a_ij`` as Python floats, zero entries skipped), so XLA fuses each
stage's linear combination into the next evaluation of the vector field: on that line (1 s, rtol =
atol = 1e-8, under load) :class:`FastTsit5` took diffrax.Tsit5's 5553 steps in 0.10 s against 0.15 s.

What. :class:`UnrolledERK` takes any explicit :class:`diffrax.ButcherTableau` and an interpolation;
it keeps ``f(t1, y1)`` in the solver state (the next step's first stage: first-same-as-last when the
tableau has it, one extra evaluation per step when it has not). Two instances:

* :class:`FastTsit5`: Tsitouras' 5(4) pair, the tableau and the 5th-order interpolation of
  ``diffrax.Tsit5`` (same steps, same results to round-off), adaptive;
* :class:`RK4`: the classical 4th-order method (as MoorDyn's ``RK4`` time scheme), for a constant
  step size (``diffrax.ConstantStepSize``): no error estimate; dense output by the cubic Hermite
  interpolant on ``(y0, f0, y1, f1)``.

Both are differentiable in forward and reverse mode like any diffrax solver (the unrolled stages
are plain JAX). Use them where the state is small and the vector field cheap; for a large state the
stage loop's overhead does not matter and ``diffrax``'s own solvers are as fast.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import diffrax
import jax
import numpy as np

__all__ = ["RK4", "AdaptiveUnrolledERK", "FastTsit5", "UnrolledERK"]


def _combine(base, coeffs, trees, scale):
    """``base + scale * sum_j coeffs[j] trees[j]`` (``coeffs`` Python floats; zeros skipped)."""
    terms = [(float(c), tr) for c, tr in zip(coeffs, trees) if float(c) != 0.0]
    if not terms:
        return base

    def leaf(b, *xs):
        acc = terms[0][0] * xs[0]
        for (c, _), x in zip(terms[1:], xs[1:]):
            acc = acc + c * x
        return acc * scale if b is None else b + scale * acc

    if base is None:
        return jax.tree_util.tree_map(lambda *xs: leaf(None, *xs), *[tr for _, tr in terms])
    return jax.tree_util.tree_map(leaf, base, *[tr for _, tr in terms])


class UnrolledERK(diffrax.AbstractSolver):
    """An explicit Runge-Kutta method with its stages unrolled at trace time (see the module docstring).

    Subclasses set ``tableau`` (an explicit ``diffrax.ButcherTableau``), ``interpolation_cls`` and
    ``method_order``. A tableau whose ``b_error`` is all zero gives no error estimate: such a solver
    is for ``diffrax.ConstantStepSize``; :class:`AdaptiveUnrolledERK` is for an embedded pair."""

    tableau: ClassVar[diffrax.ButcherTableau]
    method_order: ClassVar[int]
    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar[Callable]

    def order(self, terms):
        return self.method_order

    def init(self, terms, t0, t1, y0, args):
        return terms.vf(t0, y0, args)

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        f0 = jax.lax.cond(made_jump, lambda: terms.vf(t0, y0, args), lambda: solver_state)
        h = t1 - t0
        y1, f1, fs = self._stages(terms, t0, h, t1, y0, f0, args)
        y_error = _combine(None, self.tableau.b_error, fs, h) if np.any(self.tableau.b_error != 0.0) else None
        dense_info = self._dense_info(h, y0, y1, fs, f1)
        return y1, y_error, dense_info, f1, diffrax.RESULTS.successful

    def _stages(self, terms, t0, h, t1, y0, f0, args):
        """One step of ``h`` from ``(t0, y0)`` with ``f0 = f(t0, y0)``, ending at ``t1``:
        ``(y1, f(t1, y1), the stages' derivatives)``."""
        tab = self.tableau
        fs = [f0]
        y_stage = y0
        for i, row in enumerate(tab.a_lower):
            y_stage = _combine(y0, row, fs, h)
            fs.append(terms.vf(t0 + float(tab.c[i]) * h, y_stage, args))
        if tab.fsal:
            return y_stage, fs[-1], fs
        y1 = _combine(y0, tab.b_sol, fs, h)
        return y1, terms.vf(t1, y1, args), fs

    def _dense_info(self, h, y0, y1, fs, f1):
        def scale(f):
            return jax.tree_util.tree_map(lambda x: h * x, f)

        return {"y0": y0, "y1": y1, "k0": scale(fs[0]), "k1": scale(f1)}


class AdaptiveUnrolledERK(UnrolledERK, diffrax.AbstractAdaptiveSolver):
    """An :class:`UnrolledERK` with an embedded error estimate (``b_error`` nonzero), for adaptive
    step-size controllers."""

    def __check_init__(self):
        if not np.any(self.tableau.b_error != 0.0):
            raise ValueError(f"{type(self).__name__}: the tableau has no embedded error estimate")


class FastTsit5(AdaptiveUnrolledERK):
    """Tsitouras' 5(4) pair (``diffrax.Tsit5``'s tableau and interpolation), stages unrolled; adaptive."""

    tableau: ClassVar = diffrax.Tsit5.tableau
    interpolation_cls: ClassVar = diffrax.Tsit5.interpolation_cls
    method_order: ClassVar[int] = 5

    def _dense_info(self, h, y0, y1, fs, f1):
        k = jax.tree_util.tree_map(lambda *xs: h * jax.numpy.stack(xs), *fs)
        return {"y0": y0, "y1": y1, "k": k}


_rk4_tableau = diffrax.ButcherTableau(
    c=np.array([0.5, 0.5, 1.0]),
    b_sol=np.array([1 / 6, 1 / 3, 1 / 3, 1 / 6]),
    b_error=np.zeros(4),
    a_lower=(np.array([0.5]), np.array([0.0, 0.5]), np.array([0.0, 0.0, 1.0])),
)


class RK4(UnrolledERK):
    """The classical 4th-order Runge-Kutta method (MoorDyn's ``RK4``); constant step size only.
    Dense output: cubic Hermite on ``(y0, h f0, y1, h f1)``.

    ``substeps`` (default 1): each step of the solver loop takes that many RK4 steps of
    ``dt0 / substeps``, written out at trace time. The states at the loop's step ends are those of
    RK4 at ``dt0 / substeps``; fewer loop iterations cost less where each iteration has a fixed
    cost of its own (on a GPU the loop waits for the device at every iteration:
    ``experiments/bench_gpu.py``). Saved times between step ends are Hermite-interpolated over the
    whole ``dt0``, so put them on multiples of ``dt0`` to save RK4's own states."""

    tableau: ClassVar = _rk4_tableau
    interpolation_cls: ClassVar = diffrax.ThirdOrderHermitePolynomialInterpolation
    method_order: ClassVar[int] = 4
    substeps: int = 1

    def __check_init__(self):
        if isinstance(self.substeps, bool) or not isinstance(self.substeps, int) or self.substeps < 1:
            raise ValueError(f"RK4 substeps must be an integer >= 1, got {self.substeps!r}")

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        if self.substeps == 1:
            return super().step(terms, t0, t1, y0, args, solver_state, made_jump)
        h = (t1 - t0) / self.substeps
        f0 = jax.lax.cond(made_jump, lambda: terms.vf(t0, y0, args), lambda: solver_state)
        y, f = y0, f0
        for j in range(self.substeps):
            ta = t0 + j * h
            y, f, _ = self._stages(terms, ta, h, t1 if j == self.substeps - 1 else ta + h, y, f, args)
            # a barrier between substeps keeps XLA from fusing across them, so each substep compiles
            # like one step (the GPU figures in docs/benchmarks.md were measured with it; on a CPU
            # 8 substeps were 11x slower than 8 loop steps with it and without it)
            y, f = jax.lax.optimization_barrier((y, f))
        dense_info = self._dense_info(t1 - t0, y0, y, [f0], f)
        return y, None, dense_info, f, diffrax.RESULTS.successful
