r"""A cable over pulleys meshed with ALE elements, with the mesh rules eliminated (eqs 26-34).

Arresting-cable paper, section III.B. One cable runs through a chain of *boundary nodes* (its two
ends and the pulleys it passes over); between two boundary nodes a *span* is meshed with ALE elements
(:mod:`jaxcable.components.ale`). The paper enforces the mesh rules as algebraic constraints inside an
index-3 DAE; diffrax has no DAE solver, and here every rule is linear in the coordinates, so we
eliminate them instead (minimal coordinates; the design note ``docs/arresting_design.md`` compares
this with stabilised penalties by measurement):

* eq 32, cable end on a slider or an anchor: the node's position is the anchor's and its material
  coordinate is constant -> neither is a coordinate;
* eq 33, node on a pulley: position = pulley position -> only its material coordinate ``s`` is a
  coordinate (material flows over the pulley; the pulley radius is ignored, as in the paper);
* eq 34, internal nodes: material coordinates interpolate the span's two boundary coordinates at
  fixed fractions -> only the positions ``r`` of internal nodes are coordinates. We allow graded
  fractions (fine where hooks can touch, coarse elsewhere: the paper's refinement, done by grading
  instead of extra boundary nodes);
* the moving pulley group (:mod:`jaxcable.arresting.buffer`): nodes flagged ``moving`` sit at
  ``p0 + u d`` with ``u`` the block travel, one coordinate; the counterweight rises ``alpha u``.

Generalised coordinates ``q = (r_int (n_int,3), s_pulley (n_p,), u ())``; every nodal position and
material coordinate is an affine function of ``q``. The equations of motion are Lagrange's equations
of the discretised system, not the element-wise virtual work of eqs 29-31:

    M(q) q_dd = - (dp/dq) q_d + dT/dq - dV/dq - dD/dq_d + Q_ext,     p = dT/dq_d = M(q) q_d,

with ``T`` the exact kinetic energy of the piecewise-linear interpolated field (element by element,
``rhoA L/6 (|a1|^2 + a1.a2 + |a2|^2)``, ``a_i = v_i - r' sdot_i`` the material velocity at the element
end: the consistent ALE mass of eq 31), ``V`` strain (tension only, smoothed as in
:mod:`jaxcable.components.ale`) + gravity + counterweight energy, ``D`` the Rayleigh dissipation function
``sum beta EA L eps_dot^2 / 2`` of the damping term of eq 31, and ``Q_ext`` the brake and contact
forces. This differs from eqs 29-31 by the terms concentrated at nodes that slide through material
where the tangent or strain jumps (see :mod:`jaxcable.components.ale`): with them, the undamped discrete
model conserves energy exactly, so a landing's energy budget closes. Mass is conserved exactly: the
end material coordinates are fixed, so ``rhoA (s_end - s_start)`` is constant whatever flows over
the pulleys.

How the vector field is computed (it is evaluated ~10^5 times per landing, and on a CPU
its cost is the number of kernels XLA launches, not flops). The kinematics of a state (nodes,
element tangents, strains, material velocities) are computed once (:meth:`CableSubsystem.kinematics`)
and shared by the forces, the contact (:mod:`jaxcable.arresting.cable_sets`), the dissipation and the
tensions. The element terms of Lagrange's equations are written in closed form
(:meth:`CableSubsystem._element_forces`; autodiff of the element energies is kept as the test
reference :meth:`CableSubsystem._cable_terms_x`), as is the map ``A^T`` to the generalised
coordinates. The mass matrix is never formed: its internal-node block is ``rhoA L_j / 6 That_j``
(x) I3 per span with ``That_j`` constant (it depends only on the material fractions), so its
inverse is a parameter-only matrix, computed once on the host when the scene is built
(:func:`pattern_inverses`), and the Schur
complement on the few pulley/block coordinates is eliminated by an unrolled Gauss-Jordan: no
LAPACK call and no autodiff inside the vector field. ``_accelerations_autodiff`` (dense ``jacfwd``
mass, LU) is the reference the tests compare with (1e-11 relative).

Glossary
--------
===================  ===========================================================================
``boundary_points``  (nb,3) boundary node positions at ``u = 0`` [m]
``kinds``            static tuple, per boundary node: ``"end"``, ``"pulley"`` (passive: ``s`` free),
                     ``"active"`` (the motor-driven pulley of eq 47: ``s`` is a coordinate whose rate
                     ``s_dot = v_p`` is prescribed; its acceleration is an input) or ``"hook"`` (a
                     hook as a sliding node: ``s`` free and its position a coordinate, ``CableCoords.h``;
                     it joins the slow coordinates ``(s, h, u)`` of the mass solve's border)
``moving``           static tuple of bool: boundary node rides the moving pulley block
``elements``         static tuple, ALE elements per span (nb-1 spans)
``fractions``        tuple of (n_j-1,) arrays: internal-node material fractions per span, in (0,1)
``s_boundary0``      (nb,) material coordinates of the boundary nodes at t=0 (ends keep theirs) [m]
``block_direction``  (3,) unit vector: the block moves by ``u * block_direction``
``u``                block travel [m]; counterweight rise ``w = alpha u``
===================  ===========================================================================
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from jaxcable.core.validation import check_finite, check_positive
from jaxcable.components.ale import AleCable, axial_tension_factor, strain_energy_density
from jaxcable.arresting.buffer import BufferDevice

__all__ = [
    "CableCoords",
    "CableKinematics",
    "CableRoute",
    "CableState",
    "CableSubsystem",
    "graded_fractions",
    "pattern_inverses",
]


class CableCoords(eqx.Module):
    """Generalised coordinates (or their rates) of one cable subsystem."""

    r: jax.Array
    """Internal-node positions (n_int, 3) [m] (rates: [m/s])."""
    s: jax.Array
    """Material coordinates of the pulley and hook nodes (n_p,) [m] (rates: [m/s])."""
    u: jax.Array
    """Moving-block travel () [m] (rate: [m/s]); counterweight rise ``alpha u``."""
    h: jax.Array
    """Positions of the ``"hook"`` boundary nodes (n_h, 3) [m] (rates: [m/s]); (0, 3) without any."""

    def __init__(self, r, s, u, h=None):
        self.r, self.s, self.u = r, s, u
        self.h = jnp.zeros(jnp.shape(r)[:-2] + (0, 3), jnp.result_type(r)) if h is None else h


class CableState(eqx.Module):
    """State of one cable subsystem: coordinates and their rates."""

    q: CableCoords
    qdot: CableCoords
    dissipated: jax.Array
    """Energy dissipated so far by cable damping and the brake [J] (integrated for the budget)."""


def graded_fractions(n_elements: int, centre: float, half_width: float, n_fine: int, total: float):
    """Internal-node fractions of a span of material length ``total`` [m]: ``n_fine`` equal elements
    over ``[centre - half_width, centre + half_width]`` (material coordinate from the span start [m]),
    the rest split equally on both sides. Returns a NumPy array of ``n_elements - 1`` fractions."""
    n_coarse = n_elements - n_fine
    if n_fine < 1:
        raise ValueError(f"n_fine (fine elements around the hook) must be >= 1, got {n_fine}")
    if n_coarse < 2:
        raise ValueError(
            f"n_span_elements must be >= n_fine + 2 (a coarse element on each side), got "
            f"n_span_elements={n_elements}, n_fine={n_fine}"
        )
    lo = max(centre - half_width, 1e-3 * total)
    hi = min(centre + half_width, total * (1 - 1e-3))
    n_left = max(1, int(round(n_coarse * lo / (lo + total - hi))))
    n_right = n_coarse - n_left
    if n_right < 1:
        n_left, n_right = n_coarse - 1, 1
    edges = np.concatenate(
        [
            np.linspace(0.0, lo, n_left + 1)[:-1],
            np.linspace(lo, hi, n_fine + 1)[:-1],
            np.linspace(hi, total, n_right + 1),
        ]
    )
    return edges[1:-1] / total


class CableRoute(eqx.Module):
    """Layout of one cable: boundary nodes (ends, pulleys, moving block) joined by ALE spans."""

    boundary_points: jax.Array
    """(nb, 3) boundary-node positions at u = 0 [m]."""
    s_boundary0: jax.Array
    """(nb,) material coordinates of the boundary nodes at t = 0 [m] (strictly increasing)."""
    fractions: tuple
    """Per span, (n_j - 1,) internal-node material fractions in (0, 1), increasing."""
    block_direction: jax.Array
    """(3,) unit direction of the moving block's travel (u > 0 shortens the strands ending on it)."""
    kinds: tuple = eqx.field(static=True)
    """Per boundary node, ``"end"`` (position and material fixed) or ``"pulley"`` (s free)."""
    moving: tuple = eqx.field(static=True)
    """Per boundary node, whether it rides the moving block."""
    pattern_inverses: tuple | None = None
    """Per span with internal nodes, the inverse of its consistent-mass pattern (m_j, m_j), or
    ``None`` (computed from ``fractions`` inside the program). :func:`pattern_inverses` computes
    them on the host from concrete fractions; a scene built so carries them as data, and no
    evaluation of the vector field recomputes them (XLA hoists the in-program inverse, a loop of its
    own, out of diffrax's loop, but not out of every loop around the vector field)."""

    def __check_init__(self):
        check_finite("boundary_points", self.boundary_points)
        check_finite("s_boundary0", self.s_boundary0)
        if len(self.kinds) != len(self.moving) or len(self.fractions) != len(self.kinds) - 1:
            raise ValueError("CableRoute: kinds, moving and fractions must describe the same nodes/spans")
        for k in self.kinds:
            if k not in ("end", "pulley", "active", "hook"):
                raise ValueError(f"unknown boundary kind {k!r}; choose 'end', 'pulley', 'active' or 'hook'")
        for k, m in zip(self.kinds, self.moving):
            if k == "hook" and m:
                raise ValueError("a 'hook' boundary node cannot ride the moving block (its position is a coordinate)")
        if self.kinds[0] != "end" or self.kinds[-1] != "end":
            raise ValueError("a cable route must start and end with an 'end' node")
        s = np.asarray(self.s_boundary0) if not isinstance(self.s_boundary0, jax.core.Tracer) else None
        if s is not None and np.any(np.diff(s) <= 0):
            raise ValueError(f"s_boundary0 must increase along the route, got {s!r}")

    # -- static index bookkeeping (NumPy, computed at trace time) --------------------------------
    @property
    def elements(self):
        return tuple(int(np.shape(f)[0]) + 1 for f in self.fractions)

    @property
    def n_nodes(self):
        return sum(self.elements) + 1

    @property
    def n_internal(self):
        return sum(e - 1 for e in self.elements)

    @property
    def pulley_ids(self):
        """Boundary nodes whose material coordinate is free (pulleys, motor-driven pulleys, hooks),
        in the order of ``CableCoords.s``."""
        return tuple(i for i, k in enumerate(self.kinds) if k in ("pulley", "active", "hook"))

    @property
    def hook_ids(self):
        """Boundary nodes of kind ``"hook"`` (position and material coordinate both free), in the
        order of ``CableCoords.h``."""
        return tuple(i for i, k in enumerate(self.kinds) if k == "hook")

    def hook_node_map(self):
        """``H`` (N, n_h) constant 0/1: ``r_node = H h + ...`` (which node is each hook node)."""
        bidx, _, _, _ = self._index_tables()
        H = np.zeros((len(bidx), len(self.hook_ids)))
        for k, b in enumerate(self.hook_ids):
            H[np.nonzero(bidx == b)[0], k] = 1.0
        return H

    def hook_columns(self):
        """``Hc`` (N, 3, 3 n_h) constant: ``d r_node / d h`` with ``h`` flattened (hook-major)."""
        H = self.hook_node_map()
        return (H[:, None, :, None] * np.eye(3)[None, :, None, :]).reshape(H.shape[0], 3, 3 * H.shape[1])

    @property
    def active_slots(self):
        """Positions in ``CableCoords.s`` of the active (motor-driven) pulleys."""
        return tuple(j for j, i in enumerate(self.pulley_ids) if self.kinds[i] == "active")

    def _index_tables(self):
        """For each full node: boundary id or -1, internal id or -1, span id, fraction slot."""
        bidx, iidx, span_of, boundary_node = [], [], [], []
        count = 0
        for j, n_el in enumerate(self.elements):
            boundary_node.append(len(bidx))
            bidx.append(j)
            iidx.append(-1)
            span_of.append(j)
            for i in range(n_el - 1):
                bidx.append(-1)
                iidx.append(count)
                span_of.append(j)
                count += 1
        boundary_node.append(len(bidx))
        bidx.append(len(self.elements))
        iidx.append(-1)
        span_of.append(len(self.elements) - 1)
        return np.array(bidx), np.array(iidx), np.array(span_of), np.array(boundary_node)

    def _interpolation_tables(self):
        """Static 0/1 matrices (N, nb) of the affine node map: ``boundary`` picks a boundary node's own
        value, ``start``/``end`` pick an internal node's span ends; ``moving`` (N,) flags nodes on the
        block. With the fractions ``F`` (N,) (0 at boundary nodes) the material coordinates are
        ``s = W s_b``, ``W = boundary + (1 - F) start + F end``."""
        bidx, iidx, span_of, _ = self._index_tables()
        n, nb = len(bidx), len(self.kinds)
        rows = np.arange(n)
        boundary = np.zeros((n, nb))
        boundary[rows[bidx >= 0], bidx[bidx >= 0]] = 1.0
        start = np.zeros((n, nb))
        end = np.zeros((n, nb))
        internal = iidx >= 0
        start[rows[internal], span_of[internal]] = 1.0
        end[rows[internal], span_of[internal] + 1] = 1.0
        moving = np.zeros(n)
        moving[rows[bidx >= 0]] = np.asarray(self.moving, dtype=float)[bidx[bidx >= 0]]
        return boundary, start, end, moving

    def slow_node_maps(self, W=None):
        """How the nodes move with the slow coordinates (constant): ``(S (N, n_p), U (N, 3))``,
        ``S = d s_node / d s_pulley`` and ``U = d r_node / d u`` (the moving block's nodes follow
        ``block_direction``). ``W``: :meth:`interpolation_weights`, if at hand."""
        W = self.interpolation_weights() if W is None else W
        _, _, _, moving = self._interpolation_tables()
        S = W[:, np.array(self.pulley_ids, dtype=int)]
        U = moving[:, None] * self.block_direction[None, :]
        return S, U

    def interpolation_weights(self):
        """``W`` (N, nb): material coordinates of all nodes are ``W @ s_b`` (constant in time)."""
        boundary, start, end, _ = self._interpolation_tables()
        _, iidx, _, _ = self._index_tables()
        parts = [jnp.asarray(f, dtype=float).reshape(-1) for f in self.fractions]
        frac = jnp.concatenate(parts) if self.n_internal else jnp.zeros(0)
        F = jnp.where(iidx >= 0, frac[np.maximum(iidx, 0)] if self.n_internal else 0.0, 0.0)
        return boundary + (1.0 - F)[:, None] * start + F[:, None] * end

    def span_slow_tables(self):
        """Static, per span ``j`` (between boundary nodes ``j`` and ``j + 1``): which slow coordinates
        (``(s, h, u)`` flattened as in :meth:`CableSubsystem.accelerations`: the ``n_p`` pulley
        slots, the hooks' ``3 n_h`` positions, the block's ``u``) the span's kinetic energy sees.
        A span's material velocities depend only on its two ends' slots (its nodes' material
        coordinates interpolate those two), on a hook end's position and on a block end's travel.
        Each entry: ``dict(cols, slots, hook, block, n_el, first_element, first_internal)``:
        ``cols`` the global slow indices of the span's local columns, ``slots`` per end the local
        column of its slot or ``None`` (an ``"end"`` node has none), ``hook`` per end the local
        columns of its position (3) or ``None``, ``block`` per end the local column of ``u`` if it
        rides the block or ``None``."""
        n_p, n_h = len(self.pulley_ids), len(self.hook_ids)
        u_col = n_p + 3 * n_h
        tables, element, internal = [], 0, 0
        for j, n_el in enumerate(self.elements):
            cols, slots, hook, block = [], [], [], []
            for b in (j, j + 1):
                slots.append(len(cols) if b in self.pulley_ids else None)
                if b in self.pulley_ids:
                    cols.append(self.pulley_ids.index(b))
            for b in (j, j + 1):
                if self.kinds[b] == "hook":
                    k = self.hook_ids.index(b)
                    hook.append(tuple(range(len(cols), len(cols) + 3)))
                    cols.extend(n_p + 3 * k + i for i in range(3))
                else:
                    hook.append(None)
                if self.moving[b]:
                    if u_col not in cols:
                        cols.append(u_col)
                    block.append(cols.index(u_col))
                else:
                    block.append(None)
            tables.append(
                dict(cols=tuple(cols), slots=tuple(slots), hook=tuple(hook), block=tuple(block), n_el=n_el,
                     first_element=element, first_internal=internal)
            )  # fmt: skip
            element += n_el
            internal += n_el - 1
        return tables

    def span_pattern_inverses(self):
        """Per span with internal nodes, ``That_j^-1`` (m_j, m_j): the inverse of its internal-node
        consistent-mass pattern (the cable's pattern is block diagonal over the spans). ``That_j``
        is tridiagonal in the material fractions ``F`` (diagonal ``2 (dF_left +
        dF_right)``, off-diagonal the shared element's ``dF``), so it depends only on the (constant)
        fractions. Returns ``pattern_inverses`` when the route carries them; otherwise they are
        computed in the program where the vector field asks (XLA hoists this loop out of diffrax's
        loop, not out of a ``fori_loop`` around the vector field, where on the full level's design
        case the two spans' inverses took most of an evaluation)."""
        if self.pattern_inverses is not None:
            return list(self.pattern_inverses)
        out = []
        for f, n_el in zip(self.fractions, self.elements):
            if n_el < 2:
                continue
            out.append(_dominant_inverse(_mass_pattern(jnp.asarray(f), jnp)))
        return out

    def boundary_s(self, q: CableCoords):
        return self._boundary_values(self.s_boundary0, q.s)

    def _boundary_values(self, at_ends, at_pulleys):
        """(nb,) boundary-node values: ``at_ends[i]`` at end nodes, ``at_pulleys`` (n_p,) in order at
        pulley nodes (a concatenation: no scatter)."""
        pieces, slot = [], 0
        for i, kind in enumerate(self.kinds):
            if kind == "end":
                pieces.append(at_ends[i : i + 1])
            else:
                pieces.append(at_pulleys[slot : slot + 1])
                slot += 1
        return jnp.concatenate(pieces)

    def boundary_r(self, q: CableCoords):
        shift = jnp.asarray(self.moving, dtype=float)[:, None] * q.u * self.block_direction[None, :]
        return self._with_hooks(self.boundary_points + shift, q.h)

    def _with_hooks(self, r_boundary, h):
        """(nb, 3) boundary values with the hook nodes' rows taken from ``h`` (n_h, 3)."""
        if not self.hook_ids:
            return r_boundary
        pieces, k = [], 0
        for i, kind in enumerate(self.kinds):
            if kind == "hook":
                pieces.append(h[k : k + 1])
                k += 1
            else:
                pieces.append(r_boundary[i : i + 1])
        return jnp.concatenate(pieces)

    def _node_positions(self, r_boundary, r_internal):
        """All nodal positions (N, 3) from the boundary (nb, 3) and internal (n_int, 3) ones, in route
        order (one concatenation of slices: no gather)."""
        pieces, offset = [], 0
        for j, n_el in enumerate(self.elements):
            pieces.append(r_boundary[j : j + 1])
            if n_el > 1:
                pieces.append(r_internal[offset : offset + n_el - 1])
                offset += n_el - 1
        pieces.append(r_boundary[-1:])
        return jnp.concatenate(pieces, axis=0)

    def internal_rows(self, x):
        """Rows of the internal nodes of a nodal array (N, ...) -> (n_int, ...) (slices, no gather)."""
        pieces, node = [], 0
        for n_el in self.elements:
            if n_el > 1:
                pieces.append(x[node + 1 : node + n_el])
            node += n_el
        return jnp.concatenate(pieces) if pieces else x[:0]

    def nodes(self, q: CableCoords):
        """All nodal positions (N,3) [m] and material coordinates (N,) [m] (affine in q)."""
        r = self._node_positions(self.boundary_r(q), q.r)
        return r, _matvec(self.interpolation_weights(), self.boundary_s(q))

    def node_velocities(self, qdot: CableCoords):
        """Nodal velocities (N,3) [m/s] and material rates (N,) [m/s] of the rates ``qdot`` (the map
        is affine in q with a constant linear part, so the rates do not depend on q)."""
        v_boundary = jnp.asarray(self.moving, dtype=float)[:, None] * qdot.u * self.block_direction[None, :]
        v_boundary = self._with_hooks(v_boundary, qdot.h)
        sd_boundary = self._boundary_values(jnp.zeros_like(self.s_boundary0), qdot.s)
        v = self._node_positions(v_boundary, qdot.r)
        return v, _matvec(self.interpolation_weights(), sd_boundary)


