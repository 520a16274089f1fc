"""Physics of the finite-segment rope: O(n) solver vs the dense Kane form and sympy's KanesMethod,
energy conservation, the closed-form rope pull-out, the hanging-chain mode, the start of a segment."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from jaxcable.throw.rocket import PointRocket
from jaxcable.throw.forces import AbstractForce, Gravity, MomentumFluxPullOut
from jaxcable.components.rope import (
    ChainState,
    chain_accelerations,
    chain_accelerations_dense,
    kinematics,
    kinetic_energy,
    launch_theta,
    make_rope,
)
from jaxcable.throw.scene import Launch, LineThrowingScene, line_throwing_scene


def random_state(key, n, deployed, speed=30.0):
    k1, k2, k3 = jax.random.split(key, 3)
    return ChainState(
        r0=jnp.array([50.0, 40.0]),
        v0=speed * jax.random.normal(k1, (2,)),
        theta=jax.random.uniform(k2, (n,), minval=-3.0, maxval=3.0),
        omega=2.0 * jax.random.normal(k3, (n,)),
        deployed=jnp.asarray(deployed, dtype=float),
    )


@pytest.mark.parametrize("n,deployed", [(5, 3.4), (16, 15.5), (40, 17.2), (750, 612.7)])
def test_node_positions_and_velocities_are_the_link_sums(n, deployed):
    """The nodes (summed over the links in blocks: ``rope._blocked_cumsum``) against eq 6 and its
    rate summed link by link in NumPy: ``r_j = r_0 - sum_i l_i u_i``, ``v_j = v_0 - sum_i l_i omega_i
    p_i``, the welded tail and the links in the box following the last free link."""
    rope = make_rope(segment_length_m=1.0, rope_length_m=float(n))
    y = random_state(jax.random.PRNGKey(n), n, deployed)
    kin = kinematics(y, rope, 3.0, 0.3)
    k = int(np.floor(deployed))
    lengths = np.where(np.arange(1, n + 1) <= k, 1.0, np.where(np.arange(1, n + 1) == k + 1, deployed - k, 0.0))
    theta, omega = np.array(y.theta), np.array(y.omega)
    theta[k:], omega[k:] = theta[k - 1], omega[k - 1]
    r, v = [np.array(y.r0)], [np.array(y.v0)]
    for i in range(n):
        u = np.array([np.sin(theta[i]), np.cos(theta[i])])
        r.append(r[-1] - lengths[i] * u)
        v.append(v[-1] - lengths[i] * omega[i] * np.array([u[1], -u[0]]))
    np.testing.assert_allclose(kin.positions, np.array(r), rtol=0, atol=1e-12 * max(n, 10))
    np.testing.assert_allclose(kin.velocities, np.array(v), rtol=0, atol=1e-11 * max(n, 10))


@pytest.mark.parametrize(
    "deployed,hinged",
    [
        (12.0, False),  # every link full (no payout)
        (7.4, False),  # payout: 7 full links + 0.4 m tail welded to link 7
        (7.4, True),  # same state, tail on its own hinge (the configuration blended in at completion)
        (7.0, False),  # a segment that has just started: zero-length tail
        (0.6, False),  # no full link: tail rigidly on the rocket
        (1.3, False),  # one full link, hinged at the rocket
        (1.3, True),
    ],
)
def test_linear_solver_matches_dense_kane(deployed, hinged):
    n = 12
    rope = make_rope(segment_length_m=1.0, rope_length_m=n, linear_density_kg_per_m=0.3)
    theta_l = launch_theta(jnp.deg2rad(35.0))
    for seed in range(3):
        key = jax.random.PRNGKey(seed)
        state = random_state(key, n, deployed)
        kin = kinematics(state, rope, 7.5, theta_l, hinged_tail=hinged)
        forces = 40.0 * jax.random.normal(jax.random.fold_in(key, 9), (n + 1, 2))
        forces = forces * (kin.masses > 0)[:, None]
        a_lin, w_lin = chain_accelerations(kin, forces, 1.0)
        a_den, w_den = chain_accelerations_dense(state, kin, forces, 1.0, theta_l)
        np.testing.assert_allclose(a_lin, a_den, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(w_lin, w_den, rtol=1e-9, atol=1e-8)


def test_matches_sympy_kanes_method():
    """A free point mass with a 3-link chain of point masses under gravity, built independently with
    sympy.physics.mechanics.KanesMethod (generalized coordinates x0, y0, theta_1..3 as in the paper)."""
    sm = pytest.importorskip("sympy")
    me = pytest.importorskip("sympy.physics.mechanics")
    n = 3
    lengths = [1.0, 0.7, 1.3]
    masses = [5.0, 0.4, 0.3, 0.5]
    g = 9.81
    q = me.dynamicsymbols(f"x0 y0 th1:{n + 1}")
    u = me.dynamicsymbols(f"vx vy w1:{n + 1}")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = [O.locatenew("P0", q[0] * N.x + q[1] * N.y)]
    P[0].set_vel(N, u[0] * N.x + u[1] * N.y)
    for i in range(n):
        th = q[2 + i]
        Pi = P[-1].locatenew(f"P{i + 1}", -lengths[i] * (sm.sin(th) * N.x + sm.cos(th) * N.y))
        Pi.set_vel(N, P[-1].vel(N) + (-lengths[i] * u[2 + i]) * (sm.cos(th) * N.x - sm.sin(th) * N.y))
        P.append(Pi)
    particles = [me.Particle(f"m{i}", P[i], masses[i]) for i in range(n + 1)]
    loads = [(P[i], -masses[i] * g * N.y) for i in range(n + 1)]
    kd = [qi.diff() - ui for qi, ui in zip(q, u)]
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(particles, loads)
    rhs = sm.lambdify(q + u, km.mass_matrix.LUsolve(km.forcing), "numpy")

    from jaxcable.components.rope import ChainKinematics, unit_vectors

    rng = np.random.default_rng(0)
    for _ in range(4):
        qv = rng.normal(size=n + 2)
        uv = rng.normal(size=n + 2)
        expected = np.asarray(rhs(*qv, *uv), dtype=float).ravel()
        th = jnp.asarray(qv[2:])
        uu, pp = unit_vectors(th)
        L = jnp.asarray(lengths)
        pos = jnp.concatenate([jnp.asarray(qv[:2])[None], jnp.asarray(qv[:2]) - jnp.cumsum(L[:, None] * uu, 0)])
        vel = jnp.concatenate(
            [jnp.asarray(uv[:2])[None], jnp.asarray(uv[:2]) - jnp.cumsum((L * jnp.asarray(uv[2:]))[:, None] * pp, 0)]
        )
        m = jnp.asarray(masses)
        kin = ChainKinematics(
            positions=pos,
            velocities=vel,
            masses=m,
            lengths=L,
            u=uu,
            p=pp,
            omega=jnp.asarray(uv[2:]),
            n_full=jnp.asarray(n),
            n_free=jnp.asarray(n),
            tail_length=jnp.asarray(0.0),
            tail_direction=uu[-1],
            payout_rate=jnp.asarray(0.0),
        )
        forces = jnp.stack([jnp.zeros(n + 1), -m * g], -1)
        a0, dw = chain_accelerations_lengths(kin, forces)
        np.testing.assert_allclose(np.concatenate([a0, dw]), expected, rtol=1e-10, atol=1e-10)


def chain_accelerations_lengths(kin, forces):
    # chain_accelerations takes the full-segment length for the hinge-hinge rows from kin.lengths
    # (its `segment_length_m` argument is used only for the dense reference); any value works here.
    return chain_accelerations(kin, forces, 1.0)


class _Hold(AbstractForce):
    """Test helper: cancels gravity on the rocket node (a pinned top for a heavy 'rocket')."""

    g: float = 9.81

    def node_forces(self, t, kin, scene):
        return jnp.zeros_like(kin.velocities).at[0, 1].set(kin.masses[0] * self.g)


def _fixed_chain_scene(n, seg=1.0, rocket_mass=3.0, forces=None, rho=0.4):
    rope = make_rope(segment_length_m=seg, rope_length_m=n * seg, linear_density_kg_per_m=rho)
    rocket = PointRocket(
        mass_kg=jnp.asarray(rocket_mass),
        propellant_mass_kg=jnp.asarray(0.0),
        total_impulse_Ns=jnp.asarray(0.0),
        burn_time_s=jnp.asarray(1.0),
        diameter_m=jnp.asarray(0.1),
        drag_coefficient=jnp.asarray(0.0),
    )
    launch = Launch(angle_rad=jnp.asarray(0.6), rail_length_m=jnp.asarray(n * seg))
    forces = forces if forces is not None else (Gravity(),)
    return LineThrowingScene(rocket=rocket, rope=rope, launch=launch, forces=tuple(forces))


def _potential(scene, state, g=9.81):
    kin = scene.kinematics(0.0, state)
    return jnp.sum(kin.masses * g * kin.positions[:, 1])


def test_energy_conserved_fixed_chain_no_drag_no_thrust():
    n = 8
    scene = _fixed_chain_scene(n)
    state = ChainState(
        r0=jnp.array([0.0, 500.0]),
        v0=jnp.array([20.0, 15.0]),
        theta=jnp.linspace(0.3, 2.5, n),
        omega=jnp.linspace(-2.0, 3.0, n),
        deployed=jnp.asarray(float(n)),
    )
    energy = lambda s: kinetic_energy(scene.kinematics(0.0, s)) + _potential(scene, s)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(lambda t, y, a: scene.vector_field(t, y)),
        diffrax.Dopri8(),
        0.0,
        3.0,
        None,
        state,
        saveat=diffrax.SaveAt(ts=jnp.linspace(0, 3.0, 7)),
        stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-10),
        max_steps=100_000,
    )
    E = jax.vmap(energy)(sol.ys)
    E0 = energy(state)
    scale = kinetic_energy(scene.kinematics(0.0, state))
    assert np.max(np.abs(np.asarray(E - E0))) / scale < 1e-7
    # the test can fail: a wrong inertia term (e.g. dropping the tension coupling) breaks it
    assert abs(float(E[-1] - E0)) / scale < 1e-7


def test_closed_form_rope_lifted_from_heap():
    """Vertical pull-out with thrust 2 m g: x'' = ((m - rho x) g - rho x'^2) / (m + rho x)."""
    m, rho, g, seg = 4.0, 0.5, 9.81, 1.0
    n = 30
    rope = make_rope(segment_length_m=seg, rope_length_m=n * seg, linear_density_kg_per_m=rho)
    rocket = PointRocket(
        mass_kg=jnp.asarray(m),
        propellant_mass_kg=jnp.asarray(0.0),
        total_impulse_Ns=jnp.asarray(2 * m * g * 1e3),
        burn_time_s=jnp.asarray(1e3),
        diameter_m=jnp.asarray(0.1),
        drag_coefficient=jnp.asarray(0.0),
    )
    launch = Launch(angle_rad=jnp.asarray(np.pi / 2 - 1e-9), rail_length_m=jnp.asarray(1.5))  # thrust axis vertical at rest
    from jaxcable.throw.forces import Thrust

    scene = LineThrowingScene(
        rocket=rocket, rope=rope, launch=launch, forces=(Gravity(g_mps2=g), Thrust(), MomentumFluxPullOut())
    )
    x0, v0 = 1.5, 3.0
    state = ChainState(
        r0=jnp.array([0.0, x0]),
        v0=jnp.array([0.0, v0]),
        theta=jnp.zeros(n),  # u = (0, 1): every link vertical
        omega=jnp.zeros(n),
        deployed=jnp.asarray(x0),
    )
    t_end = 2.0
    ts = jnp.linspace(0, t_end, 9)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(lambda t, y, a: scene.vector_field(t, y)),
        diffrax.Dopri5(),
        0.0,
        t_end,
        None,
        state,
        saveat=diffrax.SaveAt(ts=ts),
        stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-10),
        max_steps=200_000,
    )

    def closed(t, y):
        x, v = y
        return [v, ((m - rho * x) * g - rho * v**2) / (m + rho * x)]

    ref = solve_ivp(closed, (0, t_end), [x0, v0], t_eval=np.asarray(ts), rtol=1e-12, atol=1e-12)
    assert float(sol.ys.deployed[-1]) > 5.0  # several new segments were pulled out
    np.testing.assert_allclose(sol.ys.r0[:, 1], ref.y[0], rtol=1e-7)
    np.testing.assert_allclose(sol.ys.v0[:, 1], ref.y[1], rtol=1e-7)
    np.testing.assert_allclose(sol.ys.deployed, ref.y[0], rtol=1e-7)  # rope in the air = height


