"""Two-phase landing (tracking -> capture -> passive deceleration), level rigid.

Checks: the descent hold and the capture instant against closed forms, the paper's deviated case
(section IV.A) captured in scenario I as the paper reports, a case whose hooks miss reported as not
captured (finite, no hang), reproducible noise/gust seeds, the command line's JSON keys, the sweep's
two-phase case function, and (slow) gradients w.r.t. a_p against central finite differences.
"""

import json

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.layout import CaptureState
from jaxcable.arresting.two_phase import (
    SCENARIO_SETTINGS,
    deviated_case,
    run_two_phase,
    tracking_scene,
    two_phase_outputs,
)

EVENT = int(diffrax.RESULTS.event_occurred._value)
_run = eqx.filter_jit(lambda sc, buf: two_phase_outputs(sc, "rigid", buf, passive_t_end_s=1.5))


@pytest.fixture(scope="module")
def deviated():
    scene = tracking_scene()
    return scene, _run(scene, BufferDevice())


def test_deviated_case_is_captured_with_consistent_capture_instant(deviated):
    scene, out = deviated
    # the paper reports the deviated case of IV.A captured (scenario I)
    assert bool(out["captured"]), float(out["capture_margin_m"])
    assert int(out["tracking_status"]) == EVENT  # the throats reached the plane
    # descent hold: the CoM's vertical speed stays h / t_c = 20 m/s (thrust cancels gravity and the
    # vertical aerodynamic force); O moves with the slow rotation only (0.1 deg/s rates)
    s = SCENARIO_SETTINGS["I"]
    v = s["height_m"] / s["tracking_time_s"]
    cs = out["captured_state"]
    assert abs(float(cs.vz_m_s) + v) < 0.05
    # capture instant: the throats start (h + their depth below O) above the plane
    state0 = scene.initial_state()
    depth = float(scene.terminal.z_m - scene.terminal_event(0.0, state0))
    t_expected = (s["height_m"] - depth) / v
    assert abs(float(out["capture_time_s"]) - t_expected) < 0.02, (float(out["capture_time_s"]), t_expected)
    # at the event the mean throat height is zero (root found)
    assert abs(float(cs.z_m) - depth) < 0.05
    for k in ("z_max_m", "a_max_g", "sigma_max_mpa", "tracking_error_m", "capture_margin_m"):
        assert np.isfinite(float(out[k])), k
    assert float(out["energy_budget_error"]) < 1e-3
    # the frame moved from the centre toward the rocket (13 m off) during tracking
    assert np.all(np.asarray(out["frame_centre_at_capture_m"]) > 5.0)


def test_hooks_that_miss_are_reported_not_captured():
    # a gain of ~0: the frame hardly leaves the centre while the rocket comes down 13 m off
    scene = tracking_scene(gain_per_s=1e-3)
    out = _run(scene, BufferDevice())
    assert int(out["tracking_status"]) == EVENT
    assert not bool(out["captured"])
    assert float(out["capture_margin_m"]) < -5.0
    assert not bool(out["landed"])
    assert np.isfinite(float(out["z_max_m"]))


def test_noise_and_gust_reproducible_from_seed():
    a = _run(tracking_scene(seed=3), BufferDevice())
    b = _run(tracking_scene(seed=3), BufferDevice())
    c = _run(tracking_scene(seed=4), BufferDevice())
    assert float(a["tracking_error_m"]) == float(b["tracking_error_m"])
    assert float(a["tracking_error_m"]) != float(c["tracking_error_m"])


def test_centre_vertical_still_air_tracks_to_zero_and_matches_passive_design_case():
    scene = tracking_scene(CaptureState(), wind_speed_m_s=0.0, noise_rms_m=0.0, motor_delay_s=0.0)
    out = _run(scene, BufferDevice())
    assert bool(out["captured"])
    assert float(out["tracking_error_at_capture_m"]) < 1e-6
    # captured centred, vertical, at 20 m/s: the passive phase is the design case of section II.B
    from jaxcable.arresting.passive import landing_outputs, passive_landing_scene
    from jaxcable.core.simulate import simulate

    # the passive phase keeps the (still) air: the rocket's own drag at 20 m/s acts in both
    ref_scene = passive_landing_scene("rigid", t_end_s=1.5, wind=scene.wind, aero=scene.aero)
    land = simulate(ref_scene, 1.5, rtol=1e-6, atol=1e-6, max_steps=200_000)
    ref = landing_outputs(land.ts, land.probes, land.status)
    for k in ("z_max_m", "a_max_g", "sigma_max_mpa"):
        assert abs(float(out[k]) / float(ref[k]) - 1) < 2e-3, (k, float(out[k]), float(ref[k]))


