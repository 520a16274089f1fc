"""Tests of the Kane/autodiff multibody engine and the landing rocket (paper Sec. III.C, eqs 35-41).

Tiers: conservation (torque-free body, free-falling and spinning flexible rocket), closed forms
(hook pendulum period, cantilever deflection/rotation/axial/torsion, axial two-body frequency,
quaternion-norm stabilisation), cross-model agreement (rigid vs flexible rocket), consistency of the
autodiff pieces (virtual power), bad input, and a gradient against central finite differences.

Time integration is a classical RK4 written here (a nested ``lax.scan`` so the vector field is
compiled once); step sizes are stated per test.
"""

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from jaxcable.components import multibody as mb  # noqa: E402
from jaxcable.arresting.landing_rocket import (  # noqa: E402
    LandingRocketParams,
    flexible_landing_rocket,
    rigid_landing_rocket,
)

G = 9.81
GRAVITY = jnp.array([0.0, 0.0, -G])
UNDAMPED = LandingRocketParams(hook_damping_N_s_per_m=0.0, beam_damping_s=0.0)


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------


def _axpy(a, x, y):
    return jax.tree.map(lambda xi, yi: yi + a * xi, x, y)


def rk4_step(f, y, dt):
    """One classical RK4 step; the four stages run in a scan so ``f`` is traced once."""

    def stage(carry, coeffs):
        k_prev, acc = carry
        a, b = coeffs
        k = f(_axpy(a * dt, k_prev, y))
        return (k, _axpy(b, k, acc)), None

    zero = jax.tree.map(jnp.zeros_like, y)
    coeffs = (jnp.array([0.0, 0.5, 0.5, 1.0]), jnp.array([1.0, 2.0, 2.0, 1.0]) / 6.0)
    (_, acc), _ = jax.lax.scan(stage, (zero, zero), coeffs)
    return _axpy(dt, acc, y)


def integrate(f, y0, dt, n_steps, output):
    """RK4 from ``y0``: ``(final state, stacked output(y) after every step)``."""

    def step(y, _):
        y = rk4_step(f, y, dt)
        return y, output(y)

    return jax.lax.scan(step, y0, None, length=n_steps)


def single_body_state(r, quat, v, omega_body, n_hinges=0):
    return mb.MultibodyState(
        r=jnp.asarray(r, float)[None],
        quat=jnp.asarray(quat, float)[None],
        v=jnp.asarray(v, float)[None],
        omega_body=jnp.asarray(omega_body, float)[None],
        hinge_angle=jnp.zeros(n_hinges),
        hinge_rate=jnp.zeros(n_hinges),
    )


N_FLY = 1000  # one step count for every rocket flight: one compilation per rocket structure


def fly(rocket, state, hook_forces, gravity, dt):
    """RK4 flight, ``N_FLY`` steps of ``dt``, under constant world forces (4, 3, 3) at the hook points."""
    return _fly(rocket, state, jnp.asarray(hook_forces), jnp.asarray(gravity), jnp.asarray(dt))


@eqx.filter_jit
def _fly(rocket, state, hook_forces, gravity, dt):

    def output(s):
        energies = rocket.energies(s, gravity)
        tips, _ = rocket.hook_points_world(s)
        deformation = mb.beam_deformations(rocket.system, rocket.beams, s)
        return dict(
            dissipation=rocket.dissipation_power(s),
            total=energies["total"],
            kinetic=energies["kinetic"],
            elastic=energies["elastic"],
            tips=tips[:, 1],
            reference=rocket.reference_point(s)[0],
            max_strain_m=jnp.max(jnp.abs(deformation[:, :3]), initial=0.0),
            max_strain_rad=jnp.max(jnp.abs(deformation[:, 3:]), initial=0.0),
            quat_norm_error=jnp.max(jnp.abs(jnp.linalg.norm(s.quat, axis=1) - 1.0)),
        )

    return integrate(lambda s: rocket.derivative(s, gravity, hook_forces), state, dt, N_FLY, output)


def _tilted_state(rocket, omega=(0.0, 0.0, 0.0)):
    return rocket.initial_state(
        jnp.array([1.0, -2.0, 30.0]),
        jnp.array([0.8, -0.5, -20.0]),
        jnp.array([0.06, -0.04, 0.3]),
        jnp.asarray(omega, float),
    )


# ---------------------------------------------------------------------------------------------
# consistency of the autodiff pieces (virtual power)
# ---------------------------------------------------------------------------------------------


def _perturbed_flexible_state(rocket):
    """A rigid motion plus random mm/mrad deformations, hook angles and rates, body velocities."""
    keys = jax.random.split(jax.random.PRNGKey(0), 5)
    s = _tilted_state(rocket, omega=(0.2, -0.1, 0.4))
    twist = mb.quat_from_rotation_vector(1e-3 * jax.random.normal(keys[1], (rocket.n_bodies, 3)))
    return eqx.tree_at(
        lambda s: (s.r, s.quat, s.hinge_angle, s.hinge_rate, s.v),
        s,
        (
            s.r + 1e-3 * jax.random.normal(keys[0], s.r.shape),
            mb.quat_multiply(s.quat, twist),
            0.1 * jax.random.normal(keys[2], (4,)),
            jax.random.normal(keys[3], (4,)),
            s.v + 0.1 * jax.random.normal(keys[4], s.v.shape),
        ),
    )


