"""Calibration of the cables' Rayleigh damping to section III.F: the objective, the fit, its bounds."""

import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.arresting import calibration as C
from jaxcable.arresting.landing import run_landing
from jaxcable.arresting.layout import ArrestingLayout


@pytest.fixture(scope="module")
def reference():
    ref = C.one_dof_reference(1.0)
    return {k: (jnp.asarray(v) if isinstance(v, np.ndarray) else v) for k, v in ref.items()}


def test_reference_is_the_one_dof_stroke(reference):
    # the window ends at the 1-DOF stop (0.77 s on the design case), the scales are its peaks
    assert 0.5 < reference["t_stop_s"] < 1.0
    assert bool(reference["window"][0]) and not bool(reference["window"][-1])
    one = run_landing("1dof", t_end_s=1.0).outputs
    assert reference["scales"]["drop_m"] == pytest.approx(one["z_max_m"], rel=1e-3)
    # the record is interpolated linearly onto the scenes' 1 ms grid: the peak moves by 0.1%
    assert reference["scales"]["acceleration_g"] == pytest.approx(one["a_max_g"], rel=3e-3)


def test_misfit_vanishes_in_the_rigid_cable_limit_and_sees_the_ringing(reference):
    """The objective measures the distance from the analytical (rigid-cable) solution: 1000x stiffer,
    damped cables (the limit in which the rigid level converges to the 1-DOF model,
    test_passive) sit within 1.5% of it (measured J = 0.0074; the stress channel's 0.015 is the stiff
    cable's ~4 ms rise against the rigid cable's jump at capture), the lightly damped Table 1 cables
    ring +-3 g around it (measured J = 0.27)."""
    stiff = run_landing("rigid", t_end_s=1.0, layout=ArrestingLayout(EA_N=2.64e11), cable_damping_s=1e-2)
    j_stiff, per = C.landing_misfit(stiff, reference)
    assert j_stiff < 0.015
    assert per["drop_m"] < 2e-3 and per["acceleration_g"] < 5e-3
    ringing = run_landing("rigid", t_end_s=1.0, cable_damping_s=1e-5)
    j_ring, per = C.landing_misfit(ringing, reference)
    assert j_ring > 0.2 and per["acceleration_g"] > 0.3


@pytest.mark.slow  # reverse mode through three rigid-level solves: ~1.5 min on 2 cores, 5 min under load
def test_fit_lowers_the_objective_inside_its_bounds_and_its_sensitivity_matches_differences():
    bounds = (1e-4, 3e-3)
    fit = C.fit_cable_damping("rigid", bounds_s=bounds, beta0_s=5e-4, steps=3, learning_rate=0.5, t_end_s=0.4)
    betas = [b for b, _ in fit.history]
    assert all(bounds[0] <= b <= bounds[1] for b in betas)
    assert fit.history[-1][1] < fit.history[0][1]  # more damping, closer to the rigid-cable solution
    assert betas[-1] > betas[0]
    assert np.isfinite(list(fit.sensitivity.values())).all()
    # forward-mode sensitivity d a_max / d ln beta against a central difference of two solves
    run = C._scene_fn("rigid", 0.4, dict(solver="tsit5", rtol=1e-6, atol=1e-6, max_steps=200_000), {})
    h = 0.05
    up = float(run(fit.beta_s * np.exp(h)).outputs["sigma_max_mpa"])
    down = float(run(fit.beta_s * np.exp(-h)).outputs["sigma_max_mpa"])
    assert fit.sensitivity["sigma_max_mpa"] == pytest.approx((up - down) / (2 * h), rel=0.05, abs=0.05)


def test_bounds_follow_the_damping_ratio_of_the_counterweight_mode():
    lo, hi = C.beta_bounds_s()
    assert lo == C.BETA_MIN_S
    assert hi == pytest.approx(2 * C.ZETA_MAX / C.OMEGA_1_RAD_S)
    assert lo < C.CALIBRATED_CABLE_DAMPING_S <= hi * 1.001


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(fidelity="1dof"), "fidelity"),
        (dict(bounds_s=(1e-3, 1e-4)), "bounds_s"),
        (dict(bounds_s=(-1e-3, 1e-2)), "bounds_s"),
        (dict(beta0_s=1.0), "beta0_s"),
    ],
)
def test_bad_input_names_the_field(kwargs, match):
    with pytest.raises(ValueError, match=match):
        C.fit_cable_damping(**kwargs)


def test_bad_bound_parameters_name_the_field():
    with pytest.raises(ValueError, match="zeta_max"):
        C.beta_bounds_s(zeta_max=-0.1)


def test_cli_takes_the_calibrated_value_by_name():
    import argparse

    from jaxcable.cli.report import cable_damping

    parse = cable_damping()
    assert parse("calibrated") == C.CALIBRATED_CABLE_DAMPING_S
    assert parse("1e-3") == 1e-3
    for bad in ("foo", "-1", "nan"):
        with pytest.raises(argparse.ArgumentTypeError, match="--cable-damping"):
            parse(bad)