class CableKinematics(eqx.Module):
    """Nodal and element kinematics of one cable state (see :meth:`CableSubsystem.kinematics`)."""

    r: jax.Array
    """(N, 3) nodal positions [m]."""
    s: jax.Array
    """(N,) nodal material coordinates [m]."""
    v: jax.Array
    """(N, 3) nodal velocities [m/s]."""
    sd: jax.Array
    """(N,) nodal material rates [m/s]."""
    W: jax.Array
    """(N, nb) interpolation weights ``s = W s_b`` [-]."""
    length: jax.Array
    """(n_el,) material element lengths ``L`` [m]."""
    tangent: jax.Array
    """(n_el, 3) ``r' = (r2 - r1) / L`` [-]."""
    tangent_sq: jax.Array
    """(n_el,) ``|r'|^2`` [-]."""
    strain: jax.Array
    """(n_el,) Green strain [-]."""
    strain_rate: jax.Array
    """(n_el,) its rate [1/s]."""
    a1: jax.Array
    """(n_el, 3) material velocity at each element's first end ``v_1 - r' sdot_1`` [m/s]."""
    a2: jax.Array
    """(n_el, 3) same at the second end [m/s]."""


def chain_kinematics(r, s, v, sd, W=None):
    """:class:`CableKinematics` of a chain of nodes: positions ``r`` (N, 3) [m], material
    coordinates ``s`` (N,) [m], velocities ``v`` (N, 3) [m/s], material rates ``sd`` (N,) [m/s]
    (``W``: the interpolation weights, carried along). Used for a whole cable
    (:meth:`CableSubsystem.kinematics`) and for one element at a time (a two-node chain,
    :func:`element_chain`: the contact pairs' Jacobians of the W-method's linearisation)."""
    length = s[1:] - s[:-1]
    tangent = (r[1:] - r[:-1]) / length[:, None]
    tt = jnp.sum(tangent * tangent, axis=1)
    d_v = v[1:] - v[:-1]
    d_sd = sd[1:] - sd[:-1]
    strain_rate = (jnp.sum(tangent * d_v, axis=1) - tt * d_sd) / length
    return CableKinematics(
        r=r, s=s, v=v, sd=sd, W=W, length=length, tangent=tangent, tangent_sq=tt,
        strain=0.5 * (tt - 1.0), strain_rate=strain_rate,
        a1=v[:-1] - tangent * sd[:-1, None], a2=v[1:] - tangent * sd[1:, None],
    )  # fmt: skip


