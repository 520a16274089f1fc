"""The massless-beam element: linear 3D Euler-Bernoulli beams between body attachment frames.

Massless beams (the paper's "massless-beam elements" [25], eq 39's ``f_beam``)
-----------------------------------------------------------------------------
:class:`MasslessBeams` joins attachment frames ``A`` (on body ``a``) and ``B`` (on body ``b``),
parallel in the undeformed state, with the beam axis along ``A``'s local ``z``. Its deformation is
measured in the co-rotated frame of ``A``:

    ``d = R_A^T (x_B - x_A) - L e_z`` (3,) [m],   ``psi = log(R_A^T R_B)`` (3,) [rad],

so rigid motions store no energy. The energy ``V = 1/2 e^T K e`` with ``e = [d, psi]`` and ``K`` the
clamped-free stiffness of a linear 3D Euler-Bernoulli beam (axial ``EA/L``, torsion ``GJ/L``, bending
``EJ/L^3 [[12, -6L], [-6L, 4L^2]]`` in ``(d_x, psi_y)`` and ``[[12, 6L], [6L, 4L^2]]`` in
``(d_y, psi_x)``). For small deformation this is exactly the 12-DOF Euler-Bernoulli element (its
stiffness is ``T^T K T`` with ``T`` the rigid-motion-free relative displacement), so a chain of them
is nodally exact for a cantilever with a tip load. For large rotations the reference frame is ``A``,
not a mean frame (fine for the small deformations of the rocket). Forces come from the energy by
autodiff: ``de/dq`` of each beam by ``jax.jacfwd``, then ``Q = -(de/du)^T K e`` (a quaternion
cotangent ``g`` is the body torque ``1/2 vec(q* (x) g)``), so the undamped model is
energy-consistent (tested against :func:`generalized_force_from_energy` of :func:`beam_energy`);
stiffness-proportional (Rayleigh) damping ``-(de/du)^T beta K e_dot`` dissipates
``beta e_dot^T K e_dot >= 0``.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.components.quaternion import quat_conjugate, quat_multiply, quat_to_matrix, rotation_vector_from_quat
from jaxcable.core.validation import check_finite, check_positive
from jaxcable.core.validation import float_array as _float_array


class MasslessBeams(eqx.Module):
    """A set of linear 3D Euler-Bernoulli massless beams between body attachment frames.

    Each beam's attachment frames are parallel to the body frames; the beam axis is the local
    ``z`` from ``A`` (on ``body_a``) to ``B`` (on ``body_b``), and both transverse axes have the
    same bending stiffness ``EJ``.
    """

    body_a: tuple[int, ...] = eqx.field(static=True, default=())
    """Body index of each beam's end A (length nbeam, static)."""
    body_b: tuple[int, ...] = eqx.field(static=True, default=())
    """Body index of each beam's end B (length nbeam, static)."""
    attach_a_m: jax.Array = eqx.field(converter=_float_array, default_factory=lambda: np.zeros((0, 3)))
    """End A in body a's frame, from its CoM, shape (nbeam, 3) [m]."""
    attach_b_m: jax.Array = eqx.field(converter=_float_array, default_factory=lambda: np.zeros((0, 3)))
    """End B in body b's frame, from its CoM, shape (nbeam, 3) [m]."""
    length_m: jax.Array = eqx.field(converter=_float_array, default_factory=lambda: np.zeros((0,)))
    """Undeformed lengths ``L``, shape (nbeam,) [m]."""
    EA_N: jax.Array = eqx.field(converter=_float_array, default_factory=lambda: np.zeros((0,)))
    """Axial stiffness ``EA``, shape (nbeam,) [N]."""
    EJ_N_m2: jax.Array = eqx.field(converter=_float_array, default_factory=lambda: np.zeros((0,)))
    """Bending stiffness ``EJ`` about both transverse axes, shape (nbeam,) [N m^2]."""
    GJ_N_m2: jax.Array = eqx.field(converter=_float_array, default_factory=lambda: np.zeros((0,)))
    """Torsional stiffness ``GJ``, shape (nbeam,) [N m^2]."""
    damping_s: jax.Array = eqx.field(converter=_float_array, default=0.0)
    """``beta``: stiffness-proportional (Rayleigh) damping factor [s] (0 = undamped)."""

    def __check_init__(self):
        n = self.n_beams
        if len(self.body_b) != n:
            raise ValueError(f"body_b must have {n} entries like body_a, got {len(self.body_b)}")
        for name, shape in {
            "attach_a_m": (n, 3),
            "attach_b_m": (n, 3),
            "length_m": (n,),
            "EA_N": (n,),
            "EJ_N_m2": (n,),
            "GJ_N_m2": (n,),
        }.items():
            got = tuple(getattr(self, name).shape)
            if got != shape:
                raise ValueError(f"{name} must have shape {shape}, got {got}")
        check_finite("attach_a_m", self.attach_a_m)
        check_finite("attach_b_m", self.attach_b_m)
        for name in ("length_m", "EA_N", "EJ_N_m2", "GJ_N_m2"):
            check_positive(name, getattr(self, name))
        check_positive("damping_s", self.damping_s, allow_zero=True)

    @property
    def n_beams(self) -> int:
        return len(self.body_a)


