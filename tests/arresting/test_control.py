"""Tests of the active-tracking controller (arresting-cable paper, section II.A eqs 1-11, Fig 4;
section III.E eq 46).

References are independent of the code under test: closed forms (eqs 9-11, the filter's Taylor
series), scipy.signal.lsim of the hand-derived closed-loop transfer function, a NumPy RK4 with an
exact dead time (``delayed_loop_reference``, itself checked for fourth-order convergence), and
central finite differences in float64.

Compile time dominates: every run uses the same save grid and a noise track of the same shape
(zeros for noise-free runs), so each controller structure compiles once.
"""

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import scipy.signal  # noqa: E402

from jaxcable.arresting.control import (  # noqa: E402
    FILTER_DELAYS,
    FILTER_WEIGHTS,
    LagChainDelay,
    NoiseTrack,
    PadeDelay,
    RocketPath,
    TrackingController,
    delayed_loop_reference,
    delayed_measurement,
    filter_noise_samples,
    kappa,
    measurement_noise,
    measurement_noise_track,
    run_tracking_loop,
    slider_target,
    target_point,
)

T1 = 10.0
SAVE_TS = jnp.linspace(0.0, T1, 201)  # 0.05 s: contains t_c / 2 = 5 s and t = 4 s
TARGET = 17.0  # Fig 4's "e = 17": initial error 17 m
KEY = jax.random.PRNGKey(4)


def figure4_rocket(target_m):
    """Fig 4's constant target: a still, vertical rocket whose bottom is 20 m above the plane at
    x = y = ``target_m`` (as ``experiments/figure4_controller.py`` builds it)."""
    return RocketPath(
        head_m=jnp.array([target_m, target_m, 60.0]), bottom_m=jnp.array([target_m, target_m, 20.0])
    )


@pytest.fixture(scope="module")
def noisy_track():
    return measurement_noise_track(KEY, TrackingController(), T1)


@pytest.fixture(scope="module")
def zero_track(noisy_track):
    return NoiseTrack(noisy_track.sample_period_s, jnp.zeros_like(noisy_track.values_m))


def run(controller, noise, rocket=None, tol=1e-10):
    rocket = figure4_rocket(TARGET) if rocket is None else rocket
    res = run_tracking_loop(controller, rocket, SAVE_TS, noise=noise, rtol=tol, atol=tol)
    assert int(res.status) == 0
    return res


@pytest.fixture(scope="module")
def fig4_reference():
    """Exact-delay reference of the noise-free Fig 4 loop, sampled on SAVE_TS."""
    ts, d, v = delayed_loop_reference(TrackingController(), TARGET, T1, steps_per_delay=20)
    every = int(round(float(SAVE_TS[1] - SAVE_TS[0]) / (ts[1] - ts[0])))
    assert np.allclose(ts[::every], SAVE_TS)
    return d[::every], v[::every]


@pytest.fixture(scope="module")
def fig4_default(zero_track):
    return run(TrackingController(), zero_track)


# ---------------------------------------------------------------------------------------------
# closed forms: eqs 9-11 (P law, no motor lag, no delay)
# ---------------------------------------------------------------------------------------------


