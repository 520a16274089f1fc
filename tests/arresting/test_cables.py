"""The ALE cable over pulleys (jaxcable.arresting.cables) and the buffer device against closed forms."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.cables import CableCoords, CableRoute, CableState, CableSubsystem, graded_fractions
from jaxcable.components.ale import AleCable

G = 9.81


def _route(points, kinds, moving, elements, stretch=1.0):
    points = np.asarray(points, float)
    geo = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s_b = np.concatenate([[0.0], np.cumsum(geo)]) / stretch
    fractions = tuple(jnp.asarray(np.linspace(0, 1, n + 1)[1:-1]) for n in elements)
    route = CableRoute(
        boundary_points=jnp.asarray(points),
        s_boundary0=jnp.asarray(s_b),
        fractions=fractions,
        block_direction=jnp.array([0.0, 0.0, 1.0]),
        kinds=tuple(kinds),
        moving=tuple(moving),
    )
    r_int = [points[j] + f * (points[j + 1] - points[j]) for j, fr in enumerate(fractions) for f in np.asarray(fr)]
    pulleys = np.array([i for i, k in enumerate(kinds) if k in ("pulley", "active")], int)
    q0 = CableCoords(r=jnp.asarray(np.array(r_int).reshape(-1, 3)), s=jnp.asarray(s_b[pulleys]), u=jnp.zeros(()))
    return route, q0


def _state(q0):
    return CableState(q=q0, qdot=jax.tree_util.tree_map(jnp.zeros_like, q0), dissipated=jnp.zeros(()))


def _solve(sub, y0, t1, rtol=1e-9, n=5):
    term = diffrax.ODETerm(lambda t, y, a: sub.derivative(y))
    ts = jnp.linspace(0.0, t1, n)
    sol = diffrax.diffeqsolve(
        term, diffrax.Tsit5(), 0.0, t1, None, y0,
        stepsize_controller=diffrax.PIDController(rtol=rtol, atol=rtol),
        saveat=diffrax.SaveAt(ts=ts), max_steps=400_000,
    )
    return [jax.tree_util.tree_map(lambda x: x[i], sol.ys) for i in range(n)]


def _buffer_route():
    """Block strand - ground pulley - slider pulley - span - slider pulley - ground pulley - block."""
    pts = [[0, 0, -40.0], [0, 0, -30.0], [0, -25, 0], [0, 25, 0], [0, 0, -30.0], [0, 0, -40.0]]
    return _route(pts, ["end", "pulley", "pulley", "pulley", "pulley", "end"], [1, 0, 0, 0, 0, 1], [1, 2, 8, 2, 1], 1.0005)


def total_energy(sub, y):
    return sum(sub.energy(y).values())


def test_undamped_cable_over_pulleys_with_counterweight_conserves_energy_and_mass():
    """No damping, no brake: T + V is constant (the Lagrangian form is exactly conservative), while
    material flows over the pulleys (s changes) and the total material length stays the ends'."""
    route, q0 = _buffer_route()
    sub = CableSubsystem(route, AleCable(EA_N=2.64e6, rhoA_kg_per_m=9.8), BufferDevice(brake_force_N=0.0, counterweight_mass_kg=300.0))
    ys = _solve(sub, _state(q0), 0.3, rtol=1e-8)
    e = np.array([float(total_energy(sub, y)) for y in ys])
    scale = float(sub.energy(ys[0])["elastic"]) + abs(float(sub.energy(ys[0])["counterweight_potential"])) + 1e3
    drift = np.max(np.abs(e - e[0])) / scale
    assert drift < 1e-7, drift
    flow = float(jnp.max(jnp.abs(ys[-1].q.s - ys[0].q.s)))
    assert flow > 1e-3, "material should flow over the pulleys"
    for y in ys:
        r, s = route.nodes(y.q)
        assert float(jnp.sum(jnp.diff(s))) == pytest.approx(float(sub.material_length()), rel=1e-12)
        assert np.all(np.diff(np.asarray(s)) > 0)


