"""The W-method on the ALE cables: structured linearisation and bordered solve against dense
references, stiff limits that explicit solvers cannot take, the energy budget, gradients against
central differences, vmap against single runs.

A small mesh (4 span elements, 2 of them fine) keeps the compile short; the structure (internal
nodes in three chains per cable, pulleys and the moving block as the border, four cables, contact
with the hooks) is the one of the default mesh."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree

from jaxcable import simulate
from jaxcable.arresting.passive import passive_landing_scene
from jaxcable.arresting.stiff import chain_plan, dense_reference
from jaxcable.components.contact import ContactLaw
from jaxcable.core.config import enable_x64
from jaxcable.core.rosenbrock import ROS34PW2, RosenbrockW

enable_x64()

T_END = 0.01  # [s]: the capture and the hook pick-up of the cable
MESH = dict(n_span_elements=4, n_fine=2)


def _scene(beta=1e-5, **kw):
    # the capsule contact unless asked: these tests differentiate its pairs (the node's: test_hook_node.py)
    return passive_landing_scene("ale", t_end_s=T_END, cable_damping_s=beta, **MESH, **{"hook_contact": "capsule", **kw})


def _moving_state(scene):
    """The capture state with the cables already moving (0.5 m/s downward at every internal node,
    0.2 m/s material flow over the pulleys), so the damping and friction terms are exercised."""
    y = scene.initial_state()
    qdot = y.cables.qdot
    qdot = eqx.tree_at(lambda d: (d.r, d.s), qdot, (qdot.r.at[..., 2].set(-0.5), qdot.s + 0.2))
    return eqx.tree_at(lambda s: s.cables.qdot, y, qdot)


SOLVER = RosenbrockW(jacobian_every=4)


# The blocks hold the stiff terms in closed form (AleCables.stiff_blocks): elasticity, Rayleigh
# damping, the weight, the contact. They leave out the moving material's inertia terms (of order
# rhoA sdot), so they equal the dense Jacobian exactly when the cable's mass per length is scaled
# away, and differ from it by those terms at the real mass: measured on this state (beta = 1e-3 s)
# 1.5e-9 of the largest entry in K, 1.1e-5 in C's internal blocks, 5.7e-3 in C's border columns.
# the real mass in the slow tier (20-25 s on 2 cores): the exact comparison is the massless one, and
# the real-mass difference is the measured size of the terms the blocks leave out (above)
@pytest.mark.parametrize(
    "mass_scale, rtol",
    [(1e-9, 1e-9), pytest.param(1.0, 3e-2, marks=pytest.mark.slow)],
    ids=["massless", "real mass"],
)
def test_blocks_equal_the_dense_jacobian_of_the_cable_forces(mass_scale, rtol):
    scene = _scene(beta=1e-3)
    scene = eqx.tree_at(lambda s: s.cables.subsystems.cable.rhoA_kg_per_m, scene, scene.cables.subsystems.cable.rhoA_kg_per_m * mass_scale)  # fmt: skip
    y = _moving_state(scene)
    hooks = scene.hooks(y.rocket)
    touching = float(scene.probe(0.0, y)["contact_pairs_touching"])
    assert touching > 0  # the hooks press on the cables: the contact blocks are exercised
    blocks = jax.jit(lambda y: scene.cables.stiff_blocks(y.cables, hooks, 0.0))(y)
    q, qdot = y.cables.q, y.cables.qdot

    def forces(q_, qdot_):
        st = eqx.tree_at(lambda s: (s.q, s.qdot), y.cables, (q_, qdot_))
        return scene.cables.cable_forces(st, hooks, 0.0)

    # output first: (d Q_r / d (q, qdot), d Q_slow / d (q, qdot))
    jac_r, jac_z = jax.jit(jax.jacfwd(forces, argnums=(0, 1)))(q, qdot)
    n = q.r.shape[1]
    for arg, tri, rz, zr, zz in ((0, "K_rr", "K_rz", "K_zr", "K_zz"), (1, "C_rr", "C_rz", "C_zr", "C_zz")):
        d_rr = np.asarray(jac_r[arg].r)  # (4, n, 3, 4, n, 3)
        lower, diag, upper = (np.asarray(b) for b in blocks[tri])
        scale = np.abs(d_rr).max()
        for c in range(4):
            for j in range(n):
                np.testing.assert_allclose(diag[c, j], d_rr[c, j, :, c, j, :], atol=rtol * scale)
                if j > 0:
                    np.testing.assert_allclose(lower[c, j], d_rr[c, j, :, c, j - 1, :], atol=rtol * scale)
                if j < n - 1:
                    np.testing.assert_allclose(upper[c, j], d_rr[c, j, :, c, j + 1, :], atol=rtol * scale)
                # nothing beyond the neighbours, and nothing between cables (the hooks held fixed)
                far = [k for k in range(n) if abs(k - j) > 1]
                assert np.abs(d_rr[c, j, :, c, far, :]).max(initial=0.0) <= 1e-12 * scale
                others = [k for k in range(4) if k != c]
                assert np.abs(d_rr[c, j, :, others]).max() <= 1e-12 * scale
        # the border's columns (pulley s, block u) on the internal rows and on the border rows
        cols_r = np.concatenate([np.asarray(jac_r[arg].s), np.asarray(jac_r[arg].u)[..., None]], axis=-1)
        cols_z = np.concatenate([np.asarray(jac_z[arg].s), np.asarray(jac_z[arg].u)[..., None]], axis=-1)
        for c in range(4):
            np.testing.assert_allclose(np.asarray(blocks[rz])[c], cols_r[c, :, :, c], atol=rtol * np.abs(cols_r).max())
            np.testing.assert_allclose(np.asarray(blocks[zz])[c], cols_z[c, :, c], atol=rtol * np.abs(cols_z).max())
            # the border's rows (stored transposed, as the columns): d Q_slow / d r
            rows_z = np.transpose(np.asarray(jac_z[arg].r)[c, :, c], (1, 2, 0))  # (n, 3, n_slow)
            np.testing.assert_allclose(np.asarray(blocks[zr])[c], rows_z, atol=rtol * np.abs(rows_z).max())


def test_stiff_contact_pairs_are_exact_while_that_many_pairs_touch():
    """The linearisation differentiates only the ``stiff_contact_pairs`` deepest hook-cable pairs
    (:class:`jaxcable.arresting.cable_sets.AleCables`): its blocks equal those from every picked
    pair while no more pairs touch than that, and lose contact stiffness when fewer are taken (so
    the setting is live); a bad count is refused by name."""
    import dataclasses

    scene = _scene(beta=1e-3)
    y = _moving_state(scene)
    hooks = scene.hooks(y.rocket)
    touching = int(scene.probe(0.0, y)["contact_pairs_touching"])
    assert touching >= 2

    def blocks(m):
        cables = dataclasses.replace(scene.cables, stiff_contact_pairs=m)
        return jax.jit(lambda y: cables.stiff_blocks(y.cables, hooks, 0.0))(y)

    # short: 1 pair. Not touching - 1: on this state the hooks' tips touch, and the pairs of the
    # barb capsule (which shares the tip) report the arm's penetration with zero force (measured:
    # 3e-33 N against 49 N), so dropping the last touching pairs changes nothing
    every, enough, short = blocks(None), blocks(touching), blocks(1)
    for name in ("K_rr", "C_rr", "K_rz", "K_zr", "K_zz"):
        for a, b in zip(jax.tree_util.tree_leaves(every[name]), jax.tree_util.tree_leaves(enough[name])):
            np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=0, atol=1e-12 * np.abs(np.asarray(a)).max())
    diag_every, diag_short = np.asarray(every["K_rr"][1]), np.asarray(short["K_rr"][1])
    assert np.abs(diag_short - diag_every).max() > 1e-3 * np.abs(diag_every).max()
    with pytest.raises(ValueError, match="stiff_contact_pairs.*0"):
        dataclasses.replace(scene.cables, stiff_contact_pairs=0)


@pytest.mark.parametrize("touching", [0, 5, 16, 40, 700])
def test_threshold_pick_is_the_deepest_pairs(touching):
    """The linearisation's cheap pick (bisected threshold and ``jnp.nonzero``, not ``lax.top_k``)
    against ``lax.top_k``: the same touching pairs while at most ``m`` touch; beyond, only pairs
    of the ``m`` deepest, each once, and nearly ``m`` of them; the free slots hold a pair out of
    contact."""
    from jaxcable.arresting.cable_sets import _deepest_pairs_by_threshold

    m, n = 16, 1024
    rng = np.random.default_rng(touching)
    depth = rng.uniform(1e-6, 1e-3, size=n)
    depth[rng.permutation(n)[touching:]] *= -1.0  # exactly `touching` pairs with positive penetration
    picked = np.asarray(_deepest_pairs_by_threshold(jnp.asarray(depth), m))
    deepest = set(np.asarray(jax.lax.top_k(jnp.asarray(depth), m)[1]).tolist())
    inside = [int(i) for i in picked if depth[i] > 0]
    assert len(inside) == len(set(inside))
    assert set(inside) <= deepest
    if touching <= m:
        assert set(inside) == {i for i in deepest if depth[i] > 0}
    else:
        assert len(inside) >= m - 2  # the bisection's resolution leaves out at most a near tie
    assert all(depth[i] <= 0 for i in picked if int(i) not in inside)


# h = 2e-3 s in the slow tier (each case 80-120 s on 2 cores; the same code path at another step);
# the hooks as sliding nodes in the slow tier too (50 s; the default tier checks their bordered solve
# against the dense LU, tests/arresting/test_hook_node.py)
@pytest.mark.parametrize(
    "h, hook_contact",
    [(1e-4, "capsule"), pytest.param(2e-3, "capsule", marks=pytest.mark.slow), pytest.param(1e-4, "node", marks=pytest.mark.slow)],
)
def test_structured_step_equals_the_dense_reference(h, hook_contact):
    """One step of the same method with the same ``J``, solved densely (LU of the assembled
    ``beta I - J``) and with the block-tridiagonal bordered solve: the same new state and the same
    error estimate (hence the same step-size decisions) to round-off; at a step where the stiff
    modes are far beyond ``1 / h`` (2 ms) as at one that resolves them (0.1 ms); with the hooks as
    sliding nodes (their positions and material coordinates in the border)."""
    scene = _scene(beta=1e-3, hook_contact=hook_contact)
    y = _moving_state(scene)
    term = diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y))
    structured = RosenbrockW(linearise=scene.stiff_linearisation)
    dense = RosenbrockW(linearise=lambda t, y: dense_reference(scene.stiff_linearisation(t, y), y))

    @jax.jit
    def step(y):
        out = []
        for solver in (structured, dense):
            state = solver.init(term, 0.0, h, y, None)
            y1, err, *_ = solver.step(term, 0.0, h, y, None, state, False)
            out.append((ravel_pytree(y1)[0], ravel_pytree(err)[0]))
        return out

    (y_s, e_s), (y_d, e_d) = step(y)
    scale = np.abs(np.asarray(y_d)).max()
    np.testing.assert_allclose(np.asarray(y_s), np.asarray(y_d), atol=1e-10 * scale)
    np.testing.assert_allclose(np.asarray(e_s), np.asarray(e_d), atol=1e-10 * scale)
    assert np.all(np.isfinite(np.asarray(y_s)))


def test_chain_plan_cuts_long_spans_at_separators():
    """The split of the sweeps (:func:`chain_plan`): every internal node is in exactly one piece or
    is a separator; no piece crosses a span's end or holds a separator; pieces and chunks are at
    most ``max_nodes`` long; a separator has a piece on both sides; the default mesh's two 39-node
    spans (with the towers' single nodes) become four chunks of 20."""
    for counts in ([0, 1, 39, 39, 1, 0], [0, 1, 7, 1, 0], [5], [0, 2, 64, 2, 0], [3, 0, 3]):
        spans = np.cumsum([0] + counts)
        for max_nodes in (1, 2, 3, 7, 20, 40, 200):
            plan = chain_plan(counts, max_nodes)
            seen = np.zeros(plan.n, int)
            for a, b in plan.pieces:
                assert 0 < b - a <= max(max_nodes, 2)  # 2: an even span at max_nodes = 1
                seen[a:b] += 1
                assert np.searchsorted(spans, a, side="right") == np.searchsorted(spans, b - 1, side="right")
            for k in plan.separators:
                seen[k] += 1
                assert any(b == k for _, b in plan.pieces) and any(a == k + 1 for a, _ in plan.pieces)
            assert np.all(seen == 1) and plan.n == sum(counts)
            assert sorted(p for c in plan.chunks for p in c) == list(range(len(plan.pieces)))
            assert plan.length <= max(max_nodes, 2)
            assert plan.trivial == (max_nodes >= plan.n)
    plan = chain_plan([0, 1, 39, 39, 1, 0], 20)
    assert (len(plan.chunks), plan.length, plan.separators) == (4, 20, (20, 59))
    # the scenes' default (no separators): the two spans side by side, each with its tower node
    plan = chain_plan([0, 1, 39, 39, 1, 0])
    assert (plan.chunks, plan.length, plan.separators) == (((0, 1), (2, 3)), 40, ())
    assert chain_plan([0, 2, 64, 2, 0]).trivial and chain_plan([]).trivial
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="max_nodes"):
            chain_plan([4], bad)