def _first_mode(n, L=10.0):
    seg = L / n
    scene = _fixed_chain_scene(n, seg=seg, rocket_mass=1e9, forces=(Gravity(), _Hold()))
    state = ChainState(
        r0=jnp.array([0.0, 100.0]), v0=jnp.zeros(2), theta=jnp.zeros(n), omega=jnp.zeros(n), deployed=jnp.asarray(L)
    )

    def f(x):
        s = eqx.tree_at(lambda s: (s.theta, s.omega), state, (x[:n], x[n:]))
        d = scene.vector_field(0.0, s)
        return jnp.concatenate([d.theta, d.omega])

    J = jax.jit(jax.jacfwd(f))(jnp.zeros(2 * n))  # one compile; op by op it took 6x the CPU time
    ev = np.linalg.eigvals(np.asarray(J))
    return np.min(np.abs(ev.imag[ev.imag > 1e-6]))


def test_hanging_chain_first_mode_converges():
    L, g = 10.0, 9.81
    exact = 1.2024 * np.sqrt(g / L)
    errs = [abs(_first_mode(n, L) / exact - 1) for n in (5, 10, 20, 40)]
    assert all(a > b for a, b in zip(errs, errs[1:])), errs  # refinement converges
    assert errs[-1] < 0.01, errs


