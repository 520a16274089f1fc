"""The hook as a sliding node (``hook_contact="node"``): a boundary node of the arresting span whose
position and material coordinate are both coordinates, held at the hook's throat by a ring.

Checked against things not written in the node's code: Lagrange's equations by autodiff of the
energies (the closed-form accelerations with the hook node in the border), energy conservation of
the undamped cable on a conservative ring, the frictionless string's equal tensions on both sides
of a kinked support (statics by Newton), the dense Jacobian of the cable forces (the W-method's
blocks), the dense solve of the same W-method step, and the landing's energy budget."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree

from jaxcable import simulate
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.cables import (
    CableCoords,
    CableRoute,
    CableState,
    CableSubsystem,
)
from jaxcable.arresting.passive import passive_landing_scene
from jaxcable.arresting.stiff import dense_reference
from jaxcable.components.ale import AleCable
from jaxcable.components.contact import ContactLaw
from jaxcable.core.config import enable_x64

enable_x64()

THROAT = np.array([6.0, 0.0, -4.0])
"""A hook 6 m off the span's middle and 4 m below the sliders: the legs bend by 0.36 rad there."""


def _hook_route(elements=(1, 2, 4, 3, 2, 1), stretch=1.0005):
    """Block strand - ground pulley - slider - hook node - slider - ground pulley - block strand."""
    pts = np.array([[0, 0, -40.0], [0, 0, -30.0], [-25.0, 0, 0], THROAT, [25.0, 0, 0], [0, 0, -30.0], [0, 0, -40.0]])
    geo = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s_b = np.concatenate([[0.0], np.cumsum(geo)]) / stretch
    fractions = tuple(jnp.asarray(np.linspace(0, 1, n + 1)[1:-1]) for n in elements)
    route = CableRoute(
        boundary_points=jnp.asarray(pts), s_boundary0=jnp.asarray(s_b), fractions=fractions,
        block_direction=jnp.array([0.0, 0.0, 1.0]),
        kinds=("end", "pulley", "pulley", "hook", "pulley", "pulley", "end"),
        moving=(True, False, False, False, False, False, True),
    )  # fmt: skip
    r_int = np.array([pts[j] + f * (pts[j + 1] - pts[j]) for j, fr in enumerate(fractions) for f in np.asarray(fr)])
    q0 = CableCoords(r=jnp.asarray(r_int), s=jnp.asarray(s_b[1:-1]), u=jnp.zeros(()), h=jnp.asarray(THROAT[None]))
    return route, q0


def _ring(k):
    """Generalised force of a spring ``k`` [N/m] holding the hook node at THROAT (conservative)."""
    return lambda q: CableCoords(
        r=jnp.zeros_like(q.r), s=jnp.zeros_like(q.s), u=jnp.zeros_like(q.u), h=-k * (q.h - THROAT[None])
    )


def test_accelerations_with_a_hook_node_equal_lagranges_equations_by_autodiff():
    """The hook node's position joins the border (the slow coordinates) and its material
    coordinate the pulleys': the closed-form mass solve and forces against the dense ``jacfwd``
    mass matrix and the autodiff of T, V and D, at a perturbed, moving state with external forces."""
    route, q0 = _hook_route()
    rng = np.random.default_rng(0)
    q = jax.tree_util.tree_map(lambda x: x + 0.01 * jnp.asarray(rng.normal(size=np.shape(x))), q0)
    qdot = jax.tree_util.tree_map(lambda x: jnp.asarray(rng.normal(size=np.shape(x))), q0)
    external = jax.tree_util.tree_map(lambda x: 100.0 * jnp.asarray(rng.normal(size=np.shape(x))), q0)
    sub = CableSubsystem(route, AleCable(EA_N=2.64e6, rhoA_kg_per_m=9.8, damping_s=1e-3), BufferDevice(counterweight_mass_kg=300.0))  # fmt: skip
    got = ravel_pytree(eqx.filter_jit(sub.accelerations)(q, qdot, external))[0]
    want = ravel_pytree(eqx.filter_jit(sub._accelerations_autodiff)(q, qdot, external))[0]
    assert float(jnp.max(jnp.abs(want[-4:]))) > 1.0  # the hook node moves (the last coordinates: h, u)
    np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=0, atol=1e-9 * float(jnp.max(jnp.abs(want))))


