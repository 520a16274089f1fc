r"""Block-tridiagonal linear algebra with 3x3 blocks, O(n) and differentiable, for cable nodes.

A chain of cable nodes couples each node only to its neighbours, so the Jacobian of the nodal
forces with respect to the nodal positions (or velocities) is block-tridiagonal with 3x3 blocks.
This module gives the two pieces a linearly implicit integrator needs:

* :func:`tridiagonal_blocks`: the blocks of such a Jacobian from 9 Jacobian-vector products
  (colouring: nodes ``j = k (mod 3)`` share a tangent, component by component), never the dense
  Jacobian and never ``3 n`` products;
* :func:`factor` / :func:`solve`: block LU without pivoting (the block Thomas algorithm), for the
  symmetric-positive-definite-like matrices ``beta^2 M - beta C - K`` of a damped elastic chain
  (``M`` the consistent mass, ``-K``, ``-C`` the stiffness and damping). The 3x3 inverses are in
  closed form (cofactors), so each sweep step is elementwise work that XLA fuses; ``jax.lax.scan``
  keeps the cost and the compiled program O(n). Both are plain JAX, so forward and reverse mode
  differentiate through them (structured: the derivative of a scan is a scan).

Layout: a block-tridiagonal matrix is ``(lower, diag, upper)``, each ``(..., n, 3, 3)``:
row block ``j`` is ``lower[j] x[j-1] + diag[j] x[j] + upper[j] x[j+1]`` (``lower[0]`` and
``upper[n-1]`` are ignored). Leading axes batch (e.g. the four cables of an arresting set).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

UNROLL = 1
"""``unroll`` of the sweeps' ``jax.lax.scan`` loops. Measured on the ale design mesh (4 cables x 17
internal nodes, 2-core CPU, JAX 0.10.2, float64, under load): a solve 20 us rolled against 80 us
fully unrolled (unrolled, XLA emits a kernel per 3x3 operation instead of one loop body)."""

__all__ = ["dense", "factor", "inverse3", "matvec", "solve", "tridiagonal_blocks"]


def inverse3(A):
    """Inverse of 3x3 matrices ``A`` (..., 3, 3) by cofactors (no LAPACK call)."""
    a, b, c = A[..., 0, 0], A[..., 0, 1], A[..., 0, 2]
    d, e, f = A[..., 1, 0], A[..., 1, 1], A[..., 1, 2]
    g, h, i = A[..., 2, 0], A[..., 2, 1], A[..., 2, 2]
    co = jnp.stack(
        [
            jnp.stack([e * i - f * h, c * h - b * i, b * f - c * e], axis=-1),
            jnp.stack([f * g - d * i, a * i - c * g, c * d - a * f], axis=-1),
            jnp.stack([d * h - e * g, b * g - a * h, a * e - b * d], axis=-1),
        ],
        axis=-2,
    )
    det = a * co[..., 0, 0] + b * co[..., 1, 0] + c * co[..., 2, 0]
    return co / det[..., None, None]


def _mv(A, x):
    return jnp.sum(A * x[..., None, :], axis=-1)


def _mm(A, B):
    """``A @ B`` for (..., 3, 3) blocks as a multiply-sum (XLA fuses it; a ``dot`` is a separate
    kernel launch on a CPU, and launches, not flops, dominate at this size)."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


def factor(lower, diag, upper):
    """Block LU of a block-tridiagonal matrix: ``(inv_pivots, multipliers, upper)``, each
    ``(..., n, 3, 3)``, where the pivots are ``S_j = D_j - L_j S_{j-1}^-1 U_{j-1}`` and the
    multipliers ``L_j S_{j-1}^-1``. No pivoting: meant for matrices whose pivots stay well
    conditioned (``beta^2 M - beta C - K`` of a damped elastic chain)."""

    def one(lower, diag, upper):
        def step(prev_inv, xs):
            L, D, U_prev = xs
            G = _mm(L, prev_inv)
            S_inv = inverse3(D - _mm(G, U_prev))
            return S_inv, (S_inv, G)

        first = inverse3(diag[0])
        zero = jnp.zeros_like(diag[0])
        _, (inv_rest, G_rest) = jax.lax.scan(step, first, (lower[1:], diag[1:], upper[:-1]), unroll=UNROLL)
        inv_pivots = jnp.concatenate([first[None], inv_rest])
        multipliers = jnp.concatenate([zero[None], G_rest])
        return inv_pivots, multipliers, upper

    batch = diag.shape[:-3]
    fn = one
    for _ in batch:
        fn = jax.vmap(fn)
    return fn(lower, diag, upper)


