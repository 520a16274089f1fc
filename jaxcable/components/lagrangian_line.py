r"""A Lagrangian line (material coordinates fixed): lumped or consistent mass, factored once.

The cheap fidelity level of the ALE cable (:mod:`jaxcable.components.ale`, arresting-cable paper,
section III.B.1, eqs 26-31) for lines whose nodes never slide through the material (mooring lines,
pinned spans, towed lines without payout). With every material coordinate fixed, the ALE element's
mass matrix is the constant 2-node bar matrix ``rhoA L / 6 [[2, 1], [1, 2]] kron I3`` and the
mass-flow inertia ``Q_s`` vanishes, so the ALE model reduces to ``M r_dd = F(r, v)`` with a
*constant* ``M``. This module exploits that: the nodal forces are a few vectorised array
operations (no assembly, no scatter), and ``M`` is inverted once per mesh, not once per step
(the ALE vector field assembles a dense ``4n x 4n`` matrix and LU-solves it at every evaluation).

Mass (``LineMesh.mass``)
------------------------
* ``"consistent"``: the ALE element's mass matrix (the same model as
  :func:`jaxcable.components.ale.ale_cable_vector_field` with ``s`` fixed and the same strain and
  switch: agreement to round-off, tested). Its inverse (``n x n``, the same for the three
  components unless a node is prescribed in only some of them) is formed once by
  :func:`line_mesh`; a step multiplies by it (``O(n^2)``: fine up to a few hundred nodes).
* ``"lumped"``: half of each adjacent element's mass on a node, ``m_i = rhoA (L_{i-1} + L_i) / 2``
  (the row sums of the consistent matrix: same total mass, same static load, same
  centre of mass). Diagonal, so a step divides. This is MoorDyn's mass model. Lumping lowers the
  mesh's highest axial frequency by ``sqrt(3)`` (``2 c / h`` against ``2 sqrt(3) c / h`` for the
  consistent bar, ``c = sqrt(EA / rhoA)``), which is what limits an explicit solver's step here (see
  below), and changes how axial waves travel on the mesh (dispersion of the opposite sign to the
  consistent mass). Both converge to the continuum as ``h -> 0``; at a given mesh they differ by a
  discretisation error (``experiments/peers/moordyn_line.py`` measures it on its case).

Axial law (one element of unstretched length ``L``, tangent ``t = (r2 - r1) / L``)
------------------------------------------------------------------------------
* ``strain="green"`` (the ALE element's, eq 31): ``eps = (t.t - 1) / 2``,
  ``N = EA (T(eps) + beta t.t_dot)``; force on node 1 ``+N t``, on node 2 ``-N t``.
* ``strain="engineering"`` (MoorDyn's): ``e = |t| - 1``, ``N = EA (T(e) + beta d|t|/dt)`` with the
  force along the unit tangent; ``beta EA`` is MoorDyn's internal damping ``BA`` [N s].

``T`` is the tension-only switch, smoothed over ``slack_width`` [strain] and written as the
derivative of a strain energy, so the undamped line conserves energy:

* ``switch="softplus"`` (the ALE element's): ``T = smooth_relu(x, w) smooth_step(x, w)``
  (:func:`jaxcable.components.ale.axial_tension_factor`);
* ``switch="quadratic"``: ``T = 0`` below ``-w``, ``(x + w)^2 / (4 w)`` within ``|x| < w``, ``x``
  above (C1; no exponentials: the vector field costs about half as much on a CPU, measured in
  ``experiments/peers/moordyn_line.py``). The two differ only within ``w`` of slack, by at most
  ``EA w / 4`` in tension.

Stiffness and step size. With ``beta > 0`` the highest mesh modes are overdamped and their fast
eigenvalue is ``~ -beta omega_max^2`` with ``omega_max^2 = 4 EA / (rhoA h^2)`` (lumped; three
times that consistent); e.g. EA = 1e6 N, rhoA = 1 kg/m, h = 0.525 m, beta = 1e-3 s: 1.45e4 1/s
(lumped), 4.4e4 1/s (consistent), which bound an explicit step to ~1.9e-4 s and ~6.4e-5 s (RK4's
real stability interval is 2.785; measured on the 20-segment pull of
``experiments/peers/moordyn_line.py``: RK4 stable at 1.75e-4 s lumped, at 6e-5 s but not at 8e-5 s
consistent). The step count of an explicit solver is then set by stability, not accuracy: on that
case RK4 at 1.25e-4 s is already as accurate as MoorDyn's RK4 at 1e-4 s.
:class:`jaxcable.core.explicit_rk.RK4` at a constant step below that bound and
:class:`jaxcable.core.explicit_rk.FastTsit5` (adaptive) are the measured fast choices on a CPU.

Glossary
--------
==================  ===========================================================================
``r``, ``v`` (n,3)  nodal positions [m] and velocities [m/s]
``L`` (n-1,)        unstretched (material) element lengths ``segment_lengths_m`` [m]
``t``               ``(r2 - r1) / L``, the stretch vector [-]; ``|t|`` the stretch ``lambda``
``EA_N``            axial stiffness [N]; ``rhoA_kg_per_m`` mass per unstretched length [kg/m]
``damping_s``       ``beta``, stiffness-proportional (Rayleigh) damping factor [s]
``fixed`` (n,3)     prescribed position components: zero acceleration, they keep their state
                    velocity (zero: pinned; nonzero: moved uniformly, e.g. a pulled end)
==================  ===========================================================================
"""