def element_chain(z, zd):
    """One element as a two-node chain's :func:`chain_kinematics`, from its ends' coordinates
    ``z = (r1, s1, r2, s2)`` (8,) and rates ``zd = (v1, sd1, v2, sd2)`` (8,)."""
    r = jnp.stack([z[0:3], z[4:7]])
    v = jnp.stack([zd[0:3], zd[4:7]])
    return chain_kinematics(r, jnp.stack([z[3], z[7]]), v, jnp.stack([zd[3], zd[7]]))


def element_rows(f_r, f_s):
    """An element's rows ``f_r`` (2, 3), ``f_s`` (2,) as ``(f_r1, f_s1, f_r2, f_s2)`` (8,)."""
    return jnp.concatenate([f_r[0], f_s[:1], f_r[1], f_s[1:]])


def _material_force_rows(tangent, element_forces):
    """Point forces on the material at element ends (n_el, 2, 3) -> their ``(r, s)`` rows: the
    power ``F . (v - r' sdot)`` gives ``F`` on ``r`` and ``-r'.F`` on ``s``."""
    return element_forces, -jnp.sum(tangent[:, None, :] * element_forces, axis=2)


def _scatter_element_ends(rows):
    """Element-end rows ``(f_r (n_el, 2, 3), f_s (n_el, 2))`` summed onto the nodes (N, 3), (N,)
    (two shifted adds: no scatter)."""
    f_r, f_s = rows
    zr = jnp.zeros((1, 3), f_r.dtype)
    zs = jnp.zeros((1,), f_s.dtype)
    F_r = jnp.concatenate([f_r[:, 0], zr]) + jnp.concatenate([zr, f_r[:, 1]])
    F_s = jnp.concatenate([f_s[:, 0], zs]) + jnp.concatenate([zs, f_s[:, 1]])
    return F_r, F_s


def _contract(A, B):
    """``sum_{e,x} A[e, x, k] B[e, x, l]`` (k, l): one ``dot`` (over the elements and the three
    components) into a span's small slow block."""
    return jnp.einsum("exk,exl->kl", A, B)


def _spread(cols, M, n):
    """A span's (k, k) slow block ``M`` on its global slow columns ``cols`` (static) of an (n, n)
    block: a scatter-add. (As one-hot products ``E M E^T`` an evaluation of the full design case's
    vector field took 1.1-1.2x as long, with multiply-sums 1.4-1.6x: ``docs/stiff_integrator.md``.)"""
    idx = np.asarray(cols, dtype=int)
    return jnp.zeros((n, n), M.dtype).at[idx[:, None], idx[None, :]].add(M)


def _spread_vec(cols, v, n):
    """``v`` (k,) on the global slow columns ``cols`` of an (n,) vector."""
    return jnp.zeros(n, v.dtype).at[np.asarray(cols, dtype=int)].add(v)


def _gather_vec(cols, v):
    """``v[cols]`` (k,) of the (n,) vector ``v`` for static ``cols``, as a one-hot multiply-sum (no gather)."""
    E = np.eye(v.shape[0])[:, list(cols)]
    return jnp.sum(E * v[:, None], axis=0)


