"""Variable-length (ALE) cable elements: the arresting-cable paper, section III.B.1, eqs 26-31.

A cable node carries a position ``r`` (3,) [m] and a material (unstretched arc-length) coordinate
``s`` [m]; the element between nodes 1 and 2 interpolates the material points ``s in [s1, s2]``
linearly (eq 28). Because ``s1, s2`` are generalised coordinates, an element can slide along the
material and change its length (arbitrary Lagrangian-Eulerian description). This module gives the
element's generalised mass matrix, mass-flow inertia, elastic+damping force and distributed-load
force (eqs 30-31), lifts them to a cable with ``jax.vmap`` + scatter-add, and a vector field that
solves ``M qdd = Q`` with prescribed coordinates removed. The mesh constraints of eqs 32-34 are not
implemented here; coordinates are either free or prescribed (see :func:`ale_cable_vector_field`).

Glossary (paper's symbols, eqs 26-31)
-------------------------------------
==================  ===========================================================================
``r`` (n,3)         nodal positions ``r_i`` [m] (eq 26)
``s`` (n,)          nodal material coordinates ``s_i`` [m] (eq 26)
``v``, ``sdot``     ``d r_i/dt`` [m/s], ``d s_i/dt`` [m/s]
``q_e`` (8,)        ``[r1, s1, r2, s2]`` (eq 27); global ``q`` (4n,) is ``[r_0, s_0, r_1, s_1, ...]``
``length``          ``L_e = s2 - s1`` [m], unstretched (material) element length
``u``               ``(s - s1) / L_e = (1 + xi) / 2`` in [0, 1] (xi of eq 28)
``tangent``         ``r' = dr/ds = (r2 - r1) / L_e`` (constant in a linear element) [-]
``strain``          Green strain ``eps = (r'.r' - 1) / 2`` (eq 31) [-]
``EA_N``            ``EA`` axial stiffness [N]; ``rhoA_kg_per_m`` ``rho A`` [kg/m]
``damping_s``       ``beta`` stiffness-proportional Rayleigh factor [s]
``slack_width``     smoothing width of the tension-only switch ``k`` of eq 31 [strain]
``M_e``, ``Q_s``,   eq 31: mass matrix (8,8) [kg, kg m, kg m^2 blocks], mass-flow inertia,
``Q_E``, ``Q_f``    elastic+damping force and external force (8,) [N in r rows, N m/m = N in s rows]
==================  ===========================================================================

Derivation (closed form; linear shape functions make every integral over ``u`` exact)
-------------------------------------------------------------------------------------
With ``u = (s - s1)/L`` and ``s`` held fixed (a material point),
``r = (1-u) r1 + u r2``, ``dr/ds1 = -(1-u) r'``, ``dr/ds2 = -u r'``, so the material velocity is
``N q_e_dot`` with ``N = [(1-u) B^T, u B^T]`` and ``B = [I3; -r'^T]`` (4x3). Hence

* ``M_e = rhoA L / 6 * kron([[2,1],[1,2]], B B^T)``, whose r-r block is the standard 2-node bar
  ``rhoA L / 6 [[2,1],[1,2]] kron I3``;
* ``r_dd_s = w(u) g`` with ``w = (1-u) s1dot + u s2dot`` (the mesh velocity through the material) and
  ``g = -2 (v2 - v1)/L + 2 (s2dot - s1dot)/L r'``; this re-derivation agrees with the printed
  ``r_dd_s`` of eq 31 (both terms, all signs). ``Q_s = -rhoA L [(s1dot/3 + s2dot/6) B g;
  (s1dot/6 + s2dot/3) B g]``;
* ``L d eps/dq_e = [-B r'; B r']``, so ``Q_E = N_ax [B r'; -B r']`` with axial force
  ``N_ax = EA (T(eps) + beta eps_dot)``, ``eps_dot = r'.(v2 - v1)/L - |r'|^2 (s2dot - s1dot)/L``;
* ``Q_f = L/2 [B f; B f]`` for a uniform load ``f`` per unit material length [N/m].

Choices and corrections to the printed equations
------------------------------------------------
* Eq 31 prints ``N = [N_r, dN_r/ds1 q_r, dN_r/ds2 q_r]``, i.e. columns in the order
  ``[r1, r2, s1, s2]``, while eq 27 orders ``q_e = [r1, s1, r2, s2]``. We use eq 27's order, so
  ``N_r`` is split: ``N = [(1-u) I3, dr/ds1, u I3, dr/ds2]``.
* Strain: Green strain as in eq 31. For the paper's cable (EA = 2.64e8 N, stress <= 800 MPa,
  eps <= 4e-3) Green and engineering strain differ by ``eps^2/2 < 1e-5``. Note that ``EA eps`` is
  the 2nd Piola-Kirchhoff force; the force the cable carries is ``EA eps |r'| = EA (lambda^2-1) lambda/2``
  (``Q_E`` has it right through ``B r'``), so the small-strain axial wave speed is
  ``sqrt(EA (3 lambda^2 - 1) / (2 rhoA))`` and large stretch stiffens: not a rubber-band model.
* Tension-only switch ``k``: smoothed, and written as the derivative of an energy so that the
  undamped model conserves energy exactly: strain energy per material length
  ``EA psi(eps)``, ``psi = smooth_relu(eps, w)^2 / 2``, tension ``EA T(eps)``,
  ``T = psi' = smooth_relu(eps, w) * smooth_step(eps, w)`` (-> ``EA max(eps, 0)``, error
  ``O(w)`` only within a few ``w`` of slack). The damping term ``EA beta eps_dot`` is kept in
  compression too, as printed (``k`` multiplies only ``eps``).
* The element-wise virtual work of eqs 29-31 omits terms concentrated at a node that *slides*
  through the material (``s_i_dot != 0``) where the strain or the tangent jumps: the momentum jump
  ``rhoA s_i_dot (v_left - v_right)`` of the material passing a moving kink, and the jumps of kinetic and
  strain energy density in the ``s_i`` equation. With all material coordinates fixed (a Lagrangian
  cable) these vanish and the model is the standard consistent-mass cable, which conserves energy.
  With free interior ``s_i`` the element form is the paper's; it is not exactly energy-conserving,
  and on a straight uniform stretch ``M`` is singular (``s_i`` is redundant with a tangential ``r_i``),
  which is why the paper adds the mesh constraints of eq 34.
"""