def solve(factors, rhs):
    """``x`` with ``A x = rhs`` from :func:`factor`'s output; ``rhs`` (..., n, 3)."""
    inv_pivots, multipliers, upper = factors

    def one(inv_pivots, multipliers, upper, b):
        def forward(y_prev, xs):
            G, bj = xs
            y = bj - _mv(G, y_prev)
            return y, y

        _, y = jax.lax.scan(forward, jnp.zeros_like(b[0]), (multipliers, b), unroll=UNROLL)

        def backward(x_next, xs):
            S_inv, U, yj = xs
            x = _mv(S_inv, yj - _mv(U, x_next))
            return x, x

        # upper[n-1] is ignored: x_{n} = 0 enters the last row
        _, x = jax.lax.scan(backward, jnp.zeros_like(b[0]), (inv_pivots, upper, y), reverse=True, unroll=UNROLL)
        return x

    batch = rhs.shape[:-2]
    fn = one
    for _ in batch:
        fn = jax.vmap(fn)
    return fn(inv_pivots, multipliers, upper, rhs)


def matvec(lower, diag, upper, x):
    """``A x`` for a block-tridiagonal ``A`` and ``x`` (..., n, 3)."""
    zero = jnp.zeros_like(x[..., :1, :])
    x_prev = jnp.concatenate([zero, x[..., :-1, :]], axis=-2)
    x_next = jnp.concatenate([x[..., 1:, :], zero], axis=-2)
    return _mv(lower, x_prev) + _mv(diag, x) + _mv(upper, x_next)


def dense(lower, diag, upper):
    """The dense (3n, 3n) matrix of one block-tridiagonal matrix (no batch axes; tests only)."""
    n = diag.shape[0]
    A = jnp.zeros((3 * n, 3 * n), diag.dtype)
    for j in range(n):
        A = A.at[3 * j : 3 * j + 3, 3 * j : 3 * j + 3].set(diag[j])
        if j > 0:
            A = A.at[3 * j : 3 * j + 3, 3 * j - 3 : 3 * j].set(lower[j])
        if j < n - 1:
            A = A.at[3 * j : 3 * j + 3, 3 * j + 3 : 3 * j + 6].set(upper[j])
    return A


def colour_tangents(shape, dtype):
    """The 9 coloured tangents of a nodal array ``shape = (..., n, 3)``: tangent ``3 k + c`` is 1 in
    component ``c`` of every node ``j = k (mod 3)``; returns ``(9, *shape)``."""
    n = shape[-2]
    colour = np.arange(n) % 3
    T = np.zeros((3, 3, n, 3))
    for k in range(3):
        for c in range(3):
            T[k, c, colour == k, c] = 1.0
    T = T.reshape(9, n, 3)
    return jnp.broadcast_to(jnp.asarray(T, dtype).reshape((9,) + (1,) * (len(shape) - 2) + (n, 3)), (9,) + tuple(shape))


def tridiagonal_blocks(products):
    """Blocks ``(lower, diag, upper)`` (..., n, 3, 3) of a block-tridiagonal Jacobian from its 9
    coloured products ``products`` (9, ..., n, 3) (the Jacobian times :func:`colour_tangents`).

    Node ``j``'s output sees only nodes ``j - 1, j, j + 1``, which have three different colours, so
    the column ``c`` of block ``(j, j')`` is component ``c``'s product of the colour of ``j'``."""
    n = products.shape[-2]
    P = products.reshape((3, 3) + products.shape[1:])  # (colour, input component, ..., n, out)
    P = jnp.moveaxis(P, (0, 1), (-3, -1))  # (..., n, colour, out, in)
    j = np.arange(n)

    def pick(colours):
        return P[..., j, colours, :, :]

    diag = pick(j % 3)
    lower = pick((j - 1) % 3)
    upper = pick((j + 1) % 3)
    return lower, diag, upper
