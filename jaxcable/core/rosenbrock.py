r"""A linearly implicit Rosenbrock-W solver for diffrax whose linear solve the scene supplies.

Why a W-method. The stiff parts of the cable scenes (the fine elements' axial modes and their
Rayleigh damping, the hook-cable contact's normal compliance and regularised friction) are local:
each cable node couples only to its neighbours. A Rosenbrock method needs one linear solve per
stage with ``I / (h gamma) - J`` and no Newton iteration; a *W*-method keeps its order with any
approximation ``J`` of the Jacobian, so the scene may hand over only the stiff, structured part
(block-tridiagonal over the nodes of each cable, :mod:`jaxcable.core.banded`) and leave the rest
(the rocket, the pulley and block coordinates, the work integrals) explicit. diffrax's implicit
Runge-Kutta solvers instead build the dense Jacobian from ``n`` JVPs, LU-factor it, iterate a chord
method at least twice, and solve densely again in the adjoint (``../shared/notes/stiff-cables.md``).

Method: ROS34PW2 of Rang and Angermann (2005), "New Rosenbrock W-methods of order 3 for partial
differential algebraic equations of index 1", BIT 45: 4 stages, order 3 as a W-method (any
``J``), embedded order 2 for the error estimate, L-stable (``R(inf) = 0``) and stiffly accurate.
The coefficients are the published ``alpha``, ``gamma``, ``b``, ``b_hat``; the tests check the
order conditions and the measured convergence order. Written in the transformed variables
``U_i = h sum_j gamma_ij k_j`` of Hairer and Wanner (IV.7, eq 7.25):

    (I / (h gamma) - J) U_i = f(t0 + alpha_i h, y0 + sum_j a_ij U_j) + sum_j (c_ij / h) U_j,
    y1 = y0 + sum_i m_i U_i,   error = sum_i (m_i - m_hat_i) U_i,

with ``a = A Gamma^-1``, ``c = diag(1/gamma) - Gamma^-1``, ``m = b Gamma^-1``. ``J`` and its
factorisation are computed once per step at ``(t0, y0)``; the time derivative ``df/dt`` is taken as
zero (allowed for a W-method: the time column of the augmented Jacobian is part of ``J``).
``f(t1, y1)`` is carried to the next step (first same as last), and the saved states between
steps come from the cubic Hermite interpolant on ``(y0, f0, y1, f1)``.

The linear solve. The solver calls ``linearise(t, y)`` (a scene's ``stiff_linearisation``, set by
:func:`jaxcable.core.simulate` when the scene has one), which returns an object with
``factor(beta) -> factors`` and ``factors.solve(rhs) -> x`` solving ``(beta I - J) x = rhs`` on the
state PyTree. Without one, :class:`DenseLinearisation` forms the full Jacobian (the reference the
tests compare the structured solves with; too slow for the cable scenes).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

__all__ = ["DenseLinearisation", "RosenbrockW", "ROS34PW2"]


class _Tableau:
    """ROS34PW2 (Rang & Angermann 2005, Table 4.2 coefficients) and its transformed form."""

    gamma = 4.3586652150845900e-01
    alpha = np.array(
        [
            [0.0, 0.0, 0.0, 0.0],
            [8.7173304301691801e-01, 0.0, 0.0, 0.0],
            [8.4457060015369423e-01, -1.1299064236484185e-01, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )
    Gamma = np.array(
        [
            [gamma, 0.0, 0.0, 0.0],
            [-8.7173304301691801e-01, gamma, 0.0, 0.0],
            [-9.0338057013044082e-01, 5.4180672388095326e-02, gamma, 0.0],
            [2.4212380706095346e-01, -1.2232505839045147e00, 5.4526025533510214e-01, gamma],
        ]
    )
    b = np.array([2.4212380706095346e-01, -1.2232505839045147e00, 1.5452602553351020e00, 4.3586652150845900e-01])
    b_hat = np.array([3.7810903145819369e-01, -9.6042292212423178e-02, 0.5, 2.1793326075422950e-01])
    order = 3
    embedded_order = 2

    def __init__(self):
        G_inv = np.linalg.inv(self.Gamma)
        self.a = self.alpha @ G_inv
        self.c = np.diag(1.0 / np.diag(self.Gamma)) - G_inv
        self.m = self.b @ G_inv
        self.m_err = (self.b - self.b_hat) @ G_inv
        self.stage_times = self.alpha.sum(axis=1)
        self.stages = len(self.b)


ROS34PW2 = _Tableau()


def _axpy(coeffs, trees, base=None):
    """``base + sum_j coeffs[j] trees[j]`` over PyTrees (coefficients Python floats; zeros skipped)."""
    out = base
    for c, tr in zip(coeffs, trees):
        c = float(c)
        if c == 0.0:
            continue
        term = jax.tree_util.tree_map(lambda x: c * x, tr)
        out = term if out is None else jax.tree_util.tree_map(jnp.add, out, term)
    return out


class DenseLinearisation(eqx.Module):
    """``J = df/dy`` dense (``jax.jacfwd`` on the flattened state) and an LU solve of ``beta I - J``:
    the reference for structured linearisations (O(n^3); small systems and tests only)."""

    jacobian: jax.Array
    unravel: Callable = eqx.field(static=True)

    @classmethod
    def of(cls, fn, t, y):
        flat, unravel = ravel_pytree(y)
        jac = jax.jacfwd(lambda v: ravel_pytree(fn(t, unravel(v)))[0])(flat)
        return cls(jac, unravel)

    def factor(self, beta):
        n = self.jacobian.shape[0]
        return _DenseFactors(jax.scipy.linalg.lu_factor(beta * jnp.eye(n, dtype=self.jacobian.dtype) - self.jacobian), self.unravel)


class _DenseFactors(eqx.Module):
    lu: tuple
    unravel: Callable = eqx.field(static=True)

    def solve(self, rhs):
        return self.unravel(jax.scipy.linalg.lu_solve(self.lu, ravel_pytree(rhs)[0]))


class RosenbrockW(diffrax.AbstractAdaptiveSolver):
    """ROS34PW2 (4 stages, order 3, embedded order 2, L-stable W-method) for diffrax.

    ``linearise(t, y)`` returns the structured linearisation (see the module docstring);
    ``None`` uses :class:`DenseLinearisation` of the term's vector field.
    ``simulate(solver="rosw")`` fills it with the scene's ``stiff_linearisation``."""

    linearise: Callable | None = None
    jacobian_every: int = eqx.field(static=True, default=2)
    """Recompute the linearisation every this many accepted steps (a W-method keeps its order with
    a lagged ``J``; the factorisation is redone every step, as ``h`` changes). 1: every step.
    Default 2: a lagged ``J`` costs rejected steps, a fresh one its linearisation. On the design
    case at the calibrated beta, first 0.2 s, rtol 1e-5 (2-core CPU, float64, idle), full level:
    1 -> 5.99 s (3238 steps, 86 rejected), 2 -> 5.39 s (3407, 309), 3 -> 5.51 s, 4 -> 5.81 s (3816,
    852); ale level: 1 -> 4.95 s, 2 -> 4.25 s, 4 -> 4.80 s. On the default model since (the hook
    as a sliding node, 80 span elements) the full level's design case, 1 s at rtol 3e-5 (2-core
    Intel Xeon, idle, two interleaved calls each): 1 -> 19.95 and 18.97 s (5,747 steps), 2 -> 20.89
    and 19.25 s (5,990 steps), criteria equal to 2e-5: 0.97x, within this machine's spread, so the
    default stays. Under ``vmap`` the choice between a
    fresh and a kept ``J`` runs both branches (a batched ``lax.cond`` is a select), so there 1
    costs no more linearisations than 2 and rejects fewer steps."""
    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = diffrax.ThirdOrderHermitePolynomialInterpolation

    def order(self, terms):
        return ROS34PW2.order

    def error_order(self, terms):
        return ROS34PW2.embedded_order + 1

    def __check_init__(self):
        if isinstance(self.jacobian_every, bool) or not isinstance(self.jacobian_every, int) or self.jacobian_every < 1:
            raise ValueError(f"RosenbrockW.jacobian_every must be a positive integer, got {self.jacobian_every!r}")

    def init(self, terms, t0, t1, y0, args):
        # (f(t0, y0), the linearisation, its age in accepted steps)
        return terms.vf(t0, y0, args), self._linearisation(terms, t0, y0, args), jnp.zeros((), jnp.int32)

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)

    def _linearisation(self, terms, t, y, args):
        if self.linearise is not None:
            return self.linearise(t, y)
        return DenseLinearisation.of(lambda t_, y_: terms.vf(t_, y_, args), t, y)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        tab = ROS34PW2
        f0, lin, age = solver_state
        f0 = jax.lax.cond(made_jump, lambda: terms.vf(t0, y0, args), lambda: f0)
        h = t1 - t0
        if self.jacobian_every > 1:
            fresh = made_jump | (age >= self.jacobian_every - 1)
            lin = jax.lax.cond(fresh, lambda: self._linearisation(terms, t0, y0, args), lambda: lin)
            age = jnp.where(fresh, 0, age + 1)
        else:
            lin = self._linearisation(terms, t0, y0, args)
        factors = lin.factor(1.0 / (h * tab.gamma))
        U = []
        for i in range(tab.stages):
            if i == 0:
                f_i = f0
            else:
                y_i = _axpy(tab.a[i, :i], U, base=y0)
                f_i = terms.vf(t0 + tab.stage_times[i] * h, y_i, args)
            if i:
                coupled = _axpy(tab.c[i, :i], U)
                rhs = jax.tree_util.tree_map(lambda f, u: f + u / h, f_i, coupled)
            else:
                rhs = f_i
            U.append(factors.solve(rhs))
        y1 = _axpy(tab.m, U, base=y0)
        y_error = _axpy(tab.m_err, U)
        f1 = terms.vf(t1, y1, args)
        k0 = jax.tree_util.tree_map(lambda f: h * f, f0)
        k1 = jax.tree_util.tree_map(lambda f: h * f, f1)
        dense_info = dict(y0=y0, y1=y1, k0=k0, k1=k1)
        return y1, y_error, dense_info, (f1, lin, age), diffrax.RESULTS.successful