import equinox as eqx
import jax
import jax.numpy as jnp

from jaxcable.core.math import smooth_relu, smooth_step
from jaxcable.core.validation import check_positive

__all__ = [
    "AleCable",
    "AleState",
    "ale_cable_vector_field",
    "assemble",
    "axial_tension_factor",
    "cable_energy",
    "element_matrices",
    "strain_energy_density",
]


class AleCable(eqx.Module):
    """Parameters of a cable meshed with ALE elements (arrays, so they can be vmapped/differentiated)."""

    EA_N: jax.Array = eqx.field(converter=jnp.asarray, default=2.64e8)
    """``EA``: axial stiffness [N] (Table 1: 2.64e8)."""
    rhoA_kg_per_m: jax.Array = eqx.field(converter=jnp.asarray, default=9.8)
    """``rho A``: mass per unit unstretched length [kg/m] (Table 1: 9.8)."""
    damping_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    """``beta``: stiffness-proportional Rayleigh damping factor [s] (0 = undamped)."""
    slack_width: float = eqx.field(static=True, default=1e-6)
    """Smoothing width of the tension-only switch ``k`` of eq 31 [strain]."""

    def __check_init__(self):
        check_positive("EA_N", self.EA_N)
        check_positive("rhoA_kg_per_m", self.rhoA_kg_per_m)
        check_positive("damping_s", self.damping_s, allow_zero=True)
        check_positive("slack_width", self.slack_width)


class AleState(eqx.Module):
    """State of an n-node ALE cable."""

    r: jax.Array
    """Nodal positions, shape (n, 3) [m]."""
    s: jax.Array
    """Nodal material coordinates (unstretched arc length), shape (n,) [m]."""
    v: jax.Array
    """Nodal velocities ``dr/dt``, shape (n, 3) [m/s]."""
    sdot: jax.Array
    """Material-coordinate rates ``ds/dt``, shape (n,) [m/s]."""