@eqx.filter_jit
def _virtual_power_terms(rocket, s):
    hook_forces = 100.0 * jax.random.normal(jax.random.PRNGKey(1), (4, 3, 3))
    torques = 10.0 * jax.random.normal(jax.random.PRNGKey(2), (rocket.system.n_bodies, 3))
    loads = [
        (rocket.hook_body, rocket.hook_points_local_m, hook_forces),
        (2, jnp.ones((2, 3)), jnp.ones((2, 3))),
    ]
    system, beams = rocket.system, rocket.beams
    ds = mb.accelerations(system, s, loads, torques, rocket.hook_torques(s), GRAVITY, beams=beams)
    Q_loads = mb.generalized_forces(system, s, loads, torques, rocket.hook_torques(s), GRAVITY)
    Q_beams = mb.beam_generalized_force(system, beams, s)
    _, T_dot = jax.jvp(lambda s_: mb.kinetic_energy(system, s_), (s,), (ds,))
    Q_energy = mb.generalized_force_from_energy(system, s, lambda s_: mb.beam_energy(system, beams, s_))
    q, u = (s.r, s.quat, s.hinge_angle), mb.speeds(s)
    bias = mb._bias_accelerations(system, mb.body_poses(system, s), u)
    bias_autodiff = mb._bias_accelerations_autodiff(system, q, u)
    # acceleration of O: rigid-body formula on its parent vs the jvp in reference_acceleration
    b = rocket.hook_parent_body
    com, _, R = mb.body_poses(system, s)
    arm = R[b] @ rocket.reference_local_m
    omega, alpha = R[b] @ s.omega_body[b], R[b] @ ds.omega_body[b]
    a_formula = ds.v[b] + jnp.cross(alpha, arm) + jnp.cross(omega, jnp.cross(omega, arm))
    a_reference = (rocket.reference_acceleration(s, ds), a_formula)
    return T_dot, Q_loads, Q_beams, Q_energy, bias, bias_autodiff, a_reference


def test_virtual_power_identities():
    """Kane terms: bias = jvp; dT/dt = Q_active . u (wrench path = vjp path); beam force = -K^T grad V."""
    rocket = flexible_landing_rocket(5, params=LandingRocketParams(beam_damping_s=1e-3))
    s = _perturbed_flexible_state(rocket)
    u = mb.speeds(s)
    T_dot, Q_loads, Q_beams, _, bias, bias_autodiff, (a_jvp, a_formula) = _virtual_power_terms(rocket, s)
    np.testing.assert_allclose(a_jvp, a_formula, rtol=1e-12)
    undamped = flexible_landing_rocket(5, params=LandingRocketParams(beam_damping_s=0.0))
    _, _, Q_elastic, Q_energy, _, _, _ = _virtual_power_terms(undamped, s)  # same compiled program
    # closed-form velocity-product accelerations = jax.jvp of the velocity map along q_dot
    for closed, autodiff in zip(bias, bias_autodiff):
        np.testing.assert_allclose(closed, autodiff, atol=1e-13 * float(jnp.max(jnp.abs(autodiff))))
        assert float(jnp.max(jnp.abs(autodiff))) > 0.1
    # Power balance: dT/dt along the computed motion equals the power of all active forces
    # (accelerations() reduces loads to body wrenches; generalized_forces() is the vjp reference).
    power = (Q_loads + Q_beams) @ u
    assert abs(T_dot - power) <= 1e-10 * (abs(power) + jnp.max(jnp.abs(Q_loads * u)))
    # Elastic part of the beam force = -K^T grad V by the generic energy helper.
    np.testing.assert_allclose(Q_elastic, Q_energy, atol=1e-12 * float(jnp.max(jnp.abs(Q_energy))))
    # Stiffness-proportional damping dissipates.
    assert (Q_beams - Q_elastic) @ u < 0.0


def test_quaternion_helpers():
    rv = jnp.array([0.3, -1.1, 0.7])
    q = mb.quat_from_rotation_vector(rv)
    np.testing.assert_allclose(mb.rotation_vector_from_quat(q), rv, rtol=1e-14)
    np.testing.assert_allclose(mb.rotation_vector_from_quat(-q), rv, rtol=1e-14)
    R = mb.quat_to_matrix(q)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    # Rodrigues' formula
    angle, axis = np.linalg.norm(rv), np.asarray(rv) / np.linalg.norm(rv)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    np.testing.assert_allclose(R, np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K, atol=1e-15)
    # composition: q(a) (x) q(b) about the same axis is q(a + b)
    np.testing.assert_allclose(mb.quat_multiply(q, q), mb.quat_from_rotation_vector(2 * rv), atol=1e-15)
    # gradient-safe at zero: d rotvec(quat(x))/dx = I at x = 0, finite everywhere
    J = jax.jacfwd(lambda x: mb.rotation_vector_from_quat(mb.quat_from_rotation_vector(x)))(jnp.zeros(3))
    np.testing.assert_allclose(J, np.eye(3), atol=1e-15)
    assert np.all(np.isfinite(jax.grad(lambda x: jnp.sum(mb.quat_from_rotation_vector(x)))(jnp.zeros(3))))