def _statics(sub, q0, iterations=30):
    """Static equilibrium: Newton on the accelerations at zero velocity (no time stepping)."""
    flat0, unravel = jax.flatten_util.ravel_pytree(q0)
    acc = _flat_acceleration(sub, unravel)
    fq = np.asarray(flat0)
    for _ in range(iterations):
        fq = fq - np.linalg.solve(_fd_jacobian(acc, fq, 1e-6), np.asarray(acc(fq)))
    assert float(np.max(np.abs(np.asarray(acc(fq))))) < 1e-6
    return unravel(jnp.asarray(fq))


def _flat_acceleration(sub, unravel):
    """Jitted q -> q_dd at zero velocity (compiled once; Jacobians by differences of it are much
    cheaper to compile than jacfwd through the solver)."""

    @jax.jit
    def acc(fq):
        zero = jax.tree_util.tree_map(jnp.zeros_like, unravel(fq))
        return jax.flatten_util.ravel_pytree(sub.accelerations(unravel(fq), zero))[0]

    return acc


def _fd_jacobian(fn, x, h):
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((np.asarray(fn(x + e)) - np.asarray(fn(x - e))) / (2 * h))
    return np.stack(cols, axis=1)


def test_static_tension_balances_counterweight_through_transfer_rate():
    """At rest the block strands carry alpha m_w g / 2 (the block carries 2 T, the counterweight
    alpha m_w g: eq 12's kinematics) plus the cable's hydrostatic weight up to the span, and the
    span sags as the parabola rhoA g L^2 / (8 T)."""
    route, q0 = _buffer_route()
    m_w = 2000.0
    sub = CableSubsystem(route, AleCable(EA_N=2.64e8, rhoA_kg_per_m=9.8), BufferDevice(counterweight_mass_kg=m_w))
    q = _statics(sub, q0)
    tension = np.asarray(sub.tensions(q))
    span = tension[3:11]
    r, _ = route.nodes(q)
    sag = -float(jnp.min(r[4:11, 2]))
    # block strands carry alpha m_w g / 2 each; along a cable over frictionless pulleys in statics
    # T - rhoA g z is constant, so the span's lowest point (z = -sag) carries that + rhoA g (40 - sag)
    block_z = -40.0 + float(q.u)
    expected = 3.0 * m_w * G / 2.0 + 9.8 * G * (-sag - block_z)
    assert float(np.min(span)) == pytest.approx(expected, rel=2e-3)
    # parabola vs catenary and the 8-element chord: both well under 2% at sag/L ~ 1%
    assert sag == pytest.approx(9.8 * G * 50.0**2 / (8 * expected), rel=0.02)


def test_axial_wave_speed():
    """Lowest axial mode of a taut fixed-fixed cable: omega_1 = pi c / L with c = sqrt(EA / rhoA)
    (to O(h^2) for the consistent mass; straight cable, gravity off)."""
    L, n = 10.0, 40
    route, q0 = _route([[0, 0, 0], [L, 0, 0]], ["end", "end"], [False, False], [n], 1.01)
    EA, rhoA = 1e6, 2.0
    sub = CableSubsystem(route, AleCable(EA_N=EA, rhoA_kg_per_m=rhoA), BufferDevice(), gravity=jnp.zeros(3))
    flat0, unravel = jax.flatten_util.ravel_pytree(q0)
    # central differences of the accelerations (h = 1e-7 m on a 10 m cable: truncation ~1e-12)
    K = -_fd_jacobian(_flat_acceleration(sub, unravel), np.asarray(flat0), 1e-7)
    ax = np.arange(0, 3 * (n - 1), 3)  # x components of the internal nodes
    w2 = np.sort(np.linalg.eigvals(K[np.ix_(ax, ax)]).real)
    stretch = 1.01
    # wave speed in the stretched cable (Green strain): c^2 = EA (3 lam^2 - 1) / (2 rhoA) per unit
    # material length, the mode spans the material length L / lam
    c_mat = np.sqrt(EA * (3 * stretch**2 - 1) / (2 * rhoA))
    expected = np.pi * c_mat / (L / stretch)
    assert np.sqrt(w2[0]) == pytest.approx(expected, rel=2e-3)


