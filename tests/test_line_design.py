"""Line-throwing launch design (jaxcable.throw.design): the objective's gradient w.r.t. the launch
angle and the rope diameter through the diffrax solve and the impact event against central
differences in float64, the d^2 density scaling, the penalties by hand, ``jaxcable design --scene
throw``, and bad input.

One coarse problem (40 links of 20 m, rtol 1e-8) is compiled once by a module fixture; the
differences re-use that compiled function (value and gradient), so the file costs one compile.
"""

import json

import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.cli.design import design_main
from jaxcable.throw.design import (
    ThrowLimits,
    ThrowWeights,
    calibrated_start,
    throw_design_scene,
    throw_objective_and_grad,
    throw_problem,
)


@pytest.fixture(scope="module")
def problem():
    # rtol 1e-8: differences of an adaptive solve need the solver's error far below the step's
    # effect (at 1e-6 the quotient moves by ~1 % between step sizes)
    return throw_problem("angle_deg,rope_diameter_m", segment_length_m=20.0, rope_length_m=800.0, rtol=1e-8, atol=1e-8)


@pytest.fixture(scope="module")
def at_start(problem):
    # a 9 mm rope at 30 deg: lands at 60.7 m/s (the speed penalty is active) and pulls 3.88 kN
    # (below 98 % of 4 kN: the tension penalty is not); off the bounds' middle, so dx/du matters
    x0 = jnp.array([30.0, 0.009])
    u0 = problem.space.to_unconstrained(x0)
    j, g, aux = throw_objective_and_grad(problem, u0)
    return np.asarray(x0), float(j), np.asarray(g), aux


def _value(problem, x):
    return float(throw_objective_and_grad(problem, problem.space.to_unconstrained(jnp.asarray(x)))[0])


def test_gradient_matches_central_differences(problem, at_start):
    """dJ/d(angle, diameter) in physical units (forward mode through the solve, the impact event's
    root find and the reparametrisation) against central differences of the same objective."""
    x0, j0, g_u, aux = at_start
    assert bool(aux["landed"])
    lo, hi = np.asarray(problem.space.lower), np.asarray(problem.space.upper)
    g_x = g_u / ((x0 - lo) * (hi - x0) / (hi - lo))
    # 0.3 % of the angle, 0.1 % of the diameter: the landing speed is strongly curved in d (its
    # difference quotient at h = 2e-4 / 5e-5 / 1e-5 / 2e-6 m: -2118 / -4131 / -4304 / -4306 m/s per m
    # against -4307 by AD), the range and the rope pull are not (0.01 % over the same steps)
    steps = np.array([0.1, 1e-5])
    for i in range(2):
        e = np.zeros(2)
        e[i] = steps[i]
        fd = (_value(problem, x0 + e) - _value(problem, x0 - e)) / (2 * steps[i])
        # truncation and the solver's response to the change (~rtol / h) are below 0.2 % at these
        # steps; a wrong chain rule (the deg -> rad factor, dx/du, the d^2 scaling) is off by factors
        assert g_x[i] == pytest.approx(fd, rel=1e-2), (problem.space.names[i], g_x[i], fd)
        assert abs(g_x[i]) > 0.0


def test_objective_terms_by_hand(problem, at_start):
    """J = -range / reference + w (v / v_lim - 1 + m)_+^2 + w (T_soft / T_lim - 1 + m)_+^2 from the
    outputs (m: the margin, 0.02)."""
    _, j0, _, aux = at_start
    w, lim = problem.weights, problem.limits
    m = float(w.margin)
    expected = (
        -float(aux["range_m"]) / float(w.range_reference_m)
        + float(w.speed_penalty) * max(float(aux["impact_speed_mps"]) / float(lim.landing_speed_mps) - 1.0 + m, 0.0) ** 2
        + float(w.tension_penalty) * max(float(aux["smooth_max_tension_N"]) / float(lim.max_tension_N) - 1.0 + m, 0.0) ** 2
    )
    assert float(aux["terms"]["speed_penalty"]) > 0.0  # 60.7 m/s against 60 m/s: the penalty acts
    assert j0 == pytest.approx(expected, rel=1e-12)
    # the soft maximum bounds the hard one from above, by at most width log(n_saved)
    hard, soft = float(aux["max_tension_N"]), float(aux["smooth_max_tension_N"])
    assert hard <= soft <= hard + float(w.tension_width_N) * np.log(5000)


def test_diameter_scales_density_and_drag_area(problem):
    """Same material: density ~ d^2 from the calibrated 0.0693 kg/m at 10 mm; drag area d l ~ d."""
    sc = throw_design_scene(problem, jnp.array([35.0, 0.005]))
    base = problem.scene.rope
    assert float(sc.rope.linear_density_kg_per_m) == pytest.approx(float(base.linear_density_kg_per_m) * 0.25, rel=1e-14)
    assert float(sc.rope.diameter_m) == pytest.approx(0.005, rel=1e-14)
    assert float(sc.launch.angle_rad) == pytest.approx(np.deg2rad(35.0), rel=1e-14)
    start = np.asarray(calibrated_start(problem))
    assert start[0] == 30.0 and start[1] == pytest.approx(float(base.diameter_m))


def test_cli_scene_throw(at_start, capsys):
    """``jaxcable design --scene throw`` on the fixture's problem (same static structure: no new
    compile): its "before" is the fixture's evaluation, "after" the best of its history."""
    _, j0, _, aux = at_start
    args = ["--scene", "throw", "--segment-length", "20", "--rope-length", "800", "--rtol", "1e-8",
            "--start", "rope_diameter_m=0.009", "--steps", "1", "--json"]  # fmt: skip
    assert design_main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["variables"] == ["angle_deg", "rope_diameter_m"]
    assert out["before"]["objective"] == pytest.approx(j0, rel=1e-12)
    assert out["before"]["range_m"] == pytest.approx(float(aux["range_m"]), rel=1e-12)
    assert out["after"]["objective"] == pytest.approx(min(out["history"]["objective"]), rel=1e-12)
    assert design_main(["--scene", "throw", "--vars", "angle_deg,m_w"]) == 2
    assert "design variable 'm_w'" in capsys.readouterr().err


def test_bad_input_gets_clear_errors():
    with pytest.raises(ValueError, match="design variable 'mass'"):
        throw_problem("angle_deg,mass")
    with pytest.raises(ValueError, match="angle_deg must be in"):
        throw_problem("angle_deg").space.to_unconstrained(jnp.array([80.0]))
    with pytest.raises(ValueError, match="landing_speed_mps must be positive"):
        ThrowLimits(landing_speed_mps=-1.0)
    with pytest.raises(ValueError, match="speed_penalty must be non-negative"):
        ThrowWeights(speed_penalty=-1.0)