# ---------------------------------------------------------------------------------------------
# conservation: torque-free rigid body
# ---------------------------------------------------------------------------------------------


def _asymmetric_body(k_stab):
    rotation = mb.quat_to_matrix(mb.quat_from_rotation_vector(jnp.array([0.4, -0.3, 0.2])))
    inertia = rotation @ jnp.diag(jnp.array([1.0, 2.0, 3.0])) @ rotation.T
    return mb.MultibodySystem(
        body_mass_kg=[2.0], body_inertia_kg_m2=inertia[None], quat_stabilisation_per_s=k_stab
    )


@eqx.filter_jit
def _free_body_run(system, state, dt, n_steps):
    def output(s):
        _, L = mb.momentum(system, s)
        return mb.kinetic_energy(system, s), L, jnp.sum(s.quat[0] ** 2), s.omega_body[0]

    return integrate(lambda s: mb.accelerations(system, s), state, dt, n_steps, output)


def test_torque_free_asymmetric_body_conserves_energy_and_momentum():
    """Tumbling near the intermediate axis (the body flips) for 20 s, RK4 dt = 2 ms (10^4 steps)."""
    system = _asymmetric_body(1.0)
    R0 = mb.quat_to_matrix(mb.quat_from_rotation_vector(jnp.array([0.4, -0.3, 0.2])))  # principal axes
    omega_body = R0 @ jnp.array([0.05, 1.2, 0.05])  # near the intermediate axis
    attitude = mb.quat_from_rotation_vector(jnp.array([0.1, 0.2, -0.3]))
    state = single_body_state([1.0, 2.0, 3.0], attitude, [0.3, -0.2, 0.1], omega_body)
    T0 = mb.kinetic_energy(system, state)
    _, L0 = mb.momentum(system, state)
    _, (T, L, norm_sq, omega) = _free_body_run(system, state, jnp.asarray(2e-3), 10_000)
    assert np.max(np.abs(T / T0 - 1.0)) < 1e-8
    assert np.max(np.linalg.norm(L - L0, axis=1)) / np.linalg.norm(L0) < 1e-8
    assert np.max(np.abs(np.sqrt(norm_sq) - 1.0)) < 1e-12
    # the body does flip: the body-frame spin about the intermediate axis reverses
    assert np.min(np.asarray(omega) @ np.asarray(R0)[:, 1]) < -1.0

    # Without stabilisation the norm only drifts by the RK4 error (measured ~1e-15 here).
    _, (_, _, norm_sq0, _) = _free_body_run(_asymmetric_body(0.0), state, jnp.asarray(2e-3), 10_000)
    assert np.max(np.abs(np.sqrt(norm_sq0) - 1.0)) < 1e-12


def test_quaternion_norm_stabilisation_is_logistic_and_harmless():
    """|q|^2 = x obeys dx/dt = 2 k x (1 - x): x(t) = 1 / (1 + (1/x0 - 1) e^{-2kt}); physics unchanged."""
    k = 2.0
    system = _asymmetric_body(k)
    q_unit = mb.quat_from_rotation_vector(jnp.array([0.1, 0.2, -0.3]))
    base = single_body_state([0.0, 0.0, 0.0], q_unit, [0.0, 0.0, 0.0], [0.3, 1.0, -0.4])
    scaled = eqx.tree_at(lambda s: s.quat, base, 1.05 * base.quat)
    dt, n = 1e-3, 10_000
    final_unit, (T1, L1, _, _) = _free_body_run(system, base, jnp.asarray(dt), n)
    final_scaled, (T2, L2, x, _) = _free_body_run(system, scaled, jnp.asarray(dt), n)
    t = dt * np.arange(1, n + 1)
    x0 = 1.05**2
    np.testing.assert_allclose(x, 1.0 / (1.0 + (1.0 / x0 - 1.0) * np.exp(-2 * k * t)), rtol=1e-9)
    np.testing.assert_allclose(T2, T1, rtol=1e-12)
    np.testing.assert_allclose(L2, L1, rtol=1e-10, atol=1e-12)
    R_unit = mb.body_poses(system, final_unit)[2]
    R_scaled = mb.body_poses(system, final_scaled)[2]
    np.testing.assert_allclose(R_scaled, R_unit, atol=1e-10)


# ---------------------------------------------------------------------------------------------
# closed form: hook on a (very heavy) fixed parent
# ---------------------------------------------------------------------------------------------


def _hook_on_heavy_parent():
    rocket = rigid_landing_rocket(hinged_hooks=True)
    s = rocket.system
    heavy = 1e12  # the hook's reaction moves it by ~45/1e12: a fixed hinge to 1e-10
    system = mb.MultibodySystem(
        body_mass_kg=[heavy],
        body_inertia_kg_m2=[heavy * np.eye(3)],
        hinge_parent=(0,),
        hinge_joint_in_parent_m=np.zeros((1, 3)),
        hinge_axis_in_parent=s.hinge_axis_in_parent[:1],
        hinge_child_com_from_joint_m=s.hinge_child_com_from_joint_m[:1],
        hinge_child_mass_kg=s.hinge_child_mass_kg[:1],
        hinge_child_inertia_kg_m2=s.hinge_child_inertia_kg_m2[:1],
    )
    return rocket, system


