"""Finite-segment (Kane) rope with payout from a box: the line-throwing rocket paper, section 3.

The rope is a planar chain of rigid, massless links; the mass of each link is lumped at its far
end (the end away from the rocket), as in the paper. Node 0 is the rocket (a point mass), node
``j`` the far end of link ``j``.

Glossary (paper's symbols, eqs 6-26):

=============  =====================================================================
``r0``         rocket position ``(x0, y0)`` [m]; y up, x along the range
``theta[j]``   angle of link ``j+1`` measured from the +Y axis, as in eq 6 [rad]:
               ``r_j = r_{j-1} - l_j (sin theta_j, cos theta_j)``
``omega[j]``   ``d theta / dt`` [rad/s]
``S``          deployed rope length (rope that has left the box) [m]
``u_j``        ``(sin theta_j, cos theta_j)``: unit vector along link j, pointing to the rocket
``p_j``        ``(cos theta_j, -sin theta_j) = d u_j / d theta_j``
``l``          full segment length [m]; ``rho`` rope linear density [kg/m]
=============  =====================================================================

Corrections to the paper (re-derived from eq 6):

* eq 7 uses ``omega_1`` for every link; the velocity of node i is
  ``v_i = v_{i-1} - l_i omega_i p_i`` (each link has its own rate), and for the growing last link
  the position also moves by ``-(dl_n/dt) u_n`` (a term the paper drops; see "payout" below).
* eq 8 has the partial velocities of the ``x0, y0`` columns right but its ``i >= j`` row must read
  ``-l_j p_j = (-l_j cos theta_j, +l_j sin theta_j)`` with the index of the *link* ``j``, not of the node.
* eq 9: ``d/dt(-l_j p_j) = +l_j omega_j u_j`` = ``(l_j sin theta_j omega_j, l_j cos theta_j omega_j)``;
  the printed signs agree, but the entries depend on ``j`` (the link), not ``i``.
* eqs 11-12: with y up, gravity is ``(0, -m g)``; the paper prints ``+m g``.
* eqs 13-14: drag must oppose the motion: ``-1/2 rho_a c S (V_x|V_x|, V_y|V_y|)``; the paper prints
  the dynamic pressures without sign.
* eqs 19 and 21 sum from ``i = 1``; the rocket (``i = 0``) must be included, as eq 20 (``Fl = u' fz``)
  and ``M = diag[m0, ..., mn]`` in eq 22 do.
* eq 26: ``fl = Fl - u' M u_dot q_dot`` (the printed ``u' M u q`` drops the dot on ``u``).

Payout and the start of a new segment (zero length)
---------------------------------------------------
The paper says only that the last segment grows until a new one is pulled out. We use fixed-size
arrays (``capacity`` links); ``k = floor(S / l)`` links are full, link ``k+1`` is the *tail* of length
``S - k l`` and the links beyond it have zero length and zero mass (inactive).

* The tail is rigidly collinear with the last full link (for ``k = 0``: with the launch direction,
  rigidly attached to the rocket). A separately hinged zero-length link would carry zero mass and an
  undetermined, infinitely fast rotation; the collinear tail keeps every mass matrix regular. When the
  tail reaches length ``l`` it becomes a full, freely hinged link; its angle and rate are those of the
  link it extended, so positions and velocities are continuous (the hinge release makes the
  accelerations jump, like any contact onset).
* Rope material enters the tail at its far end (the box side). The lumped tail mass ``rho * l_tail``
  moves with the *material* velocity of the rigid tail; the node's position additionally drifts by
  ``-dS/dt u`` (an ALE node), so that in a straight pull the tail end stays at the box.
* Payout rate: rope leaves the box at the rate the tail end's material moves forward along the rope,
  ``dS/dt = softplus(v_tail . u)`` (width ``payout_smoothing_mps``); nothing is pushed back into the box.
* The mass joining the tail comes from rest. Its momentum is supplied by the pull-out model
  (:mod:`jaxcable.throw.forces`): ``MomentumFluxPullOut`` applies ``-rho dS/dt v_tail`` (the exact balance,
  ``rho v^2`` in a straight pull); ``NoPullOut`` lets new rope appear already moving (what the paper's
  Kane equations with ``m_i a_i`` and a growing ``m_n`` imply: it does not conserve momentum).

Solvers
-------
:func:`chain_accelerations` is O(n): an articulated-body elimination of the collinear tail into its
hinge node, then link tensions from one symmetric tridiagonal system (LAPACK ``gtsv`` via
``jax.lax.linalg.tridiagonal_solve``). :func:`chain_accelerations_dense` is the paper's dense Kane form
``u' M u q_ddot = u' (f - M u_dot q_dot)`` (eq 25), built by automatic differentiation of the node
positions; tests check the two agree to rounding error.
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from jaxcable.core.math import cubic_step, smooth_relu
from jaxcable.core.validation import check_positive, check_real

MAX_SEGMENTS = 20_000
"""Most segments :func:`make_rope` builds (the state holds two numbers per segment; 800 m of rope at
0.1 m is 8,000)."""


class SegmentRope(eqx.Module):
    """A rope of finite rigid segments paid out of a box.

    Attributes:
        linear_density_kg_per_m: rope mass per unit length ``rho`` [kg/m], scalar.
        diameter_m: rope diameter used for aerodynamic reference area ``d * l`` [m], scalar.
        drag_coefficient: rope drag coefficient on the area ``d * l_j`` [-], scalar.
        segment_length_m: full segment length ``l`` [m] (static: it fixes the array sizes).
        capacity: number of segments the box holds (static); rope length = ``capacity * l``.
        payout_smoothing_mps: width of the softplus that keeps payout one-way [m/s] (static).
        runout_fraction: the payout rate fades to zero over the last ``runout_fraction * l`` of the
            rope as the box empties (C1 cubic step; static). A jump of the payout rate (and of the
            momentum flux ``rho sdot^2``) at the state-dependent run-out instant would be a
            discontinuity of the vector field whose saltation term forward/reverse-mode AD through
            the solve does not see (measured: d speed/d rail length -0.061 against -0.0003 by
            central differences); with the fade the field is C1 and AD agrees.
    """

    linear_density_kg_per_m: Float[Array, ""]
    diameter_m: Float[Array, ""]
    drag_coefficient: Float[Array, ""]
    segment_length_m: float = eqx.field(static=True)
    capacity: int = eqx.field(static=True)
    payout_smoothing_mps: float = eqx.field(static=True, default=0.05)
    runout_fraction: float = eqx.field(static=True, default=0.05)

    def __check_init__(self):
        check_positive("rope.linear_density_kg_per_m", self.linear_density_kg_per_m)
        check_positive("rope.diameter_m", self.diameter_m)
        check_positive("rope.drag_coefficient", self.drag_coefficient, allow_zero=True)
        check_positive("rope.segment_length_m", self.segment_length_m)
        if not isinstance(self.capacity, int) or self.capacity < 1:
            raise ValueError(f"rope.capacity must be a positive integer, got {self.capacity!r}")
        check_positive("rope.payout_smoothing_mps", self.payout_smoothing_mps)
        if not 0.0 < self.runout_fraction <= 1.0:
            raise ValueError(f"rope.runout_fraction must be in (0, 1], got {self.runout_fraction!r}")

    @property
    def length_m(self) -> float:
        """Total rope length in the box [m] (``capacity`` whole segments)."""
        return self.capacity * self.segment_length_m


def make_rope(
    segment_length_m=1.0,
    rope_length_m=750.0,
    linear_density_kg_per_m=0.43,
    diameter_m=0.01,
    drag_coefficient=1.0,
    payout_smoothing_mps=0.05,
) -> SegmentRope:
    """Build a :class:`SegmentRope`, rounding the rope length up to whole segments (at most
    ``MAX_SEGMENTS``; a segment no longer than the rope)."""
    check_positive("segment_length_m", segment_length_m)
    check_positive("rope_length_m", rope_length_m)
    for name, value in (("linear_density_kg_per_m", linear_density_kg_per_m), ("diameter_m", diameter_m),
                        ("drag_coefficient", drag_coefficient), ("payout_smoothing_mps", payout_smoothing_mps)):  # fmt: skip
        check_real(name, value)
    if float(segment_length_m) > float(rope_length_m):
        raise ValueError(
            f"segment_length_m must be at most rope_length_m = {float(rope_length_m):g} m, got {segment_length_m!r}"
        )
    if rope_length_m / segment_length_m > MAX_SEGMENTS:
        raise ValueError(
            f"segment_length_m must give at most {MAX_SEGMENTS} segments of the {float(rope_length_m):g} m rope "
            f"(segment_length_m >= {float(rope_length_m) / MAX_SEGMENTS:g} m), got {segment_length_m!r}"
        )
    capacity = int(math.ceil(rope_length_m / segment_length_m - 1e-9))
    f = lambda x: jnp.asarray(x, dtype=float)
    return SegmentRope(
        linear_density_kg_per_m=f(linear_density_kg_per_m),
        diameter_m=f(diameter_m),
        drag_coefficient=f(drag_coefficient),
        segment_length_m=float(segment_length_m),
        capacity=capacity,
        payout_smoothing_mps=float(payout_smoothing_mps),
    )


class ChainState(eqx.Module):
    """State of rocket + rope (paper's generalized coordinates, plus the deployed length).

    Attributes:
        r0: rocket position [m], shape (2,).
        v0: rocket velocity [m/s], shape (2,).
        theta: link angles from +Y [rad], shape (capacity,).
        omega: link angular rates [rad/s], shape (capacity,).
        deployed: deployed rope length S [m], scalar.
    """

    r0: Float[Array, "2"]
    v0: Float[Array, "2"]
    theta: Float[Array, " n"]
    omega: Float[Array, " n"]
    deployed: Float[Array, ""]


class ChainKinematics(eqx.Module):
    """Derived kinematics of the chain at one instant (node 0 = rocket).

    Attributes:
        positions: node positions [m], (n+1, 2).
        velocities: node material velocities [m/s], (n+1, 2).
        masses: node masses [kg], (n+1,); ``masses[0]`` is the rocket.
        lengths: link lengths [m], (n,).
        u, p: link unit vectors (to the rocket) and their angle derivatives, (n, 2).
        omega: effective link rates [rad/s], (n,) (inactive links follow the tail).
        n_full: number of full links ``k``.
        n_free: number of links with their own angle (``k``, or ``k + 1`` with a hinged tail).
        tail_length: length of the growing link ``k+1`` [m].
        tail_direction: unit vector of the tail, pointing to the rocket, (2,).
        payout_rate: ``dS/dt`` [m/s].
    """

    positions: Float[Array, "n1 2"]
    velocities: Float[Array, "n1 2"]
    masses: Float[Array, " n1"]
    lengths: Float[Array, " n"]
    u: Float[Array, "n 2"]
    p: Float[Array, "n 2"]
    omega: Float[Array, " n"]
    n_full: Int[Array, ""]
    n_free: Int[Array, ""]
    tail_length: Float[Array, ""]
    tail_direction: Float[Array, "2"]
    payout_rate: Float[Array, ""]

    @property
    def tail_index(self):
        """Node index of the tail's far end (``k + 1``), clipped to the last node."""
        return jnp.minimum(self.n_full + 1, self.lengths.shape[0])

    @property
    def has_tail(self):
        return self.n_full < self.lengths.shape[0]


def unit_vectors(theta):
    u = jnp.stack([jnp.sin(theta), jnp.cos(theta)], axis=-1)
    return u, u[..., ::-1] * jnp.array([1.0, -1.0], dtype=u.dtype)


def launch_theta(angle_rad):
    """Link angle (from +Y, eq 6) of a link lying along a launch elevation ``angle_rad``."""
    return jnp.pi / 2 - angle_rad


def payout_geometry(state: ChainState, rope: SegmentRope):
    """``(k, tail)``: number of full links and the growing tail's length [m]."""
    n = rope.capacity
    seg = rope.segment_length_m
    S = jnp.clip(state.deployed, 0.0, n * seg)
    k = jnp.clip(jnp.floor(S / seg), 0, n).astype(jnp.int32)
    tail = jnp.where(k < n, S - k * seg, 0.0)
    return k, tail


def kinematics(state: ChainState, rope: SegmentRope, rocket_mass, theta_launch, hinged_tail=False) -> ChainKinematics:
    """Node positions, material velocities and masses for a state (O(n), vectorised).

    ``hinged_tail=False`` (the normal configuration): links ``1..k`` have their own angles and the
    tail rides collinear on link ``k``. ``hinged_tail=True``: the tail (link ``k+1``) also has its own
    angle, as it will once complete; used only to blend across the completion (see
    :func:`vector_field_terms`).
    """
    n = rope.capacity
    seg = rope.segment_length_m
    rho = rope.linear_density_kg_per_m
    k, tail = payout_geometry(state, rope)
    n_free = jnp.minimum(k + 1, n) if hinged_tail else k
    link = jnp.arange(1, n + 1)
    lengths = jnp.where(link <= k, seg, jnp.where(link == k + 1, tail, 0.0))
    last = jnp.maximum(n_free - 1, 0)
    theta_ref = jnp.where(n_free > 0, state.theta[last], theta_launch)
    omega_ref = jnp.where(n_free > 0, state.omega[last], 0.0)
    theta = jnp.where(link <= n_free, state.theta, theta_ref)
    omega = jnp.where(link <= n_free, state.omega, omega_ref)
    u, p = unit_vectors(theta)
    # Node positions and material velocities (the collinear tail rotates with the last free link,
    # i.e. rigidly), both from one cumulative sum over the links (4 columns, in blocks).
    base = jnp.concatenate([state.r0, state.v0])
    steps = jnp.concatenate([lengths[:, None] * u, (lengths * omega)[:, None] * p], axis=1)
    nodes = jnp.concatenate([base[None], base - _blocked_cumsum(steps)], axis=0)
    positions, velocities = nodes[:, :2], nodes[:, 2:]
    masses = jnp.concatenate([jnp.reshape(rocket_mass, (1,)), rho * lengths])
    tail_dir = unit_vectors(theta_ref)[0]
    v_tail = velocities[jnp.minimum(k + 1, n)]
    rate = smooth_relu(jnp.dot(v_tail, tail_dir), rope.payout_smoothing_mps)
    # the box empties: fade the payout over the rope's last runout_fraction * l (see SegmentRope)
    full = n * seg
    S = jnp.clip(state.deployed, 0.0, full)
    rate = rate * cubic_step(S, full - rope.runout_fraction * seg, 1.0, full, 0.0)
    rate = jnp.where(k < n, rate, 0.0)
    return ChainKinematics(
        positions=positions,
        velocities=velocities,
        masses=masses,
        lengths=lengths,
        u=u,
        p=p,
        omega=omega,
        n_full=k,
        n_free=n_free,
        tail_length=tail,
        tail_direction=tail_dir,
        payout_rate=rate,
    )


def _blocked_cumsum(x, block=16):
    """``jnp.cumsum(x, axis=0)`` of ``x`` (n, c), the rows summed in blocks of ``block`` by one small
    triangular product and the blocks' totals by a cumulative sum of ``n / block`` rows.

    XLA's CPU cumulative sum pads and reduces in windows; over the chain's nodes (4 columns: the
    positions and the material velocities) this form took the 30 deg flight at 1 m segments from
    0.48-0.50 s to 0.43-0.46 s (best of 7 calls in four pairs of interleaved processes; 2-core Intel
    Xeon, JAX 0.10.2 CPU, float64); the sums agree to rounding (1e-14 m over 750 links)."""
    n = x.shape[0]
    m = -(-n // block) * block
    blocks = jnp.pad(x, ((0, m - n), (0, 0))).reshape(m // block, block, -1)
    within = jnp.einsum("ij,kjc->kic", jnp.tril(jnp.ones((block, block), x.dtype)), blocks)
    offsets = jnp.cumsum(within[:, -1], axis=0) - within[:, -1]
    return (within + offsets[:, None]).reshape(m, -1)[:n]


def _outer(a, b):
    return a[..., :, None] * b[..., None, :]


def chain_accelerations(kin: ChainKinematics, forces, segment_length_m):
    """O(n) accelerations: rocket ``a0`` [m/s^2] (2,) and link ``d omega/dt`` [rad/s^2] (n,).

    Links ``1..K-1`` (``K = kin.n_free``) are hinge-hinge links between point masses: their tensions
    come from one symmetric tridiagonal system. Link ``K`` is a rigid rod hinged at node ``K-1``
    carrying node ``K`` and, when ``K = k``, the collinear tail; it is eliminated first into an
    articulated 2x2 inertia on node ``K-1``. When ``K = k + 1`` (``hinged_tail``) the rod is the
    growing link itself, treated as it will be once complete: its far node at a fixed distance (no ALE
    term) and a zero-mass tail beyond it, so that this configuration equals the one just after the
    completion and the blend of :func:`rope_vector_field` is continuous.

    Args:
        kin: kinematics from :func:`kinematics`.
        forces: applied force on each node [N], (n+1, 2) (momentum flux included).
        segment_length_m: full segment length ``l`` [m].
    """
    n = kin.lengths.shape[0]
    K = kin.n_free
    k = kin.n_full
    m = kin.masses
    eye = jnp.eye(2)
    sdot = kin.payout_rate

    # --- the rod: link K hinged at node K-1, node K on it, plus the collinear tail if K = k ---
    kk = jnp.clip(K, 1, n)  # node K (valid when K >= 1)
    kt = jnp.minimum(K + 1, n)  # tail node
    tail_on = (K == k) & (k < n)
    m_k = m[kk]
    m_t = jnp.where(tail_on, m[kt], 0.0)
    F_k = forces[kk]
    F_t = jnp.where(tail_on, forces[kt], 0.0)
    u_r = kin.u[kk - 1]
    p_r = kin.p[kk - 1]
    w_r = kin.omega[kk - 1]
    s1 = kin.lengths[kk - 1]
    s2 = s1 + jnp.where(tail_on, kin.tail_length, 0.0)
    D = s1**2 * m_k + s2**2 * m_t
    wvec = (s1 * m_k + s2 * m_t) * p_r
    c1 = s1 * w_r**2 * u_r
    c2 = s2 * w_r**2 * u_r - sdot * w_r * p_r
    beta = -s1 * jnp.dot(p_r, F_k) + s2 * (-m_t * sdot * w_r - jnp.dot(p_r, F_t))
    A_rod = (m_k + m_t) * eye - _outer(wvec, wvec) / D
    b_rod = m_k * c1 + m_t * c2 - F_k - F_t - wvec * beta / D
    # K = 0: the tail is rigidly attached to the rocket and translates with it.
    A_h = jnp.where(K >= 1, A_rod, m_t * eye)
    b_h = jnp.where(K >= 1, b_rod, -F_t)
    h = jnp.maximum(K - 1, 0)

    # --- tension chain over hinge-hinge links 1..K-1 (nodes 0..K-1); node h carries the rod ---
    # Every node but h has an isotropic inverse mass 1/m; node h has the 2x2 matrix W_h. Since
    # |u_j| = 1, the isotropic entries need no matrix products; row h gets W_h explicitly.
    node = jnp.arange(n + 1)
    inv_m = jnp.where((m > 0) & (node <= h), 1.0 / jnp.where(m > 0, m, 1.0), 0.0)
    inv_m = inv_m.at[h].set(0.0)
    W_h = jnp.linalg.inv(m[h] * eye + A_h)
    F_h = forces[h] - b_h
    WF = inv_m[:, None] * forces
    WF = WF.at[h].set(W_h @ F_h)

    link = jnp.arange(1, n + 1)
    active = link <= K - 1
    u = kin.u
    uu_prev = jnp.concatenate([jnp.zeros(1), jnp.sum(u[1:] * u[:-1], -1)])  # u_j . u_{j-1}
    uu_next = jnp.concatenate([uu_prev[1:], jnp.zeros(1)])  # u_j . u_{j+1}
    diag = -(inv_m[:-1] + inv_m[1:])
    lower = inv_m[:-1] * uu_prev
    upper = inv_m[1:] * uu_next
    # row of link h (its far node is h): add u_h . W_h u_h to the diagonal (h >= 1 only)
    u_h = u[jnp.maximum(h - 1, 0)]
    diag = diag.at[h - 1].add(jnp.where(h >= 1, -(u_h @ W_h @ u_h), 0.0), mode="drop")
    rhs = -kin.lengths * kin.omega**2 - jnp.sum((WF[:-1] - WF[1:]) * u, -1)
    lower = jnp.where((link >= 2) & active, lower, 0.0)
    upper = jnp.where((link + 1 <= K - 1) & active, upper, 0.0)
    diag = jnp.where(active, diag, 1.0)
    rhs = jnp.where(active, rhs, 0.0)
    T = jax.lax.linalg.tridiagonal_solve(lower, diag, upper, rhs[:, None])[:, 0]
    T = jnp.where(active, T, 0.0)

    # --- node accelerations, then link angular accelerations ---
    Tu = T[:, None] * u  # force of link j on node j (toward node j-1), index j-1
    on_node = jnp.concatenate([jnp.zeros((1, 2)), Tu], 0) - jnp.concatenate([Tu, jnp.zeros((1, 2))], 0)
    acc = WF + inv_m[:, None] * on_node
    acc = acc.at[h].set(W_h @ (F_h + on_node[h]))
    acc = jnp.where((node <= h)[:, None], acc, 0.0)
    safe_len = jnp.where(kin.lengths > 0, kin.lengths, 1.0)
    domega = jnp.sum((acc[:-1] - acc[1:]) * kin.p, -1) / safe_len
    a_h = acc[h]
    domega_rod = jnp.where(K >= 1, (jnp.dot(wvec, a_h) + beta) / D, 0.0)
    domega = jnp.where(active, domega, domega_rod)
    return acc[0], domega


def chain_accelerations_dense(state: ChainState, kin: ChainKinematics, forces, segment_length_m, theta_launch):
    """Reference: the paper's dense Kane form (eq 25) with partial velocities by autodiff. O(n^3).

    The generalized coordinates are ``(x0, y0, theta_1..theta_K)`` with ``K = kin.n_free``
    (concrete, so call this outside ``jit``); the tail and inactive links follow ``theta_K``.
    Partial velocities ``u_ij`` are the Jacobian of the node positions at fixed deployed length
    (material velocities); ``u_dot q_dot`` is its time derivative including the payout.
    Returns ``a0`` (2,) and ``d omega / dt`` (n,) in the same layout as :func:`chain_accelerations`.
    """
    n = kin.lengths.shape[0]
    K = int(kin.n_free)
    lengths_of = lambda S: kinematics(
        eqx.tree_at(lambda s: s.deployed, state, S), _rope_like(kin, segment_length_m), 1.0, theta_launch
    ).lengths
    m = kin.masses

    frozen = lengths_of(state.deployed)
    free_link = jnp.arange(1, n + 1) <= K

    def positions(q, S):
        r0 = q[:2]
        th = q[2:]
        ref = th[-1] if K > 0 else theta_launch
        th_all = jnp.concatenate([th, jnp.full((n - K,), ref)]) if K < n else th
        u, _ = unit_vectors(th_all)
        # links with their own angle keep their length (material points); only the welded tail grows
        L = jnp.where(free_link, frozen, lengths_of(S))
        r = r0 - jnp.cumsum(L[:, None] * u, axis=0)
        return jnp.concatenate([r0[None], r], 0).reshape(-1)

    q = jnp.concatenate([state.r0, state.theta[:K]])
    qd = jnp.concatenate([state.v0, state.omega[:K]])
    S = state.deployed
    J = jax.jacfwd(positions)(q, S)

    def material_velocity(q_, S_):
        return jax.jacfwd(positions)(q_, S_) @ qd

    _, bias = jax.jvp(material_velocity, (q, S), (qd, kin.payout_rate))
    Mdiag = jnp.repeat(m, 2)
    A = J.T @ (Mdiag[:, None] * J)
    rhs = J.T @ (forces.reshape(-1) - Mdiag * bias)
    qdd = jnp.linalg.solve(A, rhs)
    a0 = qdd[:2]
    dom_free = qdd[2:]
    ref = dom_free[-1] if K > 0 else 0.0
    domega = jnp.concatenate([dom_free, jnp.full((n - K,), ref)]) if K < n else dom_free
    return a0, domega


def _rope_like(kin, segment_length_m):
    n = kin.lengths.shape[0]
    one = jnp.asarray(1.0)
    return SegmentRope(one, one, one, segment_length_m=segment_length_m, capacity=n)


def rope_vector_field(state: ChainState, rope: SegmentRope, rocket_mass, theta_launch, force_fn, release_fraction,
                      windows=()):
    """d(state)/dt of rocket + rope, with the tail's weld released smoothly at completion.

    Over the last ``release_fraction * l`` of a segment's growth the derivative blends (C1 cubic step)
    from the normal configuration (tail welded to link ``k``) to the configuration it will have once
    complete (its own hinge). Without the blend the accelerations jump at every segment completion and
    an adaptive stepper rejects steps at each of them; with it the vector field is continuous. Both
    configurations agree exactly on straight chains (so the closed-form pull-out test is unaffected).

    Args:
        force_fn: ``kin -> forces`` (n+1, 2) [N].
        release_fraction: blending window as a fraction of the segment length (0 disables it).
        windows: prefix sizes (links, static) to evaluate on while the rope still fits (see
            :func:`default_windows`); ``()`` evaluates every link of the box.

    Returns:
        ``(derivative, kin)`` with ``kin`` the normal-configuration kinematics (``None`` with
        ``windows``: the window's kinematics has the window's size).
    """
    sizes = window_sizes(rope.capacity, windows)
    if len(sizes) > 1:
        return _windowed_vector_field(state, rope, rocket_mass, theta_launch, force_fn, release_fraction, sizes), None
    seg = rope.segment_length_m

    def field(hinged):
        kin = kinematics(state, rope, rocket_mass, theta_launch, hinged_tail=hinged)
        a0, domega = chain_accelerations(kin, force_fn(kin), seg)
        return ChainState(r0=state.v0, v0=a0, theta=kin.omega, omega=domega, deployed=kin.payout_rate), kin

    welded, kin = field(False)
    if release_fraction <= 0:
        return welded, kin
    k, tail = payout_geometry(state, rope)
    width = release_fraction * seg
    w = cubic_step(tail, seg - width, 0.0, seg, 1.0)
    w = jnp.where(k < rope.capacity, w, 0.0)

    def blended(_):
        hinged, _k = field(True)
        return jax.tree_util.tree_map(lambda a, b: (1.0 - w) * a + w * b, welded, hinged)

    deriv = jax.lax.cond(w > 0, blended, lambda _: welded, None)
    return deriv, kin


def kinetic_energy(kin: ChainKinematics):
    """Kinetic energy of rocket and rope [J] (material velocities)."""
    return 0.5 * jnp.sum(kin.masses * jnp.sum(kin.velocities**2, -1))


@jax.custom_batching.custom_vmap
def _batch_max(index):
    return index


@_batch_max.def_vmap
def _batch_max_rule(axis_size, in_batched, index):
    # Under vmap every case computes on the window of its most deployed member: the windows nest, so
    # a larger one gives each case its own answer, and the switch stays a switch instead of becoming
    # a select that computes every branch.
    return (jnp.max(index) if in_batched[0] else index), False


MIN_WINDOWED_CAPACITY = 256
"""Smallest box (links) evaluated on windows by default. Below it the saving does not pay for the
compile time of the branches: a 30 deg flight with 5 m segments (160 links) ran in 0.93x the time
with windows 64, 128, for a first call of 16.0 s against 9.6 s; with 2 m segments (400 links)
0.70x, 14.1 s against 10.2 s (Tsit5, PI, rtol 1e-4; 2-core Intel Xeon, JAX 0.10.2 CPU, float64;
fastest of 7 interleaved calls)."""


def default_windows(capacity: int) -> tuple:
    """The prefix sizes (links) a rope of ``capacity`` segments is evaluated on by default: the powers
    of two from 64 below the capacity (64, 128, 256, 512 for the paper's 750 m box at 1 m), none for
    a box under ``MIN_WINDOWED_CAPACITY`` links."""
    if capacity < MIN_WINDOWED_CAPACITY:
        return ()
    sizes, size = [], 64
    while size < capacity:
        sizes.append(size)
        size *= 2
    return tuple(sizes)


def window_sizes(capacity: int, windows) -> tuple:
    """The prefix sizes the windowed vector field switches between: the ``windows`` above 2 and
    below ``capacity``, ascending, then ``capacity``."""
    return tuple(sorted({int(w) for w in windows if 2 < int(w) < capacity})) + (capacity,)


def on_window(state: ChainState, rope: SegmentRope, sizes: tuple, fn):
    """``fn(sub_state, sub_rope)`` computed on the first ``N`` links only, ``N`` the smallest of
    ``sizes`` (from :func:`window_sizes`) that holds the growing tail and one more link (``k + 2 <=
    N``); ``sub_rope`` is ``rope`` with ``capacity = N``.

    Links still in the box have zero length and zero mass and their angles follow the last free
    link, so whatever ``fn`` computes from the prefix equals what it computes from the whole box
    (to rounding: the same operations on fewer entries), and its cost follows the deployed rope
    instead of the box. Which window is a ``lax.switch`` on the integer ``k``; derivatives pass
    through the chosen branch (the choice has none), and under ``vmap`` the batch shares its
    largest window."""
    n = rope.capacity
    k, _ = payout_geometry(jax.lax.stop_gradient(state), rope)
    index = sum((k > size - 2).astype(jnp.int32) for size in sizes[:-1])
    index = _batch_max(jnp.asarray(index, dtype=jnp.int32))

    def branch(size):
        def run(st):
            if size == n:
                return fn(st, rope)
            part = dataclasses.replace(rope, capacity=size)
            sub = ChainState(r0=st.r0, v0=st.v0, theta=st.theta[:size], omega=st.omega[:size], deployed=st.deployed)
            return fn(sub, part)

        return run

    return jax.lax.switch(index, [branch(size) for size in sizes], state)


def _windowed_vector_field(state, rope, rocket_mass, theta_launch, force_fn, release_fraction, sizes):
    """:func:`rope_vector_field` computed on a window (:func:`on_window`), its last entry repeated
    over the rest of the box."""
    n = rope.capacity

    def field(sub, part):
        d, _ = rope_vector_field(sub, part, rocket_mass, theta_launch, force_fn, release_fraction)
        size = part.capacity
        pad = lambda a: a if size == n else jnp.concatenate([a, jnp.broadcast_to(a[-1], (n - size,))])
        return ChainState(r0=d.r0, v0=d.v0, theta=pad(d.theta), omega=pad(d.omega), deployed=d.deployed)

    return on_window(state, rope, sizes, field)