def test_graded_fractions_put_fine_elements_around_centre():
    f = graded_fractions(24, centre=20.0, half_width=3.0, n_fine=12, total=50.0)
    edges = np.concatenate([[0], f, [1]]) * 50.0
    h = np.diff(edges)
    assert len(h) == 24 and np.all(h > 0)
    fine = h[(edges[:-1] >= 17.0 - 1e-9) & (edges[1:] <= 23.0 + 1e-9)]
    assert len(fine) == 12 and np.allclose(fine, 0.5)
    with pytest.raises(ValueError, match="n_fine"):
        graded_fractions(5, 1.0, 1.0, 4, 10.0)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="counterweight_mass_kg"):
        BufferDevice(counterweight_mass_kg=-1.0)
    with pytest.raises(ValueError, match="EA_N"):
        AleCable(EA_N=0.0)
    with pytest.raises(ValueError, match="boundary kind"):
        _route([[0, 0, 0], [1, 0, 0], [2, 0, 0]], ["end", "hinge", "end"], [False] * 3, [1, 1])
    with pytest.raises(ValueError, match="boundary_points"):
        CableRoute(
            boundary_points=jnp.array([[0.0, 0, 0], [np.nan, 0, 0]]),
            s_boundary0=jnp.array([0.0, 1.0]),
            fractions=(jnp.zeros(0),),
            block_direction=jnp.array([0.0, 0, 1]),
            kinds=("end", "end"),
            moving=(False, False),
        )


def test_brake_dissipates_and_holds():
    b = BufferDevice()
    w = jnp.linspace(-1, 1, 11)
    assert np.all(np.asarray(b.brake_power(w / 3.0)) >= 0)
    # at a creep speed of width/10 the brake already gives ~tanh(0.1) F_f
    assert float(b.brake_force(0.005)) == pytest.approx(3.13e5 * np.tanh(0.1))


def test_active_pulley_reels_cable_at_the_prescribed_rate():
    """Eq 47: the active pulley's material coordinate moves at the reel speed v_p; material flows
    from one span to the other over it, the total material (and mass) stays that of the ends, and the
    free cable responds (the span being reeled in tightens)."""
    pts = [[-10.0, 0, 0], [0, 0, 0], [10.0, 0, 0]]
    route, q0 = _route(pts, ["end", "active", "end"], [False] * 3, [6, 6], 1.001)
    sub = CableSubsystem(route, AleCable(EA_N=1e6, rhoA_kg_per_m=1.0, damping_s=1e-3), BufferDevice(), gravity=jnp.zeros(3))
    v_p = 0.01
    y0 = _state(q0)
    y0 = CableState(q=q0, qdot=eqx_tree_set_s(y0.qdot, jnp.array([v_p])), dissipated=jnp.zeros(()))
    ys = _solve(sub, y0, 0.5, rtol=1e-8, n=3)
    assert float(ys[-1].q.s[0] - ys[0].q.s[0]) == pytest.approx(v_p * 0.5, rel=1e-9)
    assert float(ys[-1].qdot.s[0]) == pytest.approx(v_p, rel=1e-12)
    _, s_end = route.nodes(ys[-1].q)
    assert float(s_end[-1] - s_end[0]) == pytest.approx(float(sub.material_length()), rel=1e-12)
    t = np.asarray(sub.tensions(ys[-1].q))
    # s increases toward +x, so s_dot > 0 at the pulley moves material from the right span into the
    # left one: after quasi-static reeling each span's tension is EA (lam^2 - 1) lam / 2 (Green
    # strain force) with lam = 10 m / its material length
    for span, material in ((t[:6], 10.0 / 1.001 + v_p * 0.5), (t[6:], 10.0 / 1.001 - v_p * 0.5)):
        lam = 10.0 / material
        assert np.mean(span) == pytest.approx(1e6 * (lam**2 - 1) * lam / 2, rel=5e-3)


