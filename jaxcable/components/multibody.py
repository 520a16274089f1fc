"""Rigid multibody dynamics by Kane's method with autodiff: the arresting-cable paper, section III.C.

A :class:`MultibodySystem` is ``nb`` free rigid bodies (6 DOF each) plus ``nh`` hinge children (one
revolute DOF each, hinged to a free body: the rocket's hooks). The paper writes each body in
quaternion coordinates (eq 35), with a Lagrangian mass matrix ``M_i = diag(m I, 4 G^T J G)`` (eqs
36-38), and imposes the hinges by algebraic constraints (eq 40), giving a DAE. Here the hinges are
built into the kinematics instead (a minimal, tree-structured set of coordinates), so the equations
are an ODE with no constraint drift, and the dynamics are written with Kane's method in the
generalised speeds ``u``:

    ``M(q) u_dot = Q(q, u) - bias(q, u)``,   ``q_dot = K(q) u``.

Every body's centre-of-mass velocity and angular velocity are linear in ``u``; their partial
velocities (Jacobians) come from ``jax.jacfwd`` of that velocity map, and the generalised forces
are their transposes applied to body wrenches (virtual power; :func:`generalized_forces` is the
``jax.vjp`` reference). The velocity-product ("bias") accelerations are ``jax.jvp`` of the velocity
map along ``q_dot`` (:func:`_bias_accelerations_autodiff`); the vector field uses their short
closed form for a revolute joint (:func:`_bias_accelerations`, checked against the ``jvp`` in the
tests), which compiles in about a third of the time (rocket with hinged hooks, measured: 4.2 s ->
1.4 s). With this choice the quaternion equations of eqs 36-38 reduce to the Newton-Euler
equations ``m a = f`` and ``J omega_dot + omega x J omega = tau`` (body frame), to which they are
equivalent.

Glossary (paper's symbols, eqs 35-41)
-------------------------------------
=========================  =========================================================================
``r`` (nb,3)               ``r_i`` of eq 35: centre-of-mass positions, world frame [m]
``quat`` (nb,4)            ``theta_i`` of eq 35: unit quaternions ``[w, x, y, z]`` (scalar first), body
                           -> world; ``q/|q|`` is used wherever a rotation is needed
``v`` (nb,3)               ``r_dot`` [m/s]
``omega_body`` (nb,3)      body-frame angular velocity ``omega = 2 G theta_dot`` (G of eq 38) [rad/s]
``hinge_angle`` (nh,)      revolute coordinate replacing eq 40's constraints [rad]
``u`` (6 nb + nh,)         generalised speeds ``[v.ravel(), omega_body.ravel(), hinge_rate]``
``K(q)``                   kinematic map ``q_dot = K u``: ``r_dot = v``,
                           ``quat_dot = 1/2 quat (x) (0, omega_body)`` (= ``1/2 G^T omega``), ``phi_dot``
``M(q)``                   ``sum_b m_b Jv_b^T Jv_b + Jw_b^T J_b Jw_b`` (Kane); eq 37's ``M_i`` per body
``Q``                      generalised force: ``Q_f = H_i f`` of eq 36 written as virtual power
                           ``sum_P (dv_P/du)^T f_P`` (gravity, point loads, torques, beams, springs)
``J_b`` (3,3)              inertia tensor about the centre of mass, body frame [kg m^2]
=========================  =========================================================================

Eq 41 (the prismatic constraint of the sliders and counterweights) is not needed by the rocket and
is not implemented here.

Systems without hinges (the rigid and ale levels' rocket, hooks welded) skip the Kane machinery:
every speed is a body's own ``v`` or ``omega_body``, ``M = diag(m I, J)`` is constant, and the
equations are Newton-Euler body by body (:func:`_free_body_accelerations`; same values and tangents
as the general path to round-off, tested). It halves the XLA kernels of the rocket's derivative,
which is what a batched design gradient pays for (``docs/notes/design_call_cost.md``).

Body indices: free bodies are ``0 .. nb-1``, hinge children ``nb .. nb+nh-1``. Each body's *local
points* are measured from its centre of mass, in its own frame.

Hinges (eq 40). Child ``k`` is attached to free body ``hinge_parent[k]`` at joint position
``j_k`` (parent frame, from the parent's CoM), rotating about the unit axis ``a_k`` (parent frame).
Its orientation is ``R_child = R_parent Rot(a_k, phi_k)``, so ``phi = 0`` means the child frame is
parallel to the parent frame; its CoM is ``joint + R_child c_k`` (``c_k`` in the child frame).
A hinge torque ``tau_k`` is an internal torque pair (``+tau a`` on the child, ``-tau a`` on the
parent); its generalised force is ``tau_k`` on ``phi_k`` alone.

Quaternion norm. The kinematics use ``q/|q|``, so the norm has no physical effect; it is kept near 1
by adding ``k (1 - |q|^2) q`` to ``quat_dot`` (``k = quat_stabilisation_per_s``). This term is
radial, so it does not change the rotation; ``x = |q|^2`` obeys the logistic law
``dx/dt = 2 k x (1 - x)`` (``|q|^2 - 1 ~ exp(-2 k t)`` near 1), tested in closed form.

"""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.linalg import cho_factor, cho_solve

