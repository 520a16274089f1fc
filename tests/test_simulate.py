"""simulate(): probes evaluated inside the solver's loop or on the saved states after it.

The two ways must give the same histories, outputs and gradients (the probe of the same
interpolated state), saved times a run never reached must stay ``inf`` in the histories without
making a gradient NaN, and the automatic choice must follow the sizes of state and probe.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.arresting.passive import passive_landing_scene, smooth_landing_outputs
from jaxcable.throw import line_throwing_scene, with_angle
from jaxcable.core.simulate import probes_after_solve, simulate


def _leaves_close(a, b, rtol, atol=0.0):
    for u, v in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_allclose(np.asarray(u), np.asarray(v), rtol=rtol, atol=atol)


@pytest.fixture(scope="module")
def rigid_scene():
    return passive_landing_scene("rigid", t_end_s=0.6)


def test_automatic_choice_follows_sizes(rigid_scene):
    # rigid level: 25 state numbers, 29 probe numbers -> after; ALE cables and the rope: inside
    assert probes_after_solve(rigid_scene)
    assert not probes_after_solve(passive_landing_scene("ale", t_end_s=0.1))
    assert not probes_after_solve(line_throwing_scene(segment_length_m=5.0, rope_length_m=100.0))


def test_rigid_landing_same_histories_and_outputs(rigid_scene):
    inside = simulate(rigid_scene, 0.6, probes_after=False)
    after = simulate(rigid_scene, 0.6, probes_after=True)
    assert int(inside.num_steps) > 100
    # same steps (the step sequence does not depend on where the probe runs)
    assert int(inside.num_steps) == int(after.num_steps)
    np.testing.assert_array_equal(np.asarray(inside.ts), np.asarray(after.ts))
    # round-off apart: the probe of the same interpolated state, in another XLA program
    _leaves_close(inside.probes, after.probes, rtol=1e-9, atol=1e-6)
    for key in ("z_max_m", "a_max_g", "sigma_max_mpa", "stop_time_s", "energy_budget_error"):
        np.testing.assert_allclose(float(inside.outputs[key]), float(after.outputs[key]), rtol=1e-9, atol=1e-12)


@pytest.mark.slow
def test_rigid_landing_same_gradient(rigid_scene):
    # d(soft a_max)/d(m_w) through the solve, reverse mode, both ways. Slow tier: its two reverse-mode
    # programs took 99 s of the default tier's 18.6 min on 2 cores (CI's limit: 20 min); the histories
    # and outputs of the two ways are compared in the default tier (test above)
    def soft_a_max(m_w, probes_after):
        scene = eqx.tree_at(lambda s: s.cables.buffer.counterweight_mass_kg, rigid_scene, m_w)
        res = simulate(scene, 0.6, probes_after=probes_after, adjoint=diffrax.RecursiveCheckpointAdjoint(checkpoints=1024))
        return smooth_landing_outputs(res.ts, res.probes)["a_max_g"]

    m_w = jnp.asarray(920.0)
    grad = jax.jit(jax.grad(soft_a_max), static_argnums=1)  # one program each (eager: 1.3x the CPU time)
    g_in = grad(m_w, False)
    g_after = grad(m_w, True)
    assert np.isfinite(float(g_after)) and abs(float(g_after)) > 0
    np.testing.assert_allclose(float(g_after), float(g_in), rtol=1e-7)


# slow tier: 95-145 s on 2 cores (three compiled programs of a rope flight, one of them reverse mode);
# the default tier keeps probes inside against after the solve on the rigid landing (above)
@pytest.mark.slow
def test_unreached_saves_stay_inf_and_gradient_finite():
    # a short rope flight that ends at the ground event before the last saved times: forcing
    # probes_after=True must keep those histories inf, and the gradient finite
    scene = line_throwing_scene(angle_deg=30.0, segment_length_m=5.0, rope_length_m=100.0)
    save_ts = jnp.linspace(0.0, 40.0, 81)  # the flight lasts ~10 s
    inside = simulate(scene, 40.0, save_ts=save_ts, probes_after=False)
    after = simulate(scene, 40.0, save_ts=save_ts, probes_after=True)
    reached = np.isfinite(np.asarray(after.ts))
    assert 0 < reached.sum() < reached.size
    for u, v in zip(jax.tree_util.tree_leaves(inside.probes), jax.tree_util.tree_leaves(after.probes)):
        u, v = np.asarray(u), np.asarray(v)
        np.testing.assert_allclose(v[reached], u[reached], rtol=1e-9, atol=1e-9)
        if np.issubdtype(v.dtype, np.floating):
            assert np.all(np.isinf(v[~reached])), "unreached saved times must stay inf"
    assert float(after.outputs["range_m"]) == pytest.approx(float(inside.outputs["range_m"]), rel=1e-12)

    def summed_height(angle):
        res = simulate(with_angle(scene, angle), 40.0, save_ts=save_ts, probes_after=True)
        return jnp.sum(jnp.where(jnp.isfinite(res.ts), res.probes.position[:, 1], 0.0))

    g = jax.jit(jax.grad(summed_height))(scene.launch.angle_rad)
    assert np.isfinite(float(g))


def test_bad_probes_after_is_refused(rigid_scene):
    with pytest.raises(ValueError, match="probes_after"):
        simulate(rigid_scene, 0.1, probes_after="yes")