def _matvec(A, x):
    """``A @ x`` for a constant ``A`` (n, k) with few columns, as ``k`` elementwise multiply-adds:
    neither a ``dot`` nor a reduction over the short axis, which XLA's CPU backend (JAX 0.10)
    makes a library call of ~100 us under the linearisation's 8 tangents (``docs/stiff_integrator.md``,
    "Short reductions"). Not the sums over all elements into the slow-coordinate blocks: see
    :meth:`CableSubsystem.accelerations`."""
    out = A[:, 0] * x[0]
    for k in range(1, A.shape[1]):
        out = out + A[:, k] * x[k]
    return out


def _sum3(x):
    """``x.sum(axis=1)`` for ``x`` (n, 3, ...), written out (no reduction over the short axis)."""
    return x[:, 0] + x[:, 1] + x[:, 2]


def pattern_inverses(fractions) -> tuple:
    """Per span with internal nodes, the inverse of its consistent-mass pattern ``That_j`` (see
    :meth:`CableRoute.span_pattern_inverses`), computed on the host with NumPy from concrete
    fractions (a tuple of (n_j - 1,) arrays) and returned as JAX arrays, for
    ``CableRoute(pattern_inverses=...)``."""
    out = []
    for f in fractions:
        f = np.asarray(f, dtype=float)
        if f.shape[0] < 1:
            continue
        out.append(jnp.asarray(np.linalg.inv(_mass_pattern(f, np))))
    return tuple(out)


def _mass_pattern(f, xp):
    """A span's internal-node consistent-mass pattern ``That`` (m, m) from its (m,) material
    fractions ``f``, with array module ``xp`` (NumPy on the host, ``jax.numpy`` in a program):
    tridiagonal, diagonal ``2 (dF_left + dF_right)``, off-diagonal the shared element's ``dF``."""
    F = xp.concatenate([xp.zeros(1, f.dtype), f, xp.ones(1, f.dtype)])
    dF = F[1:] - F[:-1]
    return xp.diag(2.0 * (dF[:-1] + dF[1:])) + xp.diag(dF[1:-1], 1) + xp.diag(dF[1:-1], -1)


def _dominant_inverse(A):
    """``A^-1`` of a strictly diagonally dominant (n, n) matrix (the consistent-mass pattern): Gauss-Jordan
    without pivoting in a ``fori_loop``, no LAPACK call.

    Why not ``jnp.linalg.inv``: on XLA's CPU backend a batched LAPACK call (here one per cable) splits its
    batch over the process's intra-op thread pool and blocks its pool thread until the parts finish. With
    one JAX device per core (``jaxcable sweep --cpu-devices auto``) two programs share that pool of two
    threads; when both ran this inverse at once, each pool thread waited for work queued behind the other
    and the sweep stopped at 0% CPU (reproduced with two threads inverting on two CPU devices; JAX
    0.10.2; ``docs/sweeps.md``). Scenes built by :mod:`jaxcable.arresting.cable_sets` carry the
    inverses computed on the host (:func:`pattern_inverses`); this one serves routes built without
    them (computed once per solve where XLA hoists it, as out of diffrax's loop)."""
    n = A.shape[-1]
    M = jnp.concatenate([A, jnp.eye(n, dtype=A.dtype)], axis=1)
    return jax.lax.fori_loop(0, n, _gauss_jordan_step, M)[:, n:]


def _gauss_jordan_step(k, M):
    """One Gauss-Jordan step without pivoting on the augmented (n, n + m) matrix ``M``: row ``k``
    scaled to a unit pivot, column ``k`` cleared from every other row. ``k`` static (unrolled) or
    traced (``fori_loop``)."""
    pivot_row = M[k] / M[k, k]
    column = jax.lax.dynamic_slice_in_dim(M, k, 1, axis=1)
    rows = np.arange(M.shape[0])[:, None]
    return jnp.where(rows == k, pivot_row[None, :], M - column * pivot_row[None, :])


def _small_solve(A, b):
    """``A^-1 b`` for a small (n, n) matrix with positive pivots (SPD, possibly with some rows
    replaced by identity rows): Gauss-Jordan without pivoting, unrolled (n static), each step one
    elementwise update (XLA fuses them). A LAPACK call per evaluation costs more than this whole
    elimination for n ~ 5 (measured: 3.5 vs 1.1 us)."""
    n = A.shape[-1]
    M = jnp.concatenate([A, b[:, None]], axis=1)
    for k in range(n):
        M = _gauss_jordan_step(k, M)
    return M[:, n]


def _swap(x):
    """Swap the last two axes (a batch of matrices' transposes)."""
    return jnp.swapaxes(x, -1, -2)


def _element_terms(r1, r2, s1, s2):
    length = s2 - s1
    tangent = (r2 - r1) / length
    strain = 0.5 * (jnp.dot(tangent, tangent) - 1.0)
    return length, tangent, strain