def strain_energy_density(strain, slack_width):
    """``psi(eps) = smooth_relu(eps, w)^2 / 2``: strain energy per unit material length / EA [-]."""
    return 0.5 * smooth_relu(strain, slack_width) ** 2


def axial_tension_factor(strain, slack_width):
    """``T(eps) = psi'(eps)``: tension / EA, a smoothed ``max(eps, 0)`` (the ``k eps`` of eq 31) [-]."""
    return smooth_relu(strain, slack_width) * smooth_step(strain, slack_width)


def _element_kinematics(r_e, s_e):
    length = s_e[1] - s_e[0]
    tangent = (r_e[1] - r_e[0]) / length
    # B = [I3; -r'^T] (4x3): maps a spatial vector onto the (r, s) rows of one node.
    B = jnp.concatenate([jnp.eye(3, dtype=tangent.dtype), -tangent[None, :]], axis=0)
    return length, tangent, B


def element_matrices(cable, r_e, s_e, v_e, sdot_e, load_N_per_m):
    """One element's eq-31 terms in closed form.

    Args:
        cable: :class:`AleCable`.
        r_e: (2, 3) nodal positions [m]; s_e: (2,) material coordinates [m] (``s_e[1] > s_e[0]``).
        v_e: (2, 3) nodal velocities [m/s]; sdot_e: (2,) material-coordinate rates [m/s].
        load_N_per_m: (3,) uniform external load per unit material length ``f`` [N/m].

    Returns:
        ``(M_e (8,8), Q_s (8,), Q_E (8,), Q_f (8,))`` in the order ``[r1, s1, r2, s2]``.
    """
    rhoA, EA, beta = cable.rhoA_kg_per_m, cable.EA_N, cable.damping_s
    length, tangent, B = _element_kinematics(r_e, s_e)
    BBt = B @ B.T
    M_e = rhoA * length / 6.0 * jnp.kron(jnp.array([[2.0, 1.0], [1.0, 2.0]]), BBt)

    s1dot, s2dot = sdot_e[0], sdot_e[1]
    tangent_rate = (v_e[1] - v_e[0]) / length
    rel_sdot = (s2dot - s1dot) / length
    g = -2.0 * tangent_rate + 2.0 * rel_sdot * tangent
    Bg = B @ g
    Q_s = -rhoA * length * jnp.concatenate(
        [(s1dot / 3.0 + s2dot / 6.0) * Bg, (s1dot / 6.0 + s2dot / 3.0) * Bg]
    )

    strain = 0.5 * (jnp.dot(tangent, tangent) - 1.0)
    strain_rate = jnp.dot(tangent, tangent_rate) - jnp.dot(tangent, tangent) * rel_sdot
    axial_force = EA * (axial_tension_factor(strain, cable.slack_width) + beta * strain_rate)
    Bt = B @ tangent
    Q_E = axial_force * jnp.concatenate([Bt, -Bt])

    Bf = B @ load_N_per_m
    Q_f = 0.5 * length * jnp.concatenate([Bf, Bf])
    return M_e, Q_s, Q_E, Q_f


def _element_slices(x):
    """(n, ...) nodal array -> (n-1, 2, ...) pairs of element end values."""
    return jnp.stack([x[:-1], x[1:]], axis=1)


def assemble(cable, state, external_acc=None):
    """Global mass matrix (4n, 4n) [SI blocks] and force ``Q = Q_s + Q_E + Q_f`` (4n,).

    ``external_acc`` (3,) [m/s^2] is a uniform acceleration field (gravity); the load is
    ``f = rhoA * external_acc`` per unit material length. Dense; fine for tens of elements.
    """
    if external_acc is None:
        external_acc = jnp.zeros(3)
    n = state.r.shape[0]
    load = cable.rhoA_kg_per_m * jnp.asarray(external_acc)
    M_e, Q_s, Q_E, Q_f = jax.vmap(element_matrices, in_axes=(None, 0, 0, 0, 0, None))(
        cable,
        _element_slices(state.r),
        _element_slices(state.s),
        _element_slices(state.v),
        _element_slices(state.sdot),
        load,
    )
    # Node i owns global rows 4i..4i+3 = [r_i, s_i]; element e's q_e is rows 4e..4e+7.
    idx = 4 * jnp.arange(n - 1)[:, None] + jnp.arange(8)[None, :]
    M = jnp.zeros((4 * n, 4 * n), M_e.dtype).at[idx[:, :, None], idx[:, None, :]].add(M_e)
    Q = jnp.zeros(4 * n, Q_s.dtype).at[idx].add(Q_s + Q_E + Q_f)
    return M, Q


