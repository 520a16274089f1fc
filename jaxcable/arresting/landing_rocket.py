"""The landing rocket with four hinged hooks, rigid or flexible: the arresting-cable paper, section III.C.

Both models are a :class:`LandingRocket` (one interface, so a scene can swap them):

* :func:`rigid_landing_rocket`: one rigid body (``n_bodies = 1``);
* :func:`flexible_landing_rocket`: ``n_bodies`` lumped rigid bodies along the axis joined by
  ``n_bodies - 1`` massless Euler-Bernoulli beams (eq 39's ``f_beam``; the paper's Fig. 9).

The four hooks are hinge children of the body that carries them (one revolute DOF each, eq 40), held
by a rotational spring-damper (eq 39's ``f_sprdmp``), or, with ``hinged_hooks=False``, welded to that
body (their mass and inertia added to it). The dynamics are :mod:`jaxcable.components.multibody`.

Frames and geometry
-------------------
World: ``z`` up. Rocket frame: origin at the bottom centre, ``+z`` along the axis toward the head,
``+x`` toward hook 0; hook ``k`` points along ``e_k = Rz(k pi/2) e_x``. Every free body's frame is
parallel to the rocket frame in the undeformed state; its origin is its own centre of mass. Hook
``k``: hinge ``H = R_r e_k + hinge_height e_z`` on the shell; tangential hinge axis
``t_k = e_z x e_k`` (positive hinge angle opens the hook, away from the axis); arm of length ``l_h``
along ``sin(theta_h) e_k + cos(theta_h) e_z`` (up and out) to the tip ``T`` (radius
``R_r + l_h sin(theta_h) = 5.03 m``); barb of length ``h_h`` hanging from the tip parallel to the
axis to ``B = T - h_h e_z``. The cable is caught in the throat between arm and barb. The hook frame
is parallel to the rocket frame at hinge angle 0 (the deployed angle ``theta_h``); the hook's local
points ``(H, T, B)`` are given in its own frame from its CoM (:attr:`LandingRocket.hook_points_local_m`).

The paper's rocket frame ``OXYZ`` (section IV) has its ``XY`` plane through the four hook tips
("top points") and ``Z`` on the axis: ``O`` is the axis point at tip height, fixed to the hooks'
parent body. Attitude is the rotation vector ``theta = [theta_x, theta_y, theta_z]`` taking the
world axes to ``OXYZ``; angular velocity is in world axes.

Glossary (Table 1 and eqs 35-41)
--------------------------------
==============================  ================================================================
``R_r``, ``L_r``                rocket radius 2 m, length 40 m
``m_engine``, ``J^engine``      engine 12.5 t at the bottom, ``J_zz`` 2.5e4, ``J_xx = J_yy`` 4.16e3 kg m^2
``EA``, ``EJ``, ``GJ``          beam axial [N], bending [N m^2], torsional [N m^2] stiffness
``m_h``, ``l_h``, ``h_h``       hook mass 45 kg, arm length 3.5 m, barb length ("size") 1 m
``theta_h``, ``d_h``            deployment angle pi/3 from the axis, hook diameter ("width") 0.15 m
``k_h``, ``c_h``, ``L_h``       hook spring 1.5e5 N/m, damper 4e5 N s/m, hinge height 20 m
``phi`` (4,)                    hinge angle from the deployed position [rad] (state.hinge_angle)
==============================  ================================================================

Readings of Table 1 and corrections (numbers checked in the tests or here)
--------------------------------------------------------------------------
* **Mass.** Table 1 gives ``rho A = 501.4 kg/m``, i.e. a 20.06 t structure, 32.56 t in all with the
  engine and a CoM 12.32 m above the bottom (``L_c = 27.7 m``). The text says "a 12.5 ton landing
  rocket mounted by an engine of 12.5 ton at its bottom", section II.B designs for ``m_r = 25 t``, and
  Table 1's ``L_c = 30 m`` (CoM to top) puts the CoM 10 m above the bottom, which the 12.5 t + 12.5 t
  reading with the engine's CoM at the bottom reproduces exactly. We use **12.5 t of structure
  uniform along the axis (312.5 kg/m) + 12.5 t engine** (25 t); the four hooks (180 kg) come on top.
  The structure is a thin-walled cylinder: a segment of mass ``m`` and length ``l`` has
  ``J_zz = m R_r^2`` and ``J_xx = J_yy = m (R_r^2/2 + l^2/12)`` about its centre.
* **EJ units.** Table 1 prints ``EJ = 5.24e9 N/m``; a bending stiffness is N m^2. It is consistent
  with a thin tube, ``EJ = EA R_r^2 / 2 = 5.26e9 N m^2``.
* **GJ** is not given. We take ``GJ = EJ / (1 + nu)`` with ``nu = 0.3`` (thin tube: polar moment
  ``2 J``, ``G = E / (2 (1 + nu))``): 4.03e9 N m^2.
* **Engine inertia.** ``J_xx + J_yy = 8.32e3 < J_zz = 2.5e4`` violates the triangle inequality of
  principal moments, so no real body has Table 1's engine inertia (``J_zz`` is a solid 2 m disc,
  ``m R_r^2 / 2``). Taken as printed: every composite body here is physical, because the shell
  dominates (5-body bottom body: ``J_xx = 5.58e4``, ``J_zz = 3.5e4``). Inertias are taken about the
  engine's own CoM (the Nomenclature says "relative to OXYZ", whose origin is ~20 m away).
* **Hook height.** We put the hinges at ``L_h = 20 m`` above the bottom (the tips at 21.75 m). The
  Nomenclature defines ``L_h`` as the length from ``O`` (tip plane) to the *top*, which puts the tips
  at ``L_r - L_h = 20 m`` and the hinges at 18.25 m. ``hinge_height_m`` is a parameter; 18.25 m gives
  that reading.
* **Hook spring-damper.** Table 1 gives a linear spring-damper (N/m, N s/m) but no lever or
  attachment points. Our reading: it acts at the hook tip, perpendicular to the arm, so it is a
  rotational spring ``k_h l_h^2 = 1.84e6 N m/rad`` and damper ``c_h l_h^2 = 4.9e6 N m s/rad`` about the
  hinge with rest angle ``theta_h`` (``phi = 0``). With the hook's 251 kg m^2 about its hinge this is
  an overdamped mode (undamped 85.5 rad/s, damping ratio 114, fast time constant
  ``I / (c_h l_h^2) = 5.1e-5 s``): a stiff ODE for explicit solvers (an RK4 step must stay below
  ~ 1.4e-4 s; see :meth:`LandingRocket.hook_modes`). ``c_h`` may be a misprint (4e3 would give a
  damping ratio of 1.1).
* **Hook mass distribution.** The 45 kg is spread uniformly over arm and barb (10 kg/m), each a
  solid rod of diameter ``d_h`` (``J_axial = m d^2/8``, ``J_transverse = m (d^2/16 + l^2/12)``:
  the slender-rod inertia plus its thickness), combined about the hook CoM.

Flexible model (paper Fig. 9)
-----------------------------
The rocket is cut into ``n_bodies`` equal segments; body ``i`` is the shell segment (plus the engine
for the bottom one, plus the hooks for their parent when they are welded). Beam ``i`` joins the
geometric centres of segments ``i`` and ``i + 1`` (axis points, length ``L_r / n_bodies``). The hooks'
parent is the segment containing the hinge height (``floor(hinge_height n / L_r)``, so a hinge on a
boundary belongs to the upper segment; ``hook_parent_body`` overrides it). With 5 bodies the segments
are 8 m long and the hinges (20 m) and tips (21.75 m) lie inside body 2 (16-24 m). All bodies moving
together have exactly the rigid rocket's mass, CoM and inertia, so the two models agree for rigid
motions (tested). Cost of one :meth:`LandingRocket.derivative` inside a jitted loop (2 CPU cores,
float64): ~86 us for 5 bodies with hinged hooks (34 speeds), ~22 us for the rigid rocket.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxcable.core.validation import _concrete, check_finite, check_positive, check_range
from jaxcable.core.validation import as_float_array
from jaxcable.components.multibody import (
    MasslessBeams,
    MultibodyState,
    MultibodySystem,
    accelerations,
    beam_dissipation_power,
    beam_energy,
    body_poses,
    kinetic_energy,
    point_acceleration,
    point_kinematics,
    potential_energy,
    quat_from_rotation_vector,
    quat_to_matrix,
    rotation_vector_from_quat,
    world_to_local,
)

__all__ = [
    "GRAVITY_M_S2",
    "N_HOOKS",
    "LandingRocket",
    "LandingRocketParams",
    "flexible_landing_rocket",
    "rigid_landing_rocket",
]

N_HOOKS = 4
GRAVITY_M_S2 = (0.0, 0.0, -9.81)
"""Uniform gravity, world frame, z up [m/s^2] (the paper's g = 9.81)."""

# Exact unit directions of the four hooks (avoids cos(pi/2) = 6e-17 breaking the symmetry).
_HOOK_DIRECTIONS = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])