from __future__ import annotations

from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx

from jaxcable.core.math import smooth_relu, smooth_step
from jaxcable.core.scene import AbstractScene
from jaxcable.core.validation import check_choice, check_positive

__all__ = [
    "LagrangianLine",
    "LineMesh",
    "LineScene",
    "LineState",
    "element_forces",
    "line_energy",
    "line_mesh",
    "line_vector_field",
    "nodal_forces",
    "segment_tensions",
    "static_equilibrium",
    "tension_factor",
    "uniform_line_mesh",
]

MASS_MODELS = ("lumped", "consistent")
STRAIN_MEASURES = ("green", "engineering")
SWITCHES = ("softplus", "quadratic")


class LagrangianLine(eqx.Module):
    """Material parameters of a line (arrays: vmap/differentiate them) and its constitutive choices."""

    EA_N: jax.Array = eqx.field(converter=jnp.asarray, default=1e6)
    """``EA``: axial stiffness [N]."""
    rhoA_kg_per_m: jax.Array = eqx.field(converter=jnp.asarray, default=1.0)
    """``rho A``: mass per unit unstretched length [kg/m]."""
    damping_s: jax.Array = eqx.field(converter=jnp.asarray, default=0.0)
    """``beta``: stiffness-proportional damping factor [s] (MoorDyn's ``BA = beta EA`` [N s])."""
    slack_width: float = eqx.field(static=True, default=1e-6)
    """Smoothing width ``w`` of the tension-only switch [strain]."""
    strain: Literal["green", "engineering"] = eqx.field(static=True, default="green")
    """Strain measure: ``"green"`` (the ALE element's) or ``"engineering"`` (MoorDyn's)."""
    switch: Literal["softplus", "quadratic"] = eqx.field(static=True, default="softplus")
    """Tension-only switch: ``"softplus"`` (the ALE element's) or ``"quadratic"`` (cheaper, C1)."""

    def __check_init__(self):
        check_positive("EA_N", self.EA_N)
        check_positive("rhoA_kg_per_m", self.rhoA_kg_per_m)
        check_positive("damping_s", self.damping_s, allow_zero=True)
        check_positive("slack_width", self.slack_width)
        check_choice("strain", self.strain, STRAIN_MEASURES)
        check_choice("switch", self.switch, SWITCHES)