def test_undamped_cable_on_a_conservative_ring_conserves_energy():
    """No damping, no brake, the hook node on a spring to a fixed throat: T + V + the spring's
    energy stays constant while material flows through the node and over the pulleys."""
    route, q0 = _hook_route()
    k = 1e6
    sub = CableSubsystem(route, AleCable(EA_N=2.64e6, rhoA_kg_per_m=9.8), BufferDevice(brake_force_N=0.0, counterweight_mass_kg=300.0))  # fmt: skip
    ring = _ring(k)
    q_start = eqx.tree_at(lambda q: q.h, q0, q0.h + jnp.array([[0.3, 0.2, -0.2]]))  # off the throat: it swings

    def field(t, y, args):
        kin = sub.kinematics(y.q, y.qdot)
        return CableState(q=y.qdot, qdot=sub.accelerations(y.q, y.qdot, ring(y.q), kin=kin), dissipated=jnp.zeros(()))

    def energy(y):
        return sum(sub.energy(y).values()) + 0.5 * k * jnp.sum((y.q.h - THROAT[None]) ** 2)

    y0 = CableState(q=q_start, qdot=jax.tree_util.tree_map(jnp.zeros_like, q0), dissipated=jnp.zeros(()))
    ts = jnp.linspace(0.0, 0.2, 5)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field), diffrax.Tsit5(), 0.0, 0.2, None, y0,
        stepsize_controller=diffrax.PIDController(rtol=1e-9, atol=1e-9), saveat=diffrax.SaveAt(ts=ts), max_steps=200_000,
    )  # fmt: skip
    e = np.array([float(energy(jax.tree_util.tree_map(lambda x, i=i: x[i], sol.ys))) for i in range(5)])
    swing = 0.5 * k * 0.17  # the ring's initial energy [J]
    assert np.max(np.abs(e - e[0])) < 1e-6 * swing, (e - e[0]) / swing
    assert float(jnp.max(jnp.abs(sol.ys.q.s[-1, 2] - q0.s[2]))) > 1e-3  # material slid through the hook node


def test_a_frictionless_hook_node_carries_equal_tensions_on_both_legs():
    """A string over a frictionless support carries the same tension on both sides, however it
    bends there. Static equilibrium (Newton on the accelerations at rest, the cable weightless) of the cable
    through a hook node held 6 m off the middle by a stiff ring: the two elements at the node carry
    the same axial force to 1e-6, while the legs bend by 0.36 rad at the node (the capsule contact
    of straight elements makes them differ by 12-25% of its normal force there:
    ``tests/arresting/test_contact.py``)."""
    route, q0 = _hook_route()
    # the cable's own weight scaled away (its hydrostatic gradient would differ the elements by ~1%);
    # the counterweight's weight tensions the cable
    sub = CableSubsystem(route, AleCable(EA_N=2.64e8, rhoA_kg_per_m=1e-6), BufferDevice(counterweight_mass_kg=2000.0))

    ring = _ring(1e9)
    flat0, unravel = ravel_pytree(q0)

    @jax.jit
    def acc(fq):
        q = unravel(fq)
        return ravel_pytree(sub.accelerations(q, jax.tree_util.tree_map(jnp.zeros_like, q), ring(q)))[0]

    jac = jax.jit(jax.jacfwd(acc))
    fq = flat0
    for _ in range(30):
        step = jnp.linalg.solve(jac(fq), acc(fq))
        fq = fq - step
    assert float(jnp.max(jnp.abs(step))) < 1e-9  # [m]: converged
    q = unravel(fq)
    tension = np.asarray(sub.tensions(q))
    node = 1 + 2 + 4  # the hook node: after the block strand (1), the tower (2) and the first sub-span (4)
    r, _ = route.nodes(q)
    t_a, t_b = np.asarray(r[node] - r[node - 1]), np.asarray(r[node + 1] - r[node])
    bend = np.arccos(t_a @ t_b / np.linalg.norm(t_a) / np.linalg.norm(t_b))
    assert bend > 0.3
    np.testing.assert_allclose(tension[node], tension[node - 1], rtol=1e-6)
    assert tension[node] > 5e3  # [N]: tensioned by the counterweight (alpha m_w g / 2)
    # and the whole span carries it (a weightless cable, frictionless pulleys)
    np.testing.assert_allclose(tension[3:10], tension[node], rtol=1e-6)