def test_segment_start_is_continuous_and_finite():
    """The instant a segment is complete (tail of zero length): the vector field is finite and
    continuous across it (the weld release is blended), and the O(n) solver matches the dense form."""
    scene = line_throwing_scene(30.0, segment_length_m=1.0, rope_length_m=40.0)
    base = random_state(jax.random.PRNGKey(3), scene.rope.capacity, 20.0, speed=60.0)
    f = jax.jit(lambda S: scene.vector_field(0.2, eqx.tree_at(lambda s: s.deployed, base, S)))
    eps = 1e-7
    below, at, above = f(20.0 - eps), f(20.0), f(20.0 + eps)
    for d in (below, at, above):
        assert all(np.all(np.isfinite(np.asarray(x))) for x in jax.tree_util.tree_leaves(d))
    scale = float(jnp.max(jnp.abs(at.omega))) + 1.0
    assert float(jnp.max(jnp.abs(below.omega - above.omega))) < 1e-4 * scale
    assert float(jnp.max(jnp.abs(below.v0 - above.v0))) < 1e-4 * (float(jnp.max(jnp.abs(at.v0))) + 1.0)
    # and the gradient of the field with respect to the deployed length is finite there
    g = jax.jit(jax.jacfwd(lambda S: scene.vector_field(0.2, eqx.tree_at(lambda s: s.deployed, base, S)).v0))(20.0)
    assert np.all(np.isfinite(np.asarray(g)))
