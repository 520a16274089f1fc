"""The ale level's sparse contact derivative (``AleCables.contact_tangent_pairs``).

The values of the hook-cable contact are computed for every (cable, hook capsule, element) pair;
a JVP carries tangents through the M pairs of largest penetration only. Pairs out of contact
have zero force and zero derivative, so the derivative is exact while at most M pairs touch.
Checked here against the all-pairs derivative and against central finite differences of the
vector field (an independent check of the hand-written JVP rule), and shown to go wrong when M is
below the number of touching pairs (so the comparison can fail)."""

import dataclasses

import equinox as eqx
import jax
import numpy as np
import pytest

import jaxcable
from jaxcable.arresting.cable_sets import AleCables
from jaxcable.arresting.passive import LIGHT_CABLE_DAMPING_S, passive_landing_scene
from jaxcable.core.simulate import simulate

T_STATE = 0.06  # s into the design case: the hooks hold the cables (8 pairs touch)


@pytest.fixture(scope="module")
def mid_landing():
    jaxcable.enable_x64()
    # the lightly damped cable on 16 span elements (the pair counts below are this mesh's), explicit
    # Bosh3: the contact derivative is under test here, not the scenes' calibrated, stiff default
    base = passive_landing_scene("ale", t_end_s=0.3, cable_damping_s=LIGHT_CABLE_DAMPING_S, n_span_elements=16, n_fine=8, hook_contact="capsule")
    y = simulate(base, T_STATE, solver="bosh3", rtol=1e-4, atol=1e-4, max_steps=100_000).final_state
    direction = jax.tree_util.tree_map(lambda x: jax.random.normal(jax.random.PRNGKey(3), x.shape), y)
    return base, y, direction


# Compiled once per cable structure (``contact_tangent_pairs`` is static) and shared by the tests;
# everything else is NumPy, so no test compiles an operation at a time.
_touching = eqx.filter_jit(lambda scene, y: scene.probe(T_STATE, y)["contact_pairs_touching"])
_vector_field = eqx.filter_jit(lambda scene, y: scene.vector_field(T_STATE, y))
_jvp = eqx.filter_jit(lambda scene, y, d: jax.jvp(lambda y_: scene.vector_field(T_STATE, y_), (y,), (d,)))
_vjp = eqx.filter_jit(lambda scene, y, c: jax.vjp(lambda y_: scene.vector_field(T_STATE, y_), y)[1](c)[0])


def _with(scene, m):
    return dataclasses.replace(scene, cables=dataclasses.replace(scene.cables, contact_tangent_pairs=m))


def _jvp_vjp(scene, y, direction, vjp=True):
    value, tangent = _jvp(scene, y, direction)
    cotangent = _vjp(scene, y, direction) if vjp else None
    return value, tangent, cotangent


def _max_rel(a, b):
    la = [np.asarray(x) for x in jax.tree_util.tree_leaves(a)]
    lb = [np.asarray(x) for x in jax.tree_util.tree_leaves(b)]
    scale = max(float(np.max(np.abs(x))) for x in la if x.size)
    return max(float(np.max(np.abs(x - z))) for x, z in zip(la, lb) if x.size) / scale


# slow tier: 100-120 s on 2 cores; test_too_few_tangent_pairs_break_the_derivative (below) keeps the
# sparse derivative's failure mode in the default tier
@pytest.mark.slow
def test_sparse_contact_derivative_equals_all_pairs_and_finite_differences(mid_landing):
    base, y, direction = mid_landing
    assert base.cables.contact_tangent_pairs == 48  # the default
    touching = int(_touching(base, y))
    assert 0 < touching <= 48
    v_all, t_all, c_all = _jvp_vjp(_with(base, None), y, direction)
    v_48, t_48, c_48 = _jvp_vjp(base, y, direction)
    assert _max_rel(v_all, v_48) < 1e-12  # values never depend on M (to round-off: two programs)
    assert _max_rel(t_all, t_48) < 1e-12
    assert _max_rel(c_all, c_48) < 1e-12
    # independent: central differences of the vector field along the same direction
    h = 1e-7
    step = lambda s: jax.tree_util.tree_map(lambda a, d: np.asarray(a) + s * h * np.asarray(d), y, direction)  # noqa: E731
    up, down = _vector_field(base, step(1.0)), _vector_field(base, step(-1.0))
    fd = jax.tree_util.tree_map(lambda p, m: (np.asarray(p) - np.asarray(m)) / (2 * h), up, down)
    # measured 2.8e-8 of the largest component at h = 1e-7 (2.8e-6 at h = 1e-6: the truncation
    # error of the stiff contact, ~h^2; round-off ~eps/h is 1e-9)
    assert _max_rel(t_48, fd) < 1e-6


def test_too_few_tangent_pairs_break_the_derivative(mid_landing):
    """The comparison above can fail: with M below the number of touching pairs the dropped pairs'
    derivative is missing (the values stay exact: equal to round-off, since the two programs are
    compiled apart and XLA may order their sums differently; measured 1e-20)."""
    base, y, direction = mid_landing
    touching = int(_touching(base, y))
    v_all, t_all, _ = _jvp_vjp(_with(base, None), y, direction, vjp=False)
    v_few, t_few, _ = _jvp_vjp(_with(base, max(1, touching // 2)), y, direction, vjp=False)
    assert _max_rel(v_all, v_few) < 1e-12
    assert _max_rel(t_all, t_few) > 1e-3  # measured 0.15 with 4 of the 8 touching pairs


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, "48"])
def test_bad_tangent_pair_count_is_refused(mid_landing, bad):
    base, _, _ = mid_landing
    with pytest.raises(ValueError, match="contact_tangent_pairs"):
        dataclasses.replace(base.cables, contact_tangent_pairs=bad)
    assert isinstance(base.cables, AleCables)