# --- the landing scene with hook nodes ------------------------------------------------------------

T_END = 0.01  # [s]
MESH = {"n_span_elements": 4, "n_fine": 2}


def _scene(contact=None, beta=1e-3, **kw):
    return passive_landing_scene(
        "ale", t_end_s=T_END, cable_damping_s=beta, hook_contact="node", contact=contact, **MESH, **kw
    )  # fmt: skip


def _moving_state(scene):
    """The capture state with the cables moving (0.5 m/s down at every internal node, 0.2 m/s of
    material flow) and the hook nodes 2 cm off their throats, moving at 0.3 m/s."""
    y = scene.initial_state()
    q, qdot = y.cables.q, y.cables.qdot
    q = eqx.tree_at(lambda c: c.h, q, q.h + jnp.array([0.01, -0.005, -0.02]))
    qdot = eqx.tree_at(lambda d: (d.r, d.s, d.h), qdot, (qdot.r.at[..., 2].set(-0.5), qdot.s + 0.2, qdot.h - 0.3))
    return eqx.tree_at(lambda s: (s.cables.q, s.cables.qdot), y, (q, qdot))


def test_node_blocks_equal_the_dense_jacobian_of_the_cable_forces():
    """The W-method's blocks with hook nodes (the ring's rows and columns on the node's ``s_h`` and
    position in the border) against ``jax.jacfwd`` of the cable forces, the cable's mass scaled
    away (the blocks leave out the moving material's inertia terms, see ``test_stiff.py``) and the
    friction off (its columns on the internal nodes next to the hook are left out by design)."""
    scene = _scene(contact=ContactLaw(mu_s=0.0, mu_d=0.0))
    scene = eqx.tree_at(lambda s: s.cables.subsystems.cable.rhoA_kg_per_m, scene, scene.cables.subsystems.cable.rhoA_kg_per_m * 1e-9)  # fmt: skip
    y = _moving_state(scene)
    hooks = scene.hooks(y.rocket)
    blocks = jax.jit(lambda y: scene.cables.stiff_blocks(y.cables, hooks, 0.0))(y)

    def forces(q_, qdot_):
        st = eqx.tree_at(lambda s: (s.q, s.qdot), y.cables, (q_, qdot_))
        return scene.cables.cable_forces(st, hooks, 0.0)

    jac_r, jac_z = jax.jit(jax.jacfwd(forces, argnums=(0, 1)))(y.cables.q, y.cables.qdot)
    # the ring's stiffness on the node (9e7 N/m) and its Hunt-Crossley damping (0.2 s/m x the
    # spring's 2e6 N at the node's 2.2 cm offset: 4e5 N s/m)
    for arg, rz, zr, zz, least in ((0, "K_rz", "K_zr", "K_zz", 5e7), (1, "C_rz", "C_zr", "C_zz", 2e5)):

        def slow(d):
            return np.concatenate([np.asarray(d.s), np.asarray(d.h).reshape(d.h.shape[:-2] + (-1,)), np.asarray(d.u)[..., None]], axis=-1)  # fmt: skip

        cols_r, cols_z = slow(jac_r[arg]), slow(jac_z[arg])
        assert np.abs(cols_z[:, 5:8, :, 5:8]).max() > least
        for c in range(4):
            np.testing.assert_allclose(np.asarray(blocks[rz])[c], cols_r[c, :, :, c], atol=1e-9 * np.abs(cols_r).max())
            np.testing.assert_allclose(np.asarray(blocks[zz])[c], cols_z[c, :, c], atol=1e-9 * np.abs(cols_z).max())
            # the border's rows (stored transposed, as the columns): d Q_slow / d r
            rows_z = np.transpose(np.asarray(jac_z[arg].r)[c, :, c], (1, 2, 0))  # (n, 3, n_slow)
            np.testing.assert_allclose(np.asarray(blocks[zr])[c], rows_z, atol=1e-9 * np.abs(rows_z).max())