def eqx_tree_set_s(coords, s):
    return CableCoords(r=coords.r, s=s, u=coords.u)


# -- the closed-form vector field against autodiff of the Lagrangian ------------------------------


def _random_state(q0, seed, spread=1e-2):
    """A state near ``q0`` with every rate nonzero (material sliding over the pulleys, nodes moving)."""
    rng = np.random.default_rng(seed)
    flat, unravel = jax.flatten_util.ravel_pytree(q0)
    q = unravel(flat + spread * jnp.asarray(rng.normal(size=flat.shape)))
    qdot = unravel(jnp.asarray(rng.normal(size=flat.shape)))
    return q, qdot, unravel, rng


def _buffer_subsystem(damping_s=1e-3):
    route, q0 = _buffer_route()
    cable = AleCable(EA_N=2.64e8, rhoA_kg_per_m=9.8, damping_s=damping_s)
    return CableSubsystem(route, cable, BufferDevice(counterweight_mass_kg=300.0)), q0


def test_closed_form_element_forces_match_autodiff_of_T_V_D():
    """Per element, ``-(dp/dx) x_dot + dT/dx - dV/dx - dD/dx_dot`` in closed form (the vector field)
    equals autodiff of the element's kinetic energy, potential and Rayleigh function, with every node
    sliding through the material (s_dot != 0) and damping on."""
    from jaxcable.arresting.cables import _scatter_element_ends

    sub, q0 = _buffer_subsystem()
    q, qdot, _, _ = _random_state(q0, 0)

    @jax.jit
    def both(q, qdot):
        kin = sub.kinematics(q, qdot)
        F_r, F_s = _scatter_element_ends(sub._element_forces(kin))
        closed = jnp.concatenate([F_r, F_s[:, None]], axis=1).reshape(-1)
        x = jnp.concatenate([kin.r, kin.s[:, None]], axis=1).reshape(-1)
        xd = jnp.concatenate([kin.v, kin.sd[:, None]], axis=1).reshape(-1)
        _, reference = sub._cable_terms_x(x, xd, assemble=False)
        return closed, reference

    closed, reference = both(q, qdot)
    scale = float(jnp.max(jnp.abs(reference)))
    assert scale > 1e3  # a loaded, moving cable
    np.testing.assert_allclose(np.asarray(closed), np.asarray(reference), rtol=0, atol=1e-10 * scale)


@pytest.fixture(scope="module")
def buffer_accelerations():
    """Compiled fast and reference accelerations of the buffer route (shared by two tests)."""
    sub, q0 = _buffer_subsystem()
    fast = jax.jit(lambda q, qd, ext, ef: sub.accelerations(q, qd, ext, element_forces=ef))
    reference = jax.jit(lambda q, qd, ext: sub._accelerations_autodiff(q, qd, ext))
    return sub, q0, fast, reference


def test_accelerations_match_dense_autodiff_lagrange(buffer_accelerations):
    """The O(n) solve (closed-form forces, Schur complement on the pulley/block coordinates, the
    constant mass-pattern inverse, unrolled elimination) against Lagrange's equations by autodiff of
    the total T, V, D in q with a dense jacfwd mass matrix and LU, with external generalised forces
    and forces on the material at element ends (through :meth:`material_point_forces`)."""
    sub, q0, fast, reference = buffer_accelerations
    n_el = sum(sub.route.elements)
    for seed in range(3):
        q, qdot, unravel, rng = _random_state(q0, seed)
        flat = jax.flatten_util.ravel_pytree(q0)[0]
        external = unravel(1e3 * jnp.asarray(rng.normal(size=flat.shape)))
        element_forces = 1e4 * jnp.asarray(rng.normal(size=(n_el, 2, 3)))
        got = jax.flatten_util.ravel_pytree(fast(q, qdot, external, element_forces))[0]
        total = jax.tree_util.tree_map(jnp.add, external, sub.material_point_forces(q, element_forces))
        want = jax.flatten_util.ravel_pytree(reference(q, qdot, total))[0]
        scale = float(jnp.max(jnp.abs(want)))
        np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=0, atol=1e-11 * scale)