from jaxcable.components.beams import (
    MasslessBeams,
    beam_stiffness_matrix,
    _beam_deformation,
    _beam_wrenches,
    _stiffness_matrices,
)
from jaxcable.components.quaternion import (
    quat_multiply,
    quat_conjugate,
    quat_to_matrix,
    quat_from_rotation_vector,
    rotation_vector_from_quat,
    _unit_quat,
    _matvec,
    _matvec_t,
    _matvec_points,
    _matvec_t_points,
)
from jaxcable.core.math import safe_normalize
from jaxcable.core.validation import _concrete, check_finite, check_positive
from jaxcable.core.validation import float_array as _float_array

__all__ = [
    "MasslessBeams",
    "MultibodyState",
    "MultibodySystem",
    "accelerations",
    "beam_deformation_rates",
    "beam_deformations",
    "beam_dissipation_power",
    "beam_energy",
    "beam_generalized_force",
    "beam_stiffness_matrix",
    "body_poses",
    "body_velocities",
    "generalized_force_from_energy",
    "generalized_forces",
    "kinetic_energy",
    "mass_matrix",
    "momentum",
    "point_acceleration",
    "point_kinematics",
    "potential_energy",
    "quat_conjugate",
    "quat_from_rotation_vector",
    "quat_multiply",
    "quat_to_matrix",
    "rotation_vector_from_quat",
    "speeds",
    "world_to_local",
]


# ---------------------------------------------------------------------------------------------
# system and state
# ---------------------------------------------------------------------------------------------




def _check_inertia(name, value):
    """Finite, symmetric and positive definite (..., 3, 3)."""
    check_finite(name, value)
    v = _concrete(value)
    if v is None or v.size == 0:
        return
    if v.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have shape (..., 3, 3), got {v.shape}")
    asym = np.max(np.abs(v - np.swapaxes(v, -1, -2)))
    scale = np.max(np.abs(v))
    if asym > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric, got {value!r}")
    eig = np.linalg.eigvalsh(0.5 * (v + np.swapaxes(v, -1, -2)))
    if np.any(eig <= 0.0):
        raise ValueError(
            f"{name} must be positive definite (eigenvalues {eig.tolist()}), got {value!r}"
        )


class MultibodySystem(eqx.Module):
    """``nb`` free rigid bodies and ``nh`` hinge children (structure static, parameters arrays)."""

    body_mass_kg: jax.Array = eqx.field(converter=_float_array)
    """Free-body masses, shape (nb,) [kg]."""
    body_inertia_kg_m2: jax.Array = eqx.field(converter=_float_array)
    """Free-body inertia tensors ``J_i`` about the CoM in the body frame, shape (nb, 3, 3) [kg m^2]."""
    hinge_parent: tuple[int, ...] = eqx.field(static=True, default=())
    """Parent free-body index of each hinge child, length nh (static)."""
    hinge_joint_in_parent_m: jax.Array = eqx.field(
        converter=_float_array, default_factory=lambda: np.zeros((0, 3))
    )
    """Joint positions in the parent frame, from the parent's CoM, shape (nh, 3) [m]."""
    hinge_axis_in_parent: jax.Array = eqx.field(
        converter=_float_array, default_factory=lambda: np.zeros((0, 3))
    )
    """Hinge axes in the parent frame, shape (nh, 3) [-] (normalised in the kinematics)."""
    hinge_child_com_from_joint_m: jax.Array = eqx.field(
        converter=_float_array, default_factory=lambda: np.zeros((0, 3))
    )
    """Child CoM offset from the joint, child frame, shape (nh, 3) [m]."""
    hinge_child_mass_kg: jax.Array = eqx.field(
        converter=_float_array, default_factory=lambda: np.zeros((0,))
    )
    """Hinge-child masses, shape (nh,) [kg]."""
    hinge_child_inertia_kg_m2: jax.Array = eqx.field(
        converter=_float_array, default_factory=lambda: np.zeros((0, 3, 3))
    )
    """Hinge-child inertia tensors about their CoM, child frame, shape (nh, 3, 3) [kg m^2]."""
    quat_stabilisation_per_s: jax.Array = eqx.field(converter=_float_array, default=1.0)
    """``k`` of the norm-stabilisation term ``k (1 - |q|^2) q`` added to ``quat_dot`` [1/s]."""

    def __check_init__(self):
        nb, nh = self.n_free_bodies, self.n_hinges
        expected = {
            "body_mass_kg": (nb,),
            "body_inertia_kg_m2": (nb, 3, 3),
            "hinge_joint_in_parent_m": (nh, 3),
            "hinge_axis_in_parent": (nh, 3),
            "hinge_child_com_from_joint_m": (nh, 3),
            "hinge_child_mass_kg": (nh,),
            "hinge_child_inertia_kg_m2": (nh, 3, 3),
        }
        for name, shape in expected.items():
            got = tuple(getattr(self, name).shape)
            if got != shape:
                raise ValueError(f"{name} must have shape {shape}, got {got}")
        check_positive("body_mass_kg", self.body_mass_kg)
        _check_inertia("body_inertia_kg_m2", self.body_inertia_kg_m2)
        for k, p in enumerate(self.hinge_parent):
            if not (isinstance(p, (int, np.integer)) and 0 <= p < nb):
                raise ValueError(f"hinge_parent[{k}] must be a free-body index in [0, {nb}), got {p!r}")
        check_finite("hinge_joint_in_parent_m", self.hinge_joint_in_parent_m)
        check_finite("hinge_axis_in_parent", self.hinge_axis_in_parent)
        axis = _concrete(self.hinge_axis_in_parent)
        if axis is not None and np.any(np.linalg.norm(axis, axis=-1) < 1e-12):
            raise ValueError(f"hinge_axis_in_parent must be non-zero, got {self.hinge_axis_in_parent!r}")
        check_finite("hinge_child_com_from_joint_m", self.hinge_child_com_from_joint_m)
        check_positive("hinge_child_mass_kg", self.hinge_child_mass_kg)
        _check_inertia("hinge_child_inertia_kg_m2", self.hinge_child_inertia_kg_m2)
        check_positive("quat_stabilisation_per_s", self.quat_stabilisation_per_s, allow_zero=True)

    @property
    def n_free_bodies(self) -> int:
        return self.body_mass_kg.shape[0]

    @property
    def n_hinges(self) -> int:
        return len(self.hinge_parent)

    @property
    def n_bodies(self) -> int:
        """All bodies, free and hinged: ``nb + nh``."""
        return self.n_free_bodies + self.n_hinges

    @property
    def n_speeds(self) -> int:
        """Number of generalised speeds ``6 nb + nh``."""
        return 6 * self.n_free_bodies + self.n_hinges

    def all_masses(self):
        """Masses of all bodies (nb + nh,) [kg]."""
        return jnp.concatenate([self.body_mass_kg, self.hinge_child_mass_kg])

    def all_inertias(self):
        """Inertia tensors of all bodies about their CoM, own frame, (nb + nh, 3, 3) [kg m^2]."""
        return jnp.concatenate([self.body_inertia_kg_m2, self.hinge_child_inertia_kg_m2])