@eqx.filter_jit
def _pendulum_run(system, phi0, k_rot, dt, n_steps):
    support = -jnp.sum(system.all_masses()) * GRAVITY  # holds the heavy parent against gravity

    def field(s):
        loads = [(0, jnp.zeros((1, 3)), support[None])]
        return mb.accelerations(system, s, loads, hinge_torques=-k_rot * s.hinge_angle, gravity=GRAVITY)

    at_rest = single_body_state(jnp.zeros(3), [1.0, 0.0, 0.0, 0.0], jnp.zeros(3), jnp.zeros(3), n_hinges=1)
    state = eqx.tree_at(lambda s: s.hinge_angle, at_rest, jnp.atleast_1d(phi0))
    return integrate(field, state, dt, n_steps, lambda s: s.hinge_angle[0])


def _upward_crossings(t, y):
    i = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


@pytest.mark.parametrize("spring", ["paper_spring", "no_spring"])
def test_hook_pendulum_period(spring):
    """Small oscillation of a hinged hook about its equilibrium: T = 2 pi sqrt(I_hinge / U'')."""
    rocket, system = _hook_on_heavy_parent()
    k = float(rocket.params.hook_rotational_stiffness_N_m_per_rad) if spring == "paper_spring" else 0.0
    m = float(system.hinge_child_mass_kg[0])
    c = np.asarray(system.hinge_child_com_from_joint_m[0])
    axis = np.asarray(system.hinge_axis_in_parent[0])
    J = np.asarray(system.hinge_child_inertia_kg_m2[0])
    assert np.allclose(axis, [0.0, 1.0, 0.0]) and abs(c[1]) < 1e-15  # hook 0: hinge axis +y
    # U(phi) = k phi^2 / 2 + m g z(phi), z = -c_x sin(phi) + c_z cos(phi)
    phi = np.arctan2(c[0], -c[2]) if k == 0.0 else 0.0
    for _ in range(50):
        dU = k * phi - m * G * (c[0] * np.cos(phi) + c[2] * np.sin(phi))
        d2U = k + m * G * (c[0] * np.sin(phi) - c[2] * np.cos(phi))
        phi -= dU / d2U
    inertia = axis @ J @ axis + m * (c @ c - (c @ axis) ** 2)
    period = 2 * np.pi * np.sqrt(inertia / d2U)

    amplitude, n = 1e-3, 1500
    dt = 3 * period / n  # 500 steps per period
    phis = _pendulum_run(system, jnp.asarray(phi + amplitude), jnp.asarray(k), jnp.asarray(dt), n)[1]
    crossings = _upward_crossings(dt * np.arange(1, n + 1), np.asarray(phis) - phi)
    measured = np.mean(np.diff(crossings))
    assert len(crossings) >= 2
    assert abs(measured / period - 1.0) < 1e-7, (measured, period)


# ---------------------------------------------------------------------------------------------
# closed form: the massless beam
# ---------------------------------------------------------------------------------------------


@eqx.filter_jit
def _cantilever_solve_jit(rocket, tip_force, tip_moment):
    """Statics of the 5-body rocket chain clamped at body 0 (no gravity), by Newton on Q = 0."""
    system, beams = rocket.system, rocket.beams
    base = rocket.initial_state(jnp.zeros(3), jnp.zeros(3), jnp.zeros(3), jnp.zeros(3))
    top, top_node = rocket.n_bodies - 1, beams.attach_b_m[-1]
    free_v = np.arange(3, 3 * rocket.n_bodies)
    free_w = 3 * rocket.n_bodies + np.arange(3, 3 * rocket.n_bodies)

    def state_of(x):
        x = x.reshape(rocket.n_bodies - 1, 6)
        r = base.r.at[1:].add(x[:, :3])
        quat = base.quat.at[1:].set(mb.quat_multiply(base.quat[1:], mb.quat_from_rotation_vector(x[:, 3:])))
        return eqx.tree_at(lambda s: (s.r, s.quat), base, (r, quat))

    def residual(x):
        s = state_of(x)
        torques = jnp.zeros((rocket.n_bodies, 3)).at[top].set(tip_moment)
        tip_load = [(top, top_node[None], tip_force[None])]
        Q = mb.beam_generalized_force(system, beams, s) + mb.generalized_forces(system, s, tip_load, torques)
        return jnp.concatenate([Q[free_v], Q[free_w]])

    # Chord Newton: the tangent stiffness at the undeformed state, reused (the problem is linear to
    # ~1e-5 here, so each iteration gains ~5 digits).
    x = jnp.zeros(6 * (rocket.n_bodies - 1))
    stiffness = jax.jacfwd(residual)(x)
    x = jax.lax.fori_loop(0, 5, lambda _, x: x - jnp.linalg.solve(stiffness, residual(x)), x)
    s = state_of(x)
    node, _ = mb.point_kinematics(system, s, top, top_node[None])
    rotation = mb.rotation_vector_from_quat(s.quat[top])
    return node[0] - (base.r[top] + top_node), rotation, jnp.max(jnp.abs(residual(x)))