def test_accelerations_match_autodiff_with_a_span_between_two_block_pulleys():
    """A strand between two pulleys that both ride the block: its span sees the block's travel at
    both ends (one shared slow column of the span-by-span solve), against the dense ``jacfwd``
    Lagrange reference, with external forces on every coordinate."""
    pts = [[0, -20.0, 0], [0, -5.0, -10.0], [0, 5.0, -10.0], [0, 20.0, 0]]
    route, q0 = _route(pts, ["end", "pulley", "pulley", "end"], [0, 1, 1, 0], [3, 4, 3], 1.0005)
    sub = CableSubsystem(route, AleCable(EA_N=2.64e8, rhoA_kg_per_m=9.8, damping_s=1e-3), BufferDevice(counterweight_mass_kg=300.0))  # fmt: skip
    assert route.span_slow_tables()[1]["block"] == (2, 2)  # both ends of the middle span: the same column
    fast = jax.jit(lambda q, qd, ext: sub.accelerations(q, qd, ext))
    reference = jax.jit(lambda q, qd, ext: sub._accelerations_autodiff(q, qd, ext))
    for seed in range(2):
        q, qdot, unravel, rng = _random_state(q0, seed)
        external = unravel(1e3 * jnp.asarray(rng.normal(size=jax.flatten_util.ravel_pytree(q0)[0].shape)))
        got = jax.flatten_util.ravel_pytree(fast(q, qdot, external))[0]
        want = jax.flatten_util.ravel_pytree(reference(q, qdot, external))[0]
        scale = float(jnp.max(jnp.abs(want)))
        np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=0, atol=1e-11 * scale)


def test_material_point_forces_are_the_power_gradient():
    """``material_point_forces`` is d(power)/d(q_dot) of ``F . (v - r' s_dot)`` at the element ends,
    the definition, here by autodiff through the nodal map (independent of the closed form)."""
    sub, q0 = _buffer_subsystem()
    q, _, unravel, rng = _random_state(q0, 4)
    n_el = sum(sub.route.elements)
    forces = 1e4 * jnp.asarray(rng.normal(size=(n_el, 2, 3)))

    def power(qdot):
        (r, s), (v, sd) = jax.jvp(sub.route.nodes, (q,), (qdot,))
        tangent = (r[1:] - r[:-1]) / (s[1:] - s[:-1])[:, None]
        a1 = v[:-1] - tangent * sd[:-1, None]
        a2 = v[1:] - tangent * sd[1:, None]
        return jnp.sum(forces[:, 0] * a1) + jnp.sum(forces[:, 1] * a2)

    zero = jax.tree_util.tree_map(jnp.zeros_like, q)
    want = jax.flatten_util.ravel_pytree(jax.grad(power)(zero))[0]
    got = jax.flatten_util.ravel_pytree(sub.material_point_forces(q, forces))[0]
    np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=1e-12, atol=1e-9)