@pytest.mark.parametrize("hook_contact, max_nodes", [("capsule", 2), ("node", 1), ("node", 2)])
def test_shorter_sweeps_solve_like_the_dense_reference(hook_contact, max_nodes):
    """The sweeps cut at separator nodes (which join the border's Schur complement) and run side by
    side: one step equals the dense LU of the same ``J`` to round-off, as the single sweep does;
    on 8 span elements with 1-2 nodes a piece, so that the cuts fall inside the spans (the scenes'
    default makes no cuts: it splits at the spans' ends only)."""
    import dataclasses

    scene = passive_landing_scene("ale", t_end_s=T_END, cable_damping_s=1e-3, n_span_elements=8, n_fine=4, hook_contact=hook_contact)
    y = _moving_state(scene)
    counts = [np.shape(f)[-1] for f in scene.cables.subsystems.route.fractions]
    plan = chain_plan(counts, max_nodes)
    assert plan.separators and not plan.trivial
    term = diffrax.ODETerm(lambda t, y, args: scene.vector_field(t, y))
    cut = RosenbrockW(linearise=lambda t, y_: dataclasses.replace(scene.stiff_linearisation(t, y_), plan=plan))
    dense = RosenbrockW(linearise=lambda t, y_: dense_reference(scene.stiff_linearisation(t, y_), y_))

    @jax.jit
    def step(y):
        out = []
        for solver in (cut, dense):
            state = solver.init(term, 0.0, 1e-4, y, None)
            y1, err, *_ = solver.step(term, 0.0, 1e-4, y, None, state, False)
            out.append((ravel_pytree(y1)[0], ravel_pytree(err)[0]))
        return out

    (y_c, e_c), (y_d, e_d) = step(y)
    np.testing.assert_allclose(np.asarray(y_c), np.asarray(y_d), atol=1e-10 * np.abs(np.asarray(y_d)).max())
    np.testing.assert_allclose(np.asarray(e_c), np.asarray(e_d), atol=1e-10 * np.abs(np.asarray(e_d)).max())

    # derivatives through the cut solve: those of the single sweep (whose solves the whole-run
    # gradient test checks against central differences), forward and reverse
    lin = scene.stiff_linearisation(0.0, y)
    rhs = jax.tree_util.tree_map(lambda x: jnp.cos(jnp.arange(x.size, dtype=float).reshape(x.shape)), y)

    def solution(beta, plan_):
        x = dataclasses.replace(lin, plan=plan_).factor(beta).solve(rhs)
        return jnp.sum(jnp.sin(ravel_pytree(x)[0]))

    beta0 = 1.0 / (1e-4 * ROS34PW2.gamma)
    for mode in (jax.grad, lambda f: (lambda b: jax.jvp(f, (b,), (1.0,))[1])):
        d_cut = float(mode(lambda b: solution(b, plan))(beta0))
        d_one = float(mode(lambda b: solution(b, None))(beta0))
        assert np.isfinite(d_cut) and d_cut == pytest.approx(d_one, rel=1e-8, abs=1e-14)