class LandingRocketParams(eqx.Module):
    """Table 1's rocket and hook values (defaults) and our readings of it (see the module docstring).

    All fields are arrays, so they can be swept or differentiated; the geometry and mass fields are
    consumed by the builders, ``hook_stiffness_N_per_m`` and ``hook_damping_N_s_per_m`` are read at
    run time (``eqx.tree_at`` on ``rocket.params`` changes them in a built rocket).
    """

    radius_m: jax.Array = eqx.field(converter=as_float_array, default=2.0)
    """``R_r``: rocket radius [m]."""
    length_m: jax.Array = eqx.field(converter=as_float_array, default=40.0)
    """``L_r``: rocket length [m]."""
    structure_mass_kg: jax.Array = eqx.field(converter=as_float_array, default=12.5e3)
    """Thin-walled structure, uniform along the axis [kg] (our reading; Table 1's rhoA gives 20.06 t)."""
    engine_mass_kg: jax.Array = eqx.field(converter=as_float_array, default=12.5e3)
    """``m_engine`` [kg]."""
    engine_height_m: jax.Array = eqx.field(converter=as_float_array, default=0.0)
    """Height of the engine's CoM above the bottom [m] (0: "at its bottom"; gives L_c = 30 m)."""
    engine_inertia_axial_kg_m2: jax.Array = eqx.field(converter=as_float_array, default=2.5e4)
    """``J_zz^engine`` about the engine CoM [kg m^2]."""
    engine_inertia_transverse_kg_m2: jax.Array = eqx.field(converter=as_float_array, default=4.16e3)
    """``J_xx^engine = J_yy^engine`` about the engine CoM [kg m^2]."""
    EA_N: jax.Array = eqx.field(converter=as_float_array, default=2.63e9)
    """``EA``: axial stiffness of the rocket beams [N]."""
    EJ_N_m2: jax.Array = eqx.field(converter=as_float_array, default=5.24e9)
    """``EJ``: bending stiffness [N m^2] (Table 1 prints the unit as N/m)."""
    GJ_N_m2: jax.Array = eqx.field(converter=as_float_array, default=5.24e9 / 1.3)
    """``GJ``: torsional stiffness [N m^2]; not in Table 1, ``EJ / (1 + 0.3)``."""
    beam_damping_s: jax.Array = eqx.field(converter=as_float_array, default=0.0)
    """``beta``: stiffness-proportional damping of the rocket beams [s]; not in Table 1 (0 = undamped)."""
    hook_mass_kg: jax.Array = eqx.field(converter=as_float_array, default=45.0)
    """``m_h``: mass of one hook [kg]."""
    hook_length_m: jax.Array = eqx.field(converter=as_float_array, default=3.5)
    """``l_h``: arm length, hinge to tip [m]."""
    hook_barb_m: jax.Array = eqx.field(converter=as_float_array, default=1.0)
    """``h_h``: barb length, tip downward parallel to the axis [m]."""
    hook_deploy_angle_rad: jax.Array = eqx.field(converter=as_float_array, default=math.pi / 3)
    """``theta_h``: deployed angle between arm and rocket axis [rad] (rest angle of the spring)."""
    hook_diameter_m: jax.Array = eqx.field(converter=as_float_array, default=0.15)
    """``d_h``: hook (rod) diameter [m]."""
    hook_stiffness_N_per_m: jax.Array = eqx.field(converter=as_float_array, default=1.5e5)
    """``k_h``: hook spring, acting at the tip perpendicular to the arm (our reading) [N/m]."""
    hook_damping_N_s_per_m: jax.Array = eqx.field(converter=as_float_array, default=4.0e5)
    """``c_h``: hook damper, acting at the tip perpendicular to the arm (our reading) [N s/m]."""
    hinge_height_m: jax.Array = eqx.field(converter=as_float_array, default=20.0)
    """``L_h``: height of the hook hinges above the bottom [m] (see the module docstring)."""

    def __check_init__(self):
        for name in (
            "radius_m",
            "length_m",
            "structure_mass_kg",
            "engine_mass_kg",
            "engine_inertia_axial_kg_m2",
            "engine_inertia_transverse_kg_m2",
            "EA_N",
            "EJ_N_m2",
            "GJ_N_m2",
            "hook_mass_kg",
            "hook_length_m",
            "hook_barb_m",
            "hook_diameter_m",
        ):
            check_positive(f"params.{name}", getattr(self, name))
        for name in ("beam_damping_s", "hook_stiffness_N_per_m", "hook_damping_N_s_per_m"):
            check_positive(f"params.{name}", getattr(self, name), allow_zero=True)
        check_range("params.hook_deploy_angle_rad", self.hook_deploy_angle_rad, 0.0, math.pi, unit=" rad")
        length = _concrete(self.length_m)
        if length is not None:
            check_range("params.hinge_height_m", self.hinge_height_m, 0.0, float(length), unit=" m")
            check_range(
                "params.engine_height_m", self.engine_height_m, 0.0, float(length), inclusive=True, unit=" m"
            )

    @property
    def hook_rotational_stiffness_N_m_per_rad(self):
        """``k_h l_h^2``: the hook spring as a torque about the hinge [N m/rad]."""
        return self.hook_stiffness_N_per_m * self.hook_length_m**2

    @property
    def hook_rotational_damping_N_m_s_per_rad(self):
        """``c_h l_h^2``: the hook damper as a torque about the hinge [N m s/rad]."""
        return self.hook_damping_N_s_per_m * self.hook_length_m**2