def test_cantilever_tip_deflection_and_rotation():
    """Nodally exact Euler-Bernoulli chain: tip node 32 m from the clamp node (5 bodies of 8 m)."""
    p = LandingRocketParams()
    EJ, EA, GJ = float(p.EJ_N_m2), float(p.EA_N), float(p.GJ_N_m2)
    L = 32.0
    P, M = 150.0, 2.0e3  # deflections ~0.3 mm: geometric nonlinearity ~1e-10 relative
    zero = jnp.zeros(3)
    chain = flexible_landing_rocket(5, hinged_hooks=False)

    def _cantilever_solve(force, moment):
        return _cantilever_solve_jit(chain, force, moment)

    disp, rot, res = _cantilever_solve(jnp.array([P, 0.0, 0.0]), zero)
    assert res < 1e-8 * P * L  # round-off of ~1e5 N internal forces
    np.testing.assert_allclose(disp[0], P * L**3 / (3 * EJ), rtol=1e-7)
    np.testing.assert_allclose(rot[1], P * L**2 / (2 * EJ), rtol=1e-7)  # slope: +x tip load turns about +y
    disp, rot, _ = _cantilever_solve(jnp.array([0.0, P, 0.0]), zero)
    np.testing.assert_allclose(disp[1], P * L**3 / (3 * EJ), rtol=1e-7)
    np.testing.assert_allclose(rot[0], -P * L**2 / (2 * EJ), rtol=1e-7)
    disp, rot, _ = _cantilever_solve(zero, jnp.array([0.0, M, 0.0]))  # end moment
    np.testing.assert_allclose(disp[0], M * L**2 / (2 * EJ), rtol=1e-7)
    np.testing.assert_allclose(rot[1], M * L / EJ, rtol=1e-7)
    disp, _, _ = _cantilever_solve(jnp.array([0.0, 0.0, 1e4]), zero)  # axial
    np.testing.assert_allclose(disp[2], 1e4 * L / EA, rtol=1e-7)
    _, rot, _ = _cantilever_solve(zero, jnp.array([0.0, 0.0, M]))  # torsion
    np.testing.assert_allclose(rot[2], M * L / GJ, rtol=1e-7)


def test_two_body_axial_oscillation():
    """Two bodies on one beam: relative stretch d0 cos(w t), w = sqrt(EA/L (m1+m2)/(m1 m2))."""
    m1, m2, L, EA = 3000.0, 1000.0, 8.0, 2.63e9
    system = mb.MultibodySystem(
        body_mass_kg=[m1, m2], body_inertia_kg_m2=[np.diag([1e4, 2e4, 3e3]), np.diag([5e3, 4e3, 1e3])]
    )
    beams = mb.MasslessBeams(
        body_a=(0,), body_b=(1,), attach_a_m=[[0.0, 0.0, 0.5]], attach_b_m=[[0.0, 0.0, -0.5]],
        length_m=[L - 1.0], EA_N=[EA], EJ_N_m2=[5.24e9], GJ_N_m2=[4e9],
    )  # fmt: skip
    d0 = 1e-4
    state = mb.MultibodyState(
        r=jnp.array([[0.0, 0.0, -m2 / (m1 + m2) * d0], [0.0, 0.0, L + m1 / (m1 + m2) * d0]]),
        quat=jnp.array([[1.0, 0.0, 0.0, 0.0]] * 2),
        v=jnp.zeros((2, 3)),
        omega_body=jnp.zeros((2, 3)),
        hinge_angle=jnp.zeros(0),
        hinge_rate=jnp.zeros(0),
    )
    omega = np.sqrt(EA / (L - 1.0) * (m1 + m2) / (m1 * m2))
    n, dt = 400, 2 * (2 * np.pi / omega) / 400
    _, (stretch, lateral, energy) = jax.jit(
        lambda s: integrate(
            lambda s_: mb.accelerations(system, s_, beams=beams),
            s,
            dt,
            n,
            lambda s_: (
                mb.beam_deformations(system, beams, s_)[0, 2],
                jnp.max(jnp.abs(mb.beam_deformations(system, beams, s_)[0, jnp.array([0, 1, 3, 4, 5])])),
                mb.kinetic_energy(system, s_) + mb.beam_energy(system, beams, s_),
            ),
        )
    )(state)
    t = dt * np.arange(1, n + 1)
    np.testing.assert_allclose(stretch, d0 * np.cos(omega * t), atol=1e-6 * d0)
    assert np.max(lateral) < 1e-15
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 1e-6