@pytest.fixture(scope="module")
def stiff_runs():
    """One compiled solve, four variants: default, beta = 1e-2 s, contact stiffness x10, both."""
    base = ContactLaw(v_s=0.5, v_d=1.25)
    variants = {
        "default": _scene(beta=1e-5, contact=base),
        "beta 1e-2": _scene(beta=1e-2, contact=base),
        "contact x10": _scene(beta=1e-5, contact=eqx.tree_at(lambda c: c.k, base, base.k * 10.0)),
        "both": _scene(beta=1e-2, contact=eqx.tree_at(lambda c: c.k, base, base.k * 10.0)),
    }
    return {k: simulate(s, T_END, solver=SOLVER, rtol=1e-6, atol=1e-6) for k, s in variants.items()}


def test_stiff_limits_run_and_close_the_energy_budget(stiff_runs):
    """beta = 1e-2 s needs explicit steps of ~1e-6 s on the fine elements (the stability limit of
    central differences with stiffness-proportional damping, ``../shared/notes/stiff-cables.md``);
    here the run takes a few hundred steps and the energy budget closes to 1e-4 of the initial
    energy."""
    for name, r in stiff_runs.items():
        o = r.outputs
        assert r.status_message == "successful", name
        for k in ("z_max_m", "a_max_g", "sigma_max_mpa", "energy_budget_error"):
            assert np.isfinite(float(o[k])), (name, k)
        assert float(o["energy_budget_error"]) < 1e-4, (name, float(o["energy_budget_error"]))
        # an explicit solver at 1e-6 s would take 1e4 steps over these 10 ms
        assert int(r.num_steps) < 2_000, (name, int(r.num_steps))