def test_eq9_eq10_closed_form_p_law(zero_track):
    """d = d_T (1 - exp(-a_p t^2 / t_c)) up to t_c / 2 (eq 9), then the plain exponential; the
    relative error (eq 10) is the same for every channel whatever its target."""
    a_p, t_c = 1.3, 8.0
    ctrl = TrackingController(
        gain_per_s=a_p, tracking_time_s=t_c, derivative_gain=0.0, motor_delay_s=0.0,
        motor_lag=False,
    )
    rocket = RocketPath(head_m=jnp.array([-5.0, 8.0, 40.0]), bottom_m=jnp.array([-5.0, 8.0, 3.0]))
    res = run(ctrl, zero_track, rocket)
    t = np.asarray(res.ts)
    d_target = np.array([-5.0, -5.0, 8.0, 8.0])
    # independent closed form: e' = -kappa a_p e, kappa = min(2 t / t_c, 1)
    half = t_c / 2
    exponent = np.where(t <= half, a_p * t**2 / t_c, a_p * half**2 / t_c + a_p * (t - half))
    expected = d_target * (1.0 - np.exp(-exponent))[:, None]
    # rtol = atol = 1e-10 on states of size <= 8 m: 1e-7 m is integration tolerance with margin
    np.testing.assert_allclose(np.asarray(res.slider_m), expected, atol=1e-7, rtol=0)
    rel_error = np.abs((d_target - np.asarray(res.slider_m)) / d_target)
    np.testing.assert_allclose(rel_error, np.broadcast_to(np.exp(-exponent)[:, None], rel_error.shape),
                               atol=2e-8, rtol=0)
    # the reel-out speed is kappa a_p e (no lag, no delay)
    kap = np.minimum(2 * t / t_c, 1.0)
    np.testing.assert_allclose(np.asarray(res.reelout_m_s),
                               kap[:, None] * a_p * (d_target - np.asarray(res.slider_m)), atol=1e-9)


def test_eq11_gain_bound(zero_track):
    """a_p = 20 / t_c puts the relative error at exactly e^-5 at t = t_c / 2; a smaller gain does not."""
    t_c = 8.0
    i_half = int(np.argmin(np.abs(np.asarray(SAVE_TS) - t_c / 2)))
    assert float(SAVE_TS[i_half]) == pytest.approx(t_c / 2)
    rel = {}
    for a_p in (20.0 / t_c, 0.9 * 20.0 / t_c):
        ctrl = TrackingController(
            gain_per_s=a_p, tracking_time_s=t_c, derivative_gain=0.0, motor_delay_s=0.0,
            motor_lag=False,
        )
        res = run(ctrl, zero_track)
        rel[a_p] = abs(TARGET - float(res.slider_m[i_half, 0])) / TARGET
    assert rel[20.0 / t_c] == pytest.approx(np.exp(-5.0), rel=1e-6)
    assert rel[0.9 * 20.0 / t_c] > np.exp(-5.0)


# ---------------------------------------------------------------------------------------------
# full motor model, tau = 0: scipy.signal.lsim of the hand-derived closed loop
# ---------------------------------------------------------------------------------------------


def test_motor_model_tau0_matches_lsim(zero_track):
    """kappa = 1 and tau = 0: D / D_T = b (g_d s + a_p) / (s^2 + b (1 + g_d) s + b a_p) (eqs 4, 7,
    8 closed with e = d_T - d). The rocket moves at constant velocity, placed so that the filtered
    target is d_T = v t (e(0) = 0: no initial-condition convention involved)."""
    a_p, g_d, b = 1.3, 0.7, 1.5
    ctrl = TrackingController(
        gain_per_s=a_p, derivative_gain=g_d, motor_bandwidth_per_s=b, motor_delay_s=0.0,
        ramp=False,
    )
    v = np.array([1.5, -0.8, 0.0])
    start = 2 * 0.02 * v  # the filter's mean delay 2 Delta t shifts the seen position back by 2 Dt v
    rocket = RocketPath(
        head_m=jnp.asarray(start + [0, 0, 50.0]),
        bottom_m=jnp.asarray(start + [0, 0, 10.0]),
        velocity_m_s=jnp.asarray(v),
    )
    res = run(ctrl, zero_track, rocket)
    t = np.asarray(res.ts)
    np.testing.assert_allclose(np.asarray(res.target_m), t[:, None] * v[[0, 0, 1, 1]], atol=1e-12)
    den = [1.0, b * (1 + g_d), b * a_p]
    pos = scipy.signal.lti([b * g_d, b * a_p], den)
    speed = scipy.signal.lti([b * g_d, b * a_p, 0.0], den)
    t_fine = np.linspace(0.0, T1, 4001)
    for ch, vel in ((0, v[0]), (2, v[1])):
        _, d_ref, _ = scipy.signal.lsim(pos, vel * t_fine, t_fine)
        _, v_ref, _ = scipy.signal.lsim(speed, vel * t_fine, t_fine)
        np.testing.assert_allclose(np.asarray(res.slider_m[:, ch]), d_ref[::20], atol=1e-8)
        np.testing.assert_allclose(np.asarray(res.reelout_m_s[:, ch]), v_ref[::20], atol=1e-8)