# slow tier: 45-55 s on 2 cores (the Kane path's tangents compiled); the default tier keeps the
# free-body path against closed forms (the torque-free body, the free fall of the flexible rocket)
@pytest.mark.slow
def test_free_body_path_equals_kane_path():
    """Without hinges ``accelerations`` takes a Newton-Euler shortcut (block-diagonal constant M);
    it must give the general Kane path's accelerations and their tangents, for two free bodies on a
    beam with point loads, body torques, gravity, a generalised force and non-unit quaternions."""
    system = mb.MultibodySystem(
        body_mass_kg=[3000.0, 1000.0],
        body_inertia_kg_m2=[[[1e4, 200.0, -50.0], [200.0, 2e4, 30.0], [-50.0, 30.0, 3e3]], np.diag([5e3, 4e3, 1e3])],
    )
    beams = mb.MasslessBeams(
        body_a=(0,), body_b=(1,), attach_a_m=[[0.0, 0.0, 0.5]], attach_b_m=[[0.0, 0.0, -0.5]],
        length_m=[7.0], EA_N=[2.63e9], EJ_N_m2=[5.24e9], GJ_N_m2=[4e9], damping_s=[1e-3],
    )  # fmt: skip
    k = jax.random.split(jax.random.PRNGKey(3), 8)
    state = mb.MultibodyState(
        r=jnp.array([[0.0, 0.0, 0.0], [0.0, 0.0, 8.0]]) + 1e-3 * jax.random.normal(k[0], (2, 3)),
        quat=jnp.array([[1.0, 0.0, 0.0, 0.0]] * 2) * 1.02 + 1e-3 * jax.random.normal(k[1], (2, 4)),
        v=jax.random.normal(k[2], (2, 3)),
        omega_body=jax.random.normal(k[3], (2, 3)),
        hinge_angle=jnp.zeros(0),
        hinge_rate=jnp.zeros(0),
    )
    loads = (((0, 1), jnp.ones((2, 3, 3)), 1e4 * jax.random.normal(k[4], (2, 3, 3))),)
    extra = dict(body_torques_world=1e3 * jax.random.normal(k[5], (2, 3)), gravity=GRAVITY, beams=beams,
                 generalized_force=1e3 * jax.random.normal(k[6], (12,)))  # fmt: skip

    def args(s):
        return (system, s, loads, extra["body_torques_world"], None, GRAVITY, beams, extra["generalized_force"])

    tangent = jax.tree.map(lambda x: jax.random.normal(k[7], x.shape), state)
    fast = jax.jvp(lambda s: mb._free_body_accelerations(*args(s)), (state,), (tangent,))
    kane = jax.jvp(lambda s: mb._kane_accelerations(*args(s)), (state,), (tangent,))
    public = mb.accelerations(system, state, point_forces=loads, **extra)
    for a, b, c in zip(jax.tree.leaves(fast), jax.tree.leaves(kane), jax.tree.leaves((public, fast[1]))):
        if np.size(a) == 0:  # the hinge rows
            continue
        scale = np.max(np.abs(b)) + 1e-300
        assert np.max(np.abs(np.asarray(a) - np.asarray(b))) < 1e-12 * scale
        np.testing.assert_array_equal(c, a)


# ---------------------------------------------------------------------------------------------
# the landing rocket
# ---------------------------------------------------------------------------------------------


def test_rocket_mass_properties_and_geometry():
    """25 t + 4 x 45 kg hooks, CoM 10 m above the bottom (L_c = 30 m), tips at r = 5.03 m."""
    rigid = rigid_landing_rocket(hinged_hooks=False)
    np.testing.assert_allclose(rigid.total_mass_kg, 25_180.0)
    flexible = flexible_landing_rocket(5, hinged_hooks=True)
    assert flexible.hook_parent_body == 2 and flexible.system.n_speeds == 34
    rigid_hinged = rigid_landing_rocket(hinged_hooks=True)
    np.testing.assert_allclose(rigid_hinged.body_com_in_rocket_m[0], [0.0, 0.0, 10.0], atol=1e-12)
    # all bodies together (rigid) == the rigid rocket: mass, CoM, inertia about the common CoM
    com = jnp.sum(flexible.system.body_mass_kg[:, None] * flexible.body_com_in_rocket_m, 0) / 25e3
    np.testing.assert_allclose(com, [0.0, 0.0, 10.0], atol=1e-12)
    d = flexible.body_com_in_rocket_m - com
    parallel_axis = jnp.sum(d * d, 1)[:, None, None] * jnp.eye(3) - d[:, :, None] * d[:, None, :]
    inertia = jnp.sum(
        flexible.system.body_inertia_kg_m2 + flexible.system.body_mass_kg[:, None, None] * parallel_axis, 0
    )
    np.testing.assert_allclose(inertia, rigid_hinged.system.body_inertia_kg_m2[0], rtol=1e-13)

    @eqx.filter_jit
    def geometry(rocket):
        state = rocket.initial_state(jnp.array([0.0, 0.0, 50.0]), jnp.zeros(3), jnp.zeros(3), jnp.zeros(3))
        return rocket.hook_points_world(state)[0], rocket.head_and_bottom_world(state)[0]

    points, ends = geometry(flexible)
    tip_radius = jnp.linalg.norm(points[:, 1, :2], axis=1)
    np.testing.assert_allclose(tip_radius, 2.0 + 3.5 * np.sin(np.pi / 3), rtol=1e-14)
    np.testing.assert_allclose(points[:, 1, 2], 50.0, atol=1e-12)  # O lies in the tip plane
    np.testing.assert_allclose(points[:, 0, 2], 50.0 - 3.5 * np.cos(np.pi / 3), atol=1e-12)
    np.testing.assert_allclose(points[:, 2, 2], 49.0, atol=1e-12)
    np.testing.assert_allclose(ends, [[0.0, 0.0, 50.0 + 18.25], [0.0, 0.0, 50.0 - 21.75]], atol=1e-12)
    modes = flexible.hook_modes()
    assert 100.0 < modes["damping_ratio"] < 130.0  # the paper's c_h makes the hook mode overdamped (stiff)