def test_damping_dissipates_what_the_rayleigh_function_says(stiff_runs):
    """With beta = 1e-2 s the cables' dissipation (integrated ``2 D = beta EA sum L eps_dot^2``) is
    far above the default's, and the stored + dissipated energy still balances (budget above)."""
    e_hi = float(stiff_runs["beta 1e-2"].probes["energy"]["dissipated_brakes_damping"][-1])
    e_lo = float(stiff_runs["default"].probes["energy"]["dissipated_brakes_damping"][-1])
    assert e_hi > 10.0 * max(e_lo, 1.0)


def _final_vz(scene, adjoint):
    def f(mass_scale):
        scene_ = eqx.tree_at(
            lambda s: s.cables.subsystems.buffer.counterweight_mass_kg,
            scene,
            scene.cables.subsystems.buffer.counterweight_mass_kg * mass_scale,
        )
        r = simulate(scene_, 5e-3, solver=SOLVER, rtol=1e-8, atol=1e-8, adjoint=adjoint, save_ts=jnp.array([0.0, 5e-3]))
        return jnp.ravel(r.final_state.rocket.v)[2]  # vertical velocity of the (first) body [m/s]

    return f


@pytest.mark.slow
def test_gradients_match_central_differences_forward_and_reverse():
    """d(vertical velocity at 5 ms)/d(counterweight mass scale) through the W-method (its
    linearisation and structured solves included), forward and reverse mode, against central
    differences of the same solve."""
    scene = _scene(beta=1e-3)
    f_rev = _final_vz(scene, diffrax.RecursiveCheckpointAdjoint())
    f_fwd = _final_vz(scene, diffrax.ForwardMode())
    g_rev = float(jax.jit(jax.grad(f_rev))(1.0))
    # one compiled forward-mode program gives the tangent at 1 and the values at 1 -+ h
    h = 1e-3
    values, tangents = jax.jit(jax.vmap(lambda x: jax.jvp(f_fwd, (x,), (1.0,))))(jnp.array([1.0 - h, 1.0, 1.0 + h]))
    g_fwd = float(tangents[1])
    fd = float((values[2] - values[0]) / (2 * h))
    assert np.isfinite(g_rev) and np.isfinite(g_fwd)
    assert g_fwd == pytest.approx(g_rev, rel=1e-6)
    assert g_rev == pytest.approx(fd, rel=1e-3, abs=1e-6)