def test_nodes_follow_the_mesh_rules():
    """Eqs 32-34 node by node (an explicit loop, not the vectorised map): ends keep their material
    coordinate, pulley nodes take q.s, internal nodes sit at s_b1 + f (s_b2 - s_b1); moving nodes
    ride the block, internal positions are q.r."""
    route, q0 = _buffer_route()
    q, qdot, _, _ = _random_state(q0, 5)
    r, s = route.nodes(q)
    v, sd = route.node_velocities(qdot)
    sb, sbd, slot = [], [], 0
    for i, kind in enumerate(route.kinds):
        if kind == "end":
            sb.append(float(route.s_boundary0[i]))
            sbd.append(0.0)
        else:
            sb.append(float(q.s[slot]))
            sbd.append(float(qdot.s[slot]))
            slot += 1
    node, internal = 0, 0
    for j, fr in enumerate(route.fractions):
        for k, f in enumerate([0.0] + list(np.asarray(fr))):
            if k == 0:
                shift = float(q.u) if route.moving[j] else 0.0
                assert np.allclose(r[node], np.asarray(route.boundary_points[j]) + [0, 0, shift])
                rate = float(qdot.u) if route.moving[j] else 0.0
                assert np.allclose(v[node], [0, 0, rate])
                assert s[node] == pytest.approx(sb[j], abs=1e-12)
            else:
                assert np.allclose(r[node], q.r[internal]) and np.allclose(v[node], qdot.r[internal])
                assert s[node] == pytest.approx(sb[j] + f * (sb[j + 1] - sb[j]), abs=1e-12)
                assert sd[node] == pytest.approx(sbd[j] + f * (sbd[j + 1] - sbd[j]), abs=1e-12)
                internal += 1
            node += 1
    assert s[-1] == pytest.approx(sb[-1], abs=1e-12) and node == r.shape[0] - 1


def test_active_pulley_rows_are_prescribed_and_the_rest_is_lagrange():
    """With an active pulley (eq 47) the solve returns the prescribed reel acceleration for its s,
    and every other row satisfies the dense autodiff equations ``M q_dd = rhs`` (the motor's force
    acts on the active row only)."""
    pts = [[-10.0, 0, 0], [0, 0, 0], [10.0, 0, -1.0], [20.0, 0, 0]]
    route, q0 = _route(pts, ["end", "active", "pulley", "end"], [False] * 4, [4, 3, 2], 1.001)
    sub = CableSubsystem(route, AleCable(EA_N=1e6, rhoA_kg_per_m=1.0, damping_s=1e-3), BufferDevice())
    q, qdot, unravel, _ = _random_state(q0, 6)
    flat_q, _ = jax.flatten_util.ravel_pytree(q)
    flat_qd, _ = jax.flatten_util.ravel_pytree(qdot)

    @jax.jit
    def residual_of_solve(flat_q, flat_qd):
        q_, qdot_ = unravel(flat_q), unravel(flat_qd)
        qdd = sub.accelerations(q_, qdot_, reel_acceleration=jnp.array([0.7]))

        def T(fq, fqd):
            return sub.kinetic_energy(unravel(fq), unravel(fqd))

        mass = jax.jacfwd(lambda fqd: jax.grad(T, argnums=1)(flat_q, fqd))(flat_qd)
        _, dp = jax.jvp(lambda fq: jax.grad(T, argnums=1)(fq, flat_qd), (flat_q,), (flat_qd,))
        rhs = -dp + jax.grad(T, argnums=0)(flat_q, flat_qd)
        rhs = rhs - jax.grad(lambda fq: sub.potential_energy(unravel(fq)))(flat_q)
        rhs = rhs - jax.grad(lambda fqd: sub.dissipation_function(q_, unravel(fqd)))(flat_qd)
        rhs = rhs.at[-1].add(sub.buffer.generalized_force(qdot_.u))
        return qdd.s[0], mass @ jax.flatten_util.ravel_pytree(qdd)[0] - rhs, rhs

    reel, residual, rhs = residual_of_solve(flat_q, flat_qd)
    assert float(reel) == pytest.approx(0.7, rel=1e-12)
    active_row = q.r.size  # first entry of s in the ravel order (r, s, u)
    free = np.ones(residual.shape[0], bool)
    free[active_row] = False
    assert float(jnp.max(jnp.abs(residual[free]))) < 1e-9 * float(jnp.max(jnp.abs(rhs)))