def test_command_line_json(capsys):
    from jaxcable.cli import main

    rc = main(["land", "--phase", "full", "--fidelity", "rigid", "--t-end", "1.5", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    for k in ("captured", "tracking_error_m", "captured_state", "z_max_m", "a_max_g", "sigma_max_mpa", "a_max_raw_g",
              "sigma_max_raw_mpa", "stop_time_s", "criteria_met", "solve_ok", "stopped", "landed", "unmet",
              "solver_status"):  # fmt: skip
        assert k in out, k
    assert isinstance(out["captured"], bool) and isinstance(out["criteria_met"], bool)
    # landed: captured, tracked, and the passive phase solved, stopped and within the three limits
    passive = out["solve_ok"] and out["stopped"] and out["z_ok"] and out["a_ok"] and out["sigma_ok"]
    assert out["passive_criteria_met"] == passive
    assert out["landed"] == (out["captured"] and out["tracking_ok"] and passive)
    assert out["landed"] == (out["unmet"] == [])
    assert set(out["captured_state"]) >= {"x_m", "y_m", "vx_m_s", "theta_x_deg", "omega_z_deg_s"}


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="scenario"):
        tracking_scene(scenario="IV")
    with pytest.raises(ValueError, match="height_m"):
        tracking_scene(height_m=-5.0)
    with pytest.raises(ValueError, match="fidelity"):
        two_phase_outputs(tracking_scene(), "1dof")
    # the passive phase's hook model is checked before the tracking phase runs
    with pytest.raises(ValueError, match="hook_contact must be 'capsule' or 'node', got 'ring'"):
        run_two_phase(fidelity="ale", passive_kwargs={"hook_contact": "ring"})
    with pytest.raises(ValueError, match="hook_contact='node' needs fidelity 'ale' or 'full'"):
        run_two_phase(fidelity="rigid", passive_kwargs={"hook_contact": "node"})
    # and so are its mesh and the rocket's bodies
    with pytest.raises(ValueError, match="n_span_elements must be >= n_fine"):
        run_two_phase(fidelity="full", passive_kwargs={"n_span_elements": 20, "n_fine": 20})
    with pytest.raises(ValueError, match="n_rocket_bodies=1 needs fidelity 'full'"):
        run_two_phase(fidelity="ale", passive_kwargs={"n_rocket_bodies": 1})
    with pytest.raises(ValueError, match="n_rocket_bodies must be an integer"):
        run_two_phase(fidelity="full", passive_kwargs={"n_rocket_bodies": 0})


GAIN_PER_S = 2.0  # a_p of the derivative checks


def _gain_outputs(a_p, adjoint):
    """(smooth capture margin [m], smooth a_max [g]) of the deviated case in still air without noise
    as functions of the gain ``a_p`` [1/s]: phase 1, its event time and a 1 s passive phase."""
    sc = tracking_scene(deviated_case(), gain_per_s=a_p, noise_rms_m=0.0, wind_speed_m_s=0.0)
    o = two_phase_outputs(sc, "rigid", BufferDevice(), passive_t_end_s=1.0, adjoint=adjoint)
    return jnp.stack([o["smooth_capture_margin_m"], o["smooth_a_max_g"]])


@pytest.fixture(scope="module")
def forward_jacobian():
    """d(_gain_outputs)/d a_p by forward mode (``diffrax.ForwardMode``), compiled once for the two
    derivative tests below."""
    jac = eqx.filter_jit(jax.jacfwd(lambda a: _gain_outputs(a, diffrax.ForwardMode())))(jnp.asarray(GAIN_PER_S))
    return np.asarray(jac)


@pytest.mark.slow
def test_gradients_wrt_gain_match_finite_differences(forward_jacobian):
    """d(smooth capture margin)/d a_p and d(smooth a_max)/d a_p through both solves and the event
    time, forward mode (diffrax.ForwardMode), against central differences (float64).

    Forward mode is the cheaper mode for one design parameter; reverse mode is checked against it
    in the next test. Central differences of an
    adaptive solve are noisy when a step changes: measured at h = 1e-2 / 1e-3 / 1e-4 / 1e-5 the
    margin's difference quotient was 0.2215 / 0.2210 / 0.2285 / 0.2201 (AD: 0.2214), hence h = 1e-2
    and 1% tolerance."""
    fj = eqx.filter_jit(lambda a: _gain_outputs(a, diffrax.ForwardMode()))
    h = 1e-2
    fd = (fj(jnp.asarray(GAIN_PER_S + h)) - fj(jnp.asarray(GAIN_PER_S - h))) / (2 * h)
    assert np.all(np.isfinite(forward_jacobian))
    assert abs(float(forward_jacobian[0])) > 0.05  # the gain moves the frame at capture
    np.testing.assert_allclose(forward_jacobian, np.asarray(fd), rtol=1e-2)


@pytest.mark.slow
def test_reverse_mode_gradient_equals_forward_mode(forward_jacobian):
    """Reverse-mode AD (diffrax's checkpointed adjoint) of both phases and the event time equals
    forward mode (checked against central differences above) to 1e-7. Regression: on jaxlib 0.10.2
    the reverse-mode program failed to run ("No registered implementation for untyped custom call
    to lapack_dtrsm_ffi for Host") because the passive phase starts from the traced captured state
    (see ``jaxcable.components.multibody._spd_solve``)."""
    rev = np.asarray(eqx.filter_jit(jax.jacrev(lambda a: _gain_outputs(a, None)))(jnp.asarray(GAIN_PER_S)))
    assert np.all(np.isfinite(rev)) and abs(rev[0]) > 0.05
    # both differentiate the same discrete solve: measured 1.5e-15 and 6.6e-12 apart
    np.testing.assert_allclose(rev, forward_jacobian, rtol=1e-7, atol=1e-10)


@pytest.mark.parametrize("scenario", ["I", "II", "III"])
def test_tracking_converges_under_noise_and_delay_for_each_scenario(scenario):
    """The frame's tracking error converges for each scenario's gain a_p (Table 4), with the
    deviated case's dead time (0.1 s) and measurement noise (0.1 m RMS) and the calibrated motor
    bandwidth (5 /s; eq 8 prints 1 /s). The reference is the geometry, not our own run: the error starts at the 18.4 m
    lateral offset of the deviated case (13 m, 13 m) and must fall below one tenth of it, then stay
    there over the last fifth of the tracking time up to capture (a sign error in the PD law, the
    target rule or the slider map would diverge or stall). The paper's "approaches zero" is met only
    down to a floor set by noise, delay and the target's motion (measured 0.4-1.1 m at capture with
    b = 1 /s before the calibration; see the module docstring of two_phase)."""
    from jaxcable.arresting.two_phase import tracking_outputs

    scene = tracking_scene(scenario=scenario)
    assert float(scene.controller.motor_delay_s) == pytest.approx(0.1)
    assert float(scene.controller.noise_rms_m) == pytest.approx(0.1)
    track, out = tracking_outputs(scene)
    ts = np.asarray(track.ts)
    err = np.asarray(track.probes["tracking_error_m"])
    ok = np.isfinite(ts)
    ts, err = ts[ok], err[ok]
    t_c = float(scene.controller.tracking_time_s)
    initial = np.hypot(13.0, 13.0)
    assert err[0] == pytest.approx(initial, rel=0.02)
    late = ts >= 0.8 * t_c
    assert late.sum() >= 5
    assert err[late].max() < 0.1 * initial, (scenario, err[late].max())
    assert float(out["tracking_error_at_capture_m"]) < 0.1 * initial
    # the error shrinks on every quarter of the tracking time until the noise floor is reached
    q = [err[np.argmin(abs(ts - f * t_c))] for f in (0.0, 0.25, 0.5)]
    assert q[0] > q[1] > q[2], (scenario, q)