# ---------------------------------------------------------------------------------------------
# mass properties
# ---------------------------------------------------------------------------------------------


def _rod_inertia(mass, length, diameter, direction):
    """Solid rod about its CoM, axis ``direction`` (unit): slender-rod term plus thickness [kg m^2]."""
    nn = jnp.outer(direction, direction)
    transverse = mass * (diameter**2 / 16.0 + length**2 / 12.0)
    axial = mass * diameter**2 / 8.0
    return transverse * (jnp.eye(3) - nn) + axial * nn


def _combine(parts):
    """Total mass, CoM (3,) and inertia about it (3,3) of ``[(m, com (3,), J_com (3,3)), ...]``."""
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass
    inertia = sum(
        J + m * (jnp.dot(c - com, c - com) * jnp.eye(3) - jnp.outer(c - com, c - com)) for m, c, J in parts
    )
    return mass, com, inertia


def _hook_geometry(params, k):
    """Hook k in the rocket frame: hinge, tip, barb end (3,3), axis (3,), and its (m, com, J) parts."""
    e_k = jnp.asarray(_HOOK_DIRECTIONS[k])
    e_z = jnp.array([0.0, 0.0, 1.0])
    axis = jnp.cross(e_z, e_k)
    theta = params.hook_deploy_angle_rad
    arm_dir = jnp.sin(theta) * e_k + jnp.cos(theta) * e_z
    hinge = params.radius_m * e_k + params.hinge_height_m * e_z
    tip = hinge + params.hook_length_m * arm_dir
    barb_end = tip - params.hook_barb_m * e_z
    d = params.hook_diameter_m
    per_length = params.hook_mass_kg / (params.hook_length_m + params.hook_barb_m)
    m_arm, m_barb = per_length * params.hook_length_m, per_length * params.hook_barb_m
    parts = [
        (m_arm, 0.5 * (hinge + tip), _rod_inertia(m_arm, params.hook_length_m, d, arm_dir)),
        (m_barb, 0.5 * (tip + barb_end), _rod_inertia(m_barb, params.hook_barb_m, d, e_z)),
    ]
    return jnp.stack([hinge, tip, barb_end]), axis, parts