class MultibodyState(eqx.Module):
    """State ``(q, u)`` of a :class:`MultibodySystem`; its time derivative has the same type.

    In a derivative, ``r`` holds ``v``, ``quat`` holds ``quat_dot``, ``v`` holds ``dv/dt``,
    ``omega_body`` holds ``d omega_body/dt``, ``hinge_angle`` the rate and ``hinge_rate`` the
    angular acceleration.
    """

    r: jax.Array
    """Free-body CoM positions, world frame, shape (nb, 3) [m]."""
    quat: jax.Array
    """Free-body orientations, scalar-first quaternions body -> world, shape (nb, 4) [-]."""
    v: jax.Array
    """Free-body CoM velocities, world frame, shape (nb, 3) [m/s]."""
    omega_body: jax.Array
    """Free-body angular velocities in the body frame, shape (nb, 3) [rad/s]."""
    hinge_angle: jax.Array
    """Hinge angles ``phi``, shape (nh,) [rad]."""
    hinge_rate: jax.Array
    """Hinge rates ``phi_dot``, shape (nh,) [rad/s]."""


def speeds(state):
    """Generalised speeds ``u = [v.ravel(), omega_body.ravel(), hinge_rate]`` (6 nb + nh,)."""
    return jnp.concatenate([state.v.reshape(-1), state.omega_body.reshape(-1), state.hinge_rate])


def _split_speeds(system, u):
    nb = system.n_free_bodies
    return u[: 3 * nb].reshape(nb, 3), u[3 * nb : 6 * nb].reshape(nb, 3), u[6 * nb :]


def _coords(state):
    return (state.r, state.quat, state.hinge_angle)


def _kinematic_rates(q, u, system):
    """``q_dot = K(q) u`` (no norm stabilisation): ``(r_dot, quat_dot, phi_dot)``."""
    _, quat, _ = q
    v, omega_body, hinge_rate = _split_speeds(system, u)
    omega_quat = jnp.concatenate([jnp.zeros_like(omega_body[:, :1]), omega_body], axis=1)
    return v, 0.5 * quat_multiply(quat, omega_quat), hinge_rate


# ---------------------------------------------------------------------------------------------
# kinematics of all bodies
# ---------------------------------------------------------------------------------------------


def _poses(system, q):
    """``(com (N,3), unit quat (N,4), R (N,3,3))`` of all N = nb + nh bodies at coordinates q."""
    r, quat, hinge_angle = q
    quat = _unit_quat(quat)
    R = quat_to_matrix(quat)
    if system.n_hinges == 0:
        return r, quat, R
    parent = np.asarray(system.hinge_parent)
    axis = safe_normalize(system.hinge_axis_in_parent, jnp.array([0.0, 0.0, 1.0]))
    quat_child = quat_multiply(quat[parent], quat_from_rotation_vector(axis * hinge_angle[:, None]))
    R_child = quat_to_matrix(quat_child)
    joint = r[parent] + _matvec(R[parent], system.hinge_joint_in_parent_m)
    com_child = joint + _matvec(R_child, system.hinge_child_com_from_joint_m)
    return (
        jnp.concatenate([r, com_child]),
        jnp.concatenate([quat, quat_child]),
        jnp.concatenate([R, R_child]),
    )