@pytest.mark.slow
def test_vmap_equals_single_runs(stiff_runs):
    betas = jnp.array([1e-4, 1e-2])

    base = _scene(beta=1e-4, contact=ContactLaw(v_s=0.5, v_d=1.25))

    def z_max(beta):
        scene = eqx.tree_at(lambda s: s.cables.subsystems.cable.damping_s, base, jnp.full(4, beta))
        return simulate(scene, T_END, solver=SOLVER, rtol=1e-6, atol=1e-6).outputs["sigma_max_mpa"]

    batched = np.asarray(jax.vmap(z_max)(betas))
    single = np.array([float(z_max(b)) for b in betas])
    np.testing.assert_allclose(batched, single, rtol=1e-9)


def test_level_solver_settings_follow_the_measured_crossover():
    from jaxcable.arresting.landing import (
        LEVEL_DEFAULTS,
        STIFF_DAMPING_S,
        STIFF_LEVEL_DEFAULTS,
        level_solver_settings,
    )
    from jaxcable.studies import registry

    # the default damping (calibrated, 6.3e-3 s) and a traced one take the W-method at ale and full
    assert level_solver_settings("ale") == STIFF_LEVEL_DEFAULTS["ale"]
    assert level_solver_settings("full") == STIFF_LEVEL_DEFAULTS["full"]
    assert level_solver_settings("rigid") == LEVEL_DEFAULTS["rigid"]
    traced = jax.jit(lambda b: jnp.asarray(level_solver_settings("ale", b)[0] == "rosw"))(1e-5)
    assert bool(traced)
    # the hook as a sliding node (the default): the W-method at every damping, also undamped
    for level in ("ale", "full"):
        for beta in (0.0, 1e-5, 1e-2):
            assert level_solver_settings(level, beta) == STIFF_LEVEL_DEFAULTS[level]
            assert level_solver_settings(level, beta, "node") == STIFF_LEVEL_DEFAULTS[level]
    # the capsule contact: explicit below its measured crossover, the W-method from it on
    assert level_solver_settings("ale", 1e-5, "capsule") == LEVEL_DEFAULTS["ale"]
    assert level_solver_settings("full", STIFF_DAMPING_S["full"], "capsule") == STIFF_LEVEL_DEFAULTS["full"]
    assert level_solver_settings("full", STIFF_DAMPING_S["ale"], "capsule") == LEVEL_DEFAULTS["full"]
    assert level_solver_settings("ale", 1e-2, "capsule")[0] == "rosw"
    assert level_solver_settings("rigid", 1e-2) == LEVEL_DEFAULTS["rigid"]  # no cable mass: no stiff nodes
    for name in ("ale", "full", "ale_stiff"):
        assert registry.bench_case(name).level in ("ale", "full")