def test_free_flexible_rocket_falls_with_g_unstrained():
    """Tilted, translating, non-rotating undamped rocket in gravity: every point accelerates at g."""
    rocket = flexible_landing_rocket(5, hinged_hooks=True, params=UNDAMPED)
    state = _tilted_state(rocket)
    dt, n = 1e-3, N_FLY
    _, out = fly(rocket, state, jnp.zeros((4, 3, 3)), GRAVITY, dt)
    t = dt * np.arange(1, n + 1)
    x0, v0 = rocket.reference_point(state)
    expected = x0 + v0 * t[:, None] + 0.5 * np.asarray(GRAVITY) * t[:, None] ** 2
    np.testing.assert_allclose(out["reference"], expected, atol=1e-9)
    assert np.max(out["max_strain_m"]) < 1e-11 and np.max(out["max_strain_rad"]) < 1e-12
    e0 = rocket.energies(state, GRAVITY)
    assert np.max(np.abs(out["total"] - e0["total"])) < 1e-10 * e0["kinetic"]


def _spinning_deflected_state(rocket):
    state = _tilted_state(rocket, omega=(0.3, -0.2, 0.5))
    return eqx.tree_at(
        lambda s: (s.r, s.hinge_angle),
        state,
        (state.r.at[-1, 0].add(1e-3), jnp.array([0.02, -0.01, 0.03, 0.0])),
    )


def test_undamped_flexible_rocket_conserves_energy():
    """Spin + tumble, 1 mm tip deflection, hooks off rest; RK4 dt = 0.1 ms for 0.1 s."""
    rocket = flexible_landing_rocket(5, hinged_hooks=True, params=UNDAMPED)
    state = _spinning_deflected_state(rocket)
    e0 = rocket.energies(state, GRAVITY)
    assert e0["elastic"] > 1e3  # beams (~60 J) and hook springs (~1.3 kJ) start loaded
    _, out = fly(rocket, state, jnp.zeros((4, 3, 3)), GRAVITY, 1e-4)
    scale = e0["kinetic"] + e0["elastic"]
    drift = np.max(np.abs(out["total"] - e0["total"])) / scale
    assert drift < 1e-9, drift
    assert np.max(out["quat_norm_error"]) < 1e-12


def test_damped_flexible_rocket_loses_energy_monotonically():
    """Paper hook damper (c_h = 4e5 N s/m) + beam damping 1e-3 s; RK4 dt = 50 us (stiff hook mode).

    Energy never increases, and the loss equals the integrated dissipation power (Simpson's rule).
    """
    rocket = flexible_landing_rocket(5, hinged_hooks=True, params=LandingRocketParams(beam_damping_s=1e-3))
    state = _spinning_deflected_state(rocket)
    e0 = rocket.energies(state, GRAVITY)
    dt = 5e-5
    _, out = fly(rocket, state, jnp.zeros((4, 3, 3)), GRAVITY, dt)
    total, power = np.concatenate([[e0["total"]], out["total"]]), out["dissipation"]
    scale = e0["kinetic"] + e0["elastic"]
    assert np.max(np.diff(total)) < 1e-10 * scale  # never increases (beyond round-off)
    # from the first step on (where the dissipation power is recorded), an odd number of samples
    total, power = total[1:-1], power[:-1]
    dissipated = dt / 3 * (power[0] + power[-1] + 4 * np.sum(power[1:-1:2]) + 2 * np.sum(power[2:-1:2]))
    lost = total[0] - total[-1]
    assert lost > 50.0  # J: the hook dampers and beams do work
    np.testing.assert_allclose(lost, dissipated, rtol=1e-4)


def test_rigid_and_flexible_rockets_agree_for_small_loads():
    """Same interface, same initial state, 200 N on two hook tips, 0.1 s: tip paths agree to 0.1 mm."""
    rigid = rigid_landing_rocket(hinged_hooks=True, params=UNDAMPED)
    flexible = flexible_landing_rocket(5, hinged_hooks=True, params=UNDAMPED)
    forces = jnp.zeros((4, 3, 3)).at[0, 1].set(jnp.array([0.0, 50.0, -200.0]))
    forces = forces.at[1, 1].set(jnp.array([100.0, 0.0, -200.0]))
    omega = (0.02, -0.01, 0.05)
    dt = 1e-4
    _, out_rigid = fly(rigid, _tilted_state(rigid, omega), forces, GRAVITY, dt)
    _, out_flex = fly(flexible, _tilted_state(flexible, omega), forces, GRAVITY, dt)
    moved = np.max(np.linalg.norm(out_rigid["tips"] - out_rigid["tips"][0], axis=-1))
    assert moved > 1.0  # the rocket does move (2 m at 20 m/s)
    diff = np.max(np.linalg.norm(out_rigid["tips"] - out_flex["tips"], axis=-1))
    assert diff < 1e-4, diff
    np.testing.assert_allclose(out_rigid["reference"], out_flex["reference"], atol=1e-4)
    # n_bodies = 1 is the rigid rocket exactly
    one = flexible_landing_rocket(1, hinged_hooks=True, params=UNDAMPED)
    _, out_one = fly(one, _tilted_state(one, omega), forces, GRAVITY, dt)
    np.testing.assert_allclose(out_one["tips"], out_rigid["tips"], atol=1e-12)