def _velocities_from_poses(system, poses, u):
    """``(v_com (N,3), omega_world (N,3), omega_body (N,3))``: linear in ``u`` at fixed poses."""
    v, omega_body, hinge_rate = _split_speeds(system, u)
    _, _, R = poses
    nb = system.n_free_bodies
    omega_world = _matvec(R[:nb], omega_body)
    if system.n_hinges == 0:
        return v, omega_world, omega_body
    parent = np.asarray(system.hinge_parent)
    axis = safe_normalize(system.hinge_axis_in_parent, jnp.array([0.0, 0.0, 1.0]))
    R_parent, R_child = R[parent], R[nb:]
    joint_arm = _matvec(R_parent, system.hinge_joint_in_parent_m)
    com_arm = _matvec(R_child, system.hinge_child_com_from_joint_m)
    omega_child = omega_world[parent] + _matvec(R_parent, axis) * hinge_rate[:, None]
    v_child = v[parent] + jnp.cross(omega_world[parent], joint_arm) + jnp.cross(omega_child, com_arm)
    omega_child_body = _matvec_t(R_child, omega_child)
    return (
        jnp.concatenate([v, v_child]),
        jnp.concatenate([omega_world, omega_child]),
        jnp.concatenate([omega_body, omega_child_body]),
    )


def _velocities(system, q, u):
    return _velocities_from_poses(system, _poses(system, q), u)


def body_poses(system, state):
    """CoM positions (N,3) [m], unit quaternions (N,4) and rotation matrices (N,3,3) of all bodies."""
    return _poses(system, _coords(state))


def body_velocities(system, state):
    """CoM velocities (N,3) [m/s] and world angular velocities (N,3) [rad/s] of all bodies."""
    v, omega_world, _ = _velocities(system, _coords(state), speeds(state))
    return v, omega_world


def _index_points(body_index, local_points):
    """Static body index (int or tuple) -> (B,) index array and (B, P, 3) points; ``squeeze`` flag."""
    idx = np.asarray(body_index, dtype=int)
    pts = jnp.asarray(local_points)
    if idx.ndim == 0:
        return idx[None], pts[None], True
    return idx, pts, False


def _points(system, q, u, body_index, local_points):
    idx, pts, squeeze = _index_points(body_index, local_points)
    com, _, R = _poses(system, q)
    v, omega, _ = _velocities(system, q, u)
    arm = _matvec_points(R[idx], pts)
    x = com[idx][:, None, :] + arm
    xdot = v[idx][:, None, :] + jnp.cross(omega[idx][:, None, :], arm)
    return (x[0], xdot[0]) if squeeze else (x, xdot)


def point_kinematics(system, state, body_index, local_points):
    """World positions and velocities of points fixed to a body.

    Args:
        body_index: static int (then ``local_points`` is (P, 3)) or tuple of B ints (then (B, P, 3)).
        local_points: points in the body frame, measured from the body's CoM [m].

    Returns:
        ``(positions [m], velocities [m/s])``, each shaped like ``local_points``.
    """
    return _points(system, _coords(state), speeds(state), body_index, local_points)


def world_to_local(system, state, body_index, world_points):
    """Inverse of :func:`point_kinematics`' positions: world points [m] -> body-local points [m]."""
    idx, pts, squeeze = _index_points(body_index, world_points)
    com, _, R = body_poses(system, state)
    local = _matvec_t_points(R[idx], pts - com[idx][:, None, :])
    return local[0] if squeeze else local


def point_acceleration(system, state, state_dot, body_index, local_points):
    """World accelerations [m/s^2] of body-fixed points, given the state's time derivative.

    ``state_dot`` is the output of :func:`accelerations`; the acceleration is the directional
    derivative of the point velocity along ``(q_dot, u_dot)`` (includes centripetal terms).
    """
    q, u = _coords(state), speeds(state)
    q_dot = (state_dot.r, state_dot.quat, state_dot.hinge_angle)
    u_dot = speeds(state_dot)
    _, (_, acc) = jax.jvp(
        lambda q_, u_: _points(system, q_, u_, body_index, local_points), (q, u), (q_dot, u_dot)
    )
    return acc


# ---------------------------------------------------------------------------------------------
# Kane's equations
# ---------------------------------------------------------------------------------------------


def _partial_velocities(system, poses):
    """Jacobians ``Jv`` (N,3,n_u) of CoM velocities and ``Jw`` (N,3,n_u) of body-frame omegas."""
    u0 = jnp.zeros(system.n_speeds, dtype=poses[0].dtype)
    return jax.jacfwd(lambda u: _velocities_from_poses(system, poses, u)[::2])(u0)