# ---------------------------------------------------------------------------------------------
# Fig 4: the ramp lowers the peak reel-out speed
# ---------------------------------------------------------------------------------------------


def test_ramp_lowers_peak_reelout_speed(noisy_track):
    """Fig 4 case (tau = 0.1 s, sigma_r = 0.1 m, t_c = 10 s, a_p = 2, 17 m), same noise."""
    with_ramp = run(TrackingController(), noisy_track, tol=1e-8)
    without = run(TrackingController(ramp=False), noisy_track, tol=1e-8)
    peak_with = float(jnp.max(jnp.abs(with_ramp.reelout_m_s[:, 0])))
    peak_without = float(jnp.max(jnp.abs(without.reelout_m_s[:, 0])))
    assert peak_with < 0.7 * peak_without
    # both track: after t_c the error is at the level of the filtered noise (RMS 0.058 m)
    for res in (with_ramp, without):
        late = np.asarray(res.slider_m[-20:, 0])
        assert np.max(np.abs(late - TARGET)) < 0.3
    # the speed starts from rest with the ramp (kappa(0) = 0 and d_p' is continuous)
    assert abs(float(with_ramp.reelout_m_s[0, 0])) < 1e-12


# ---------------------------------------------------------------------------------------------
# dead time: approximants against the exact delayed reference
# ---------------------------------------------------------------------------------------------


def test_reference_converges_at_fourth_order():
    ctrl = TrackingController()
    _, d10, v10 = delayed_loop_reference(ctrl, TARGET, 2.0, steps_per_delay=5)
    _, d20, v20 = delayed_loop_reference(ctrl, TARGET, 2.0, steps_per_delay=10)
    _, d40, v40 = delayed_loop_reference(ctrl, TARGET, 2.0, steps_per_delay=20)
    e1 = np.max(np.abs(d20[::2] - d10))
    e2 = np.max(np.abs(d40[::2] - d20))
    assert 10.0 < e1 / e2 < 24.0  # 16 for fourth order
    assert e2 < 1e-8


def test_default_pade_matches_exact_delay(fig4_default, fig4_reference):
    d_ref, v_ref = fig4_reference
    err_d = np.max(np.abs(np.asarray(fig4_default.slider_m[:, 0]) - d_ref))
    err_v = np.max(np.abs(np.asarray(fig4_default.reelout_m_s[:, 0]) - v_ref))
    # measured 2.2e-5 m and 6.8e-4 m/s (module docstring); bounds with a factor ~4 of margin
    assert err_d < 1e-4
    assert err_v < 3e-3
    # the approximation error is far above the integration error: tolerances are not the limit
    assert err_d > 1e-7
    # all four channels see the same target
    np.testing.assert_allclose(np.asarray(fig4_default.slider_m),
                               np.repeat(np.asarray(fig4_default.slider_m[:, :1]), 4, 1), atol=1e-12)


def test_pade_error_shrinks_with_order(fig4_default, fig4_reference, zero_track):
    d_ref, v_ref = fig4_reference
    order1 = run(TrackingController(delay_order=1), zero_track)
    err = {}
    for name, res in (("pade1", order1), ("pade2", fig4_default)):
        err[name] = (
            np.max(np.abs(np.asarray(res.slider_m[:, 0]) - d_ref)),
            np.max(np.abs(np.asarray(res.reelout_m_s[:, 0]) - v_ref)),
        )
    assert err["pade2"][0] < 0.2 * err["pade1"][0]
    assert err["pade2"][1] < 0.5 * err["pade1"][1]
    assert err["pade1"][0] < 2e-3  # measured 4.8e-4 m


