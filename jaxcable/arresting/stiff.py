r"""The linear solve of :class:`jaxcable.core.rosenbrock.RosenbrockW` for the arresting scenes.

The W-method's Jacobian ``J`` here holds only the cables' internal nodes: with ``K = dF/dr`` and
``C = dF/dv`` of their generalised forces (block-tridiagonal per cable, from
:meth:`jaxcable.arresting.cable_sets.AleCables.stiff_blocks`) and ``M`` their consistent mass,
``J`` maps ``(dr, dv)`` to ``(dv, M^-1 (K dr + C dv))``; every other coordinate (the rocket, the
pulley and block coordinates, the work integrals) has a zero row and is integrated explicitly by
the same stages. Solving ``(beta I - J) (x_r, x_v) = (b_r, b_v)``: eliminating ``x_r = (b_r +
x_v) / beta`` leaves

    (beta^2 M - beta C - K) x_v = beta M b_v + K b_r,

block-tridiagonal with 3x3 blocks, factored once per step and solved per stage in O(n)
(:mod:`jaxcable.core.banded`), its sweeps split at the spans' ends into chunks taken side by side
(:func:`chain_plan`). Every other component is ``x = b / beta``.
"""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jax.flatten_util import ravel_pytree

from jaxcable.arresting.cable_sets import HookPoints
from jaxcable.core import banded
from jaxcable.core.tracing import traced_once
from jaxcable.core.rosenbrock import DenseLinearisation

__all__ = ["CableLinearisation", "ChainPlan", "ExplicitLinearisation", "HookCoupling", "chain_plan", "dense_reference"]


def _mass_matvec(M, x):
    """Scalar tridiagonal ``M = (lower, diag, upper)`` (..., n) (x) I3 times ``x`` (..., n, 3)."""
    lower, diag, upper = M
    zero = jnp.zeros_like(x[..., :1, :])
    prev = jnp.concatenate([zero, x[..., :-1, :]], axis=-2)
    nxt = jnp.concatenate([x[..., 1:, :], zero], axis=-2)
    return lower[..., None] * prev + diag[..., None] * x + upper[..., None] * nxt


class ExplicitLinearisation(eqx.Module):
    """``J = 0``: every stage is explicit (the scene has no stiff structured part)."""

    def factor(self, beta):
        return _ScaledIdentity(beta)


class _ScaledIdentity(eqx.Module):
    beta: jax.Array

    def solve(self, rhs):
        return jax.tree_util.tree_map(lambda b: b / self.beta, rhs)


CHAIN_CHUNK_NODES = None
"""Default ``max_nodes`` of :func:`chain_plan` for the scenes' linearisation: ``None``, the spans
as they are, packed into chunks that run side by side (no separators). On the default mesh that
is 2 chunks of 40 nodes instead of one sweep over 80: the design case at the full level took
0.91-0.96x the time over its first 0.3 s and 0.97-1.02x (0.99x in one process) over the whole
1 s, in the same steps (a constant-step benchmark of 2e-6 s steps read 1.06x; the docs weigh
them); cutting the spans further at separators (20 nodes, 2 separators a cable; 10 nodes, 6) was
slower, 0.98x and 1.43x, as the border's Schur complement grows (``docs/stiff_integrator.md``,
"Shorter sweeps")."""


class ChainPlan(eqx.Module):
    """How the internal nodes of a cable (identical for the stacked cables) are split for the
    block-tridiagonal sweeps: ``pieces`` (start, stop) runs of internal nodes that couple only
    within themselves once the ``separators`` (internal node indices) are taken into the border;
    the pieces are packed in order into ``chunks`` (tuples of piece indices), each at most
    ``length`` nodes, padded to ``length`` with identity rows. Static: made at trace time."""

    pieces: tuple = eqx.field(static=True)
    separators: tuple = eqx.field(static=True)
    chunks: tuple = eqx.field(static=True)
    length: int = eqx.field(static=True)
    n: int = eqx.field(static=True)

    @property
    def trivial(self):
        """One chunk holding every node in order, no separators: the plain sweeps."""
        return not self.separators and len(self.chunks) <= 1 and self.length == self.n

    def _tables(self):
        """Static index tables: ``src`` (n_chunks * length,) the internal node of each chunk slot
        (0 at a pad), ``real`` its mask, ``first``/``last`` the slots that start/end a piece (their
        coupling to the slot before/after is cut), ``back`` (n,) where each node's value sits in
        ``[chunk slots..., separators...]``."""
        total = len(self.chunks) * self.length
        src = np.zeros(total, dtype=int)
        real = np.zeros(total, dtype=bool)
        first = np.zeros(total, dtype=bool)
        last = np.zeros(total, dtype=bool)
        back = np.zeros(self.n, dtype=int)
        for j, chunk in enumerate(self.chunks):
            slot = j * self.length
            for p in chunk:
                a, b = self.pieces[p]
                src[slot : slot + b - a] = np.arange(a, b)
                real[slot : slot + b - a] = True
                first[slot] = True
                last[slot + b - a - 1] = True
                back[a:b] = np.arange(slot, slot + b - a)
                slot += b - a
        for m, k in enumerate(self.separators):
            back[k] = total + m
        return src, real, first, last, back