def mass_matrix(system, state):
    """Generalised mass matrix ``M = sum_b m_b Jv^T Jv + Jw^T J_b Jw`` (n_u, n_u) [SI blocks]."""
    Jv, Jw = _partial_velocities(system, body_poses(system, state))
    return _mass_matrix(system, Jv, Jw)


_UNROLLED_SOLVE_MAX_N = 8


def _spd_solve(M, b):
    """Solve ``M x = b`` for the symmetric positive definite mass matrix ``M`` (Cholesky).

    Up to ``_UNROLLED_SOLVE_MAX_N`` unknowns (the rigid rocket: 6) the factorisation and the two
    triangular solves are unrolled jnp operations, with no LAPACK custom call. Two reasons, both
    measured on jax/jaxlib 0.10.2 CPU, float64:

    * Reverse-mode AD of a run whose *initial state* depends on the differentiated input (the
      two-phase landing: the passive phase starts from the captured state) failed to execute with
      "No registered implementation for untyped custom call to lapack_dtrsm_ffi / lapack_dpotrf_ffi
      for Host": inside equinox's checkpointed while loop (the no-vjp forward of its custom_vjp,
      nested in diffrax's outer loop) the LAPACK custom calls lose their typed-FFI
      ``api_version`` in the lowered HLO. Calls inlined from ``lax.linalg`` lose it too.
    * For a 6 x 6 matrix the unrolled solve is no slower than two LAPACK calls.

    Larger systems (the flexible rocket: 34) use ``jax.scipy.linalg.cho_solve`` (LAPACK), so a
    reverse-mode run of the *full* level whose initial state is differentiated still fails on this
    jaxlib (no shipped path does that: the two-phase program runs its passive phase at level rigid)."""
    n = M.shape[0]
    if n > _UNROLLED_SOLVE_MAX_N:
        # jax.scipy's jitted wrappers, not lax.linalg inline: called eagerly (outside jit), the
        # inline primitives failed with the same "untyped custom call" error (tests/arresting/test_wind.py)
        return cho_solve(cho_factor(M), b)
    cols = []  # columns of L below and on the diagonal, as full-length vectors (zeros above)
    for j in range(n):
        v = M[:, j]
        for k in range(j):
            v = v - cols[k] * cols[k][j]
        cols.append(jnp.where(jnp.arange(n) >= j, v, 0.0) / jnp.sqrt(v[j]))
    y = []
    for i in range(n):
        acc = b[i]
        for k in range(i):
            acc = acc - cols[k][i] * y[k]
        y.append(acc / cols[i][i])
    x = [None] * n
    for i in reversed(range(n)):
        acc = y[i]
        for k in range(i + 1, n):
            acc = acc - cols[i][k] * x[k]
        x[i] = acc / cols[i][i]
    return jnp.stack(x)


def _mass_matrix(system, Jv, Jw):
    m, inertia = system.all_masses(), system.all_inertias()
    return jnp.einsum("b,bin,bim->nm", m, Jv, Jv) + jnp.einsum("bin,bij,bjm->nm", Jw, inertia, Jw)


def _bias_accelerations_autodiff(system, q, u):
    """``(a_bias, alpha_bias_body)`` (N,3): ``d(v_com, omega_body)/dq . q_dot`` at fixed ``u`` (jvp)."""

    def vel(q_):
        v, _, omega_body = _velocities(system, q_, u)
        return v, omega_body

    _, bias = jax.jvp(vel, (q,), (_kinematic_rates(q, u, system),))
    return bias


def _bias_accelerations(system, poses, u):
    """Closed form of :func:`_bias_accelerations_autodiff` (same values, a fraction of the compile time).

    Free bodies have none (``u`` holds ``v`` and ``omega_body`` themselves). For hinge child ``c`` of
    parent ``p`` with world axis ``A = R_p a``, arms ``rho_j = R_p j``, ``rho_c = R_c c``:
    ``alpha_c = omega_p x A phi_dot``, ``a_c = omega_p x (omega_p x rho_j) + alpha_c x rho_c
    + omega_c x (omega_c x rho_c)``, and the body-frame ``alpha`` is ``R_c^T alpha_c``.
    """
    nb = system.n_free_bodies
    zeros = jnp.zeros((nb, 3), poses[0].dtype)
    if system.n_hinges == 0:
        return zeros, zeros
    _, _, R = poses
    v, omega_body, hinge_rate = _split_speeds(system, u)
    parent = np.asarray(system.hinge_parent)
    axis = safe_normalize(system.hinge_axis_in_parent, jnp.array([0.0, 0.0, 1.0]))
    R_parent, R_child = R[parent], R[nb:]
    omega_parent = _matvec(R_parent, omega_body[parent])
    axis_world = _matvec(R_parent, axis)
    joint_arm = _matvec(R_parent, system.hinge_joint_in_parent_m)
    com_arm = _matvec(R_child, system.hinge_child_com_from_joint_m)
    omega_child = omega_parent + axis_world * hinge_rate[:, None]
    alpha = jnp.cross(omega_parent, axis_world) * hinge_rate[:, None]
    acc = (
        jnp.cross(omega_parent, jnp.cross(omega_parent, joint_arm))
        + jnp.cross(alpha, com_arm)
        + jnp.cross(omega_child, jnp.cross(omega_child, com_arm))
    )
    return jnp.concatenate([zeros, acc]), jnp.concatenate([zeros, _matvec_t(R_child, alpha)])


