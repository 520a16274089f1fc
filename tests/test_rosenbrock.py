"""The Rosenbrock-W solver (ROS34PW2) and the block-tridiagonal algebra it uses on cables.

Checked against things not written here: the published order conditions of the tableau, the
measured convergence order (with the exact Jacobian and with wrong ones: the W-method property),
a closed-form stiff solution, and dense LU solves of the same matrices."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.core import banded
from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import ROS34PW2, DenseLinearisation, RosenbrockW
from jaxcable.core.simulate import SOLVERS

enable_x64()


def test_tableau_order_conditions():
    """Order conditions of a Rosenbrock method up to order 3 (Hairer & Wanner IV.7, Table 7.1)
    with ``beta_ij = alpha_ij + gamma_ij`` and the stage sums ``alpha_i``, ``beta'_i``; and the
    embedded method to order 2. A W-method's extra conditions are checked by measurement below."""
    t = ROS34PW2
    b, bh, A, G = t.b, t.b_hat, t.alpha, t.Gamma
    beta = A + G - np.diag(np.diag(G))  # off-diagonal beta_ij
    a_i = A.sum(1)
    bp_i = beta.sum(1)
    g = t.gamma
    assert abs(b.sum() - 1) < 1e-14
    assert abs(b @ bp_i - (0.5 - g)) < 1e-14
    assert abs(b @ a_i**2 - 1 / 3) < 1e-14
    assert abs(b @ beta @ bp_i - (1 / 6 - g + g**2)) < 1e-14
    assert abs(bh.sum() - 1) < 1e-14
    assert abs(bh @ bp_i - (0.5 - g)) < 1e-14
    # L-stability: R(z) = 1 + z b^T (I - z B)^-1 1 with B = alpha + Gamma tends to
    # 1 - b^T B^-1 1 as z -> -inf: zero
    assert abs(1.0 - b @ np.linalg.solve(A + G, np.ones(4))) < 1e-12


def _van_der_pol(t, y, args):
    return jnp.array([y[1], -y[0] + 0.5 * (1 - y[0] ** 2) * y[1] + 0.3 * jnp.sin(t)])


class _FixedJ(eqx.Module):
    """A deliberately wrong Jacobian (W-method: the order must not depend on it)."""

    J: jax.Array

    def factor(self, beta):
        return DenseLinearisation(self.J, lambda x: x).factor(beta)


@pytest.mark.parametrize(
    "jac", [None, np.zeros((2, 2)), np.array([[0.3, 1.0], [-2.0, 0.1]])], ids=["exact", "zero", "wrong"]
)
def test_convergence_order_three_with_any_jacobian(jac):
    y0 = jnp.array([1.0, 0.0])
    term = diffrax.ODETerm(_van_der_pol)
    ref = diffrax.diffeqsolve(
        term, diffrax.Dopri8(), 0.0, 2.0, 1e-3, y0,
        stepsize_controller=diffrax.PIDController(rtol=1e-13, atol=1e-13), max_steps=100_000,
    ).ys[-1]  # fmt: skip
    lin = None if jac is None else (lambda t, y: _FixedJ(jnp.asarray(jac)))
    errors = []
    for n in (20, 40, 80):
        sol = diffrax.diffeqsolve(term, RosenbrockW(linearise=lin), 0.0, 2.0, 2.0 / n, y0, max_steps=1000)
        errors.append(float(jnp.linalg.norm(sol.ys[-1] - ref)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 2.8) & (orders < 3.3)), (errors, orders)


