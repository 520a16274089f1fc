"""Calibration of the tracking phase (``jaxcable.arresting.tracking_calibration``).

Checks: the motor bandwidth's upper bound against the loop's sensitivity peak, the design error of
eqs 4-6 against its closed forms and the exact delayed loop, the residuals (zero inside the
paper's limits, scaled outside), bad input named; and (slow tier: one compilation of the
forward-mode objective) on one case the gradient against central differences and a few adam steps
that lower the objective inside the bounds.
"""

import jax

jax.config.update("jax_enable_x64", True)

import math  # noqa: E402

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from jaxcable.arresting import tracking_calibration as tc  # noqa: E402
from jaxcable.arresting.control import TrackingController, delayed_loop_reference  # noqa: E402


def test_motor_bandwidth_bound_keeps_the_loop_robust():
    hi = tc.PARAMETER_BOUNDS["motor_bandwidth_per_s"][1]
    # Table 2's largest delay, every gain of Table 4: M_s <= 2 up to the bound, not much beyond it
    for a_p in (2.0, 5.0, 6.0):
        assert tc.loop_sensitivity_peak(hi, a_p, 0.1) <= 2.0
    assert tc.loop_sensitivity_peak(10.0, 6.0, 0.1) > 2.0
    # without delay the loop is robust at any bandwidth (|L| -> 1 from the right side of -1)
    assert tc.loop_sensitivity_peak(100.0, 6.0, 0.0) < 1.2


def test_design_relative_error_closed_forms_and_exact_loop():
    # the P law (g_d -> 0) is eq 10: e^-5 at eq 11's gain a_p = 20 / t_c
    np.testing.assert_allclose(float(tc.design_relative_error(2.0, 10.0, 0.0)), math.exp(-5.0), rtol=1e-12)
    np.testing.assert_allclose(float(tc.design_relative_error(2.0, 10.0, 1e-6)), math.exp(-5.0), rtol=1e-5)
    # eq 4's PD law: exp(-(1 - ln 2) a_p t_c / 2)
    np.testing.assert_allclose(float(tc.design_relative_error(6.0, 5.0)), math.exp(-(1 - math.log(2)) * 15.0), rtol=1e-12)
    # the loop with a fast motor and a short exact delay approaches it (1/b and tau corrections)
    c = TrackingController(gain_per_s=5.0, tracking_time_s=6.0, motor_delay_s=0.005, motor_bandwidth_per_s=500.0, noise_rms_m=0.0)
    ts, d, _ = delayed_loop_reference(c, 1.0, 3.0, steps_per_delay=5)
    np.testing.assert_allclose(1.0 - np.interp(3.0, ts, d), float(tc.design_relative_error(5.0, 6.0)), rtol=0.05)


def _observables(**overrides):
    obs = dict(tracking_error_m=0.1, tracking_tolerance_m=0.2, smooth_capture_margin_m=0.5, x_m=10.0, y_m=-10.0,
               vx_m_s=1.0, vy_m_s=-1.5, theta_x_deg=5.0, theta_y_deg=-8.0, theta_z_deg=20.0, omega_x_deg_s=2.0,
               omega_y_deg_s=-3.0, omega_z_deg_s=0.1)  # fmt: skip
    obs.update(overrides)
    return {k: jnp.asarray(v) for k, v in obs.items()}


def test_residuals_zero_inside_the_paper_limits_and_scaled_outside():
    res = np.asarray(tc.case_residuals(_observables()))
    assert res.shape == (len(tc.RESIDUAL_NAMES),)
    assert np.all(res == 0.0)
    names = list(tc.RESIDUAL_NAMES)
    res = np.asarray(tc.case_residuals(_observables(tracking_error_m=0.5, smooth_capture_margin_m=-0.1, vy_m_s=-2.5, omega_y_deg_s=7.2)))
    np.testing.assert_allclose(res[names.index("tracking_error")], 0.3 / 0.1)
    np.testing.assert_allclose(res[names.index("capture_margin")], (tc.REQUIRED_MARGIN_M + 0.1) / 0.1)
    np.testing.assert_allclose(res[names.index("table8_vy_m_s")], 0.5 / 0.2)  # Table 8: |v| <= 2 m/s
    np.testing.assert_allclose(res[names.index("table8_omega_y_deg_s")], 1.2 / 0.6)  # |omega| <= 6 deg/s
    # only the capture margin applies to the deviated case (not a QMC case)
    res = np.asarray(tc.case_residuals(_observables(tracking_error_m=0.5, vy_m_s=-2.5), qmc=False))
    assert np.all(res == 0.0)
    res = np.asarray(tc.case_residuals(_observables(smooth_capture_margin_m=-0.1), qmc=False))
    assert res[names.index("capture_margin")] > 0.0