def _inertia_wrenches(system, poses, u):
    """Velocity-product terms as body wrenches: ``(-m a_bias, -(J alpha_bias + omega x J omega))``.

    Also returns ``(v_com, omega_body)`` of all bodies.
    """
    m, inertia = system.all_masses(), system.all_inertias()
    v, _, omega_body = _velocities_from_poses(system, poses, u)
    acc_bias, alpha_bias = _bias_accelerations(system, poses, u)
    gyro = _matvec(inertia, alpha_bias) + jnp.cross(omega_body, _matvec(inertia, omega_body))
    return -m[:, None] * acc_bias, -gyro, (v, omega_body)


def _sum_into_bodies(idx, values, n_bodies):
    """``out[n] = sum of values[b] over b with idx[b] == n`` for a static index ``idx`` (B,), as
    static row picks and adds: the same sums as ``zeros.at[idx].add(values)`` without a scatter
    (XLA's CPU scatter is a separate, unfused kernel, and so is its tangent; this runs ~10^5 times
    per landing) and without the constant 0/1 matrix product used before (a small ``dot`` kernel
    of its own, two with a tangent)."""
    idx = [int(i) for i in np.asarray(idx)]
    rows = []
    for n in range(n_bodies):
        picked = [values[b] for b, i in enumerate(idx) if i == n]
        rows.append(functools.reduce(jnp.add, picked) if picked else jnp.zeros_like(values[0]))
    return jnp.stack(rows)


def _load_wrenches(system, poses, point_forces, body_torques_world, gravity):
    """Point forces, body torques and gravity as ``(force (N,3) world, torque (N,3) body frame)``.

    The torque is about the body's CoM; ``Q = Jv^T F + Jw^T tau`` is then ``J_P^T f`` summed over
    the points (``J_P = Jv - [R p]x R Jw``), i.e. the virtual power of :func:`generalized_forces`.
    """
    com, _, R = poses
    force = jnp.zeros_like(com)
    torque_world = jnp.zeros_like(com)
    if gravity is not None:
        force = force + system.all_masses()[:, None] * jnp.asarray(gravity)[None, :]
    for body_index, local_points, world_forces in point_forces:
        idx, pts, squeeze = _index_points(body_index, local_points)
        f = jnp.asarray(world_forces)
        f = f[None] if squeeze else f
        arm = _matvec_points(R[idx], pts)
        force = force + _sum_into_bodies(idx, jnp.sum(f, axis=1), force.shape[0])
        torque_world = torque_world + _sum_into_bodies(idx, jnp.sum(jnp.cross(arm, f), axis=1), force.shape[0])
    if body_torques_world is not None:
        torque_world = torque_world + jnp.asarray(body_torques_world)
    return force, _matvec_t(R, torque_world)


def generalized_forces(
    system, state, point_forces=(), body_torques_world=None, hinge_torques=None, gravity=None
):
    """Generalised active force ``Q`` (n_u,) by virtual power (``Q = J_P^T F`` for every load).

    Args:
        point_forces: sequence of ``(body_index, local_points, world_forces)``; ``body_index`` static
            int with (P, 3) points/forces, or a tuple of B ints with (B, P, 3) arrays; points are in the
            body frame from its CoM [m], forces in the world frame [N].
        body_torques_world: (nb + nh, 3) torques about each body's CoM, world frame [N m], or None.
        hinge_torques: (nh,) internal torques on the hinges (+ on the child about its axis) [N m].
        gravity: (3,) uniform gravitational acceleration [m/s^2], or None.

    The point-velocity map is linear in ``u``, so one ``jax.vjp`` of it gives ``(dv_P/du)^T F``.
    (:func:`accelerations` uses the equivalent body-wrench form; this is its reference.)
    """
    q, u = _coords(state), speeds(state)

    def power_map(u_):
        v, omega_world, _ = _velocities(system, q, u_)
        pts = tuple(_points(system, q, u_, b, p)[1] for b, p, _ in point_forces)
        return v, omega_world, pts, _split_speeds(system, u_)[2]

    (v, _, _, hinge_rate), vjp = jax.vjp(power_map, u)
    com_force = jnp.zeros_like(v)
    if gravity is not None:
        com_force = system.all_masses()[:, None] * jnp.asarray(gravity)[None, :]
    torque = jnp.zeros_like(v) if body_torques_world is None else jnp.asarray(body_torques_world)
    tau = jnp.zeros_like(hinge_rate) if hinge_torques is None else jnp.asarray(hinge_torques)
    forces = tuple(jnp.asarray(f) for _, _, f in point_forces)
    (Q,) = vjp((com_force, torque, forces, tau))
    return Q