def test_lag_chain_is_a_coarser_delay(fig4_reference, zero_track):
    """A chain of lags converges to the delay (slowly): 4 lags err about 4.4e-3 m on Fig 4."""
    d_ref, v_ref = fig4_reference
    res = run(TrackingController(delay_model="lags", delay_order=4), zero_track)
    err_d = np.max(np.abs(np.asarray(res.slider_m[:, 0]) - d_ref))
    assert 1e-4 < err_d < 2e-2
    # with tau = 0.1 s the lag chain still beats no delay model at all (error of dropping tau):
    no_delay = run(TrackingController(delay_model="lags", delay_order=4, motor_delay_s=0.0), zero_track)
    err_none = np.max(np.abs(np.asarray(no_delay.slider_m[:, 0]) - d_ref))
    assert err_d < 0.5 * err_none


@pytest.mark.parametrize("kind", ["pade", "lags"])
def test_delay_frequency_response_converges(kind):
    """|R(i w tau) - e^{-i w tau}| shrinks with the order over w tau <= 1; the Pade is all-pass."""
    tau = 0.1
    w = np.linspace(0.0, 1.0 / tau, 21)
    orders = (1, 2, 3, 4, 5) if kind == "pade" else (1, 2, 4, 8, 16)
    errs = []
    for n in orders:
        dl = PadeDelay(tau, n) if kind == "pade" else LagChainDelay(tau, n)
        r = dl.frequency_response(w)
        errs.append(np.max(np.abs(r - np.exp(-1j * w * tau))))
        assert abs(r[0] - 1.0) < 1e-12  # unit DC gain
        if kind == "pade":
            np.testing.assert_allclose(np.abs(r), 1.0, atol=1e-12)
    assert np.all(np.diff(errs) < 0)
    if kind == "pade":
        assert errs[-1] < 1e-10


def test_delay_filter_is_identity_and_differentiable_at_tau0():
    x = jnp.zeros((4, 2))
    u = jnp.array([1.0, -2.0, 0.5, 3.0])

    def out(tau):
        dx, y = PadeDelay(tau, 2).derivative(x + 0.1, u)
        return jnp.sum(y) + jnp.sum(dx)

    _, y0 = PadeDelay(0.0, 2).derivative(x + 0.1, u)
    np.testing.assert_array_equal(np.asarray(y0), np.asarray(u))
    for tau in (0.0, 0.1):
        g = jax.grad(out)(jnp.asarray(tau))
        assert np.isfinite(float(g))
    lag_out = jax.vmap(lambda tau: LagChainDelay(tau, 3).derivative(jnp.zeros((4, 3)), u)[1])
    ys = lag_out(jnp.array([0.0, 0.1]))
    np.testing.assert_array_equal(np.asarray(ys[0]), np.asarray(u))


# ---------------------------------------------------------------------------------------------
# target rule (eq 3)
# ---------------------------------------------------------------------------------------------


def _axis_plane_intersection(r_head, r_bottom):
    """Independent: solve r_b + s (r_h - r_b) . e_z = 0 for s."""
    s = np.linalg.solve([[r_head[2] - r_bottom[2]]], [-r_bottom[2]])[0]
    return (r_bottom + s * (r_head - r_bottom))[:2]