def test_node_bordered_solve_equals_the_dense_lu():
    """The W-method's linear solve with hook nodes in the border (the node's ``s_h`` and position,
    and its columns on the rocket through the ring): ``(beta I - J) x = b`` by the block-tridiagonal
    bordered solve against the dense LU of the same ``J``, for a random ``b`` at two ``beta``."""
    scene = _scene()
    y = _moving_state(scene)
    flat, unravel = ravel_pytree(y)
    b = unravel(jnp.asarray(np.random.default_rng(1).normal(size=flat.shape)))

    @jax.jit
    def both(y, b, beta):
        lin = scene.stiff_linearisation(0.0, y)
        return (ravel_pytree(lin.factor(beta).solve(b))[0], ravel_pytree(dense_reference(lin, y).factor(beta).solve(b))[0])

    for beta in (1e3, 1e5):  # [1/s]: 1 / (gamma h) at h of 1 ms and 10 us
        x_s, x_d = (np.asarray(v) for v in both(y, b, beta))
        np.testing.assert_allclose(x_s, x_d, atol=1e-10 * np.abs(x_d).max())


# slow tier (about 60 s on 2 cores, mostly compiling the landing): the default tier checks the node's
# accounting through the conservative ring above and its W-method rows through the step and blocks
@pytest.mark.slow
def test_landing_with_hook_nodes_closes_the_energy_budget():
    """The capture and the cables' pick-up with hook nodes (W-method, default solver): solved, the
    hooks loaded, and the budget (the ring's and the friction's work on both sides counted) closed
    to 1e-4 of the initial energy."""
    scene = _scene(beta=1e-2)
    res = simulate(scene, 0.05, solver="rosw", rtol=1e-6, atol=1e-6)
    assert res.ok
    out = scene.summarize(res)
    assert float(np.max(np.asarray(res.probes["hook_normal_force_N"]))) > 1e4
    assert out["energy_budget_error"] < 1e-4