# slow tier: 70-100 s on 2 cores (a dense J and a jacfwd of the vector field compiled); the default
# tier keeps the W-method with the hook columns in J through the stiff limits and the structured
# step against the dense reference (this file)
@pytest.mark.slow
def test_hook_coupling_columns_are_the_vector_fields_own():
    """The W-method's ``J`` holds the cable rows' columns on the rocket's coordinates (the contact
    forces move with the hooks, :class:`jaxcable.arresting.stiff.HookCoupling`): assembled densely
    they equal the true Jacobian of the vector field on those rows and columns (``jax.jacfwd`` over
    the rocket's coordinates, independent of the structured code)."""
    scene = _scene(beta=1e-3)
    y = _moving_state(scene)
    flat, unravel = ravel_pytree(y)
    n = flat.shape[0]
    r_flat, r_unravel = ravel_pytree(y.rocket)

    @jax.jit
    def both(y):
        J = dense_reference(scene.stiff_linearisation(0.0, y), y).jacobian
        accel = lambda v: scene.vector_field(0.0, eqx.tree_at(lambda s: s.rocket, y, r_unravel(v))).cables.qdot.r.ravel()
        return J, jax.jacfwd(accel)(r_flat)

    J, block_true = (np.asarray(a) for a in both(y))
    index = unravel(jnp.arange(n, dtype=flat.dtype))
    rocket = np.asarray(ravel_pytree(index.rocket)[0]).astype(int)
    rows = np.asarray(index.cables.qdot.r).astype(int).ravel()  # the internal nodes' accelerations
    block = J[np.ix_(rows, rocket)]
    scale = np.abs(block_true).max()
    assert scale > 1e6  # [1/s^2]: the contact stiffness over a node's mass, exercised
    np.testing.assert_allclose(block, block_true, atol=1e-8 * scale)
    assert scene.stiff_linearisation(0.0, y, hook_coupling=False).coupling is None