def _fixed_dof_mask(n, fixed_r_mask, fixed_s_mask):
    fr = jnp.broadcast_to(jnp.asarray(fixed_r_mask, bool).reshape(n, -1), (n, 3))
    fs = jnp.broadcast_to(jnp.asarray(fixed_s_mask, bool).reshape(n), (n,))
    return jnp.concatenate([fr, fs[:, None]], axis=1).reshape(4 * n)


def ale_cable_vector_field(cable, state, fixed_r_mask, fixed_s_mask, external_acc=None):
    """Time derivative of an :class:`AleState`: solves ``M qdd = Q`` for the free coordinates.

    Args:
        fixed_r_mask: bool, (n,) or (n, 3): position components that are prescribed.
        fixed_s_mask: bool, (n,): material coordinates that are prescribed.
        external_acc: (3,) uniform acceleration field (gravity) [m/s^2].

    A prescribed coordinate gets zero acceleration, so it keeps its state velocity: zero velocity
    holds it fixed (a pinned end; ``s`` fixed everywhere gives a Lagrangian consistent-mass cable), a
    nonzero one moves it uniformly (e.g. all ``sdot = c``: the mesh slides along the material).
    The reactions on prescribed coordinates are dropped (``Q`` rows removed).

    Returns:
        ``AleState(r=v, s=sdot, v=r_dd (n,3) [m/s^2], sdot=s_dd (n,) [m/s^2])``.
    """
    if external_acc is None:
        external_acc = jnp.zeros(3)
    n = state.r.shape[0]
    M, Q = assemble(cable, state, external_acc)
    fixed = _fixed_dof_mask(n, fixed_r_mask, fixed_s_mask)
    free = ~fixed
    # Keep shapes static (jit/vmap): zero the fixed rows/columns and put 1 on their diagonal.
    M_free = jnp.where(free[:, None] & free[None, :], M, 0.0) + jnp.diag(fixed.astype(M.dtype))
    qdd = jnp.linalg.solve(M_free, jnp.where(free, Q, 0.0)).reshape(n, 4)
    return AleState(r=state.v, s=state.sdot, v=qdd[:, :3], sdot=qdd[:, 3])


def cable_energy(cable, state, external_acc=None):
    """``(kinetic, elastic, gravitational)`` energies [J] of the discretised cable.

    Kinetic: ``q_dot^T M q_dot / 2`` with the consistent ALE mass matrix (material-velocity terms
    included). Elastic: ``sum_e L_e EA psi(eps_e)`` (tension only, smoothed as the force is).
    Gravitational: ``-sum_e rhoA L_e external_acc . (r1 + r2)/2`` (exact for linear interpolation).
    """
    if external_acc is None:
        external_acc = jnp.zeros(3)
    n = state.r.shape[0]
    M, _ = assemble(cable, state, external_acc)
    qdot = jnp.concatenate([state.v, state.sdot[:, None]], axis=1).reshape(4 * n)
    kinetic = 0.5 * qdot @ M @ qdot
    lengths = state.s[1:] - state.s[:-1]
    tangents = (state.r[1:] - state.r[:-1]) / lengths[:, None]
    strains = 0.5 * (jnp.sum(tangents**2, axis=1) - 1.0)
    elastic = cable.EA_N * jnp.sum(lengths * strain_energy_density(strains, cable.slack_width))
    midpoints = 0.5 * (state.r[1:] + state.r[:-1])
    gravitational = -cable.rhoA_kg_per_m * jnp.sum(lengths * (midpoints @ jnp.asarray(external_acc)))
    return kinetic, elastic, gravitational