def test_stiff_scalar_closed_form():
    """``y' = lam (y - cos t) - sin t``, ``y(0) = 1``: the solution is ``cos t`` for every ``lam``. At
    ``lam = -1e8`` an explicit solver needs ~1e8 steps over 10 s; an L-stable method a few hundred."""
    lam = -1e8

    def vf(t, y, args):
        return lam * (y - jnp.cos(t)) - jnp.sin(t)

    ts = jnp.linspace(0.0, 10.0, 11)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(vf), RosenbrockW(), 0.0, 10.0, 1e-3, jnp.array(1.0),
        stepsize_controller=diffrax.PIDController(rtol=1e-6, atol=1e-6), saveat=diffrax.SaveAt(ts=ts),
    )  # fmt: skip
    assert int(sol.stats["num_steps"]) < 500
    assert np.max(np.abs(np.asarray(sol.ys) - np.cos(np.asarray(ts)))) < 1e-5


def test_solver_by_name_and_bad_settings():
    assert SOLVERS["rosw"] is RosenbrockW
    with pytest.raises(ValueError, match="jacobian_every"):
        RosenbrockW(jacobian_every=0)
    # a large scene without a structured linearisation is refused, not run with a dense Jacobian
    from jaxcable import line_throwing_scene, simulate

    with pytest.raises(ValueError, match="stiff_linearisation"):
        simulate(line_throwing_scene(), 1.0, solver="rosw")


def _random_blocks(rng, batch, n):
    L = rng.normal(size=batch + (n, 3, 3))
    U = rng.normal(size=batch + (n, 3, 3))
    D = rng.normal(size=batch + (n, 3, 3)) + 12.0 * np.eye(3)
    L[..., 0, :, :] = 0.0
    U[..., -1, :, :] = 0.0
    return L, D, U


def test_block_tridiagonal_solve_matches_dense_lu():
    rng = np.random.default_rng(0)
    L, D, U = _random_blocks(rng, (2,), 9)
    b = rng.normal(size=(2, 9, 3))
    x = banded.solve(banded.factor(L, D, U), b)
    for k in range(2):
        A = np.asarray(banded.dense(L[k], D[k], U[k]))
        np.testing.assert_allclose(np.asarray(x[k]).reshape(-1), np.linalg.solve(A, b[k].reshape(-1)), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(np.asarray(banded.matvec(L, D, U, x)), b, rtol=1e-11, atol=1e-11)


def test_colouring_recovers_the_blocks_from_nine_products():
    rng = np.random.default_rng(1)
    L, D, U = _random_blocks(rng, (), 10)
    A = banded.dense(L, D, U)

    def f(y):  # a nonlinear map whose Jacobian at 0 is A
        return (A @ y.reshape(-1) + jnp.sin(y.reshape(-1)) ** 2).reshape(10, 3)

    T = banded.colour_tangents((10, 3), jnp.float64)
    P = jax.vmap(lambda t: jax.jvp(f, (jnp.zeros((10, 3)),), (t,))[1])(T)
    lo, di, up = banded.tridiagonal_blocks(P)
    np.testing.assert_allclose(np.asarray(di), D, atol=1e-14)
    np.testing.assert_allclose(np.asarray(lo[1:]), L[1:], atol=1e-14)
    np.testing.assert_allclose(np.asarray(up[:-1]), U[:-1], atol=1e-14)


def test_block_solve_differentiates_like_the_dense_solve():
    """Forward and reverse mode through the structured factor/solve equal those of a dense solve."""
    rng = np.random.default_rng(2)
    L, D, U = _random_blocks(rng, (), 6)
    b = rng.normal(size=(6, 3))

    def structured(s):
        return jnp.sum(banded.solve(banded.factor(L * s, D, U * s), b) ** 2)

    def reference(s):
        return jnp.sum(jnp.linalg.solve(banded.dense(L * s, D, U * s), b.reshape(-1)) ** 2)

    g1, g2 = jax.grad(structured)(0.7), jax.grad(reference)(0.7)
    _, t1 = jax.jvp(structured, (0.7,), (1.0,))
    assert abs(float(g1) - float(g2)) < 1e-10 * max(1.0, abs(float(g2)))
    assert abs(float(t1) - float(g2)) < 1e-10 * max(1.0, abs(float(g2)))