BAD_START = dict(motor_bandwidth_per_s=9.0, rocket_crossflow_drag_coefficient=0.1, rocket_normal_force_slope_per_rad=1.5)


@pytest.mark.parametrize(
    "call, field",
    [
        (lambda: tc.evaluate(dict(motor_bandwidth=3.0), None), "motor_bandwidth"),
        (lambda: tc.evaluate(dict(motor_bandwidth_per_s=-1.0), None), "motor_bandwidth_per_s"),
        (lambda: tc.evaluate(dict(rocket_crossflow_drag_coefficient=float("nan")), None), "rocket_crossflow_drag_coefficient"),
        (lambda: tc.calibration_cases("IV"), "scenario"),
        (lambda: tc.calibration_cases("III", -1), "n_halton"),
        (lambda: tc.calibration_cases("III", 0, deviated=False), "n_halton"),
        (lambda: tc.calibration_space(bounds=dict(motor_bandwidth_per_s=(5.0, 2.0))), "motor_bandwidth_per_s"),
        (lambda: tc.calibration_space(names=("sample_period_s",)), "design variable"),
        (lambda: tc.fit_tracking(tc.calibration_cases("III", 0), prior_weight=-1.0), "prior_weight"),
        (lambda: tc.fit_tracking(tc.calibration_cases("III", 0), x0=BAD_START), "motor_bandwidth_per_s"),
        (lambda: tc.fit_tracking([]), "cases"),
        (lambda: tc.loop_sensitivity_peak(-1.0, 6.0, 0.1), "bandwidth_per_s"),
    ],
)
def test_bad_input_names_the_field(call, field):
    with pytest.raises((ValueError, TypeError), match=field):
        call()


# ------------------------------------------------------------------------------------------------
# one case through the forward-mode objective (one compilation): slow tier. Measured on the 2-core
# machine under load 7-9: 83 s for the first test (the compilation; 44 s of CPU for the file), 3 s
# for the second.
# ------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def one_case():
    """The deviated case of section IV.A in scenario III (the strongest wind), and the space."""
    return tc.calibration_cases("III", 0), tc.calibration_space()


@pytest.mark.slow
def test_gradient_matches_central_differences(one_case):
    cases, space = one_case
    u = space.to_unconstrained(jnp.array([2.0, 0.3, 1.8]))
    j, g, _ = tc.tracking_objective(space, u, cases, gradient=True)
    assert np.all(np.isfinite(np.asarray(g))) and np.isfinite(float(j))
    # central differences in the logistic coordinates, through the same compiled objective (measured:
    # forward mode and the quotients at h = 1e-3 agree to 5e-5 relative, component by component)
    h = 1e-3
    fd = []
    for i in range(space.size):
        e = jnp.zeros(space.size).at[i].set(h)
        jp = tc.tracking_objective(space, u + e, cases, gradient=True)[0]
        jm = tc.tracking_objective(space, u - e, cases, gradient=True)[0]
        fd.append((float(jp) - float(jm)) / (2 * h))
    np.testing.assert_allclose(np.asarray(g), fd, rtol=1e-4, atol=1e-5 * np.max(np.abs(fd)))


@pytest.mark.slow
def test_objective_decreases_and_stays_in_bounds(one_case):
    cases, _ = one_case
    fit = tc.fit_tracking(cases, steps=3, learning_rate=0.3)
    h = fit.history
    assert h.objective.shape == (4,)
    assert np.all(np.isfinite(h.objective)) and np.all(np.isfinite(h.grad_norm))
    assert h.objective[-1] < h.objective[0]
    assert np.all(np.diff(h.objective) < 0.0)
    for i, name in enumerate(fit.names):
        lo, hi = tc.PARAMETER_BOUNDS[name]
        assert np.all((h.x[:, i] > lo) & (h.x[:, i] < hi)), name
    assert set(fit.best) == set(tc.CALIBRATION_PARAMETERS)