def test_sweeps_carry_the_hook_model_in_their_identity():
    """A sweep's rows resume only under the same hook model and mesh: ``describe`` names them at the
    ale/full levels (the default: the node on the level's mesh, 80 span elements with 16 fine at
    both), and stays as before for the capsule contact on 32 span elements (16 fine),
    so that sweeps written with those still resume with them given; the rigid level names neither
    and refuses the node, whose cables have no nodes."""
    from jaxcable.arresting.sweep import passive_case_fn
    from jaxcable.arresting.two_phase import two_phase_case_fn

    for factory in (passive_case_fn, two_phase_case_fn):
        d = factory("ale").describe()
        assert (d["hook_contact"], d["n_span_elements"], d["n_fine"]) == ("node", 80, 16)
        assert factory("ale", hook_contact="node", n_span_elements=80, n_fine=16).describe() == d
        full = factory("full").describe()
        assert (full["hook_contact"], full["n_span_elements"], full["n_fine"]) == ("node", 80, 16)
        assert factory("ale", n_span_elements=64, n_fine=32).describe()["n_fine"] == 32
        assert factory("full", hook_contact="capsule").describe()["hook_contact"] == "capsule"
        assert factory("full", n_span_elements=48).describe()["n_span_elements"] == 48
        legacy = factory("full", hook_contact="capsule", n_span_elements=32, n_fine=16).describe()
        assert not {"hook_contact", "n_span_elements", "n_fine"} & set(legacy)
        assert not {"hook_contact", "n_span_elements", "n_fine"} & set(factory("rigid").describe())
        with pytest.raises(ValueError, match="n_span_elements must be >= n_fine"):
            factory("full", n_span_elements=20, n_fine=20)
        with pytest.raises(ValueError, match="hook_contact='node' needs fidelity 'ale' or 'full'"):
            factory("rigid", hook_contact="node")
        with pytest.raises(ValueError, match="hook_contact must be 'capsule' or 'node'"):
            factory("full", hook_contact="ring")
        # the rocket's bodies: named only where not the default 5, and only at the full level
        assert "n_rocket_bodies" not in full
        assert factory("full", n_rocket_bodies=5).describe() == full
        one = factory("full", n_rocket_bodies=1).describe()
        assert one["n_rocket_bodies"] == 1 and {k: v for k, v in one.items() if k != "n_rocket_bodies"} == full
        assert factory("full", hook_contact="capsule", n_span_elements=32, n_fine=16, n_rocket_bodies=1).describe()["n_rocket_bodies"] == 1
        with pytest.raises(ValueError, match="n_rocket_bodies=1 needs fidelity 'full'"):
            factory("ale", n_rocket_bodies=1)
        with pytest.raises(ValueError, match="n_rocket_bodies must be an integer"):
            factory("full", n_rocket_bodies=0)


def test_case_functions_build_the_rocket_bodies_asked_for():
    """A passive sweep's case at the full level builds its scene with the rocket's bodies of
    ``n_rocket_bodies`` (the default 5 otherwise)."""
    from jaxcable.arresting.sweep import passive_case_fn
    from jaxcable.arresting.uncertainty import halton_samples

    params = {k: float(v[0]) for k, v in halton_samples(1, "I").items()}
    assert passive_case_fn("full").build(params).rocket.n_bodies == 5
    assert passive_case_fn("full", n_rocket_bodies=1).build(params).rocket.n_bodies == 1
    # the scene itself refuses bodies where the rocket is one rigid body, rather than ignoring them
    with pytest.raises(ValueError, match="n_rocket_bodies=1 needs fidelity 'full'"):
        passive_landing_scene("ale", n_rocket_bodies=1)


def test_the_node_slot_is_the_hook_node_of_the_route():
    """The index the contact reads the hook node at is the route's hook node (an odd span mesh: the
    two sub-spans differ by an element), and its material slot holds the hook's material coordinate."""
    cables = passive_landing_scene("ale", hook_contact="node", n_span_elements=17, n_fine=8).cables
    node, s_slot, _, _ = cables._node_slots()
    sub0 = jax.tree_util.tree_map(lambda x: x[0], cables.subsystems)
    q0 = jax.tree_util.tree_map(lambda x: x[0], cables.q0)
    r, _ = sub0.route.nodes(q0)
    np.testing.assert_array_equal(np.asarray(r[node]), np.asarray(q0.h[0]))
    b = sub0.route.hook_ids[0]
    assert float(q0.s[s_slot]) == float(sub0.route.s_boundary0[b])


def test_scene_refuses_the_hook_node_on_massless_cables():
    """The massless cables have no nodes: ``hook_contact='node'`` with them is an error naming both,
    not silently the capsule contact."""
    for fidelity, model in (("rigid", None), ("full", "massless")):
        with pytest.raises(ValueError, match="hook_contact='node' needs the ALE cables"):
            passive_landing_scene(fidelity, cable_model=model, hook_contact="node")