class LineMesh(eqx.Module):
    """The mesh: element lengths, prescribed components and the inverse of the unit-density mass
    matrix (``M = rhoA M_unit``), formed once by :func:`line_mesh`. Build it with that function:
    its fields are derived from one another."""

    segment_lengths_m: jax.Array
    """Unstretched element lengths ``L``, shape (n-1,) [m]."""
    fixed: jax.Array
    """Prescribed position components, bool, shape (n, 3)."""
    inverse_unit_mass: jax.Array
    """``M_unit^-1`` with prescribed rows and columns removed [1/m]: lumped, shape (n, 3) (zero on
    prescribed components); consistent, shape (3, n, n), one matrix per component."""
    mass: Literal["lumped", "consistent"] = eqx.field(static=True, default="lumped")
    """Mass model: ``"lumped"`` (diagonal, MoorDyn's) or ``"consistent"`` (the ALE element's)."""

    @property
    def num_nodes(self) -> int:
        return self.fixed.shape[0]


class LineState(eqx.Module):
    """State of an n-node line."""

    r: jax.Array
    """Nodal positions, shape (n, 3) [m]."""
    v: jax.Array
    """Nodal velocities, shape (n, 3) [m/s]."""


def _fixed_components(fixed_mask, n):
    return jnp.broadcast_to(jnp.asarray(fixed_mask, bool).reshape(n, -1), (n, 3))


def line_mesh(segment_lengths_m, fixed_mask, mass: str = "lumped") -> LineMesh:
    """A :class:`LineMesh`: the inverse unit-density mass matrix for these element lengths and
    prescribed components, formed once here.

    Args:
        segment_lengths_m: unstretched element lengths, shape (n-1,) [m].
        fixed_mask: bool, shape (n,) (whole nodes) or (n, 3) (components) prescribed.
        mass: ``"lumped"`` or ``"consistent"``.
    """
    check_choice("mass", mass, MASS_MODELS)
    lengths = jnp.asarray(segment_lengths_m, dtype=float)
    n = lengths.shape[0] + 1
    fixed = _fixed_components(fixed_mask, n)
    free = ~fixed
    zero = jnp.zeros((1,), lengths.dtype)
    half_left = jnp.concatenate([zero, 0.5 * lengths])  # half of the element to the left of node i
    half_right = jnp.concatenate([0.5 * lengths, zero])
    if mass == "lumped":
        unit = (half_left + half_right)[:, None]
        inverse = jnp.where(free, 1.0 / unit, 0.0)
    else:
        # rhoA L / 6 [[2, 1], [1, 2]] per element, assembled: a symmetric tridiagonal matrix,
        # eigenvalues within [L_min / 6, L_max] (well conditioned: its explicit inverse is accurate).
        diag = (2.0 / 3.0) * (half_left + half_right)
        off = lengths / 6.0
        M = jnp.diag(diag) + jnp.diag(off, 1) + jnp.diag(off, -1)

        def one_component(free_c):
            keep = free_c[:, None] & free_c[None, :]
            M_c = jnp.where(keep, M, 0.0) + jnp.diag(jnp.where(free_c, 0.0, 1.0))
            return jnp.where(keep, jnp.linalg.inv(M_c), 0.0)

        inverse = jax.vmap(one_component, in_axes=1)(free)  # (3, n, n)
    return LineMesh(segment_lengths_m=lengths, fixed=fixed, inverse_unit_mass=inverse, mass=mass)


def uniform_line_mesh(length_m, segments: int, fixed_mask, mass: str = "lumped") -> LineMesh:
    """:func:`line_mesh` of ``segments`` equal elements of a line of unstretched length ``length_m`` [m]."""
    return line_mesh(jnp.full((segments,), jnp.asarray(length_m, dtype=float) / segments), fixed_mask, mass)


# ----------------------------------------------------------------------------- the axial law
def _quadratic_ramp(x, width):
    """C1 ramp: 0 below ``-width``, ``(x + width)^2 / (4 width)`` inside, ``x`` above."""
    inside = (x + width) ** 2 / (4.0 * width)
    return jnp.where(x >= width, x, jnp.where(x <= -width, 0.0, inside))


def _quadratic_ramp_energy(x, width):
    """The antiderivative of :func:`_quadratic_ramp` (zero below ``-width``)."""
    inside = (x + width) ** 3 / (12.0 * width)
    return jnp.where(x >= width, 0.5 * x**2 + width**2 / 6.0, jnp.where(x <= -width, 0.0, inside))