# slow tier: 40-45 s on 2 cores (the full level's scene compiled for one Jacobian); the default tier
# runs the full level through the W-method (tests/arresting/test_stiff_limits.py, the landing tests)
@pytest.mark.slow
def test_hinge_jacobian_is_the_vector_fields_diagonal():
    """The hooks' hinge rows of the W-method's ``J`` at the full level
    (:meth:`PassiveLandingScene._hinge_jacobian`: torque derivatives times the hinges' inverse
    inertia, hooks uncoupled) against ``jax.jacfwd`` of the vector field over the hinge angles and
    rates, with the hooks pressed 5 cm into the cables (the contact dominates: |K| ~ 1e8 1/s^2
    against the spring's 7e3). The approximation leaves out the hooks' coupling through the
    rocket's inertia (measured off-diagonal: 0.2% of the diagonal in angle, 0.5% in rate), the
    contact's push on the rocket's bodies and the lever's change with the angle (measured on the
    diagonal: 3.7% in angle, 3.2% in rate); the bounds, 2% and 10%, sit between those and an
    error of a missing term (the damper alone would miss C by 30%, the spring alone K by 100%)."""
    from jaxcable.arresting.passive import _hinge_rows

    scene = passive_landing_scene("full", t_end_s=T_END, hook_contact="capsule", **MESH)
    y = scene.initial_state()
    y = eqx.tree_at(lambda s: s.rocket.r, y, y.rocket.r.at[:, 2].add(-0.05))

    @jax.jit
    def both(y):
        K, C, _ = scene._hinge_jacobian(0.0, y)
        acc = lambda p, r: scene.vector_field(0.0, eqx.tree_at(_hinge_rows, y, (p, r))).rocket.hinge_rate
        return K, C, *jax.jacfwd(acc, argnums=(0, 1))(*_hinge_rows(y))

    K, C, K_true, C_true = (np.asarray(a) for a in both(y))
    p = scene.rocket.params
    assert np.all(-np.diag(K_true) > 1e3 * p.hook_rotational_stiffness_N_m_per_rad / 251.0)  # contact-dominated
    for approx, true in ((K, K_true), (C, C_true)):
        d = np.diag(true)
        np.testing.assert_allclose(np.diag(approx), d, rtol=0.1)
        assert np.all(approx == np.diag(np.diag(approx)))
        assert np.abs(true - np.diag(d)).max() < 0.02 * np.abs(d).min()


def test_hinge_reaction_rows_are_the_vector_fields_own_and_solve_like_the_dense_lu():
    """The rocket bodies' rows of ``J`` through the hooks' spring-dampers (``hinge_reaction``, the
    other side of the force pair the hinge rows hold): with the hooks 1 m clear of the cables and
    at rest on their hinges, the rocket's accelerations depend on the hinge rates through the
    dampers alone, so their columns must equal ``jax.jacfwd`` of the vector field to round-off (a
    wrong sign or a missing inverse-inertia column misses by 100%); and the solve with those rows
    (hinges, then the rocket's speeds, then the cables) must equal the dense LU of the same ``J``
    for a random right-hand side."""
    from jaxcable.arresting.passive import _hinge_rows

    scene = passive_landing_scene("full", t_end_s=T_END, hook_contact="capsule", **MESH)
    y = scene.initial_state()
    y = eqx.tree_at(lambda s: (s.rocket.r, s.rocket.hinge_rate), y, (y.rocket.r.at[:, 2].add(1.0), 0.0 * y.rocket.hinge_rate))
    flat, unravel = ravel_pytree(y)
    b = unravel(jnp.asarray(np.random.default_rng(2).normal(size=flat.shape)))

    @jax.jit
    def parts(y, b):
        lin = scene.stiff_linearisation(0.0, y)
        def speeds(r):
            d = scene.vector_field(0.0, eqx.tree_at(_hinge_rows, y, (_hinge_rows(y)[0], r))).rocket
            return jnp.concatenate([d.v.reshape(-1), d.omega_body.reshape(-1)])

        true = jax.jacfwd(speeds)(_hinge_rows(y)[1])  # (speeds, hinges)
        solves = [ravel_pytree(lin.factor(beta).solve(b))[0] for beta in (1e3, 1e5)]
        dense = [ravel_pytree(dense_reference(lin, y).factor(beta).solve(b))[0] for beta in (1e3, 1e5)]
        return lin.hinge_reaction, true, solves, dense

    (G_v, G_w, _, c), true, solves, dense = parts(y, b)
    G = np.concatenate([np.asarray(G_v).reshape(4, -1), np.asarray(G_w).reshape(4, -1)], axis=1).T
    np.testing.assert_allclose(G * np.asarray(c)[None, :], np.asarray(true), rtol=1e-9, atol=1e-12 * np.abs(true).max())
    assert np.abs(true).max() > 1.0  # the dampers' reaction is there to be checked
    for x_s, x_d in zip(solves, dense):
        np.testing.assert_allclose(np.asarray(x_s), np.asarray(x_d), atol=1e-10 * np.abs(np.asarray(x_d)).max())