class CableSubsystem(eqx.Module):
    """One arresting subsystem: an ALE cable on a route, and its buffer device (if the route has a
    moving block). Physics for one subsystem; the scene vmaps over the four."""

    route: CableRoute
    cable: AleCable
    buffer: BufferDevice
    gravity: jax.Array = eqx.field(converter=jnp.asarray, default=(0.0, 0.0, -9.81))
    """(3,) gravitational acceleration [m/s^2]."""

    # -- energies --------------------------------------------------------------------------------
    def kinetic_energy(self, q, qdot):
        """Kinetic energy of the cable (consistent ALE mass) + counterweight [J]."""
        (r, s), (v, sd) = jax.jvp(self.route.nodes, (q,), (qdot,))
        length, tangent, _ = jax.vmap(_element_terms)(r[:-1], r[1:], s[:-1], s[1:])
        a1 = v[:-1] - tangent * sd[:-1, None]
        a2 = v[1:] - tangent * sd[1:, None]
        per = length / 6.0 * (jnp.sum(a1 * a1, 1) + jnp.sum(a1 * a2, 1) + jnp.sum(a2 * a2, 1))
        return self.cable.rhoA_kg_per_m * jnp.sum(per) + self.buffer.kinetic_energy(qdot.u)

    def potential_parts(self, q):
        """(strain, cable gravity, counterweight) potential energies [J]."""
        r, s = self.route.nodes(q)
        length, _, strain = jax.vmap(_element_terms)(r[:-1], r[1:], s[:-1], s[1:])
        elastic = self.cable.EA_N * jnp.sum(length * strain_energy_density(strain, self.cable.slack_width))
        mid = 0.5 * (r[:-1] + r[1:])
        grav = -self.cable.rhoA_kg_per_m * jnp.sum(length * (mid @ self.gravity))
        g = -self.gravity[2]
        return elastic, grav, self.buffer.potential_energy(q.u, g)

    def potential_energy(self, q):
        e, g, c = self.potential_parts(q)
        return e + g + c

    def dissipation_function(self, q, qdot):
        """Rayleigh function ``D`` [W/2]: cable damping power is ``2 D``."""
        (r, s), (v, sd) = jax.jvp(self.route.nodes, (q,), (qdot,))
        length, tangent, _ = jax.vmap(_element_terms)(r[:-1], r[1:], s[:-1], s[1:])
        rate = (
            jnp.sum(tangent * (v[1:] - v[:-1]), 1) - jnp.sum(tangent * tangent, 1) * (sd[1:] - sd[:-1])
        ) / length
        return 0.5 * self.cable.damping_s * self.cable.EA_N * jnp.sum(length * rate**2)

    def tensions(self, q):
        """Axial force of every element [N], (n_elements,): ``EA T(eps) |r'|`` (true force)."""
        r, s = self.route.nodes(q)
        _, tangent, strain = jax.vmap(_element_terms)(r[:-1], r[1:], s[:-1], s[1:])
        stretch = jnp.sqrt(jnp.sum(tangent**2, 1))
        return self.cable.EA_N * axial_tension_factor(strain, self.cable.slack_width) * stretch

    # -- forces on material points ---------------------------------------------------------------
    def material_point_forces(self, q, element_forces):
        """Generalised forces of point forces applied to the material of the cable.

        ``element_forces``: (n_elements, 2, 3) world forces [N] already split to each element's two
        ends by the linear weights of the contact point (``(1-w) F``, ``w F``). The power of a force
        on the material is ``F . (v_i - r' sdot_i)`` at each end (the ALE ``N`` of eq 31), so the
        material coordinates get ``-r' . F``. Returned as :class:`CableCoords`.
        """
        kin = self.kinematics(q, jax.tree_util.tree_map(jnp.zeros_like, q))
        F_r, F_s = _scatter_element_ends(_material_force_rows(kin.tangent, element_forces))
        Q_r, Q_s, Q_u, Q_h = self._generalised(kin, F_r, F_s)
        return CableCoords(r=Q_r, s=Q_s, u=Q_u, h=Q_h)

    # -- dynamics --------------------------------------------------------------------------------
    def kinematics(self, q, qdot) -> "CableKinematics":
        """Nodal and element kinematics of the state (computed once per evaluation and shared by the
        accelerations, the contact, the dissipation and the tensions)."""
        route = self.route
        W = route.interpolation_weights()
        r = route._node_positions(route.boundary_r(q), q.r)
        s = _matvec(W, route.boundary_s(q))
        v, sd = route.node_velocities(qdot)
        return chain_kinematics(r, s, v, sd, W)

    def element_tensions(self, kin: "CableKinematics"):
        """:meth:`tensions` from precomputed kinematics [N], (n_elements,)."""
        factor = axial_tension_factor(kin.strain, self.cable.slack_width)
        return self.cable.EA_N * factor * jnp.sqrt(kin.tangent_sq)

    def _element_forces(self, kin: "CableKinematics"):
        """Closed form of the element terms of Lagrange's equations in nodal coordinates
        ``x = [r, s]``: ``f = -(d p / d x) x_dot + dT/dx - dV/dx - dD/dx_dot`` with ``p = dT/dx_dot``
        (:meth:`_cable_terms_x` is the autodiff reference; the tests check they agree).

        Per element (ends 1, 2), with ``c = rhoA L / 6``, ``a_i = v_i - t sdot_i`` (material
        velocities), ``m_1 = c (2 a_1 + a_2)``, ``m_2 = c (a_1 + 2 a_2)`` (their momenta),
        ``T = (a_1.m_1 + a_2.m_2) / 2``, ``t_dot = (dv - t dsdot) / L`` (rate of the tangent at fixed
        velocities), ``g = dT/dt = -(sdot_1 m_1 + sdot_2 m_2)``:

        * inertia: ``f_r1 = -m1_dot - g / L``, ``f_r2 = -m2_dot + g / L``,
          ``f_si = t_dot.m_i + t.mi_dot -+ (t.g - T) / L`` with
          ``mi_dot = (dsdot / L) m_i - c (2 sdot_i + sdot_j) t_dot`` (``d c / dt = rhoA dsdot / 6``);
        * elastic + damping with the axial force ``N = EA (psi'(eps) + beta eps_dot)``:
          ``f_r1 = N t``, ``f_r2 = -N t``, ``f_s1 = -N |t|^2 + EA psi``, ``f_s2 = -f_s1``;
        * gravity ``g_vec``: ``f_ri = rhoA L g_vec / 2``, ``f_s1 = -rhoA g_vec . (r1 + r2) / 2 = -f_s2``.

        Returns ``(f_r (n_el, 2, 3), f_s (n_el, 2))``.
        """
        rhoA, EA = self.cable.rhoA_kg_per_m, self.cable.EA_N
        L, t, tt = kin.length, kin.tangent, kin.tangent_sq
        a1, a2 = kin.a1, kin.a2
        sd1, sd2 = kin.sd[:-1, None], kin.sd[1:, None]
        c = (rhoA / 6.0) * L[:, None]
        m1 = c * (2.0 * a1 + a2)
        m2 = c * (a1 + 2.0 * a2)
        kinetic = 0.5 * jnp.sum(a1 * m1 + a2 * m2, axis=1)
        d_sd = (kin.sd[1:] - kin.sd[:-1])[:, None]
        inv_L = 1.0 / L[:, None]
        t_dot = ((kin.v[1:] - kin.v[:-1]) - t * d_sd) * inv_L
        m1_dot = d_sd * inv_L * m1 - c * (2.0 * sd1 + sd2) * t_dot
        m2_dot = d_sd * inv_L * m2 - c * (sd1 + 2.0 * sd2) * t_dot
        g = -(sd1 * m1 + sd2 * m2)
        s_inertia = (jnp.sum(t * g, axis=1) - kinetic) / L
        tension = axial_tension_factor(kin.strain, self.cable.slack_width)
        axial = EA * (tension + self.cable.damping_s * kin.strain_rate)
        weight = (0.5 * rhoA) * L[:, None] * self.gravity[None, :]
        f_r1 = -m1_dot - g * inv_L + axial[:, None] * t + weight
        f_r2 = -m2_dot + g * inv_L - axial[:, None] * t + weight
        mid = 0.5 * (kin.r[:-1] + kin.r[1:])
        elastic_energy = EA * strain_energy_density(kin.strain, self.cable.slack_width)
        s_static = -axial * tt + elastic_energy - rhoA * jnp.sum(mid * self.gravity, axis=1)
        f_s1 = jnp.sum(t_dot * m1 + t * m1_dot, axis=1) + s_inertia + s_static
        f_s2 = jnp.sum(t_dot * m2 + t * m2_dot, axis=1) - s_inertia - s_static
        return jnp.stack([f_r1, f_r2], axis=1), jnp.stack([f_s1, f_s2], axis=1)

    def nodal_forces(self, kin: "CableKinematics", element_forces=None):
        """Lagrange's element terms plus the point forces ``element_forces`` (n_el, 2, 3) [N] on the
        material at element ends, summed on the nodes: ``(F_r (N, 3) [N], F_s (N,) [N])``. Node ``i``
        depends only on elements ``i - 1`` and ``i``, hence on nodes ``i - 1, i, i + 1``."""
        f_r, f_s = self._element_forces(kin)
        if element_forces is not None:
            e_r, e_s = _material_force_rows(kin.tangent, element_forces)
            f_r, f_s = f_r + e_r, f_s + e_s
        return _scatter_element_ends((f_r, f_s))

    def generalised_forces(self, q, qdot, kin: "CableKinematics", element_forces=None):
        """All generalised forces of Lagrange's equations before the mass solve: ``(Q_r (n_int, 3),
        Q_slow (n_slow,))`` [N], the slow coordinates being the pulleys' (and hooks') ``s``, then the
        hook nodes' positions ``h`` (flattened), then the block's ``u`` (element terms, point forces
        on the material, counterweight weight and brake)."""
        F_r, F_s = self.nodal_forces(kin, element_forces)
        Q_r, Q_s, Q_u, Q_h = self._generalised(kin, F_r, F_s)
        b = self.buffer
        g = -self.gravity[2]
        Q_u = Q_u - b.counterweight_mass_kg * g * b.transfer_rate + b.generalized_force(qdot.u, q.u)
        return Q_r, jnp.concatenate([Q_s, Q_h.reshape(-1), Q_u[None]])

    def element_row_jacobians(self, kin: CableKinematics):
        """Each element's Jacobians of its rows of Lagrange's equations in nodal coordinates,
        ``f_e = (f_r1, f_s1, f_r2, f_s2)`` (8,) [N], with respect to its ends' coordinates ``z_e =
        (r1, s1, r2, s2)`` and rates ``zdot_e = (v1, sd1, v2, sd2)``: ``(J_z, J_zdot)``, each
        (n_el, 8, 8), in closed form, of the stiff terms of :meth:`_element_forces`: the axial
        force ``N = EA (T(eps) + beta eps_dot)`` (elasticity and Rayleigh damping, on ``f_r = +-N
        t`` and ``f_s1 = -N |t|^2 + EA psi = -f_s2``) and the weight. With ``G = dt/dz_e = [-I, t,
        I, -t] / L`` and ``t^T G = d eps / dz_e = d eps_dot / dzdot_e``:

            dN/dz = EA (T'(eps) t^T G + beta ((dv - 2 dsd t)^T G - eps_dot dL/dz) / L),
            dN/dzdot = EA beta t^T G,   d(N t)/dz = t dN/dz + N G.

        Left out (a W-method keeps its order with any ``J``): the inertia terms of the moving
        material (``m_dot``, ``g`` of :meth:`_element_forces`, of order ``rhoA sdot`` and ``rhoA
        sdot^2 / L``; ``tests/arresting/test_stiff.py`` bounds what they change in the blocks, and
        a run with the exact blocks took the same steps, ``docs/stiff_integrator.md``) and the
        air's drag on the span. Before, the exact Jacobians came from 28 coloured JVPs of the whole
        :meth:`generalised_forces` (2.3 ms per linearisation at the full level on the default
        mesh, about ten evaluations of the vector field); 16 tangents through each element took
        0.86 ms of that; the closed form is a few wide elementwise operations."""
        EA, beta, rhoA = self.cable.EA_N, self.cable.damping_s, self.cable.rhoA_kg_per_m
        L, t, tt = kin.length, kin.tangent, kin.tangent_sq
        eps, eps_dot = kin.strain, kin.strain_rate
        dtype = t.dtype
        n = L.shape[0]
        inv_L = (1.0 / L)[:, None, None]
        I3 = jnp.broadcast_to(jnp.eye(3, dtype=dtype), (n, 3, 3))
        G = inv_L * jnp.concatenate([-I3, t[:, :, None], I3, -t[:, :, None]], axis=2)  # (n, 3, 8)
        # sums over the 3 components written out: as reductions over that short axis XLA's CPU
        # backend made them library calls dearer than the rest of the linearisation's arithmetic
        de = _sum3(t[:, :, None] * G)  # (n, 8) d eps / dz = d eps_dot / dzdot
        dv = kin.v[1:] - kin.v[:-1]
        dsd = kin.sd[1:] - kin.sd[:-1]
        dL = jnp.asarray([0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0], dtype)
        w = dv - 2.0 * dsd[:, None] * t
        d_eps_dot = (_sum3(w[:, :, None] * G) - eps_dot[:, None] * dL[None, :]) / L[:, None]
        T, dT = jax.jvp(lambda e: axial_tension_factor(e, self.cable.slack_width), (eps,), (jnp.ones_like(eps),))
        N = EA * (T + beta * eps_dot)
        dN_z = EA * (dT[:, None] * de + beta * d_eps_dot)  # (n, 8)
        dN_zd = (EA * beta) * de
        g = self.gravity
        # z rows: (f_r1, f_s1, f_r2, f_s2) with f_r1 = N t + w_g, f_r2 = -N t + w_g, w_g = rhoA L g / 2
        dNt_z = t[:, :, None] * dN_z[:, None, :] + N[:, None, None] * G  # (n, 3, 8)
        weight_z = (0.5 * rhoA) * g[None, :, None] * dL[None, None, :]
        ds1_z = -tt[:, None] * dN_z - 2.0 * N[:, None] * de + EA * T[:, None] * de
        gs = jnp.concatenate([g, jnp.zeros(1, dtype), g, jnp.zeros(1, dtype)])  # f_s1's weight term
        ds1_z = ds1_z - (0.5 * rhoA) * gs[None, :]
        J_z = jnp.concatenate([dNt_z + weight_z, ds1_z[:, None], -dNt_z + weight_z, -ds1_z[:, None]], axis=1)
        dNt_zd = t[:, :, None] * dN_zd[:, None, :]
        ds1_zd = -tt[:, None] * dN_zd
        J_zd = jnp.concatenate([dNt_zd, ds1_zd[:, None], -dNt_zd, -ds1_zd[:, None]], axis=1)
        return J_z, J_zd

    def assemble_stiff_blocks(self, q, qdot, J_z, J_zdot):
        """``K = dQ/dq`` and ``C = dQ/dq_dot`` of :meth:`generalised_forces` from the elements'
        Jacobians ``J_z``, ``J_zdot`` (n_el, 8, 8) (:meth:`element_row_jacobians`, plus whatever
        element-local forces the caller adds, e.g. contact). Element ``e``'s ends' coordinates are
        affine in ``q`` with a constant map: ``z_e = B_e q_slow`` plus the internal ends' own ``r``
        (identity), so ``K = sum_e A_e^T J_e A_e``. Returns ``(K_rr, C_rr)`` as ``(lower, diag,
        upper)`` (n_int, 3, 3) each, ``(K_rz, C_rz)`` (n_int, 3, n_slow) (the internal rows'
        columns on the slow coordinates: the pulleys' and hooks' ``s``, the hook nodes' positions,
        the block's ``u``), ``(K_zz, C_zz)`` (n_slow, n_slow), the brake's derivative included, and
        ``(K_zr, C_zr)``, the slow rows' columns on the internal nodes, stored transposed in the
        layout of ``K_rz`` (n_int, 3, n_slow). These are not ``K_rz``: ``K`` holds the Rayleigh
        term's derivative in the positions at the current strain rates, which is not symmetric;
        next to a hook node, where the strain rates are large, the two differ by up to 4x
        (measured on the deviated case).

        Element by element, not node by node: ``J_e B_e`` and ``J_e^T B_e`` give ``K_rz`` and
        ``K_zr`` by two shifted adds, and ``K_zz = sum_e B_e^T J_e B_e``. ``B_e`` (8, n_slow) is
        sparse: its ``s`` rows hold the interpolation weights on the pulleys' columns, its ``r``
        rows only a hook node's identity and the block's direction, so ``J_e B_e`` is formed
        column block by column block from those rows alone, elementwise (no dense 8 x 8 by 8 x
        n_slow products, no reductions over short axes: on a CPU, XLA runs those as separate,
        slow kernels). ``K`` and ``C`` go through together. Against the former node-by-node
        assembly with dense ``B`` (three 4 x 4 by 4 x n_slow products per node and matrix), at the
        full level on 64 span elements: the cables' blocks 1.59 -> 0.68 ms, the whole
        linearisation 1.77 -> 0.66 ms, the design case (1 s) 72 -> 42 s in the same steps (2-core
        CPU, JAX 0.10.2, float64; ``experiments/bench_linearisation_parts.py``,
        ``docs/stiff_integrator.md``)."""
        route = self.route
        S, U = route.slow_node_maps()  # (N, n_p), (N, 3)
        H = jnp.asarray(route.hook_node_map(), J_z.dtype)  # (N, n_h) 0/1
        n_p, n_h = S.shape[1], H.shape[1]
        J = jnp.stack([J_z, J_zdot], axis=1)  # (n_el, 2, 8, 8): K's and C's element Jacobians

        def times_B(M):
            """``M_e @ B_e`` (n_el, 2, 8, n_slow), each column block from the rows of ``B_e`` that
            are not zero: the pulleys' ``s`` from the ``s`` rows (3, 7), a hook node's position
            and the block's travel from the ``r`` rows (0:3, 4:7)."""
            ends = ((slice(None, -1), 0), (slice(1, None), 4))
            cols_s = sum(M[..., k + 3, None] * S[e, None, None, :] for e, k in ends)
            cols_h = sum(M[..., k : k + 3, None] * H[e, None, None, None, :] for e, k in ends)
            cols_h = jnp.swapaxes(cols_h, -1, -2).reshape(cols_h.shape[:-2] + (3 * n_h,))  # hook-major
            cols_u = sum(M[..., k + i, None] * U[e, None, None, i, None] for e, k in ends for i in range(3))
            return jnp.concatenate([cols_s, cols_h, cols_u], axis=-1)

        JB, JtB = times_B(J), times_B(_swap(J))
        Hc = jnp.asarray(route.hook_columns(), J.dtype)
        B = jnp.concatenate(  # (N, 4, n_slow): d (r_n, s_n) / d q_slow
            [jnp.concatenate([jnp.zeros((S.shape[0], 3, n_p), J.dtype), Hc, U[:, :, None]], axis=2),
             jnp.concatenate([S, jnp.zeros((S.shape[0], 3 * n_h + 1), J.dtype)], axis=1)[:, None]], axis=1,
        )  # fmt: skip
        Bz = jnp.concatenate([B[:-1], B[1:]], axis=1)  # (n_el, 8, n_slow)
        K_zz = jnp.einsum("eis,ekit->kst", Bz, JB)

        def node_rows(X):  # element-end rows (n_el, 2, 8, k) -> the internal nodes' r rows (n_int, 2, 3, k)
            zero = jnp.zeros((1,) + X.shape[1:2] + (3,) + X.shape[3:], X.dtype)
            return route.internal_rows(jnp.concatenate([X[:, :, 0:3], zero]) + jnp.concatenate([zero, X[:, :, 4:7]]))

        K_rz, K_zr = node_rows(JB), node_rows(JtB)
        _, iidx, _, _ = route._index_tables()
        internal = np.nonzero(iidx >= 0)[0]
        prev_linked = (iidx[internal - 1] >= 0)[:, None, None, None]  # internal nodes are never a route's first or last
        next_linked = (iidx[internal + 1] >= 0)[:, None, None, None]
        zb = jnp.zeros((1, 2, 3, 3), J.dtype)
        diag = route.internal_rows(jnp.concatenate([J[:, :, 0:3, 0:3], zb]) + jnp.concatenate([zb, J[:, :, 4:7, 4:7]]))
        lower = jnp.where(prev_linked, route.internal_rows(jnp.concatenate([zb, J[:, :, 4:7, 0:3]])), 0.0)
        upper = jnp.where(next_linked, route.internal_rows(jnp.concatenate([J[:, :, 0:3, 4:7], zb])), 0.0)
        # the brake on the block coordinate (generalised_forces' Q_u)
        brake = self.buffer.generalized_force
        dQ_du = jax.jvp(lambda u: brake(qdot.u, u), (q.u,), (jnp.ones_like(q.u),))[1]
        dQ_dudot = jax.jvp(lambda ud: brake(ud, q.u), (qdot.u,), (jnp.ones_like(qdot.u),))[1]
        K_zz = K_zz.at[0, -1, -1].add(dQ_du).at[1, -1, -1].add(dQ_dudot)
        return (
            ((lower[:, 0], diag[:, 0], upper[:, 0]), (lower[:, 1], diag[:, 1], upper[:, 1])),
            (K_rz[:, 0], K_rz[:, 1]),
            (K_zz[0], K_zz[1]),
            (K_zr[:, 0], K_zr[:, 1]),
        )

    def slow_mass_blocks(self, kin: "CableKinematics"):
        """The mass matrix's rows of the slow coordinates (pulley ``s``, block ``u``): ``(M_rs
        (n_int, 3, n_slow), M_ss (n_slow, n_slow))`` [kg] (the same closed form as
        :meth:`accelerations`, which never forms them this way)."""
        *_, G1, G2, H1, H2 = self._slow_velocity_jacobians(kin)
        M_ss = jnp.einsum("eis,eit->st", G1, H1) + jnp.einsum("eis,eit->st", G2, H2)
        n_slow = M_ss.shape[0]
        b = self.buffer
        M_ss = M_ss.at[n_slow - 1, n_slow - 1].add(b.counterweight_mass_kg * b.transfer_rate**2)
        zero = jnp.zeros((1,) + H1.shape[1:], H1.dtype)
        M_rs = self.route.internal_rows(jnp.concatenate([H1, zero]) + jnp.concatenate([zero, H2]))
        return M_rs, M_ss

    def _slow_velocity_jacobians(self, kin: "CableKinematics"):
        """The slow coordinates' (pulley ``s``, block ``u``) Jacobians of the material velocity at
        each element end and their mass-weighted forms: ``(S (N, n_p) d s_node / d s_pulley, t (n_el,
        3) tangents, U (N, 3) d r_node / d u, c (n_el,) rhoA L / 6, G1, G2 (n_el, 3, n_slow) at the
        first and second ends, H1 = c (2 G1 + G2), H2 = c (G1 + 2 G2))``."""
        S, U = self.route.slow_node_maps(kin.W)
        Hc = self.route.hook_columns()
        t = kin.tangent
        G1 = jnp.concatenate([-t[:, :, None] * S[:-1, None, :], Hc[:-1], U[:-1, :, None]], axis=2)
        G2 = jnp.concatenate([-t[:, :, None] * S[1:, None, :], Hc[1:], U[1:, :, None]], axis=2)
        c = (self.cable.rhoA_kg_per_m / 6.0) * kin.length
        H1 = c[:, None, None] * (2.0 * G1 + G2)
        H2 = c[:, None, None] * (G1 + 2.0 * G2)
        return S, t, U, c, G1, G2, H1, H2

    def internal_mass_blocks(self, kin: "CableKinematics"):
        """Scalar consistent-mass tridiagonal of the internal nodes (their block is this (x) I3):
        ``(lower (n_int,), diag (n_int,), upper (n_int,))`` [kg]; ``lower[j]`` couples internal node
        ``j`` to ``j - 1`` (zero across a pulley or an end, and at ``j = 0``)."""
        _, iidx, _, _ = self.route._index_tables()
        internal = np.nonzero(iidx >= 0)[0]
        c = (self.cable.rhoA_kg_per_m / 6.0) * kin.length  # (n_el,): node i has elements i-1 and i
        diag = 2.0 * (c[internal - 1] + c[internal])
        linked = np.diff(internal) == 1  # consecutive internal nodes share element internal[j]
        off = jnp.where(linked, c[internal[:-1]], 0.0)
        zero = jnp.zeros(1, c.dtype)
        return jnp.concatenate([zero, off]), diag, jnp.concatenate([off, zero])

    def _generalised(self, kin: "CableKinematics", F_r, F_s):
        """``A^T`` of nodal forces ``F_r`` (N, 3), ``F_s`` (N,): generalised forces (r, s, u, h)."""
        S, U = self.route.slow_node_maps(kin.W)
        Q_r = self.route.internal_rows(F_r)
        Q_s = jnp.sum(S * F_s[:, None], axis=0)
        Q_u = jnp.sum(U * F_r)
        H = self.route.hook_node_map()
        Q_h = jnp.sum(H[:, :, None] * F_r[:, None, :], axis=0)  # (n_h, 3)
        return Q_r, Q_s, Q_u, Q_h

    def accelerations(
        self, q, qdot, external: CableCoords | None = None, reel_acceleration=None, element_forces=None, kin=None
    ):
        """``q_dd`` from Lagrange's equations (see module docstring); ``external`` generalised forces,
        ``element_forces`` (n_elements, 2, 3) world forces [N] on the material at each element's
        ends (as :meth:`material_point_forces`), ``kin`` precomputed :meth:`kinematics`.

        Active pulleys (eq 47, ``s_dot = v_p``): their material coordinates move as prescribed; the
        state carries ``s_dot = v_p`` and ``reel_acceleration`` (n_active,) [m/s^2] is ``dv_p/dt``
        (default 0: constant reel speed). Their rows of the reduced system are replaced by the
        prescription; the motor supplies whatever force that takes (the multiplier of eq 47).

        Nodal coordinates are affine in ``q`` (``x = A q + b``, ``A`` constant), so Lagrange's
        equations in ``q`` are ``A^T`` times those in ``x``: ``(A^T M_x A) q_dd = A^T f_x + Q_u``.
        ``A^T M_x A`` is never formed densely. Every element's kinetic energy is
        ``c (|a_1|^2 + a_1.a_2 + |a_2|^2)``, ``c = rhoA L / 6``, with the material velocities ``a_i``;
        a node's ``a`` is its internal-node velocity (identity) plus ``G q_slow_dot``, ``G`` (3, n_slow)
        = ``[-t W_pulleys, block direction if the node rides the block]`` for the few "slow"
        coordinates (pulley ``s``, block ``u``). Hence the internal-node block is the scalar
        consistent-mass tridiagonal (x) I3, the coupling rows are ``c (2 G_self + G_other)`` and the
        slow block is ``sum c (G_1^T (2 G_1 + G_2) + G_2^T (G_1 + 2 G_2))``; we solve by the Schur
        complement on the slow coordinates. The internal-node block's inverse is a constant pattern
        scaled per span (:meth:`CableRoute.span_pattern_inverses`), so the solve is one dense product
        per span (quadratic in the span's internal nodes, 39 on the default mesh's arresting spans)
        and a Gauss-Jordan on the few slow coordinates, all in closed form (no autodiff and no
        LAPACK call inside the vector field).

        Span by span: a span's nodes see only its own ends' slow coordinates
        (:meth:`CableRoute.span_slow_tables`: the two slots its material coordinates interpolate, a
        hook end's position, a block end's travel), so ``G``, the coupling rows and their product
        with the inverse are built on those ``k`` local columns (5 on an arresting span beside a hook
        node, against all 9 of the cable), and each span's share of the slow block and of the Schur
        complement is added onto its columns. On the full design case this took 0.71x the time of
        the same solve on all the cable's slow columns per evaluation of the vector field; the
        whole 1 s landing was measured 1.08x, not faster (``docs/stiff_integrator.md``).
        """
        route = self.route
        kin = self.kinematics(q, qdot) if kin is None else kin
        Q_r, Q_slow = self.generalised_forces(q, qdot, kin, element_forces)
        if external is not None:
            Q_r = Q_r + external.r
            Q_slow = Q_slow + jnp.concatenate([external.s, external.h.reshape(-1), external.u[None]])
        b = self.buffer
        n_p = len(route.pulley_ids)
        n_slow = n_p + 3 * len(route.hook_ids) + 1
        t = kin.tangent
        c = (self.cable.rhoA_kg_per_m / 6.0) * kin.length  # (n_el,)
        sb = route.boundary_s(q)
        inverses = iter(route.span_pattern_inverses())
        M_ss = jnp.zeros((n_slow, n_slow), c.dtype).at[n_slow - 1, n_slow - 1].set(
            b.counterweight_mass_kg * b.transfer_rate**2
        )
        parts = []
        reduced_rhs = Q_slow
        for j, span in enumerate(route.span_slow_tables()):
            # The span's material velocities at its elements' ends, G = d a / d q_slow (n_el, 3, k) on
            # its k local slow columns: -t (1 - F) and -t F on its ends' slots (F the node's fraction
            # of the span: 0 at its first end, 1 at its last), plus the hook's identity and the
            # block's direction at an end node that is a hook or rides the block.
            n_el, e0, cols = span["n_el"], span["first_element"], span["cols"]
            k = len(cols)
            if k == 0 and n_el < 2:
                continue
            f = route.fractions[j]
            F = jnp.concatenate([jnp.zeros(1, c.dtype), jnp.asarray(f, dtype=c.dtype), jnp.ones(1, c.dtype)])
            weights = [None, None]
            for end_, slot in enumerate(span["slots"]):
                if slot is not None:
                    weights[end_] = (slot, 1.0 - F if end_ == 0 else F)
            t_j, c_j = t[e0 : e0 + n_el], c[e0 : e0 + n_el]
            G1 = jnp.zeros((n_el, 3, k), c.dtype)
            G2 = jnp.zeros((n_el, 3, k), c.dtype)
            for w in weights:
                if w is not None:
                    onehot = np.eye(k)[w[0]]
                    G1 = G1 - t_j[:, :, None] * (w[1][:-1, None, None] * onehot)
                    G2 = G2 - t_j[:, :, None] * (w[1][1:, None, None] * onehot)
            for end_ in (0, 1):
                if span["hook"][end_] is None and span["block"][end_] is None:
                    continue
                V = np.zeros((3, k))
                if span["hook"][end_] is not None:
                    V[:, list(span["hook"][end_])] = np.eye(3)
                V = jnp.asarray(V, c.dtype)
                if span["block"][end_] is not None:
                    V = V + route.block_direction[:, None] * np.eye(k)[span["block"][end_]][None, :]
                at = np.zeros(n_el)
                at[0 if end_ == 0 else n_el - 1] = 1.0
                if end_ == 0:
                    G1 = G1 + at[:, None, None] * V[None]
                else:
                    G2 = G2 + at[:, None, None] * V[None]
            H1 = c_j[:, None, None] * (2.0 * G1 + G2)
            H2 = c_j[:, None, None] * (G1 + 2.0 * G2)
            M_j = _contract(G1, H1) + _contract(G2, H2)
            if n_el < 2:
                M_ss = M_ss + _spread(cols, M_j, n_slow)
                continue
            # The internal nodes' block is rhoA L_j / 6 That_j (x) I3 (L_j the span's material length,
            # That_j constant: route.span_pattern_inverses), coupled to the k local slow columns by
            # M_rs (m, 3, k): one product with the constant inverse for the forces and those columns.
            m = n_el - 1
            i0 = span["first_internal"]
            M_rs = H2[:-1] + H1[1:]
            rhs = jnp.concatenate([Q_r[i0 : i0 + m], M_rs.reshape(m, 3 * k)], axis=1)
            sol = (6.0 / (self.cable.rhoA_kg_per_m * (sb[j + 1] - sb[j]))) * (next(inverses) @ rhs)
            Y, Z = sol[:, :3], sol[:, 3:].reshape(m, 3, k)
            M_ss = M_ss + _spread(cols, M_j - _contract(M_rs, Z), n_slow)
            reduced_rhs = reduced_rhs - _spread_vec(cols, _contract(M_rs, Y[..., None])[:, 0], n_slow)
            parts.append((Y, Z, cols))
        schur = M_ss
        active = np.array(route.active_slots, dtype=int)
        if active.size:
            prescribed = jnp.zeros(active.size) if reel_acceleration is None else jnp.asarray(reel_acceleration)
            schur = schur.at[active].set(jnp.eye(n_slow, dtype=schur.dtype)[active])
            reduced_rhs = reduced_rhs.at[active].set(prescribed)
        a_slow = _small_solve(schur, reduced_rhs)
        if parts:
            pieces = []
            for Y, Z, cols in parts:
                a_local = _gather_vec(cols, a_slow)
                a_j = Y
                for kk in range(Z.shape[-1]):  # elementwise, not a reduction over the short slow axis
                    a_j = a_j - Z[..., kk] * a_local[kk]
                pieces.append(a_j)
            a_r = jnp.concatenate(pieces)
        else:
            a_r = q.r * 0.0
        return CableCoords(r=a_r, s=a_slow[:n_p], u=a_slow[-1], h=a_slow[n_p:-1].reshape(-1, 3))

    def _cable_terms_x(self, x, xd, assemble=True):
        """Cable mass matrix and forces in full nodal coordinates ``x = [r_i, s_i]`` (4N,).

        Returns ``(M_full (4N,4N), f (4N,))`` with ``f = -(d/dx(M xd)) xd + dT/dx - dV/dx - dD/dxd``
        for the cable alone (element by element, closed-form mass, autodiff for the rest). The test
        reference of :meth:`_element_forces` (not used by the vector field)."""
        n = x.shape[0] // 4
        X = x.reshape(n, 4)
        rhoA, EA = self.cable.rhoA_kg_per_m, self.cable.EA_N

        def element_T(xe, xde):
            r1, s1, r2, s2 = xe[:3], xe[3], xe[4:7], xe[7]
            length, tangent, _ = _element_terms(r1, r2, s1, s2)
            a1 = xde[:3] - tangent * xde[3]
            a2 = xde[4:7] - tangent * xde[7]
            return rhoA * length / 6.0 * (a1 @ a1 + a1 @ a2 + a2 @ a2)

        def element_V(xe):
            r1, s1, r2, s2 = xe[:3], xe[3], xe[4:7], xe[7]
            length, _, strain = _element_terms(r1, r2, s1, s2)
            elastic = EA * length * strain_energy_density(strain, self.cable.slack_width)
            return elastic - rhoA * length * (0.5 * (r1 + r2)) @ self.gravity

        def element_D(xe, xde):
            r1, s1, r2, s2 = xe[:3], xe[3], xe[4:7], xe[7]
            length, tangent, _ = _element_terms(r1, r2, s1, s2)
            rate = (tangent @ (xde[4:7] - xde[:3]) - (tangent @ tangent) * (xde[7] - xde[3])) / length
            return 0.5 * self.cable.damping_s * EA * length * rate**2

        def element_terms(xe, xde):
            p = lambda y: jax.grad(element_T, argnums=1)(y, xde)  # noqa: E731
            _, dp = jax.jvp(p, (xe,), (xde,))
            f = -dp + jax.grad(element_T, argnums=0)(xe, xde)
            f = f - jax.grad(element_V)(xe) - jax.grad(element_D, argnums=1)(xe, xde)
            r1, s1, r2, s2 = xe[:3], xe[3], xe[4:7], xe[7]
            length, tangent, _ = _element_terms(r1, r2, s1, s2)
            B = jnp.concatenate([jnp.eye(3, dtype=x.dtype), -tangent[None, :]], axis=0)
            M_e = rhoA * length / 6.0 * jnp.kron(jnp.array([[2.0, 1.0], [1.0, 2.0]]), B @ B.T)
            return M_e, f

        xe = jnp.concatenate([X[:-1], X[1:]], axis=1)
        xde = jnp.concatenate([xd.reshape(n, 4)[:-1], xd.reshape(n, 4)[1:]], axis=1)
        M_e, f_e = jax.vmap(element_terms)(xe, xde)
        idx = 4 * jnp.arange(n - 1)[:, None] + jnp.arange(8)[None, :]
        f = jnp.zeros(4 * n, x.dtype).at[idx].add(f_e)
        if not assemble:
            return M_e, f
        M = jnp.zeros((4 * n, 4 * n), x.dtype).at[idx[:, :, None], idx[:, None, :]].add(M_e)
        return M, f

    def _accelerations_autodiff(self, q, qdot, external: CableCoords | None = None):
        """Reference implementation: Lagrange's equations by autodiff of the total T, V, D in q
        (slow: the mass matrix by ``jacfwd``); the tests check :meth:`accelerations` against it."""
        flat_q, unravel = ravel_pytree(q)
        flat_qd, _ = ravel_pytree(qdot)

        def T(fq, fqd):
            return self.kinetic_energy(unravel(fq), unravel(fqd))

        def p(fq):
            return jax.grad(T, argnums=1)(fq, flat_qd)

        mass = jax.jacfwd(lambda fqd: jax.grad(T, argnums=1)(flat_q, fqd))(flat_qd)
        _, dp = jax.jvp(p, (flat_q,), (flat_qd,))
        dTdq = jax.grad(T, argnums=0)(flat_q, flat_qd)
        dVdq = jax.grad(lambda fq: self.potential_energy(unravel(fq)))(flat_q)
        dDdqd = jax.grad(lambda fqd: self.dissipation_function(unravel(flat_q), unravel(fqd)))(flat_qd)
        brake = ravel_pytree(
            CableCoords(r=jnp.zeros_like(q.r), s=jnp.zeros_like(q.s), u=self.buffer.generalized_force(qdot.u, q.u), h=jnp.zeros_like(q.h))
        )[0]
        rhs = -dp + dTdq - dVdq - dDdqd + brake
        if external is not None:
            rhs = rhs + ravel_pytree(external)[0]
        return unravel(jnp.linalg.solve(mass, rhs))

    def dissipated_power(self, q, qdot, kin=None):
        """Power dissipated by cable damping and the brake [W] (>= 0); ``kin``: precomputed
        :meth:`kinematics` (``2 D = beta EA sum L eps_dot^2``)."""
        kin = self.kinematics(q, qdot) if kin is None else kin
        damping = self.cable.damping_s * self.cable.EA_N * jnp.sum(kin.length * kin.strain_rate**2)
        return damping + self.buffer.brake_power(qdot.u, q.u)

    def derivative(self, state: CableState, external: CableCoords | None = None) -> CableState:
        kin = self.kinematics(state.q, state.qdot)
        qdd = self.accelerations(state.q, state.qdot, external, kin=kin)
        return CableState(q=state.qdot, qdot=qdd, dissipated=self.dissipated_power(state.q, state.qdot, kin))

    def energy(self, state: CableState):
        """dict of kinetic, elastic, cable_gravity, counterweight_potential, dissipated [J]."""
        e, g, c = self.potential_parts(state.q)
        return dict(
            kinetic=self.kinetic_energy(state.q, state.qdot),
            elastic=e,
            cable_gravity=g,
            counterweight_potential=c,
            dissipated=state.dissipated,
        )

    def material_length(self):
        """Total material (unstretched) length of the cable [m] (constant: ends are fixed)."""
        return self.route.s_boundary0[-1] - self.route.s_boundary0[0]


def check_cable_inputs(EA_N, rhoA_kg_per_m):
    check_positive("EA_N", EA_N)
    check_positive("rhoA_kg_per_m", rhoA_kg_per_m)