def test_derivative_of_tip_height_wrt_hook_stiffness():
    """d z_tip(T) / d k_h through 500 RK4 steps vs central finite difference, float64.

    Forward mode (``jax.jvp``): one parameter, and it compiles in ~1/3 of the time of
    ``jax.value_and_grad`` (which gives the same number; measured).
    """
    base = rigid_landing_rocket(hinged_hooks=True, params=LandingRocketParams(hook_damping_N_s_per_m=2e3))
    state = _tilted_state(base, omega=(0.05, 0.0, 0.1))
    forces = jnp.zeros((4, 3, 3)).at[:, 1, 2].set(-3e3)  # pull the tips down: the springs deflect

    def tip_height(k_h):
        rocket = eqx.tree_at(lambda r: r.params.hook_stiffness_N_per_m, base, k_h)
        field = lambda s: rocket.derivative(s, GRAVITY, forces)  # noqa: E731
        final, _ = integrate(field, state, 1e-4, 500, lambda s: None)
        return rocket.hook_points_world(final)[0][0, 1, 2]

    value_and_derivative = jax.jit(lambda k: jax.jvp(tip_height, (k,), (jnp.ones_like(k),)))
    k0 = jnp.asarray(1.5e5)
    _, derivative = value_and_derivative(k0)
    h = 1e-4 * k0  # truncation error ~ (h/k)^2 ~ 1e-10 here (measured), round-off ~ 1e-9
    fd = (value_and_derivative(k0 + h)[0] - value_and_derivative(k0 - h)[0]) / (2 * h)
    assert abs(derivative) > 1e-8  # m per N/m: the tip does feel the spring
    np.testing.assert_allclose(derivative, fd, rtol=1e-7)


# ---------------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------------


def _one_hinge(**changes):
    fields = dict(
        body_mass_kg=[1.0],
        body_inertia_kg_m2=[np.eye(3)],
        hinge_parent=(0,),
        hinge_joint_in_parent_m=[[0.0, 0.0, 0.0]],
        hinge_axis_in_parent=[[0.0, 1.0, 0.0]],
        hinge_child_com_from_joint_m=[[1.0, 0.0, 0.0]],
        hinge_child_mass_kg=[2.0],
        hinge_child_inertia_kg_m2=[np.eye(3)],
    )
    return fields | changes


def test_bad_input_names_the_field():
    inertia = [np.eye(3)]
    with pytest.raises(ValueError, match="body_mass_kg"):
        mb.MultibodySystem(body_mass_kg=[-1.0], body_inertia_kg_m2=inertia)
    with pytest.raises(ValueError, match="body_mass_kg"):
        mb.MultibodySystem(body_mass_kg=[0.0], body_inertia_kg_m2=inertia)
    with pytest.raises(ValueError, match="body_inertia_kg_m2"):
        mb.MultibodySystem(body_mass_kg=[1.0], body_inertia_kg_m2=[np.diag([1.0, np.nan, 1.0])])
    with pytest.raises(ValueError, match="body_inertia_kg_m2 must be positive definite"):
        mb.MultibodySystem(body_mass_kg=[1.0], body_inertia_kg_m2=[np.diag([1.0, -1.0, 1.0])])
    with pytest.raises(ValueError, match="hinge_child_mass_kg"):
        mb.MultibodySystem(**_one_hinge(hinge_child_mass_kg=[-2.0]))
    with pytest.raises(ValueError, match="hinge_parent"):
        mb.MultibodySystem(**_one_hinge(hinge_parent=(1,)))
    with pytest.raises(ValueError, match="hinge_child_inertia_kg_m2 must be positive definite"):
        mb.MultibodySystem(**_one_hinge(hinge_child_inertia_kg_m2=[np.diag([1.0, 1.0, 0.0])]))
    with pytest.raises(ValueError, match="EA_N"):
        mb.MasslessBeams(
            body_a=(0,), body_b=(1,), attach_a_m=[[0.0, 0, 0]], attach_b_m=[[0.0, 0, 0]],
            length_m=[1.0], EA_N=[-1.0], EJ_N_m2=[1.0], GJ_N_m2=[1.0],
        )  # fmt: skip
    with pytest.raises(ValueError, match="params.hook_mass_kg"):
        LandingRocketParams(hook_mass_kg=-45.0)
    with pytest.raises(ValueError, match="params.engine_inertia_axial_kg_m2"):
        LandingRocketParams(engine_inertia_axial_kg_m2=float("nan"))
    with pytest.raises(ValueError, match="params.hinge_height_m"):
        LandingRocketParams(hinge_height_m=45.0)
    with pytest.raises(ValueError, match="n_bodies"):
        flexible_landing_rocket(n_bodies=0)
    rocket = rigid_landing_rocket()
    state = rocket.initial_state(jnp.zeros(3), jnp.zeros(3), jnp.zeros(3), jnp.zeros(3))
    rocket.validate(state)
    bad = eqx.tree_at(lambda s: s.quat, state, jnp.zeros((1, 4)))
    with pytest.raises(ValueError, match="state.quat"):
        rocket.validate(bad)