def test_target_rule_both_sides_and_continuity():
    head = np.array([3.0, -2.0, 30.0])
    above = np.array([1.0, 4.0, 2.5])
    np.testing.assert_allclose(np.asarray(target_point(head, above)), above[:2])
    below = np.array([1.0, 4.0, -6.0])
    np.testing.assert_allclose(np.asarray(target_point(head, below)),
                               _axis_plane_intersection(head, below), rtol=1e-14)
    # the paper's printed formula, eq 3, second branch
    x_b, y_b, z_b = below
    x_h, y_h, z_h = head
    printed = [x_b - (x_b - x_h) / (z_b - z_h) * z_b, y_b - (y_b - y_h) / (z_b - z_h) * z_b]
    np.testing.assert_allclose(np.asarray(target_point(head, below)), printed, rtol=1e-14)
    # continuity at z_b = 0
    for eps in (1e-9, -1e-9):
        bottom = np.array([1.0, 4.0, eps])
        np.testing.assert_allclose(np.asarray(target_point(head, bottom)), [1.0, 4.0], atol=1e-9)
    # slider ordering: sliders 1-2 follow x_t, 3-4 follow y_t
    np.testing.assert_allclose(np.asarray(slider_target(head, above)), [1.0, 1.0, 4.0, 4.0])
    # head below the plane too: the head's projection (clamp)
    np.testing.assert_allclose(np.asarray(target_point(np.array([3.0, -2.0, -1.0]), below)), [3.0, -2.0])


def test_target_rule_nan_free_gradients():
    def f(z_b, z_h):
        return jnp.sum(target_point(jnp.array([3.0, -2.0, z_h]), jnp.array([1.0, 4.0, z_b])))

    grad = jax.grad(f, argnums=(0, 1))
    # on the plane; horizontal axis above, on and below the plane; inverted below
    for z_b, z_h in ((0.0, 30.0), (5.0, 5.0), (0.0, 0.0), (-2.0, -2.0), (-2.0, -10.0)):
        assert np.isfinite(float(f(z_b, z_h)))
        assert all(np.isfinite(float(g)) for g in grad(z_b, z_h))
    # below the plane the gradient matches central differences
    g = grad(-6.0, 30.0)
    h = 1e-6
    fd = (
        (f(-6.0 + h, 30.0) - f(-6.0 - h, 30.0)) / (2 * h),
        (f(-6.0, 30.0 + h) - f(-6.0, 30.0 - h)) / (2 * h),
    )
    np.testing.assert_allclose([float(x) for x in g], [float(x) for x in fd], rtol=1e-7)


# ---------------------------------------------------------------------------------------------
# measurement: the continuous filter model, noise (eqs 1-2)
# ---------------------------------------------------------------------------------------------


def _discrete_filter(path, t, dt):
    return sum(w * path(t - j * dt) for w, j in zip(FILTER_WEIGHTS, FILTER_DELAYS))


def test_delayed_measurement_second_order_error():
    """exact filter - (r - 2 Dt v) = 2.3 Dt^2 a for a quadratic path; O(Dt^3) beyond."""
    r0, v0, a = np.array([1.0, -2.0, 40.0]), np.array([0.7, 0.3, -12.0]), np.array([0.5, -1.0, -9.81])
    quad = lambda t: r0 + v0 * t + 0.5 * a * t**2  # noqa: E731
    for dt in (0.01, 0.02, 0.05):
        for t in (0.3, 1.7):
            approx = np.asarray(delayed_measurement(quad(t), v0 + a * t, dt))
            residual = _discrete_filter(quad, t, dt) - approx
            np.testing.assert_allclose(residual, 2.3 * dt**2 * a, atol=1e-12)
    # constant velocity: exact
    lin = lambda t: r0 + v0 * t  # noqa: E731
    np.testing.assert_allclose(np.asarray(delayed_measurement(lin(1.0), v0, 0.02)),
                               _discrete_filter(lin, 1.0, 0.02), atol=1e-13)
    # smooth non-quadratic path: the residual after the 2.3 Dt^2 a term is third order
    om = 3.0
    path = lambda t: np.sin(om * t)  # noqa: E731
    res = []
    for dt in (0.02, 0.01):
        t = 0.4
        approx = np.asarray(delayed_measurement(path(t), om * np.cos(om * t), dt))
        res.append(abs(_discrete_filter(path, t, dt) - approx - 2.3 * dt**2 * (-om**2 * np.sin(om * t))))
    assert 6.0 < res[0] / res[1] < 10.0


