"""Calibration of the line-throwing rocket's unknown coefficients to flight-test data, by gradient
descent through the simulator (optax).

The paper gives no drag coefficients, rope diameter or pull-out force. :func:`fit_throw` fits up to
three positive scalars of a :class:`~jaxcable.throw.scene.LineThrowingScene`, each in log
space (so they stay positive), to the 30 deg flight test: Table 3's test row (range, maximum speed,
flight time) and the radar speeds at 1-4 s (section 4.3). The 40 deg test is held out.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

from jaxcable.core.simulate import simulate

#: The 30 deg flight test (paper Table 3 test row and section 4.3 radar speeds).
TEST_30DEG = {
    "range_m": 629.9,
    "max_speed_mps": 199.5,
    "flight_time_s": 8.6,
    "speed_at_1_2_3_4_s_mps": (154.3, 99.3, 73.8, 60.5),
}

#: Scene fields that can be fitted, by name.
FITTABLE = {
    "rocket_drag_coefficient": lambda s: s.rocket.drag_coefficient,
    "rope_drag_coefficient": lambda s: s.rope.drag_coefficient,
    "rope_linear_density_kg_per_m": lambda s: s.rope.linear_density_kg_per_m,
    "rope_diameter_m": lambda s: s.rope.diameter_m,
}


def _observables(outputs):
    return jnp.concatenate(
        [
            jnp.stack([outputs["range_m"], outputs["max_speed_mps"], outputs["flight_time_s"]]),
            outputs["speed_at_1_2_3_4_s_mps"],
        ]
    )


def target_vector(targets=TEST_30DEG):
    return jnp.concatenate(
        [
            jnp.array([targets["range_m"], targets["max_speed_mps"], targets["flight_time_s"]]),
            jnp.asarray(targets["speed_at_1_2_3_4_s_mps"], dtype=float),
        ]
    )


OBSERVABLE_NAMES = ["range_m", "max_speed_mps", "flight_time_s", "v1_mps", "v2_mps", "v3_mps", "v4_mps"]


def with_parameters(scene, names, values):
    """Scene with the named fields set to ``values`` (array of the same length)."""
    for i, name in enumerate(names):
        scene = eqx.tree_at(FITTABLE[name], scene, values[i])
    return scene


def residuals(log_values, scene, names, targets=TEST_30DEG, **sim_kw):
    """Relative residuals (model / test - 1) of the seven observables."""
    sc = with_parameters(scene, names, jnp.exp(log_values))
    res = simulate(sc, **sim_kw)
    return _observables(res.outputs) / target_vector(targets) - 1.0


def loss(log_values, scene, names, targets=TEST_30DEG, **sim_kw):
    """Mean squared relative residual."""
    r = residuals(log_values, scene, names, targets, **sim_kw)
    return jnp.mean(r**2)


@dataclass
class FitHistory:
    names: list
    values: list = field(default_factory=list)
    losses: list = field(default_factory=list)
    wall_s: list = field(default_factory=list)


def fit_throw(
    scene,
    names=("rocket_drag_coefficient", "rope_drag_coefficient", "rope_linear_density_kg_per_m"),
    steps: int = 40,
    learning_rate: float = 0.05,
    targets=TEST_30DEG,
    callback=None,
    **sim_kw,
):
    """Fit at most three positive scene parameters to the flight test with optax Adam in log space.

    Args:
        scene: starting scene (its current values are the initial guess).
        names: fields to fit (keys of ``FITTABLE``), at most three.
        steps: optimiser steps.
        learning_rate: Adam step in log space (0.05 = about 5% per step).
        callback: ``callback(step, values, loss)`` after each step (progress reporting).
        sim_kw: passed to :func:`jaxcable.core.simulate` (t1, solver, rtol, ...).

    Returns:
        ``(fitted_scene, history)``.
    """
    names = list(names)
    if len(names) > 3:
        raise ValueError(f"fit at most three scalars, got {len(names)}: {names}")
    for n in names:
        if n not in FITTABLE:
            raise ValueError(f"unknown parameter {n!r}; choose from {sorted(FITTABLE)}")
    x = jnp.log(jnp.stack([FITTABLE[n](scene) for n in names]))
    opt = optax.adam(learning_rate)
    state = opt.init(x)
    vg = eqx.filter_jit(jax.value_and_grad(lambda x_: loss(x_, scene, names, targets, **sim_kw)))
    hist = FitHistory(names=names)
    t0 = time.perf_counter()
    for step in range(steps):
        value, grad = vg(x)
        if not np.all(np.isfinite(np.asarray(grad))):
            raise FloatingPointError(f"non-finite gradient at step {step}: {grad}")
        hist.values.append(np.exp(np.asarray(x)).tolist())
        hist.losses.append(float(value))
        hist.wall_s.append(time.perf_counter() - t0)
        if callback is not None:
            callback(step, hist.values[-1], float(value))
        updates, state = opt.update(grad, state, x)
        x = optax.apply_updates(x, updates)
    final_loss = float(loss(x, scene, names, targets, **sim_kw))
    hist.values.append(np.exp(np.asarray(x)).tolist())
    hist.losses.append(final_loss)
    hist.wall_s.append(time.perf_counter() - t0)
    return with_parameters(scene, names, jnp.exp(x)), hist
