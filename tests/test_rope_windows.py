"""The rope's windowed evaluation: the vector field (and the saved probe) computed on a prefix of the
box's links equals the one over every link (values, vmap, forward and reverse derivatives), and a
flight with it lands where one without it does."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxcable
from jaxcable.components.rope import ChainState, default_windows, window_sizes
from jaxcable.throw.scene import line_throwing_scene

CAPACITY = 40
WINDOWS = (8, 16)  # window 8 holds k <= 6, window 16 k <= 14; beyond, the whole box
# deployed lengths [m]: inside each window, at and across its edges, in the completion blend
# (the last 5% of a segment), and in the box's run-out fade (its last 5% of a segment)
DEPLOYED = [0.3, 1.0, 5.97, 6.0, 6.99, 7.2, 13.98, 14.5, 14.999, 15.5, 30.0, 39.5, 39.98]


def _scenes():
    base = line_throwing_scene(angle_deg=35.0, segment_length_m=1.0, rope_length_m=float(CAPACITY))
    return dataclasses.replace(base, window_links=()), dataclasses.replace(base, window_links=WINDOWS)


def _state(seed, deployed):
    # every link its own random angle and rate, also those in the box: the field must ignore them
    # the same way with and without windows
    rng = np.random.default_rng(seed)
    return ChainState(
        r0=jnp.array([60.0, 25.0]),
        v0=jnp.array([55.0, 20.0]) + 5.0 * jnp.asarray(rng.standard_normal(2)),
        theta=jnp.asarray(1.0 + 0.2 * rng.standard_normal(CAPACITY)),
        omega=jnp.asarray(2.0 * rng.standard_normal(CAPACITY)),
        deployed=jnp.asarray(deployed),
    )


def _relative_difference(a, b):
    """Largest difference of the leaves, each relative to its largest entry."""
    leaves = zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b))
    return max(float(jnp.max(jnp.abs(x - y)) / max(float(jnp.max(jnp.abs(x))), 1e-300)) for x, y in leaves)


def test_window_sizes():
    assert default_windows(750) == (64, 128, 256, 512)
    assert default_windows(400) == (64, 128, 256)
    assert default_windows(160) == ()  # a small box compiles no windows
    assert window_sizes(40, (16, 8, 8, 40, 80, 2)) == (8, 16, 40)


WHOLE, WINDOWED = _scenes()


@eqx.filter_jit
def _field(scene, y):
    return scene.vector_field(1.5, y)


def _scalar(scene, drag, angle, y):
    scene = eqx.tree_at(lambda s: (s.rope.drag_coefficient, s.launch.angle_rad), scene, (drag, angle))
    d = scene.vector_field(1.5, y)
    return jnp.sum(d.v0**2) + jnp.sum(jnp.sin(d.omega)) + d.deployed


@eqx.filter_jit
def _derivatives(scene, y):
    """Reverse mode in the drag coefficient, the launch angle and the state; forward mode in the state."""
    grads = jax.grad(_scalar, argnums=(1, 2, 3))(scene, scene.rope.drag_coefficient, scene.launch.angle_rad, y)
    tangent = jax.tree_util.tree_map(jnp.ones_like, y)
    return grads, jax.jvp(lambda y_: scene.vector_field(1.5, y_), (y,), (tangent,))[1]


@pytest.mark.parametrize("deployed", DEPLOYED)
def test_windowed_field_equals_the_whole_box(deployed):
    for seed in range(2):
        y = _state(seed, deployed)
        assert _relative_difference(_field(WHOLE, y), _field(WINDOWED, y)) < 1e-12


@eqx.filter_jit
def _probe(scene, y):
    return scene.probe(1.5, y)


@pytest.mark.parametrize("deployed", DEPLOYED)
def test_windowed_probe_equals_the_whole_box(deployed):
    """The saved quantities (the acceleration with the completion blend, the rope's pull, the kinetic
    energy) on the largest window, and beyond it on the whole box, equal the whole box's; the
    windows given in any order."""
    for seed in range(2):
        y = _state(seed, deployed)
        for scene in (WINDOWED, dataclasses.replace(WINDOWED, window_links=WINDOWS[::-1])):
            assert _relative_difference(_probe(WHOLE, y), _probe(scene, y)) < 1e-12


def test_windowed_field_under_vmap():
    # one batch spanning all three windows: each case gets its own derivative
    states = [_state(i, s) for i, s in enumerate(DEPLOYED)]
    batch = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *states)
    got = eqx.filter_jit(jax.vmap(lambda y: WINDOWED.vector_field(1.5, y)))(batch)
    for i, y in enumerate(states):
        assert _relative_difference(_field(WHOLE, y), jax.tree_util.tree_map(lambda a, i=i: a[i], got)) < 1e-12


@pytest.mark.parametrize("deployed", [6.99, 14.5, 30.0])
def test_windowed_field_derivatives(deployed):
    """Forward and reverse derivatives through the switch, in the state and in scene parameters."""
    y = _state(3, deployed)
    assert _relative_difference(_derivatives(WHOLE, y), _derivatives(WINDOWED, y)) < 1e-10


def test_windowed_flight_lands_where_the_whole_box_does():
    # 2 m segments, 200 m box: window 64 switches to the whole box at 126 m, mid-flight. The two
    # fields agree to rounding, so the runs differ only where rounding moves the adaptive steps:
    # far below the tolerance (1e-6 relative here; measured 9e-8 in the flight time).
    base = line_throwing_scene(angle_deg=30.0, segment_length_m=2.0, rope_length_m=200.0)
    runs = [jaxcable.simulate(dataclasses.replace(base, window_links=w), 40.0, rtol=1e-6, atol=1e-6) for w in ((), (64,))]
    for r in runs:
        assert r.status_message == "event_occurred"  # ground impact
    assert float(runs[0].outputs["deployed_rope_m"]) > 130.0  # the flight did cross the window's edge
    for key in ("range_m", "max_speed_mps", "flight_time_s", "deployed_rope_m"):
        a, b = float(runs[0].outputs[key]), float(runs[1].outputs[key])
        assert abs(a - b) <= 1e-6 * abs(a), key


def test_window_links_are_checked():
    base = WHOLE
    for bad in ((0,), (8.5,), "8", (True,)):
        with pytest.raises((TypeError, ValueError), match="window_links"):
            dataclasses.replace(base, window_links=bad)
    assert dataclasses.replace(base, window_links=[16, 8]).windows == (16, 8)
