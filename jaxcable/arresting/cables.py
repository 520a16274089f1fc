r"""A cable over pulleys meshed with ALE elements, with the mesh rules eliminated (eqs 26-34).

Arresting-cable paper, section III.B. One cable runs through a chain of *boundary nodes* (its two
ends and the pulleys it passes over); between two boundary nodes a *span* is meshed with ALE elements
(:mod:`jaxcable.line.ale`). The paper enforces the mesh rules as algebraic constraints inside an
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
:mod:`jaxcable.line.ale`) + gravity + counterweight energy, ``D`` the Rayleigh dissipation function
``sum beta EA L eps_dot^2 / 2`` of the damping term of eq 31, and ``Q_ext`` the brake and contact
forces. This differs from eqs 29-31 by the terms concentrated at nodes that slide through material
where the tangent or strain jumps (see :mod:`jaxcable.line.ale`): with them, the undamped discrete
model conserves energy exactly, so a landing's energy budget closes. Mass is conserved exactly: the
end material coordinates are fixed, so ``rhoA (s_end - s_start)`` is constant whatever flows over
the pulleys.

Glossary
--------
===================  ===========================================================================
``boundary_points``  (nb,3) boundary node positions at ``u = 0`` [m]
``kinds``            static tuple, per boundary node: ``"end"``, ``"pulley"`` (passive: ``s`` free) or
                     ``"active"`` (the motor-driven pulley of eq 47: ``s`` is a coordinate whose rate
                     ``s_dot = v_p`` is prescribed; its acceleration is an input)
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

from .._validation import check_finite, check_positive
from ..line.ale import AleCable, axial_tension_factor, strain_energy_density
from .buffer import BufferDevice

__all__ = [
    "CableCoords",
    "CableRoute",
    "CableState",
    "CableSubsystem",
    "graded_fractions",
]


class CableCoords(eqx.Module):
    """Generalised coordinates (or their rates) of one cable subsystem."""

    r: jax.Array
    """Internal-node positions (n_int, 3) [m] (rates: [m/s])."""
    s: jax.Array
    """Material coordinates of the pulley nodes (n_p,) [m] (rates: [m/s])."""
    u: jax.Array
    """Moving-block travel () [m] (rate: [m/s]); counterweight rise ``alpha u``."""


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
    if n_coarse < 2 or n_fine < 1:
        raise ValueError(f"need n_elements >= n_fine + 2, got n_elements={n_elements}, n_fine={n_fine}")
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

    def __check_init__(self):
        check_finite("boundary_points", self.boundary_points)
        check_finite("s_boundary0", self.s_boundary0)
        if len(self.kinds) != len(self.moving) or len(self.fractions) != len(self.kinds) - 1:
            raise ValueError("CableRoute: kinds, moving and fractions must describe the same nodes/spans")
        for k in self.kinds:
            if k not in ("end", "pulley", "active"):
                raise ValueError(f"unknown boundary kind {k!r}; choose 'end', 'pulley' or 'active'")
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
        return tuple(i for i, k in enumerate(self.kinds) if k in ("pulley", "active"))

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

    def boundary_s(self, q: CableCoords):
        s = self.s_boundary0
        if self.pulley_ids:
            s = s.at[np.array(self.pulley_ids)].set(q.s)
        return s

    def boundary_r(self, q: CableCoords):
        shift = jnp.asarray(self.moving, dtype=float)[:, None] * q.u * self.block_direction[None, :]
        return self.boundary_points + shift

    def nodes(self, q: CableCoords):
        """All nodal positions (N,3) [m] and material coordinates (N,) [m] (affine in q)."""
        bidx, iidx, span_of, _ = self._index_tables()
        rb = self.boundary_r(q)
        sb = self.boundary_s(q)
        frac = jnp.concatenate([jnp.asarray(f, dtype=float).reshape(-1) for f in self.fractions])
        is_b = bidx >= 0
        r = jnp.where(is_b[:, None], rb[np.maximum(bidx, 0)], q.r[np.maximum(iidx, 0)])
        s_int = sb[span_of] + frac[np.maximum(iidx, 0)] * (sb[span_of + 1] - sb[span_of])
        s = jnp.where(is_b, sb[np.maximum(bidx, 0)], s_int)
        return r, s


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

        def power(qdot):
            (r, s), (v, sd) = jax.jvp(self.route.nodes, (q,), (qdot,))
            _, tangent, _ = jax.vmap(_element_terms)(r[:-1], r[1:], s[:-1], s[1:])
            a1 = v[:-1] - tangent * sd[:-1, None]
            a2 = v[1:] - tangent * sd[1:, None]
            return jnp.sum(element_forces[:, 0] * a1) + jnp.sum(element_forces[:, 1] * a2)

        zero = jax.tree_util.tree_map(jnp.zeros_like, q)
        return jax.grad(power)(zero)

    # -- dynamics --------------------------------------------------------------------------------
    def _cable_terms_x(self, x, xd, assemble=True):
        """Cable mass matrix and forces in full nodal coordinates ``x = [r_i, s_i]`` (4N,).

        Returns ``(M_full (4N,4N), f (4N,))`` with ``f = -(d/dx(M xd)) xd + dT/dx - dV/dx - dD/dxd``
        for the cable alone (element by element, closed-form mass, autodiff for the rest)."""
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

    def accelerations(self, q, qdot, external: CableCoords | None = None, reel_acceleration=None):
        """``q_dd`` from Lagrange's equations (see module docstring); ``external`` generalised forces.

        Active pulleys (eq 47, ``s_dot = v_p``): their material coordinates move as prescribed; the
        state carries ``s_dot = v_p`` and ``reel_acceleration`` (n_active,) [m/s^2] is ``dv_p/dt``
        (default 0: constant reel speed). Their rows of the reduced system are replaced by the
        prescription; the motor supplies whatever force that takes (the multiplier of eq 47).

        Nodal coordinates are affine in ``q`` (``x = A q + b``, ``A`` constant), so Lagrange's
        equations in ``q`` are ``A^T`` times those in ``x``: ``(A^T M_x A) q_dd = A^T f_x + Q_u``.
        ``A^T M_x A`` is never formed densely: its block for the internal-node positions is the
        scalar consistent-mass tridiagonal (x) I3 (the r-r block of every ALE element mass is
        ``rhoA L/6 [[2,1],[1,2]] (x) I3``), coupled to the few pulley/block coordinates; we solve by
        the Schur complement on those, with one tridiagonal solve: O(n) per cable.
        """
        flat_q, unravel = ravel_pytree(q)
        flat_qd, _ = ravel_pytree(qdot)
        n_r = q.r.size
        n_int = q.r.shape[0]

        def xfun(fq):
            r, s = self.route.nodes(unravel(fq))
            return jnp.concatenate([r, s[:, None]], axis=1).reshape(-1)

        x, xd = jax.jvp(xfun, (flat_q,), (flat_qd,))
        _, xfun_T = jax.vjp(xfun, flat_q)  # A^T (the map is affine)
        M_x_apply, f_x, lengths = self._cable_terms_x_apply(x, xd)
        rhs = xfun_T(f_x)[0]
        # columns of A^T M_x A for the few "slow" coordinates (pulley s, block u)
        n_slow = flat_q.shape[0] - n_r
        eye = jnp.eye(flat_q.shape[0], dtype=x.dtype)[n_r:]
        cols = jax.vmap(lambda e: xfun_T(M_x_apply(jax.jvp(xfun, (flat_q,), (e,))[1] - 0 * x))[0])(eye)
        M_slow = cols.T  # (n_dof, n_slow): column j = M_q e_j
        # counterweight: kinetic m_w alpha^2 u_dot^2 / 2, potential m_w g alpha u, brake
        b = self.buffer
        u_slow = n_slow - 1  # ravel order of CableCoords: r, s, u
        M_slow = M_slow.at[n_r + u_slow, u_slow].add(b.counterweight_mass_kg * b.transfer_rate**2)
        g = -self.gravity[2]
        rhs = rhs.at[-1].add(-b.counterweight_mass_kg * g * b.transfer_rate + b.generalized_force(qdot.u))
        if external is not None:
            rhs = rhs + ravel_pytree(external)[0]
        # tridiagonal consistent mass of the internal nodes (per coordinate direction)
        bidx, iidx, _, _ = self.route._index_tables()
        full_of_int = np.nonzero(iidx >= 0)[0]
        rhoA = self.cable.rhoA_kg_per_m
        diag = rhoA * (lengths[full_of_int - 1] + lengths[full_of_int]) / 3.0
        has_next = (iidx[np.minimum(full_of_int + 1, len(iidx) - 1)] >= 0) & (full_of_int + 1 < len(iidx))
        upper = jnp.where(has_next, rhoA * lengths[full_of_int] / 6.0, 0.0)
        du = upper.at[-1].set(0.0)
        dl = jnp.concatenate([jnp.zeros(1, x.dtype), upper[:-1]])
        M_rs = M_slow[:n_r].reshape(n_int, 3 * n_slow)
        M_ss = M_slow[n_r:]
        f_r = rhs[:n_r].reshape(n_int, 3)
        f_s = rhs[n_r:]
        # (a dense solve of this small n_int x n_int tridiagonal: LAPACK gtsv has no batched CPU
        # kernel under vmap in this jaxlib, and n_int ~ 25 makes the dense LU ~1e4 flops)
        tri = jnp.diag(diag) + jnp.diag(du[:-1], 1) + jnp.diag(dl[1:], -1)
        sol = jnp.linalg.solve(tri, jnp.concatenate([f_r, M_rs], axis=1))
        Minv_fr = sol[:, :3].reshape(-1)
        Minv_Mrs = sol[:, 3:].reshape(n_int, 3, n_slow).reshape(n_r, n_slow)
        M_rs_flat = M_slow[:n_r]
        schur = M_ss - M_rs_flat.T @ Minv_Mrs
        reduced_rhs = f_s - M_rs_flat.T @ Minv_fr
        active = np.array(self.route.active_slots, dtype=int)
        if active.size:
            prescribed = jnp.zeros(active.size) if reel_acceleration is None else jnp.asarray(reel_acceleration)
            schur = schur.at[active].set(jnp.eye(n_slow, dtype=x.dtype)[active])
            reduced_rhs = reduced_rhs.at[active].set(prescribed)
        a_s = jnp.linalg.solve(schur, reduced_rhs)
        a_r = Minv_fr - Minv_Mrs @ a_s
        return unravel(jnp.concatenate([a_r, a_s]))

    def _cable_terms_x_apply(self, x, xd):
        """As :meth:`_cable_terms_x`, but the mass matrix as a function ``v -> M_x v`` (element by
        element, never assembled), and the element material lengths."""
        n = x.shape[0] // 4
        X = x.reshape(n, 4)
        rhoA = self.cable.rhoA_kg_per_m
        M_x, f = self._cable_terms_x(x, xd, assemble=False)
        lengths = X[1:, 3] - X[:-1, 3]
        idx = 4 * jnp.arange(n - 1)[:, None] + jnp.arange(8)[None, :]

        def apply(v):
            ve = v[idx]
            return jnp.zeros(4 * n, x.dtype).at[idx].add(jnp.einsum("eij,ej->ei", M_x, ve))

        return apply, f, lengths

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
            CableCoords(r=jnp.zeros_like(q.r), s=jnp.zeros_like(q.s), u=self.buffer.generalized_force(qdot.u))
        )[0]
        rhs = -dp + dTdq - dVdq - dDdqd + brake
        if external is not None:
            rhs = rhs + ravel_pytree(external)[0]
        return unravel(jnp.linalg.solve(mass, rhs))

    def dissipated_power(self, q, qdot):
        """Power dissipated by cable damping and the brake [W] (>= 0)."""
        return 2.0 * self.dissipation_function(q, qdot) + self.buffer.brake_power(qdot.u)

    def derivative(self, state: CableState, external: CableCoords | None = None) -> CableState:
        qdd = self.accelerations(state.q, state.qdot, external)
        return CableState(q=state.qdot, qdot=qdd, dissipated=self.dissipated_power(state.q, state.qdot))

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