def test_noise_reproducible_rms_and_filter():
    sigma = 0.1
    raw = measurement_noise(KEY, 20000, sigma)
    assert raw.shape == (20000, 2, 3)
    np.testing.assert_array_equal(np.asarray(raw), np.asarray(measurement_noise(KEY, 20000, sigma)))
    other = measurement_noise(jax.random.PRNGKey(5), 20000, sigma)
    assert not np.allclose(np.asarray(raw), np.asarray(other))
    x = np.asarray(raw).reshape(20000, 6)
    # RMS of each component: 20000 samples, std of the estimate 0.5 %: 2 % is > 4 sigma
    np.testing.assert_allclose(np.sqrt(np.mean(x**2, axis=0)), sigma, rtol=0.02)
    np.testing.assert_allclose(np.mean(x, axis=0), 0.0, atol=4 * sigma / np.sqrt(20000))
    corr = np.corrcoef(x.T)
    assert np.max(np.abs(corr - np.eye(6))) < 0.03  # isotropic, independent axes
    # filtered sequence: independent convolution, RMS sqrt(0.34) sigma
    filt = np.asarray(filter_noise_samples(raw))
    conv = np.apply_along_axis(lambda s: np.convolve(s, [0.3, 0.4, 0.3], mode="valid"), 0, x)
    # raw sample j sits at (j - 3) Dt; output k uses raw k+2, k+1, k (1, 2, 3 samples back)
    np.testing.assert_allclose(filt.reshape(-1, 6), conv[: filt.shape[0]], atol=1e-15)
    np.testing.assert_allclose(np.sqrt(np.mean(filt**2)), np.sqrt(0.34) * sigma, rtol=0.02)


def test_noise_track_interpolates_and_is_differentiable_in_t(noisy_track):
    tr = noisy_track
    dt = float(tr.sample_period_s)
    vals = np.asarray(tr.values_m)
    for k in (0, 7, 250):
        np.testing.assert_allclose(np.asarray(tr(k * dt)), vals[k], atol=1e-15)
        quarter = 0.75 * vals[k] + 0.25 * vals[k + 1]
        np.testing.assert_allclose(np.asarray(tr((k + 0.25) * dt)), quarter, atol=1e-15)
        slope = jax.jacfwd(tr)((k + 0.5) * dt)
        np.testing.assert_allclose(np.asarray(slope), (vals[k + 1] - vals[k]) / dt, rtol=1e-10)
    # the track covers the run; its RMS is the filtered noise's
    assert (vals.shape[0] - 1) * dt >= T1
    np.testing.assert_allclose(np.sqrt(np.mean(vals**2)), np.sqrt(0.34) * 0.1, rtol=0.1)
    # the noise enters the target: bottom noise in x, y for a rocket above the plane
    ctrl = TrackingController()
    rk = figure4_rocket(TARGET)
    t = 3 * dt
    tgt = ctrl.measured_slider_target(t, rk.positions(t), rk.velocities(t), tr)
    np.testing.assert_allclose(np.asarray(tgt), TARGET + vals[3, 1, [0, 0, 1, 1]], atol=1e-14)


# ---------------------------------------------------------------------------------------------
# gradients against central finite differences (float64)
# ---------------------------------------------------------------------------------------------