def _shell_segment(params, z_low, z_high):
    length = z_high - z_low
    mass = params.structure_mass_kg * length / params.length_m
    R2 = params.radius_m**2
    transverse = mass * (R2 / 2 + length**2 / 12)
    inertia = jnp.diag(jnp.stack([transverse, transverse, mass * R2]))
    return mass, jnp.array([0.0, 0.0, 1.0]) * 0.5 * (z_low + z_high), inertia


# ---------------------------------------------------------------------------------------------
# the rocket
# ---------------------------------------------------------------------------------------------


class LandingRocket(eqx.Module):
    """A landing rocket (rigid or flexible) with four hooks, behind one interface.

    Build it with :func:`rigid_landing_rocket` or :func:`flexible_landing_rocket`; ``system``,
    ``beams`` and the geometry arrays are derived from ``params`` there (rebuild to change masses,
    geometry or beam stiffness; the hook spring/damper are read from ``params`` at run time).
    """

    params: LandingRocketParams
    """Table 1 values and readings."""
    system: MultibodySystem
    """The rigid bodies (free bodies ``0 .. n_bodies-1``, bottom to top) and hook hinges."""
    beams: MasslessBeams
    """Massless beams between consecutive bodies (none for the rigid rocket)."""
    body_com_in_rocket_m: jax.Array
    """Free-body CoMs in the undeformed rocket frame (origin bottom centre), shape (nb, 3) [m]."""
    hook_points_local_m: jax.Array
    """Hinge, tip and barb end of each hook in its hook body's frame from that body's CoM, (4, 3, 3) [m]."""
    reference_local_m: jax.Array
    """``O`` (axis point at tip height) in the reference body's frame from its CoM, (3,) [m]."""
    reference_in_rocket_m: jax.Array
    """``O`` in the rocket frame (origin bottom centre), (3,) [m]."""
    head_local_m: jax.Array
    """Head (top centre) in the top body's frame from its CoM, (3,) [m]."""
    bottom_local_m: jax.Array
    """Bottom centre in the bottom body's frame from its CoM, (3,) [m]."""
    hinged_hooks: bool = eqx.field(static=True)
    """True: hooks are hinge children (4 DOFs); False: welded to their parent body."""
    hook_body: tuple[int, ...] = eqx.field(static=True)
    """Body index holding each hook's points (the hook itself, or its parent when welded)."""
    hook_parent_body: int = eqx.field(static=True)
    """Free body carrying the hooks (and the reference point ``O``)."""

    def __check_init__(self):
        if len(self.hook_body) != N_HOOKS:
            raise ValueError(f"hook_body must have {N_HOOKS} entries, got {self.hook_body!r}")
        if tuple(self.hook_points_local_m.shape) != (N_HOOKS, 3, 3):
            raise ValueError(
                f"hook_points_local_m must have shape (4, 3, 3), got {self.hook_points_local_m.shape}"
            )
        nb = self.system.n_free_bodies
        if tuple(self.body_com_in_rocket_m.shape) != (nb, 3):
            raise ValueError(
                f"body_com_in_rocket_m must have shape ({nb}, 3), got {self.body_com_in_rocket_m.shape}"
            )
        expected_hinges = N_HOOKS if self.hinged_hooks else 0
        if self.system.n_hinges != expected_hinges:
            raise ValueError(f"system must have {expected_hinges} hinges, got {self.system.n_hinges}")

    # -- structure -----------------------------------------------------------------------------

    @property
    def n_bodies(self) -> int:
        """Number of lumped rigid bodies of the rocket structure (1 for the rigid rocket)."""
        return self.system.n_free_bodies

    @property
    def head_body(self) -> int:
        return self.n_bodies - 1

    @property
    def bottom_body(self) -> int:
        return 0

    @property
    def total_mass_kg(self):
        """Rocket + hooks [kg]."""
        return jnp.sum(self.system.all_masses())

    def hook_modes(self):
        """Hook hinge mode about a fixed rocket: ``dict(inertia_about_hinge_kg_m2, natural_frequency_rad_s,
        damping_ratio, fast_time_constant_s)`` (``fast_time_constant`` = ``I / (c_h l_h^2)``)."""
        points, axis, parts = _hook_geometry(self.params, 0)
        mass, com, J = _combine(parts)
        arm = com - points[0]
        inertia = axis @ J @ axis + mass * (arm @ arm - (arm @ axis) ** 2)
        k = self.params.hook_rotational_stiffness_N_m_per_rad
        c = self.params.hook_rotational_damping_N_m_s_per_rad
        return dict(
            inertia_about_hinge_kg_m2=inertia,
            natural_frequency_rad_s=jnp.sqrt(k / inertia),
            damping_ratio=c / (2.0 * jnp.sqrt(k * inertia)),
            fast_time_constant_s=inertia / c,
        )

    # -- state ---------------------------------------------------------------------------------

    def initial_state(self, position_of_hook_plane_centre_m, velocity_m_s, rotation_vector_rad, omega_rad_s):
        """Undeformed rocket in a rigid motion (section IV's convention).

        Args:
            position_of_hook_plane_centre_m: (3,) world position of ``O`` (axis point in the tip plane) [m].
            velocity_m_s: (3,) world velocity of ``O`` [m/s].
            rotation_vector_rad: (3,) rotation vector taking the world axes to ``OXYZ`` [rad].
            omega_rad_s: (3,) angular velocity in world axes [rad/s].

        Hooks start at their deployed angle (``phi = 0``) at rest relative to the rocket.
        """
        origin = jnp.asarray(position_of_hook_plane_centre_m, dtype=float)
        velocity = jnp.asarray(velocity_m_s, dtype=float)
        omega = jnp.asarray(omega_rad_s, dtype=float)
        quat = quat_from_rotation_vector(jnp.asarray(rotation_vector_rad, dtype=float))
        R = quat_to_matrix(quat)
        arm = (self.body_com_in_rocket_m - self.reference_in_rocket_m) @ R.T
        nb, nh = self.n_bodies, self.system.n_hinges
        return MultibodyState(
            r=origin + arm,
            quat=jnp.broadcast_to(quat, (nb, 4)),
            v=velocity + jnp.cross(omega, arm),
            omega_body=jnp.broadcast_to(R.T @ omega, (nb, 3)),
            hinge_angle=jnp.zeros(nh),
            hinge_rate=jnp.zeros(nh),
        )

    def validate(self, state=None):
        """Raise ValueError on bad parameters (re-runs the checks) or a bad concrete ``state``."""
        for module in (self.params, self.system, self.beams, self):
            module.__check_init__()
        if state is None:
            return
        nb, nh = self.n_bodies, self.system.n_hinges
        shapes = dict(
            r=(nb, 3), quat=(nb, 4), v=(nb, 3), omega_body=(nb, 3), hinge_angle=(nh,), hinge_rate=(nh,)
        )
        for name, shape in shapes.items():
            value = getattr(state, name)
            if tuple(value.shape) != shape:
                raise ValueError(f"state.{name} must have shape {shape}, got {tuple(value.shape)}")
            check_finite(f"state.{name}", value)
        quat = _concrete(state.quat)
        if quat is not None:
            norm = np.linalg.norm(quat, axis=1)
            if np.any(np.abs(norm - 1.0) > 1e-3):
                raise ValueError(f"state.quat must have unit norm (within 1e-3), got norms {norm.tolist()}")

    # -- dynamics ------------------------------------------------------------------------------

    def hook_torques(self, state):
        """Spring-damper torques on the hinges, ``-k_h l_h^2 phi - c_h l_h^2 phi_dot`` (nh,) [N m]."""
        return (
            -self.params.hook_rotational_stiffness_N_m_per_rad * state.hinge_angle
            - self.params.hook_rotational_damping_N_m_s_per_rad * state.hinge_rate
        )

    def derivative(
        self,
        state,
        gravity_m_s2=GRAVITY_M_S2,
        hook_forces_N=None,
        hook_force_points_m=None,
        point_forces=(),
        body_torques_world_N_m=None,
        hinge_torques_N_m=None,
    ):
        """Time derivative of the rocket state (a :class:`MultibodyState`).

        Args:
            gravity_m_s2: (3,) uniform gravity [m/s^2].
            hook_forces_N: (4, P, 3) world forces on the hooks [N], or None.
            hook_force_points_m: (4, P, 3) their points in each hook body's frame from its CoM [m];
                default :attr:`hook_points_local_m` (P = 3: hinge, tip, barb end). World points convert
                with :meth:`hook_world_to_local`.
            point_forces: further ``(body_index, local_points, world_forces)`` loads (see
                :func:`jaxcable.components.multibody.generalized_forces`), e.g. aerodynamics.
            body_torques_world_N_m: (nb + nh, 3) torques about the bodies' CoMs [N m], or None.
            hinge_torques_N_m: (nh,) extra hinge torques (added to the spring-damper) [N m], or None.
        """
        loads = list(point_forces)
        if hook_forces_N is not None:
            points = self.hook_points_local_m if hook_force_points_m is None else hook_force_points_m
            loads.append((self.hook_body, points, hook_forces_N))
        hinge_torques = self.hook_torques(state)
        if hinge_torques_N_m is not None:
            hinge_torques = hinge_torques + hinge_torques_N_m
        return accelerations(
            self.system,
            state,
            point_forces=tuple(loads),
            body_torques_world=body_torques_world_N_m,
            hinge_torques=hinge_torques if self.hinged_hooks else None,
            gravity=jnp.asarray(gravity_m_s2),
            beams=self.beams,
        )

    # -- outputs -------------------------------------------------------------------------------

    def hook_points_world(self, state):
        """World positions and velocities of each hook's hinge, tip and barb end, each (4, 3, 3)."""
        return point_kinematics(self.system, state, self.hook_body, self.hook_points_local_m)

    def hook_world_to_local(self, state, world_points_m):
        """(4, P, 3) world points -> the hook bodies' local points (for ``hook_force_points_m``)."""
        return world_to_local(self.system, state, self.hook_body, world_points_m)

    def head_and_bottom_world(self, state):
        """World positions (2, 3) [m] and velocities (2, 3) [m/s] of the head (row 0) and bottom (row 1)."""
        points = jnp.stack([self.head_local_m, self.bottom_local_m])[:, None, :]
        x, v = point_kinematics(self.system, state, (self.head_body, self.bottom_body), points)
        return x[:, 0], v[:, 0]

    def reference_point(self, state):
        """World position (3,) [m] and velocity (3,) [m/s] of ``O`` (hook-plane centre)."""
        x, v = point_kinematics(self.system, state, self.hook_parent_body, self.reference_local_m[None])
        return x[0], v[0]

    def reference_acceleration(self, state, state_dot):
        """World acceleration (3,) of ``O`` [m/s^2]; ``state_dot`` from :meth:`derivative`."""
        point = self.reference_local_m[None]
        return point_acceleration(self.system, state, state_dot, self.hook_parent_body, point)[0]

    def reference_attitude(self, state):
        """Rotation vector (3,) [rad] of the hooks' parent body (``OXYZ``), world angular velocity (3,)."""
        _, quat, R = body_poses(self.system, state)
        b = self.hook_parent_body
        return rotation_vector_from_quat(quat[b]), R[b] @ state.omega_body[b]

    def dissipation_power(self, state):
        """Power dissipated by the hook dampers and the beams' Rayleigh damping [W] (>= 0)."""
        hooks = jnp.sum(self.params.hook_rotational_damping_N_m_s_per_rad * state.hinge_rate**2)
        return hooks + beam_dissipation_power(self.system, self.beams, state)

    def energies(self, state, gravity_m_s2=GRAVITY_M_S2):
        """``dict(kinetic, gravitational, elastic, total)`` [J]; elastic = beams + hook springs."""
        kinetic = kinetic_energy(self.system, state)
        gravitational = potential_energy(self.system, state, jnp.asarray(gravity_m_s2))
        elastic = beam_energy(self.system, self.beams, state) + 0.5 * jnp.sum(
            self.params.hook_rotational_stiffness_N_m_per_rad * state.hinge_angle**2
        )
        total = kinetic + gravitational + elastic
        return dict(kinetic=kinetic, gravitational=gravitational, elastic=elastic, total=total)