def chain_plan(span_nodes, max_nodes: int | None = CHAIN_CHUNK_NODES) -> ChainPlan:
    """The :class:`ChainPlan` of a cable whose spans hold ``span_nodes`` internal nodes each (in
    order; nodes of different spans never couple directly, the span ends being border
    coordinates). A span of more than ``max_nodes`` nodes is cut into equal pieces at the fewest
    separators that make each piece at most ``max_nodes`` long (with a piece on both sides of every
    separator: at ``max_nodes = 1`` an even span keeps one piece of 2); then consecutive pieces are
    packed into chunks of at most ``max_nodes`` nodes (the longest piece, if longer).

    ``max_nodes=None``: no separators; the spans are packed into the chunks that minimise
    ``length * (1 + chunks / 8)``, the sweeps' sequential length weighted by a small cost per
    chunk run side by side (on the default mesh's spans of 1, 39, 39 and 1 nodes: 2 chunks of 40,
    where 4 of 39 would take more work for one step less)."""
    if max_nodes is not None and (isinstance(max_nodes, bool) or not isinstance(max_nodes, int) or max_nodes < 1):
        raise ValueError(f"max_nodes (internal nodes per sweep) must be None or a positive integer, got {max_nodes!r}")
    pieces, separators, start = [], [], 0
    for count in (int(c) for c in span_nodes):
        if count <= 0:
            continue
        cuts = 0  # a piece on both sides of every separator: at most (count - 1) // 2 of them
        while max_nodes is not None and -(-(count - cuts) // (cuts + 1)) > max_nodes and cuts < (count - 1) // 2:
            cuts += 1
        sizes = np.full(cuts + 1, (count - cuts) // (cuts + 1))
        sizes[: (count - cuts) % (cuts + 1)] += 1
        a = start
        for i, size in enumerate(sizes):
            pieces.append((a, a + int(size)))
            a += int(size)
            if i < cuts:
                separators.append(a)
                a += 1
        start += count
    sizes = [b - a for a, b in pieces]
    if not sizes:
        return ChainPlan((), (), (), 0, 0)
    if max_nodes is None:  # the first of equal costs: the fewest nodes a chunk
        packings = (_pack(sizes, capacity) for capacity in range(max(sizes), sum(sizes) + 1))
        chunks = min(packings, key=lambda c: _chunk_length(sizes, c) * (1.0 + len(c) / 8.0))
    else:
        chunks = _pack(sizes, max([max_nodes] + sizes))
    return ChainPlan(tuple(pieces), tuple(separators), chunks, _chunk_length(sizes, chunks), int(start))


def _chunk_length(sizes, chunks):
    """The nodes in the longest of ``chunks`` (tuples of piece indices into ``sizes``)."""
    return int(max(sum(sizes[p] for p in c) for c in chunks))


def _pack(sizes, capacity):
    """Consecutive pieces of ``sizes`` nodes packed greedily into chunks of at most ``capacity``."""
    chunks, current, used = [], [], 0
    for p, size in enumerate(sizes):
        if current and used + size > capacity:
            chunks.append(tuple(current))
            current, used = [], 0
        current.append(p)
        used += size
    if current:
        chunks.append(tuple(current))
    return tuple(chunks)


def _slots(x, plan, src, real):
    """Internal-node rows ``x`` (c, n, ...) -> chunk slots (c, n_chunks, length, ...), pads zero."""
    picked = x[:, src] * real.reshape((1, -1) + (1,) * (x.ndim - 2))
    return picked.reshape((x.shape[0], len(plan.chunks), plan.length) + x.shape[2:])


def _chunked_blocks(A_rr, plan, tables):
    """The block-tridiagonal ``(lower, diag, upper)`` (c, n, 3, 3) on the chunk slots: pads are
    identity rows, and the coupling across a piece's ends is cut (a separator or another span)."""
    src, real, first, last, _ = tables
    lower, diag, upper = A_rr
    eye = jnp.eye(3, dtype=diag.dtype)
    shape = (1, len(plan.chunks), plan.length, 1, 1)
    keep_lower = (real & ~first).reshape(shape)
    keep_upper = (real & ~last).reshape(shape)
    lo = _slots(lower, plan, src, real) * keep_lower
    up = _slots(upper, plan, src, real) * keep_upper
    di = _slots(diag, plan, src, real) + (~real).reshape(shape) * eye
    return lo, di, up


def _bordered(A_rr, A_rz, A_zr, A_zz, plan):
    """The separators moved into the border: ``(A_rz, A_zr)`` (c, n, 3, Z) over all internal nodes
    and ``A_zz`` (c, Z, Z) with ``Z = 3 n_sep + n_slow`` (separator coordinates first)."""
    if not plan.separators:
        return A_rz, A_zr, A_zz
    lower, diag, upper = A_rr
    c, n = diag.shape[:2]
    m = len(plan.separators)
    sep = np.array(plan.separators)
    # the separators' columns on their neighbours' rows, and their rows on their neighbours' columns
    cols = jnp.zeros((c, n, 3, m, 3), diag.dtype)
    cols = cols.at[:, sep - 1, :, np.arange(m), :].set(jnp.swapaxes(upper[:, sep - 1], 0, 1))
    cols = cols.at[:, sep + 1, :, np.arange(m), :].set(jnp.swapaxes(lower[:, sep + 1], 0, 1))
    rows = jnp.zeros((c, n, 3, m, 3), diag.dtype)  # rows[c, node, i, s, a] = A[(k_s, a), (node, i)]
    rows = rows.at[:, sep - 1, :, np.arange(m), :].set(jnp.swapaxes(jnp.swapaxes(lower[:, sep], -1, -2), 0, 1))
    rows = rows.at[:, sep + 1, :, np.arange(m), :].set(jnp.swapaxes(jnp.swapaxes(upper[:, sep], -1, -2), 0, 1))
    A_rz_x = jnp.concatenate([cols.reshape(c, n, 3, 3 * m), A_rz], axis=-1)
    A_zr_x = jnp.concatenate([rows.reshape(c, n, 3, 3 * m), A_zr], axis=-1)
    top_left = jnp.zeros((c, m, 3, m, 3), diag.dtype).at[:, np.arange(m), :, np.arange(m), :].set(jnp.swapaxes(diag[:, sep], 0, 1))
    top = jnp.concatenate([top_left.reshape(c, 3 * m, 3 * m), A_rz[:, sep].reshape(c, 3 * m, -1)], axis=-1)
    bottom = jnp.concatenate([jnp.swapaxes(A_zr[:, sep].reshape(c, 3 * m, -1), -1, -2), A_zz], axis=-1)
    return A_rz_x, A_zr_x, jnp.concatenate([top, bottom], axis=-2)


class CableLinearisation(eqx.Module):
    """The cables' blocks (:meth:`jaxcable.arresting.cable_sets.AleCables.stiff_blocks`) and where
    their rows sit in the scene's state: ``rows(state) -> (q.r, q.s, q.h, q.u, qdot.r, qdot.s,
    qdot.h, qdot.u)`` of the stacked cable coordinates (the slow coordinates are ``s``, then ``h``
    flattened, then ``u``)."""

    blocks: dict
    rows: Callable = eqx.field(static=True)
    active: tuple = eqx.field(static=True, default=())
    """Slots of the slow coordinates whose rates are prescribed (motor-driven pulleys)."""
    hinge: tuple | None = None
    """``(K_h, C_h)`` (4, 4) each: ``d phi_dd / d phi`` and ``d phi_dd / d phi_dot`` of the hooks'
    hinge coordinates (the spring-dampers of eq 39 and the contact on the hooks, the rocket's
    bodies held fixed), or None (hooks welded)."""
    hinge_rows: Callable | None = eqx.field(static=True, default=None)
    """``hinge_rows(state) -> (hinge angles (4,), hinge rates (4,))``."""
    hinge_reaction: tuple | None = None
    """``(G_v, G_w, k, c)``: the rocket bodies' rows of the same ``J`` through the hinges'
    spring-dampers, ``d (v_dot, omega_dot) / d phi = G k`` and ``/ d phi_dot = G c``: ``G_v``,
    ``G_w`` (nh, nb, 3) the rocket's accelerations per unit hinge torque (the inverse mass matrix's
    columns), ``k = -k_h l_h^2``, ``c = -c_h l_h^2`` (nh,). The spring-damper is a force pair
    between a hook and its body: with only the hook's side in ``J``, the pair is integrated
    differently on its two sides and does work (the full level's energy drift,
    ``docs/stiff_integrator.md``). None: the rocket's rows explicit."""
    speed_rows: Callable | None = eqx.field(static=True, default=None)
    """``speed_rows(state) -> (v (nb, 3), omega_body (nb, 3))`` of the rocket's bodies."""
    coupling: "HookCoupling | None" = None
    """The cable rows' columns on the rocket's coordinates (the contact forces move with the
    hooks), applied as a JVP per solve; None: the hooks held fixed (the rocket's columns zero)."""
    plan: ChainPlan | None = None
    """How the internal nodes are split for the sweeps (:func:`chain_plan`); None: one sweep over
    all of them."""

    def factor(self, beta):
        B = self.blocks
        I3 = jnp.eye(3, dtype=B["K_rr"][1].dtype)
        A_rr = tuple(
            (beta**2) * m[..., None, None] * I3 - beta * c - k for m, c, k in zip(B["M_rr"], B["C_rr"], B["K_rr"])
        )
        A_rz = (beta**2) * B["M_rs"] - beta * B["C_rz"] - B["K_rz"]  # (4, n, 3, n_slow)
        A_zr = (beta**2) * B["M_rs"] - beta * B["C_zr"] - B["K_zr"]  # the slow rows, transposed (the mass is symmetric)
        A_zz = (beta**2) * B["M_ss"] - beta * B["C_zz"] - B["K_zz"]
        active = list(self.active)
        if active:  # prescribed rates: the row is beta^2 x = beta b
            n_slow = A_zz.shape[-1]
            E = jnp.eye(n_slow, dtype=A_zz.dtype)[active]
            A_zz = A_zz.at[..., active, :].set((beta**2) * E)
            A_zr = A_zr.at[..., active].set(0.0)
        plan = self.plan
        if plan is None or plan.trivial:
            F = banded.factor(*A_rr)
            Y = jax.vmap(lambda col: banded.solve(F, col), in_axes=-1, out_axes=-1)(A_rz)  # A_rr^-1 A_rz
        else:  # shorter sweeps: the chunks side by side, the separators in the border
            tables = plan._tables()
            A_rz, A_zr, A_zz = _bordered(A_rr, A_rz, A_zr, A_zz, plan)
            A_rz, A_zr = (_slots(a, plan, tables[0], tables[1]) for a in (A_rz, A_zr))
            F = banded.factor(*_chunked_blocks(A_rr, plan, tables))
            Y = jax.vmap(lambda col: banded.solve(F, col), in_axes=-1, out_axes=-1)(A_rz)
            A_rz, A_zr, Y = (a.reshape(a.shape[:1] + (-1,) + a.shape[3:]) for a in (A_rz, A_zr, Y))
        S = A_zz - jnp.einsum("cnis,cnit->cst", A_zr, Y)
        hinge_inv = None
        if self.hinge is not None:  # the hooks' hinges: beta^2 I - beta C_h - K_h, inverted once per step
            K_h, C_h = self.hinge
            hinge_inv = _small_inverse((beta**2) * jnp.eye(K_h.shape[0], dtype=K_h.dtype) - beta * C_h - K_h)
        return _CableFactors(F, Y, A_zr, _small_inverse(S), self, beta, hinge_inv)


def _rz(A, x):
    """``(c, n, i, s) x (c, s) -> (c, n, i)``: a border's columns times slow values (a batched
    ``dot``; as a multiply-sum XLA's CPU backend made it a library reduction several times dearer)."""
    c, n, i, s = A.shape
    return jax.lax.dot_general(A.reshape(c, n * i, s), x, (((2,), (1,)), ((0,), (0,)))).reshape(c, n, i)


def _zr(A, x):
    """``(c, n, i, s) x (c, n, i) -> (c, s)``: the transpose (a batched ``dot``)."""
    c, n, i, s = A.shape
    return jax.lax.dot_general(A.reshape(c, n * i, s), x.reshape(c, n * i), (((1,), (1,)), ((0,), (0,))))


def _zz(A, x):
    """``(c, s, t) x (c, t) -> (c, s)`` (a batched ``dot``)."""
    return jax.lax.dot_general(A, x, (((2,), (1,)), ((0,), (0,))))


def _small_inverse(S):
    """Inverse of small (..., k, k) matrices with positive pivots (the Schur complement of the
    positive definite ``beta^2 M - beta C - K`` on the border): Gauss-Jordan without pivoting,
    unrolled (k static), elementwise steps that XLA fuses; no LAPACK call."""
    k = S.shape[-1]
    eye = jnp.broadcast_to(jnp.eye(k, dtype=S.dtype), S.shape)
    M = jnp.concatenate([S, eye], axis=-1)
    rows = np.arange(k)[:, None]
    for i in range(k):
        pivot_row = M[..., i, :] / M[..., i, i : i + 1]
        M = jnp.where(rows == i, pivot_row[..., None, :], M - M[..., :, i : i + 1] * pivot_row[..., None, :])
    return M[..., k:]


def _slow(s, h, u):
    return jnp.concatenate([s, h.reshape(h.shape[:-2] + (-1,)), u[..., None]], axis=-1)


class _CableFactors(eqx.Module):
    F: tuple
    Y: jax.Array
    A_zr: jax.Array
    S_inv: jax.Array
    lin: CableLinearisation
    beta: jax.Array
    hinge_inv: jax.Array | None = None
    """``(beta^2 I - beta C_h - K_h)^-1`` (nh, nh) of the hooks' hinge rows, None without hinges."""

    def solve(self, rhs):
        return traced_once(type(self)._solve, self, rhs)

    def _solve(self, rhs):
        beta, B = self.beta, self.lin.blocks
        out = jax.tree_util.tree_map(lambda b: b / beta, rhs)
        if self.lin.hinge is not None:
            # the hooks' hinges: (beta^2 I - beta C_h - K_h) x_rate = beta b_rate + K_h b_angle
            K_h, _ = self.lin.hinge
            b_a, b_w = self.lin.hinge_rows(rhs)
            x_w = jnp.sum(self.hinge_inv * (beta * b_w + K_h @ b_a)[None, :], axis=-1)
            x_a = (b_a + x_w) / beta
            out = eqx.tree_at(self.lin.hinge_rows, out, (x_a, x_w))
            if self.lin.hinge_reaction is not None:
                # the rocket's speeds: beta x_v - G (k x_a + c x_w) = b_v, after the hinges
                G_v, G_w, k, c = self.lin.hinge_reaction
                tau = k * x_a + c * x_w
                b_v, b_o = self.lin.speed_rows(rhs)
                new = (b_v + jnp.einsum("h,hbi->bi", tau, G_v)) / beta, (b_o + jnp.einsum("h,hbi->bi", tau, G_w)) / beta
                out = eqx.tree_at(self.lin.speed_rows, out, new)
        bq_r, bq_s, bq_h, bq_u, bv_r, bv_s, bv_h, bv_u = self.lin.rows(rhs)
        bq_z, bv_z = _slow(bq_s, bq_h, bq_u), _slow(bv_s, bv_h, bv_u)
        g_r = (
            beta * (_mass_matvec(B["M_rr"], bv_r) + _rz(B["M_rs"], bv_z))
            + banded.matvec(*B["K_rr"], bq_r)
            + _rz(B["K_rz"], bq_z)
        )
        g_z = (
            beta * (_zr(B["M_rs"], bv_r) + _zz(B["M_ss"], bv_z))
            + _zr(B["K_zr"], bq_r)
            + _zz(B["K_zz"], bq_z)
        )
        if self.lin.coupling is not None:
            # the rocket's rows are solved first (J holds no cable columns there); their solution
            # moves the hooks, whose contact forces enter the cable rows: + beta D x_rocket
            d_r, d_z = self.lin.coupling.forces_jvp(self.lin.coupling.rows(out))
            g_r, g_z = g_r + beta * d_r, g_z + beta * d_z
        active = list(self.lin.active)
        if active:
            g_z = g_z.at[..., active].set(beta * bv_z[..., active])
        plan = self.lin.plan
        if plan is None or plan.trivial:
            w = banded.solve(self.F, g_r)
            x_z = _zz(self.S_inv, g_z - _zr(self.A_zr, w))
            x_r = w - _rz(self.Y, x_z)
        else:
            src, real, _, _, back = plan._tables()
            c, m = g_r.shape[0], len(plan.separators)
            g_x = jnp.concatenate([g_r[:, np.array(plan.separators, dtype=int)].reshape(c, 3 * m), g_z], axis=-1)
            w = banded.solve(self.F, _slots(g_r, plan, src, real)).reshape(c, -1, 3)
            x_x = _zz(self.S_inv, g_x - _zr(self.A_zr, w))
            x_slots = w - _rz(self.Y, x_x)
            x_r = jnp.concatenate([x_slots, x_x[:, : 3 * m].reshape(c, m, 3)], axis=1)[:, back]
            x_z = x_x[:, 3 * m :]
        xq_r, xq_z = (bq_r + x_r) / beta, (bq_z + x_z) / beta
        n_p, h_shape = bq_s.shape[-1], bq_h.shape
        new = (
            xq_r, xq_z[..., :n_p], xq_z[..., n_p:-1].reshape(h_shape), xq_z[..., -1],
            x_r, x_z[..., :n_p], x_z[..., n_p:-1].reshape(h_shape), x_z[..., -1],
        )  # fmt: skip
        return eqx.tree_at(self.lin.rows, out, new)


class HookCoupling(eqx.Module):
    """The cables' generalised forces as functions of the rocket's state, through the hooks'
    points (the hook-cable contact), linearised at one state: ``forces_jvp(x)`` is ``D x`` with
    ``D = dQ / d(rocket state)`` of :meth:`jaxcable.arresting.cable_sets.AleCables.cable_forces`:
    one JVP of the hooks' points and one of the contact on the pairs picked at that state
    (:meth:`~jaxcable.arresting.cable_sets.AleCables.contact_forces_jvp`; the cables' kinematics
    and the pick computed once per linearisation, not per stage). Without these columns the
    contact node under a hook sees a fixed hook: the W-method's error estimate then resolves the
    node's motion relative to the rocket, holding the step near 3e-5 s on the design case (with
    them, the same error at 4x the step; ``docs/stiff_integrator.md``)."""

    cables: eqx.Module
    rocket: eqx.Module
    cable_state: eqx.Module
    rocket_state: eqx.Module
    kin: eqx.Module
    """The cables' kinematics at ``cable_state`` (:meth:`AleCables.kinematics`)."""
    picked: jax.Array
    """The contact pairs whose derivative is taken (:meth:`AleCables.contact_pairs_picked` with
    ``stiff=True``, as for the cables' blocks and the hinge rows of the same linearisation)."""
    rows: Callable = eqx.field(static=True)
    """``rows(state) -> the rocket's state`` within the scene's state."""

    @classmethod
    def at(cls, cables, rocket, cable_state, rocket_state, rows, kin=None, picked=None):
        """The coupling at one state, with the cables' kinematics (``kin``) and the contact pick
        (``picked``), each computed unless given."""
        kin = cables.kinematics(cable_state) if kin is None else kin
        picked = cables.contact_pairs_picked(kin, _hook_points(rocket, rocket_state), stiff=True) if picked is None else picked
        return cls(cables, rocket, cable_state, rocket_state, kin, picked, rows=rows)

    def forces_jvp(self, x_rocket):
        hooks, d_hooks = jax.jvp(lambda r: _hook_points(self.rocket, r), (self.rocket_state,), (x_rocket,))
        return self.cables.contact_forces_jvp(self.cable_state, self.kin, hooks, d_hooks, self.picked)


def _hook_points(rocket, rocket_state):
    pos, vel = rocket.hook_points_world(rocket_state)
    return HookPoints(positions=pos, velocities=vel)


def dense_reference(lin: CableLinearisation, state):
    """The same ``J`` as ``lin``, assembled densely over the flattened state, as a
    :class:`jaxcable.core.rosenbrock.DenseLinearisation` (LU of ``beta I - J``): the reference the
    tests compare the structured, bordered solve with (O(n^3); small meshes only)."""
    flat, unravel = ravel_pytree(state)
    n = flat.shape[0]
    index = [jnp.asarray(x).astype(int) for x in lin.rows(unravel(jnp.arange(n, dtype=flat.dtype)))]
    q_r, q_s, q_h, q_u, v_r, v_s, v_h, v_u = index
    B = lin.blocks
    J = jnp.zeros((n, n), flat.dtype)
    if lin.coupling is not None:
        r_flat, r_unravel = ravel_pytree(lin.coupling.rows(state))
        i_rocket = ravel_pytree(lin.coupling.rows(unravel(jnp.arange(n, dtype=flat.dtype))))[0].astype(int)

        def coupled(x):
            d_r, d_z = lin.coupling.forces_jvp(r_unravel(x))
            return jnp.concatenate([d_r.reshape(d_r.shape[0], -1), d_z], axis=-1)  # (cables, rows)

        coupling_columns = jax.jacfwd(coupled)(jnp.zeros_like(r_flat))  # (cables, rows, rocket)
    for c in range(q_r.shape[0]):
        iq = jnp.concatenate([q_r[c].reshape(-1), q_s[c].reshape(-1), q_h[c].reshape(-1), q_u[c].reshape(-1)])
        iv = jnp.concatenate([v_r[c].reshape(-1), v_s[c].reshape(-1), v_h[c].reshape(-1), v_u[c].reshape(-1)])
        n_r = q_r[c].size

        def full(tri, rz, zr, zz):
            top = jnp.concatenate([banded.dense(*tri), rz.reshape(n_r, -1)], axis=1)
            bottom = jnp.concatenate([zr.reshape(n_r, -1).T, zz], axis=1)
            return jnp.concatenate([top, bottom], axis=0)

        I3 = jnp.eye(3, dtype=flat.dtype)
        M = full(tuple(m[c][:, None, None] * I3 for m in B["M_rr"]), B["M_rs"][c], B["M_rs"][c], B["M_ss"][c])
        K = full(tuple(k[c] for k in B["K_rr"]), B["K_rz"][c], B["K_zr"][c], B["K_zz"][c])
        C = full(tuple(k[c] for k in B["C_rr"]), B["C_rz"][c], B["C_zr"][c], B["C_zz"][c])
        JK, JC = jnp.linalg.solve(M, K), jnp.linalg.solve(M, C)
        if lin.active:  # prescribed rates: zero rows
            rows = jnp.asarray([n_r + a for a in lin.active])
            JK, JC = JK.at[rows].set(0.0), JC.at[rows].set(0.0)
        J = J.at[iq[:, None], iv[None, :]].set(jnp.eye(iq.size, dtype=flat.dtype))
        J = J.at[iv[:, None], iq[None, :]].set(JK)
        J = J.at[iv[:, None], iv[None, :]].set(JC)
        if lin.coupling is not None:
            D = coupling_columns[c]
            JD = jnp.linalg.solve(M, D)
            if lin.active:
                JD = JD.at[jnp.asarray([n_r + a for a in lin.active])].set(0.0)
            J = J.at[iv[:, None], i_rocket[None, :]].set(JD)
    if lin.hinge is not None:
        ia, iw = (jnp.asarray(x).astype(int) for x in lin.hinge_rows(unravel(jnp.arange(n, dtype=flat.dtype))))
        K_h, C_h = lin.hinge
        J = J.at[ia[:, None], iw[None, :]].set(jnp.eye(ia.size, dtype=flat.dtype))
        J = J.at[iw[:, None], ia[None, :]].set(K_h)
        J = J.at[iw[:, None], iw[None, :]].set(C_h)
        if lin.hinge_reaction is not None:
            G_v, G_w, k, c = lin.hinge_reaction
            i_v, i_o = (jnp.asarray(x).astype(int).reshape(-1) for x in lin.speed_rows(unravel(jnp.arange(n, dtype=flat.dtype))))
            G = jnp.concatenate([G_v.reshape(G_v.shape[0], -1), G_w.reshape(G_w.shape[0], -1)], axis=1).T  # (speeds, nh)
            i_s = jnp.concatenate([i_v, i_o])
            J = J.at[i_s[:, None], ia[None, :]].set(G * k[None, :])
            J = J.at[i_s[:, None], iw[None, :]].set(G * c[None, :])
    return DenseLinearisation(J, unravel)