def tension_factor(line: LagrangianLine, strain):
    """``T(strain)``: tension / EA of the smoothed tension-only switch [-] (``~max(strain, 0)``)."""
    if line.switch == "softplus":
        return smooth_relu(strain, line.slack_width) * smooth_step(strain, line.slack_width)
    return _quadratic_ramp(strain, line.slack_width)


def _strain_energy_factor(line: LagrangianLine, strain):
    """``psi(strain)`` with ``psi' = T``: strain energy per unstretched length / EA [-]."""
    if line.switch == "softplus":
        return 0.5 * smooth_relu(strain, line.slack_width) ** 2
    return _quadratic_ramp_energy(strain, line.slack_width)


def _stretch(t):
    # |t| with a finite gradient at t = 0 (a fully collapsed element)
    sq = jnp.sum(t * t, axis=-1)
    safe = jnp.where(sq > 0.0, sq, 1.0)
    return jnp.where(sq > 0.0, jnp.sqrt(safe), 0.0), safe


def element_forces(line: LagrangianLine, tangent, tangent_rate):
    """The axial force vector each element pulls its first node with, ``N t`` (Green) or
    ``N t / |t|`` (engineering) [N], shape (..., 3); the second node gets minus it.

    Args:
        tangent: ``t = (r2 - r1) / L`` (..., 3) [-]; tangent_rate: ``(v2 - v1) / L`` (..., 3) [1/s].
    """
    EA, beta = line.EA_N, line.damping_s
    t_dot_rate = jnp.sum(tangent * tangent_rate, axis=-1)
    if line.strain == "green":
        strain = 0.5 * (jnp.sum(tangent * tangent, axis=-1) - 1.0)
        N = EA * (tension_factor(line, strain) + beta * t_dot_rate)
        return N[..., None] * tangent
    stretch, safe_sq = _stretch(tangent)
    inv = jax.lax.rsqrt(safe_sq)
    N = EA * (tension_factor(line, stretch - 1.0) + beta * t_dot_rate * inv)
    return (N * inv)[..., None] * tangent


def segment_tensions(line: LagrangianLine, mesh: LineMesh, state: LineState):
    """Force each element carries, ``|element_forces|`` signed by ``N`` [N], shape (n-1,)."""
    L = mesh.segment_lengths_m[:, None]
    tangent = jnp.diff(state.r, axis=0) / L
    force = element_forces(line, tangent, jnp.diff(state.v, axis=0) / L)
    stretch, _ = _stretch(tangent)
    return jnp.sum(force * tangent, axis=-1) / jnp.where(stretch > 0.0, stretch, 1.0)


def nodal_forces(line: LagrangianLine, mesh: LineMesh, state: LineState, external_acc=None):
    """Axial (elastic + damping) forces plus the uniform field's load on each node [N], (n, 3).

    ``external_acc`` (3,) [m/s^2] (gravity) loads each node with half of each adjacent element's
    mass (the consistent load of linear elements, the same for both mass models)."""
    L = mesh.segment_lengths_m
    tangent = jnp.diff(state.r, axis=0) / L[:, None]
    f = element_forces(line, tangent, jnp.diff(state.v, axis=0) / L[:, None])
    zero = jnp.zeros_like(f[:1])
    F = jnp.concatenate([f, zero]) - jnp.concatenate([zero, f])
    if external_acc is not None:
        half = jnp.concatenate([zero[:, 0], 0.5 * L]) + jnp.concatenate([0.5 * L, zero[:, 0]])
        F = F + (line.rhoA_kg_per_m * half)[:, None] * jnp.asarray(external_acc)
    return F


def line_vector_field(line: LagrangianLine, mesh: LineMesh, state: LineState, external_acc=None) -> LineState:
    """``d(state)/dt``: ``r_dot = v``, ``v_dot = M^-1 F`` on the free components, 0 on prescribed ones.

    Returns:
        ``LineState(r=v (n,3) [m/s], v=acceleration (n,3) [m/s^2])``.
    """
    F = nodal_forces(line, mesh, state, external_acc)
    if mesh.mass == "lumped":
        acc = mesh.inverse_unit_mass * F / line.rhoA_kg_per_m
    else:
        acc = jnp.einsum("cij,jc->ic", mesh.inverse_unit_mass, F) / line.rhoA_kg_per_m
    return LineState(r=state.v, v=acc)