def test_gradients_match_finite_differences(zero_track):
    """d/d(a_p, tau) of the mean squared tracking error of the Fig 4 loop (reverse mode)."""

    def loss(params):
        ctrl = eqx.tree_at(
            lambda c: (c.gain_per_s, c.motor_delay_s), TrackingController(), tuple(params)
        )
        res = run_tracking_loop(
            ctrl, figure4_rocket(TARGET), SAVE_TS, noise=zero_track, rtol=1e-10, atol=1e-10
        )
        return jnp.mean((res.target_m - res.slider_m) ** 2)

    p = jnp.array([2.0, 0.1])
    grad = np.asarray(jax.jit(jax.grad(loss))(p))  # one program each (op by op costs more CPU time)
    loss_ = jax.jit(loss)
    fd = []
    for i in range(2):
        # relative step 1e-3: the adaptive steps change with the parameter, which puts noise
        # ~ rtol * loss / (2 h) in the difference; 1e-3 keeps it ~ 1e-5 of the derivative
        h = 1e-3 * float(p[i])
        fd.append((float(loss_(p.at[i].add(h))) - float(loss_(p.at[i].add(-h)))) / (2 * h))
    np.testing.assert_allclose(grad, fd, rtol=2e-5)
    assert grad[0] < 0 < grad[1]  # more gain tracks better, more delay tracks worse


# ---------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(gain_per_s=-2.0), "gain_per_s"),
        (dict(gain_per_s=float("nan")), "gain_per_s"),
        (dict(derivative_gain=-1.0), "derivative_gain"),
        (dict(motor_delay_s=-0.1), "motor_delay_s"),
        (dict(sample_period_s=0.0), "sample_period_s"),
        (dict(tracking_time_s=0.0), "tracking_time_s"),
        (dict(motor_bandwidth_per_s=float("inf")), "motor_bandwidth_per_s"),
        (dict(noise_rms_m=-0.1), "noise_rms_m"),
        (dict(motor_lag=False), "derivative_gain"),
        (dict(delay_model="bessel"), "delay_model"),
        (dict(delay_order=0), "delay_order"),
        (dict(delay_order=9), "delay_order"),
    ],
)
def test_bad_input_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        TrackingController(**kwargs)


def test_bad_delay_and_noise_inputs():
    with pytest.raises(ValueError, match="delay_s"):
        PadeDelay(-0.1, 2)
    with pytest.raises(ValueError, match="n_lags"):
        LagChainDelay(0.1, 0)
    with pytest.raises(ValueError, match="sample_period_s"):
        NoiseTrack(0.0, jnp.zeros((3, 2, 3)))
    with pytest.raises(ValueError, match="values_m"):
        NoiseTrack(0.02, jnp.zeros((3, 3)))
    with pytest.raises(ValueError, match="bottom_m"):
        RocketPath(head_m=jnp.zeros(3), bottom_m=jnp.array([0.0, float("nan"), 1.0]))
    with pytest.raises(ValueError, match="delay_s"):
        delayed_loop_reference(TrackingController(motor_delay_s=0.0), TARGET, 1.0)


def test_kappa_ramp():
    t = jnp.array([-1.0, 0.0, 2.5, 5.0, 7.0])
    np.testing.assert_allclose(np.asarray(kappa(t, 10.0)), [0.0, 0.0, 0.5, 1.0, 1.0])


@pytest.mark.slow  # four more compiles of the loop (~3 s each on a 2-core CPU)
def test_delay_error_shrinks_along_both_families(fig4_default, fig4_reference, zero_track):
    """Pade orders 2 < 3 < 4 and lag chains 2 < 8 on the Fig 4 loop (the experiment's table)."""
    d_ref, v_ref = fig4_reference

    def errors(res):
        return (np.max(np.abs(np.asarray(res.slider_m[:, 0]) - d_ref)),
                np.max(np.abs(np.asarray(res.reelout_m_s[:, 0]) - v_ref)))

    pade = [errors(fig4_default)]
    pade += [errors(run(TrackingController(delay_order=n), zero_track)) for n in (3, 4)]
    lags = [
        errors(run(TrackingController(delay_model="lags", delay_order=n), zero_track)) for n in (2, 8)
    ]
    for family in (pade, lags):
        assert np.all(np.diff([e[0] for e in family]) < 0)
        assert np.all(np.diff([e[1] for e in family]) < 0)
    # a chain of 8 lags is still coarser than Pade order 2
    assert lags[-1][0] > 10 * pade[0][0]