def generalized_force_from_energy(system, state, energy_fn):
    """``Q = -K(q)^T grad_q V`` (n_u,) of a potential ``energy_fn(state) -> V`` [J].

    ``energy_fn`` may depend only on the coordinates ``(r, quat, hinge_angle)`` of the state (use
    :func:`body_poses`/:func:`point_kinematics` inside it). The transpose of ``K`` is a vjp through
    the (linear in ``u``) kinematic map, so ``Q . u = -dV/dt`` exactly.
    """
    q, u = _coords(state), speeds(state)

    def energy_of_q(q_):
        return energy_fn(eqx.tree_at(lambda s: (s.r, s.quat, s.hinge_angle), state, q_))

    grad_q = jax.grad(energy_of_q)(q)
    _, vjp = jax.vjp(lambda u_: _kinematic_rates(q, u_, system), u)
    (Q,) = vjp(grad_q)
    return -Q


def _stabilised_rates(system, state):
    """``q_dot = K(q) u`` with the norm-stabilisation term ``k (1 - |q|^2) q`` added to ``quat_dot``."""
    r_dot, quat_dot, hinge_rate = _kinematic_rates(_coords(state), speeds(state), system)
    norm_sq = jnp.sum(state.quat**2, axis=1, keepdims=True)
    return r_dot, quat_dot + system.quat_stabilisation_per_s * (1.0 - norm_sq) * state.quat, hinge_rate


def _free_body_accelerations(
    system, state, point_forces, body_torques_world, hinge_torques, gravity, beams, generalized_force
):
    """:func:`accelerations` of a system without hinges: Newton-Euler body by body.

    With no hinge every generalised speed is a body's own ``v`` or ``omega_body``, so ``Jv`` and
    ``Jw`` select, ``M = diag(m_b I, J_b)`` is block diagonal and constant, there is no bias
    acceleration, and Kane's equations are ``m_b v_dot_b = F_b``, ``J_b omega_dot_b = tau_b -
    omega_b x J_b omega_b``. Written this way the rigid and ale levels' rocket (one body, hooks
    welded) skips the partial velocities (a ``jacfwd``), the mass matrix and its 6 x 6 Cholesky
    solve: its derivative compiles to 22 XLA fusions instead of 47, and with two tangents to 42
    instead of 71 (32 cases vmapped). Same values as the general path (:func:`_kane_accelerations`)
    to round-off (``tests/arresting/test_multibody.py``). ``hinge_torques`` has nothing to act on.
    """
    del hinge_torques
    nb = system.n_free_bodies
    poses = _poses(system, _coords(state))
    force, torque = _load_wrenches(system, poses, point_forces, body_torques_world, gravity)
    J, omega = system.body_inertia_kg_m2, state.omega_body
    torque = torque - jnp.cross(omega, _matvec(J, omega))
    if beams is not None and beams.n_beams:
        f_beam, t_beam = _beam_wrenches(beams, poses, state.v, omega)
        force, torque = force + f_beam, torque + t_beam
    if generalized_force is not None:
        force = force + generalized_force[: 3 * nb].reshape(nb, 3)
        torque = torque + generalized_force[3 * nb : 6 * nb].reshape(nb, 3)
    v_dot = force / system.body_mass_kg[:, None]
    omega_dot = jax.vmap(_spd_solve)(J, torque)
    r_dot, quat_dot, hinge_rate = _stabilised_rates(system, state)
    return MultibodyState(
        r=r_dot, quat=quat_dot, v=v_dot, omega_body=omega_dot, hinge_angle=hinge_rate,
        hinge_rate=jnp.zeros_like(state.hinge_rate),
    )


def accelerations(
    system,
    state,
    point_forces=(),
    body_torques_world=None,
    hinge_torques=None,
    gravity=None,
    beams=None,
    generalized_force=None,
):
    """Time derivative of a :class:`MultibodyState` (Kane: ``M u_dot = Q - bias``).

    Args: as :func:`generalized_forces`, plus ``beams`` (a :class:`MasslessBeams` or None) and
    ``generalized_force`` (n_u,): an extra generalised force (e.g. from
    :func:`generalized_force_from_energy`).

    Every load is first reduced to a body wrench (force at the CoM, world; torque, body frame), then
    ``Q = sum_b Jv_b^T F_b + Jw_b^T tau_b`` with the partial velocities from one ``jax.jacfwd``.
    ``M`` is symmetric positive definite; the dense Cholesky solve costs ``O(n_u^3)`` with
    ``n_u = 6 nb + nh`` (34 for the 5-body rocket with four hooks).
    """
    args = (system, state, point_forces, body_torques_world, hinge_torques, gravity, beams, generalized_force)
    if system.n_hinges == 0:
        return _free_body_accelerations(*args)
    return _kane_accelerations(*args)