def line_energy(line: LagrangianLine, mesh: LineMesh, state: LineState, external_acc=None):
    """``(kinetic, elastic, gravitational)`` energies [J] (the undamped line conserves their sum).

    Kinetic with the mesh's mass model (all nodes, prescribed ones included); elastic
    ``sum L EA psi(strain)``; gravitational ``-sum rhoA L external_acc . (r1 + r2) / 2``."""
    L = mesh.segment_lengths_m
    rhoA = line.rhoA_kg_per_m
    if mesh.mass == "lumped":
        zero = jnp.zeros((1,), L.dtype)
        m = rhoA * (jnp.concatenate([zero, 0.5 * L]) + jnp.concatenate([0.5 * L, zero]))
        kinetic = 0.5 * jnp.sum(m[:, None] * state.v**2)
    else:
        dv = state.v[1:], state.v[:-1]
        kinetic = rhoA / 6.0 * jnp.sum(L[:, None] * (dv[0] ** 2 + dv[0] * dv[1] + dv[1] ** 2))
    tangent = jnp.diff(state.r, axis=0) / L[:, None]
    if line.strain == "green":
        strain = 0.5 * (jnp.sum(tangent**2, axis=-1) - 1.0)
    else:
        strain = _stretch(tangent)[0] - 1.0
    elastic = line.EA_N * jnp.sum(L * _strain_energy_factor(line, strain))
    gravitational = jnp.zeros(())
    if external_acc is not None:
        mid = 0.5 * (state.r[1:] + state.r[:-1])
        gravitational = -rhoA * jnp.sum(L * (mid @ jnp.asarray(external_acc)))
    return kinetic, elastic, gravitational


def static_equilibrium(line: LagrangianLine, mesh: LineMesh, guess, external_acc=None, *, rtol=1e-10, atol=1e-9, max_steps=100):
    """Positions (n, 3) [m] where the free components carry no net force (Newton, optimistix;
    differentiable by the implicit function theorem). Prescribed components stay at ``guess``.

    ``atol`` applies to the residual as a fraction of the line's weight (its round-off floor is
    ``~EA eps_mach / (rhoA g h)``, 4e-10 for EA = 1e6 N, 1 kg/m, h = 0.5 m) and to the positions
    [m]. Start from a stretched guess (every element in tension): a slack element has no stiffness
    and makes the Newton matrix singular."""
    r0 = jnp.asarray(guess, dtype=float)
    free = ~mesh.fixed
    zeros = jnp.zeros_like(r0)
    scale = line.rhoA_kg_per_m * jnp.sum(mesh.segment_lengths_m) * (
        1.0 if external_acc is None else jnp.linalg.norm(jnp.asarray(external_acc))
    )

    def residual(x, _):
        r = jnp.where(free, x, r0)
        F = nodal_forces(line, mesh, LineState(r=r, v=zeros), external_acc)
        return jnp.where(free, F, x - r0) / jnp.where(free, scale, 1.0)

    sol = optx.root_find(residual, optx.Newton(rtol=rtol, atol=atol), r0, max_steps=max_steps, throw=True)
    return jnp.where(free, sol.value, r0)


class LineScene(AbstractScene):
    """A line on its own under a uniform field (gravity), some components prescribed: a scene for
    :func:`jaxcable.simulate` (state :class:`LineState`; the probe is the state)."""

    line: LagrangianLine
    mesh: LineMesh
    r0: jax.Array
    """Initial nodal positions (n, 3) [m]."""
    v0: jax.Array
    """Initial nodal velocities (n, 3) [m/s]; a prescribed component keeps its value."""
    gravity_mps2: jax.Array = eqx.field(converter=jnp.asarray, default_factory=lambda: jnp.array([0.0, 0.0, -9.81]))
    """Uniform acceleration field (3,) [m/s^2]."""

    def initial_state(self):
        return LineState(r=jnp.asarray(self.r0), v=jnp.asarray(self.v0))

    def vector_field(self, t, state):
        return line_vector_field(self.line, self.mesh, state, self.gravity_mps2)