# ---------------------------------------------------------------------------------------------
# builders
# ---------------------------------------------------------------------------------------------


def _default_hook_parent(params, n_bodies):
    length, hinge = _concrete(params.length_m), _concrete(params.hinge_height_m)
    if length is None or hinge is None:
        raise ValueError("hook_parent_body must be given when params.length_m/hinge_height_m are traced")
    return min(int(np.floor(float(hinge) * n_bodies / float(length))), n_bodies - 1)


def _build(params, n_bodies, hinged_hooks, hook_parent_body, quat_stabilisation_per_s):
    params = LandingRocketParams() if params is None else params
    if not (isinstance(n_bodies, int) and n_bodies >= 1):
        raise ValueError(f"n_bodies must be an integer >= 1, got {n_bodies!r}")
    parent = _default_hook_parent(params, n_bodies) if hook_parent_body is None else int(hook_parent_body)
    if not 0 <= parent < n_bodies:
        raise ValueError(f"hook_parent_body must be in [0, {n_bodies}), got {parent}")

    hooks = [_hook_geometry(params, k) for k in range(N_HOOKS)]
    hook_mass_props = [_combine(parts) for _, _, parts in hooks]
    e_z = jnp.array([0.0, 0.0, 1.0])
    boundaries = [params.length_m * i / n_bodies for i in range(n_bodies + 1)]
    engine = (
        params.engine_mass_kg,
        params.engine_height_m * e_z,
        jnp.diag(
            jnp.stack(
                [
                    params.engine_inertia_transverse_kg_m2,
                    params.engine_inertia_transverse_kg_m2,
                    params.engine_inertia_axial_kg_m2,
                ]
            )
        ),
    )
    masses, coms, inertias = [], [], []
    for i in range(n_bodies):
        parts = [_shell_segment(params, boundaries[i], boundaries[i + 1])]
        if i == 0:
            parts.append(engine)
        if i == parent and not hinged_hooks:
            parts.extend(hook_mass_props)
        m, c, J = _combine(parts)
        masses.append(m)
        coms.append(c)
        inertias.append(J)
    coms = jnp.stack(coms)

    hinge_kw = {}
    if hinged_hooks:
        hinge_kw = dict(
            hinge_parent=(parent,) * N_HOOKS,
            hinge_joint_in_parent_m=jnp.stack([points[0] - coms[parent] for points, _, _ in hooks]),
            hinge_axis_in_parent=jnp.stack([axis for _, axis, _ in hooks]),
            hinge_child_com_from_joint_m=jnp.stack(
                [c - points[0] for (points, _, _), (_, c, _) in zip(hooks, hook_mass_props)]
            ),
            hinge_child_mass_kg=jnp.stack([m for m, _, _ in hook_mass_props]),
            hinge_child_inertia_kg_m2=jnp.stack([J for _, _, J in hook_mass_props]),
        )
        hook_body = tuple(n_bodies + k for k in range(N_HOOKS))
        hook_points = jnp.stack([points - c for (points, _, _), (_, c, _) in zip(hooks, hook_mass_props)])
    else:
        hook_body = (parent,) * N_HOOKS
        hook_points = jnp.stack([points - coms[parent] for points, _, _ in hooks])
    system = MultibodySystem(
        body_mass_kg=jnp.stack(masses),
        body_inertia_kg_m2=jnp.stack(inertias),
        quat_stabilisation_per_s=quat_stabilisation_per_s,
        **hinge_kw,
    )

    centres = jnp.stack([0.5 * (boundaries[i] + boundaries[i + 1]) * e_z for i in range(n_bodies)])
    n_beams = n_bodies - 1
    ones = jnp.ones(n_beams)
    beams = MasslessBeams(
        body_a=tuple(range(n_beams)),
        body_b=tuple(range(1, n_bodies)),
        attach_a_m=(centres - coms)[:-1].reshape(n_beams, 3),
        attach_b_m=(centres - coms)[1:].reshape(n_beams, 3),
        length_m=(centres[1:, 2] - centres[:-1, 2]).reshape(n_beams),
        EA_N=params.EA_N * ones,
        EJ_N_m2=params.EJ_N_m2 * ones,
        GJ_N_m2=params.GJ_N_m2 * ones,
        damping_s=params.beam_damping_s,
    )
    reference = (params.hinge_height_m + params.hook_length_m * jnp.cos(params.hook_deploy_angle_rad)) * e_z
    return LandingRocket(
        params=params,
        system=system,
        beams=beams,
        body_com_in_rocket_m=coms,
        hook_points_local_m=hook_points,
        reference_local_m=reference - coms[parent],
        reference_in_rocket_m=reference,
        head_local_m=params.length_m * e_z - coms[-1],
        bottom_local_m=-coms[0],
        hinged_hooks=bool(hinged_hooks),
        hook_body=hook_body,
        hook_parent_body=parent,
    )


def rigid_landing_rocket(hinged_hooks=True, params=None, quat_stabilisation_per_s=1.0):
    """The rocket as one rigid body (25 t, CoM 10 m above the bottom) with four hooks.

    ``hinged_hooks=False`` welds the hooks to the body (no hinge DOFs; their mass is added to it).
    """
    return _build(params, 1, hinged_hooks, 0, quat_stabilisation_per_s)


def flexible_landing_rocket(
    n_bodies=5, hinged_hooks=True, params=None, hook_parent_body=None, quat_stabilisation_per_s=1.0
):
    """The rocket as ``n_bodies`` lumped rigid bodies joined by ``n_bodies - 1`` massless beams.

    The hooks' parent is the segment containing the hinge height (``hook_parent_body`` overrides).
    ``n_bodies = 1`` is the rigid rocket.
    """
    return _build(params, n_bodies, hinged_hooks, hook_parent_body, quat_stabilisation_per_s)