@pytest.mark.parametrize("hook_contact", ["capsule", "node"])
def test_block_assembly_equals_the_dense_chain_rule(hook_contact):
    """:meth:`CableSubsystem.assemble_stiff_blocks` (element by element, on the nonzero rows of
    the map to the slow coordinates only) against the plain chain rule ``K = A^T K_x A``: random
    dense element Jacobians summed into the nodal matrix ``K_x``, and ``A`` the Jacobian of
    :meth:`CableRoute.nodes` by ``jax.jacfwd`` (independent of the assembly's hand-made map).
    Every cable of the scene: with hook nodes (node contact) and without (capsule), the moving
    block, pulleys and fixed ends. The brake's derivative is switched off (zero friction), so the
    blocks are the assembly alone."""
    scene = _scene(hook_contact=hook_contact)
    y = _moving_state(scene)
    rng = np.random.default_rng(7)
    for c in range(4):
        sub = jax.tree_util.tree_map(lambda x, c=c: x[c] if eqx.is_array(x) and x.ndim > 0 else x, scene.cables.subsystems)
        sub = eqx.tree_at(lambda s: s.buffer, sub, eqx.tree_at(lambda b: b.brake_force_N, sub.buffer, 0.0 * sub.buffer.brake_force_N))
        q = jax.tree_util.tree_map(lambda x, c=c: x[c], y.cables.q)
        qdot = jax.tree_util.tree_map(lambda x, c=c: x[c], y.cables.qdot)
        n_el = sub.route.n_nodes - 1
        J_z, J_zd = (jnp.asarray(rng.normal(size=(n_el, 8, 8))) for _ in range(2))
        (K_rr, C_rr), (K_rz, C_rz), (K_zz, C_zz), (K_zr, C_zr) = sub.assemble_stiff_blocks(q, qdot, J_z, J_zd)
        flat, unravel = ravel_pytree(q)

        def nodal(v, sub=sub, unravel=unravel):
            r, s = sub.route.nodes(unravel(v))
            return jnp.concatenate([r, s[:, None]], axis=1).reshape(-1)  # (N * 4,): (r_n, s_n) per node

        A = np.asarray(jax.jacfwd(nodal)(flat))  # (4 N, n_q)
        n_int = q.r.shape[0]
        for J, tri, rz, zz, zr in ((J_z, K_rr, K_rz, K_zz, K_zr), (J_zd, C_rr, C_rz, C_zz, C_zr)):
            Kx = np.zeros((4 * (n_el + 1),) * 2)
            for e in range(n_el):
                Kx[4 * e : 4 * e + 8, 4 * e : 4 * e + 8] += np.asarray(J[e])
            K = A.T @ Kx @ A  # in the order of ravel_pytree(q)
            # each coordinate's position in the flat vector; the slow ones in the blocks' order: s, h (flattened), u
            index = jax.tree_util.tree_map(lambda x: np.asarray(x).astype(int).ravel(), unravel(jnp.arange(flat.size, dtype=flat.dtype)))
            r_idx, slow_idx = index.r, np.concatenate([index.s, index.h, index.u])
            scale = np.abs(K).max()
            lower, diag, upper = (np.asarray(b) for b in tri)
            Krr = K[np.ix_(r_idx, r_idx)].reshape(n_int, 3, n_int, 3)
            for j in range(n_int):
                np.testing.assert_allclose(diag[j], Krr[j, :, j], atol=1e-12 * scale)
                if j > 0:
                    np.testing.assert_allclose(lower[j], Krr[j, :, j - 1], atol=1e-12 * scale)
                if j < n_int - 1:
                    np.testing.assert_allclose(upper[j], Krr[j, :, j + 1], atol=1e-12 * scale)
            np.testing.assert_allclose(np.asarray(rz), K[np.ix_(r_idx, slow_idx)].reshape(n_int, 3, -1), atol=1e-12 * scale)
            np.testing.assert_allclose(np.asarray(zz), K[np.ix_(slow_idx, slow_idx)], atol=1e-12 * scale)
            np.testing.assert_allclose(np.asarray(zr), K[np.ix_(slow_idx, r_idx)].T.reshape(n_int, 3, -1), atol=1e-12 * scale)
            assert np.abs(K[np.ix_(r_idx, slow_idx)]).max() > 0.1  # the border is exercised