def test_span_pattern_inverses_invert_the_spans_mass_patterns_without_a_lapack_call():
    """Each span's consistent-mass pattern inverse times the pattern built here from the material
    fractions (diagonal ``2 (dF_left + dF_right)``, off-diagonal the shared element's ``dF``) is the
    identity, and the compiled accelerations call no LAPACK kernel: batched LAPACK calls from two
    CPU devices at once deadlocked the two-device sweep on XLA's shared thread pool
    (``_dominant_inverse``)."""
    route, q0 = _buffer_route()
    spans = [np.asarray(f) for f, n in zip(route.fractions, route.elements) if n > 1]
    got = route.span_pattern_inverses()
    assert len(got) == len(spans) > 1
    for inverse, f in zip(got, spans):
        dF = np.diff(np.concatenate([[0.0], f, [1.0]]))
        pattern = np.diag(2.0 * (dF[:-1] + dF[1:])) + np.diag(dF[1:-1], 1) + np.diag(dF[1:-1], -1)
        np.testing.assert_allclose(np.asarray(inverse) @ pattern, np.eye(f.size), rtol=0, atol=1e-12)
    sub, _ = _buffer_subsystem()
    stacked = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), (sub, q0))
    zero = jax.tree_util.tree_map(jnp.zeros_like, stacked[1])
    compiled = jax.jit(jax.vmap(lambda s, q, qd: s.accelerations(q, qd))).lower(*stacked, zero).compile()
    assert 'custom_call_target="lapack' not in compiled.as_text()


def _primitives(jaxpr):
    """Every primitive's name in ``jaxpr`` and its sub-jaxprs (bodies of calls, loops, conds)."""
    names = set()
    for eqn in jaxpr.eqns:
        names.add(eqn.primitive.name)
        for sub in jax.core.jaxprs_in_params(eqn.params):
            names |= _primitives(sub)
    return names


def test_scene_routes_carry_their_pattern_inverses_and_the_vector_field_has_no_loop():
    """A scene's cables (``AleCables.build``, both hook models) carry each span's mass-pattern inverse
    computed on the host (:func:`pattern_inverses`), equal to the in-program Gauss-Jordan of the same
    fractions (``_dominant_inverse``, what a route built without them computes), and the vector
    field traced from the scene has no loop: XLA does not hoist that inverse's ``fori_loop`` out of
    a loop around the vector field, where it took most of an evaluation's time."""
    from jaxcable.arresting.cables import _dominant_inverse, pattern_inverses
    from jaxcable.arresting.passive import passive_landing_scene

    for hook_contact, mesh in (("node", (24, 8)), ("capsule", (16, 8))):
        scene = passive_landing_scene(
            "full", t_end_s=0.01, hook_contact=hook_contact, n_span_elements=mesh[0], n_fine=mesh[1], n_rocket_bodies=1
        )
        route = scene.cables.subsystems.route
        assert route.pattern_inverses is not None
        n_cables = np.shape(route.s_boundary0)[0]
        for k in range(n_cables):
            fractions = [np.asarray(f[k]) for f in route.fractions]
            carried = [np.asarray(x[k]) for x in route.pattern_inverses]
            assert len(carried) == len(pattern_inverses(fractions)) == sum(f.size > 0 for f in fractions) > 1
            for inverse, f in zip(carried, [f for f in fractions if f.size > 0]):
                dF = np.diff(np.concatenate([[0.0], f, [1.0]]))
                pattern = np.diag(2.0 * (dF[:-1] + dF[1:])) + np.diag(dF[1:-1], 1) + np.diag(dF[1:-1], -1)
                np.testing.assert_allclose(inverse, np.asarray(_dominant_inverse(jnp.asarray(pattern))), rtol=0, atol=1e-12)
        y0 = scene.initial_state()
        jaxpr = jax.make_jaxpr(lambda y: scene.vector_field(0.0, y))(y0).jaxpr
        assert not {"while", "scan"} & _primitives(jaxpr), hook_contact