def _kane_accelerations(
    system, state, point_forces, body_torques_world, hinge_torques, gravity, beams, generalized_force
):
    """The general path of :func:`accelerations` (any tree of free bodies and hinge children)."""
    q, u = _coords(state), speeds(state)
    poses = _poses(system, q)
    Jv, Jw = _partial_velocities(system, poses)
    force, torque, (v, omega_body) = _inertia_wrenches(system, poses, u)
    f_load, t_load = _load_wrenches(system, poses, point_forces, body_torques_world, gravity)
    force, torque = force + f_load, torque + t_load
    if beams is not None and beams.n_beams:
        f_beam, t_beam = _beam_wrenches(beams, poses, v, omega_body)
        force, torque = force + f_beam, torque + t_beam
    Q = jnp.einsum("bin,bi->n", Jv, force) + jnp.einsum("bin,bi->n", Jw, torque)
    if hinge_torques is not None:
        Q = Q.at[6 * system.n_free_bodies :].add(hinge_torques)
    if generalized_force is not None:
        Q = Q + generalized_force
    M = _mass_matrix(system, Jv, Jw)
    u_dot = _spd_solve(M, Q)
    v_dot, omega_dot, hinge_acc = _split_speeds(system, u_dot)
    r_dot, quat_dot, hinge_rate = _stabilised_rates(system, state)
    return MultibodyState(
        r=r_dot, quat=quat_dot, v=v_dot, omega_body=omega_dot, hinge_angle=hinge_rate, hinge_rate=hinge_acc
    )


# ---------------------------------------------------------------------------------------------
# energies and momenta
# ---------------------------------------------------------------------------------------------


def kinetic_energy(system, state):
    """``sum_b 1/2 m |v|^2 + 1/2 omega_b . J omega_b`` over all bodies [J]."""
    v, _, omega_body = _velocities(system, _coords(state), speeds(state))
    inertia = system.all_inertias()
    return 0.5 * jnp.sum(system.all_masses() * jnp.sum(v * v, axis=1)) + 0.5 * jnp.sum(
        omega_body * _matvec(inertia, omega_body)
    )


def potential_energy(system, state, gravity):
    """Gravitational energy ``-sum_b m_b g . r_b`` [J] (zero at the world origin)."""
    com, _, _ = body_poses(system, state)
    return -jnp.sum(system.all_masses() * (com @ jnp.asarray(gravity)))


def momentum(system, state):
    """Linear momentum (3,) [kg m/s] and angular momentum about the world origin (3,) [kg m^2/s]."""
    com, _, R = body_poses(system, state)
    v, _, omega_body = _velocities(system, _coords(state), speeds(state))
    m = system.all_masses()
    spin = jnp.einsum("bij,bjk,bk->bi", R, system.all_inertias(), omega_body)
    linear = jnp.sum(m[:, None] * v, axis=0)
    angular = jnp.sum(m[:, None] * jnp.cross(com, v) + spin, axis=0)
    return linear, angular


# ---------------------------------------------------------------------------------------------
# massless beams: the system-level quantities (the element is in jaxcable.components.beams)
# ---------------------------------------------------------------------------------------------


def _beam_deformations(system, beams, q):
    com, quat, _ = _poses(system, q)
    a, b = np.asarray(beams.body_a, dtype=int), np.asarray(beams.body_b, dtype=int)
    return jax.vmap(_beam_deformation)(
        com[a], quat[a], com[b], quat[b], beams.attach_a_m, beams.attach_b_m, beams.length_m
    )


def beam_deformations(system, beams, state):
    """Deformations ``e = [d, psi]`` (nbeam, 6) [m, rad] measured in each beam's end-A frame."""
    return _beam_deformations(system, beams, _coords(state))


def beam_deformation_rates(system, beams, state):
    """``e_dot`` (nbeam, 6) [m/s, rad/s]: ``jax.jvp`` of the deformations along ``q_dot = K(q) u``."""
    q = _coords(state)
    _, e_dot = jax.jvp(
        lambda q_: _beam_deformations(system, beams, q_), (q,), (_kinematic_rates(q, speeds(state), system),)
    )
    return e_dot


def beam_dissipation_power(system, beams, state):
    """Power dissipated by the beams' Rayleigh damping, ``beta sum e_dot^T K e_dot`` [W] (>= 0)."""
    if beams.n_beams == 0:
        return jnp.zeros((), state.r.dtype)
    e_dot = beam_deformation_rates(system, beams, state)
    return beams.damping_s * jnp.einsum("ni,nij,nj->", e_dot, _stiffness_matrices(beams), e_dot)




def beam_energy(system, beams, state):
    """Elastic energy ``sum 1/2 e^T K e`` of the beams [J]."""
    if beams.n_beams == 0:
        return jnp.zeros((), state.r.dtype)
    e = beam_deformations(system, beams, state)
    return 0.5 * jnp.einsum("ni,nij,nj->", e, _stiffness_matrices(beams), e)


def beam_generalized_force(system, beams, state):
    """Elastic + damping generalised force of the beams (n_u,): ``-(de/du)^T K (e + beta e_dot)``."""
    if beams.n_beams == 0:
        return jnp.zeros(system.n_speeds, state.r.dtype)
    poses = body_poses(system, state)
    _, _, omega_body = _velocities_from_poses(system, poses, speeds(state))
    v, _ = body_velocities(system, state)
    force, torque = _beam_wrenches(beams, poses, v, omega_body)
    Jv, Jw = _partial_velocities(system, poses)
    return jnp.einsum("bin,bi->n", Jv, force) + jnp.einsum("bin,bi->n", Jw, torque)