def beam_stiffness_matrix(EA_N, EJ_N_m2, GJ_N_m2, length_m):
    """Clamped-free 6x6 stiffness of one beam in ``e = [d_x, d_y, d_z, psi_x, psi_y, psi_z]`` [SI].

    ``psi_y = +d(d_x)/dz`` and ``psi_x = -d(d_y)/dz`` for a small rotation, hence the opposite signs
    of the two bending couplings.
    """
    L = length_m
    b = EJ_N_m2 / L**3
    K = jnp.zeros((6, 6), dtype=jnp.result_type(EA_N, float))
    K = K.at[0, 0].set(12 * b).at[4, 4].set(4 * b * L**2)
    K = K.at[0, 4].set(-6 * b * L).at[4, 0].set(-6 * b * L)
    K = K.at[1, 1].set(12 * b).at[3, 3].set(4 * b * L**2)
    K = K.at[1, 3].set(6 * b * L).at[3, 1].set(6 * b * L)
    K = K.at[2, 2].set(EA_N / L).at[5, 5].set(GJ_N_m2 / L)
    return K


def _beam_deformation(r_a, quat_a, r_b, quat_b, attach_a, attach_b, length):
    """One beam's ``e = [d, psi]`` (6,) from its bodies' CoMs (3,) and unit quaternions (4,)."""
    R_a, R_b = quat_to_matrix(quat_a), quat_to_matrix(quat_b)
    gap = r_b + jnp.sum(R_b * attach_b, axis=1) - r_a - jnp.sum(R_a * attach_a, axis=1)
    d = jnp.sum(R_a * gap[:, None], axis=0) - length * jnp.array([0.0, 0.0, 1.0])
    psi = rotation_vector_from_quat(quat_multiply(quat_conjugate(quat_a), quat_b))
    return jnp.concatenate([d, psi])


def _beam_end_wrenches(
    r_a, quat_a, v_a, omega_a, r_b, quat_b, v_b, omega_b, attach_a, attach_b, length, K, beta
):
    """One beam's wrenches on its two bodies: ``(F_a, tau_a, F_b, tau_b)`` (world force, body torque).

    With ``s = K (e + beta e_dot)`` the generalised force is ``-(de/dq K)^T s``; for a body with
    ``quat_dot = 1/2 quat (x) (0, omega)`` a quaternion cotangent ``g`` is the body torque
    ``1/2 vec(quat* (x) g)``, and a position cotangent is the force.
    """

    def deformation(r_a_, quat_a_, r_b_, quat_b_):
        return _beam_deformation(r_a_, quat_a_, r_b_, quat_b_, attach_a, attach_b, length)

    def quat_rate(quat, omega):
        return 0.5 * quat_multiply(quat, jnp.concatenate([jnp.zeros(1, omega.dtype), omega]))

    # One forward Jacobian (6 x 14) serves both e_dot = J q_dot and the forces J^T s.
    primals = (r_a, quat_a, r_b, quat_b)
    J = jax.jacfwd(deformation, argnums=(0, 1, 2, 3))(*primals)
    rates = (v_a, quat_rate(quat_a, omega_a), v_b, quat_rate(quat_b, omega_b))
    e = deformation(*primals)
    e_dot = sum(jnp.sum(J_i * rate, axis=1) for J_i, rate in zip(J, rates))
    stress = jnp.sum(K * (e + beta * e_dot), axis=1)
    g_ra, g_qa, g_rb, g_qb = (jnp.sum(J_i * stress[:, None], axis=0) for J_i in J)

    def torque(quat, g):
        return 0.5 * quat_multiply(quat_conjugate(quat), g)[1:]

    return -g_ra, -torque(quat_a, g_qa), -g_rb, -torque(quat_b, g_qb)


def _beam_wrenches(beams, poses, v, omega_body):
    """All beams' wrenches scattered onto the bodies: ``(force (N,3) world, torque (N,3) body)``."""
    com, quat, _ = poses
    a, b = np.asarray(beams.body_a, dtype=int), np.asarray(beams.body_b, dtype=int)
    F_a, t_a, F_b, t_b = jax.vmap(_beam_end_wrenches, in_axes=(0,) * 12 + (None,))(
        com[a], quat[a], v[a], omega_body[a], com[b], quat[b], v[b], omega_body[b],
        beams.attach_a_m, beams.attach_b_m, beams.length_m, _stiffness_matrices(beams), beams.damping_s,
    )
    force = jnp.zeros_like(com).at[a].add(F_a).at[b].add(F_b)
    torque = jnp.zeros_like(com).at[a].add(t_a).at[b].add(t_b)
    return force, torque


def _stiffness_matrices(beams):
    return jax.vmap(beam_stiffness_matrix)(beams.EA_N, beams.EJ_N_m2, beams.GJ_N_m2, beams.length_m)