def test_sweeps_at_the_calibrated_damping_run_the_w_method():
    """A sweep's case function chooses the level's solver from its static damping (inside the
    sweep's trace the scene's beta is a tracer): the W-method at the calibrated beta, which is the
    default (Bosh3 there: ~2 million steps per 2 s case, a sweep that never ends); at a lightly
    damped 1e-5 s the W-method with the hook as a sliding node (the default) and explicit Bosh3 with
    the capsule contact, where each is the faster (``landing.STIFF_DAMPING_S``)."""
    from jaxcable.arresting.passive import (
        DEFAULT_CABLE_DAMPING_S,
        LIGHT_CABLE_DAMPING_S,
    )
    from jaxcable.arresting.sweep import passive_case_fn, qmc_case_fn
    from jaxcable.core.rosenbrock import RosenbrockW

    beta = C.CALIBRATED_CABLE_DAMPING_S
    assert DEFAULT_CABLE_DAMPING_S == beta
    for level in ("ale", "full"):
        assert passive_case_fn(level, cable_damping_s=beta).solver == "rosw"
        assert passive_case_fn(level).solver == "rosw"  # the default damping
        # lightly damped: the W-method with the hook as a sliding node (Bosh3's step there is 4-5e-6 s),
        # explicit Bosh3 with the capsule contact
        assert passive_case_fn(level, cable_damping_s=LIGHT_CABLE_DAMPING_S).solver == "rosw"
        capsule = passive_case_fn(level, cable_damping_s=LIGHT_CABLE_DAMPING_S, hook_contact="capsule")
        assert capsule.solver == "bosh3"
        # the two-phase sweep vmaps its passive phase: the W-method relinearised at every step
        for fn in (qmc_case_fn("I", phase="full", fidelity=level, cable_damping_s=beta),
                   qmc_case_fn("I", phase="full", fidelity=level)):  # fmt: skip
            solver = fn.passive_solver_settings()[level][0]
            assert isinstance(solver, RosenbrockW) and solver.jacobian_every == 1
        light = qmc_case_fn("I", phase="full", fidelity=level, cable_damping_s=LIGHT_CABLE_DAMPING_S)
        assert isinstance(light.passive_solver_settings()[level][0], RosenbrockW)
        light = qmc_case_fn("I", phase="full", fidelity=level, cable_damping_s=LIGHT_CABLE_DAMPING_S,
                            hook_contact="capsule")  # fmt: skip
        assert light.passive_solver_settings()[level][0] == "bosh3"


def test_batched_sweeps_relinearise_the_w_method_at_every_step():
    """Vmapped, the W-method's lagged J saves no linearisation (a batched cond computes both
    branches): the passive sweep's cases run it with jacobian_every 1; other solvers pass as given."""
    from jaxcable.arresting.landing import batched_solver
    from jaxcable.core.rosenbrock import RosenbrockW

    solver = batched_solver("rosw")
    assert isinstance(solver, RosenbrockW) and solver.jacobian_every == 1
    assert RosenbrockW().jacobian_every == 2  # single runs keep the lagged J
    assert batched_solver("bosh3") == "bosh3"
    custom = RosenbrockW(jacobian_every=3)
    assert batched_solver(custom) is custom


def test_vmapped_design_batches_relinearise_the_w_method_at_every_step():
    """The design objective vmaps its cases: at the calibrated damping its ale cases run the
    W-method relinearised at every step; lightly damped, the W-method with the hook as a sliding node
    and explicit Bosh3 with the capsule contact."""
    from jaxcable.arresting.design import design_problem
    from jaxcable.arresting.design_objective import case_solver
    from jaxcable.arresting.passive import LIGHT_CABLE_DAMPING_S
    from jaxcable.core.rosenbrock import RosenbrockW

    mesh = {"n_span_elements": 8, "n_fine": 4}
    solver = case_solver(design_problem("m_w", n=1, fidelity="ale", t_end_s=0.05, scene_options=mesh))
    assert isinstance(solver, RosenbrockW) and solver.jacobian_every == 1
    light = design_problem("m_w", n=1, fidelity="ale", t_end_s=0.05, cable_damping_s=LIGHT_CABLE_DAMPING_S,
                           scene_options=mesh)  # fmt: skip
    assert isinstance(case_solver(light), RosenbrockW)  # the hook as a sliding node: the W-method
    light = design_problem("m_w", n=1, fidelity="ale", t_end_s=0.05, cable_damping_s=LIGHT_CABLE_DAMPING_S,
                           scene_options=dict(mesh, hook_contact="capsule"))  # fmt: skip
    assert case_solver(light) == "bosh3"
    assert light.rtol == 1e-4  # Bosh3's tolerance, not the W-method's
