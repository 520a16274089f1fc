"""Passive-deceleration scenes: levels, the 1-DOF limit, energy budget, gradients, bad input, CLI."""

import dataclasses
import json
import subprocess
import sys

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable import simulate
from jaxcable.arresting.buffer import BufferDevice
from jaxcable.arresting.landing import report_landing, run_landing
from jaxcable.arresting.layout import ArrestingLayout, CaptureState
from jaxcable.arresting.passive import (
    SAVE_SPACING_S,
    LandingCriteria,
    filtered_maxima,
    passive_landing_scene,
    smooth_landing_outputs,
)
from jaxcable.components.wind import WindField
from jaxcable.core.filters import cfc_gain

KEYS = ("z_max_m", "a_max_g", "sigma_max_mpa", "a_max_raw_g", "sigma_max_raw_mpa", "stop_time_s", "criteria_met",
        "solve_ok", "stopped", "z_ok", "a_ok", "sigma_ok", "solver_status", "filter_cfc_hz", "unmet")  # fmt: skip
FLAGS = ("solve_ok", "stopped", "z_ok", "a_ok", "sigma_ok")
STIFF = dict(layout=ArrestingLayout(EA_N=2.64e11), cable_damping_s=1e-2)
"""The rigid level's 1-DOF limit: 1000x stiffer cables, damped (beta = 1e-2 s)."""


@pytest.fixture(scope="module")
def one_dof():
    return run_landing("1dof").outputs


def test_rigid_level_design_case_closes_energy_budget(one_dof):
    run = run_landing("rigid")
    o = run.outputs
    assert o["solver_status"] == "successful"
    assert o["stopped"] and np.isfinite(o["stop_time_s"])
    # the budget (kinetic + potential + counterweight + elastic + dissipated) is closed to the solver
    # tolerance; the issue asks for 1%
    assert o["energy_budget_error"] < 1e-2
    assert o["energy_budget_error"] < 1e-4
    # elastic cables stop the rocket near the rigid-cable distance (within 3%: cable stretch and the
    # throat 1.4 m outside the frame line)
    assert o["z_max_m"] == pytest.approx(one_dof["z_max_m"], rel=0.03)
    rep = report_landing(run)
    for k in KEYS:
        assert k in rep
    json.dumps(rep)
    # success is the conjunction of the flags; z_max is 10.24 m here (Table 1's buffer, see the docs)
    assert rep["criteria_met"] == all(rep[f] for f in FLAGS) and not rep["z_ok"] and not rep["criteria_met"]
    assert "z_max over the limit" in rep["unmet"] and rep["solve_ok"] and rep["stopped"]
    # the peaks are the ~5 Hz cable-counterweight ringing, in CFC 60's pass band (gain 1 - 2e-6 at
    # 5 Hz): filtering moves them by less than 1e-5 (measured 1e-6 and 5e-7)
    assert float(cfc_gain(5.0, 60.0, 1e-3)) > 1.0 - 1e-5
    assert o["a_max_g"] == pytest.approx(o["a_max_raw_g"], rel=1e-5)
    assert o["sigma_max_mpa"] == pytest.approx(o["sigma_max_raw_mpa"], rel=1e-5)


def test_rigid_level_converges_to_one_dof_with_stiff_damped_cables(one_dof):
    """The 1-DOF model is the rigid-cable limit: 1000x stiffer cables with stiffness-proportional
    damping (beta = 1e-2 s overdamps the cable-counterweight mode, which a rigid cable does not have)
    reproduce z_max, the raw a_max and peak cable stress and the stop to 1% (measured 0.02-0.25%).

    The filtered (CFC 60) maxima agree to 2%: the filter rings on a sharp change (3.8% overshoot on an
    ideal step). At the stop the rigid cable's deceleration drops to zero at once, the stiff
    cable's within a few ms, so the 1-DOF model's filtered a_max is the higher one (measured 1.5%);
    at capture the 1-DOF stress jumps from 0 to 437 MPa, the stiff cable's rises within ~4 ms
    (0.6%). Both filtered a_max exceed the raw ones: the peak is the end of the stroke, right
    before that drop."""
    run = run_landing("rigid", t_end_s=1.0, **STIFF)
    o = run.outputs
    for key in ("z_max_m", "a_max_raw_g", "sigma_max_raw_mpa", "stop_time_s"):
        assert o[key] == pytest.approx(one_dof[key], rel=0.01), key
    for key in ("a_max_g", "sigma_max_mpa"):
        assert o[key] == pytest.approx(one_dof[key], rel=0.02), key
    for out in (o, one_dof):
        assert out["a_max_raw_g"] < out["a_max_g"] < 1.04 * out["a_max_raw_g"]


def test_unfinished_landings_do_not_meet_the_criteria():
    """A landing meets the criteria only if the solve succeeded, the rocket stopped and z_max, a_max,
    sigma_max are within their limits. 0.3 s of the damped design case is within every limit so far
    but still descending; a run out of solver steps has solve_ok False; both say why, in the JSON
    report (``unmet``) and the text report."""
    from jaxcable.cli import main as cli_main

    short = report_landing(run_landing("rigid", t_end_s=0.3, cable_damping_s=1e-2))
    assert short["z_ok"] and short["a_ok"] and short["sigma_ok"] and short["solve_ok"]
    assert not short["stopped"] and short["stop_time_s"] is None
    assert not short["criteria_met"] and short["unmet"] == ["not stopped within t_end"]
    steps = report_landing(run_landing("rigid", t_end_s=1.0, max_steps=50))
    assert steps["solver_status"] == "max_steps_reached" and not steps["solve_ok"]
    assert not steps["criteria_met"] and steps["unmet"][:2] == ["solver: max_steps_reached", "not stopped within t_end"]
    # the samples after the early end are inf; the filtered maxima over the samples before it are finite
    assert np.isfinite(steps["a_max_g"]) and np.isfinite(steps["sigma_max_mpa"])
    # the same run through the command line's text report
    text = _land_text(cli_main, ["--fidelity", "rigid", "--t-end", "0.3", "--cable-damping", "1e-2"])
    assert "not stopped within t_end = 0.3 s" in text and "criteria met NO (not stopped within t_end)" in text
    one = report_landing(run_landing("1dof", t_end_s=0.5))  # the 1-DOF model too
    assert not one["stopped"] and not one["criteria_met"] and one["unmet"] == ["not stopped within t_end"]


def _land_text(cli_main, argv):
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        cli_main(["land", *argv])
    return buf.getvalue()


def test_filtered_maxima_converge_with_the_save_spacing():
    """The filtered criteria are a property of the landing, not of its sampling: on the stiff-cable
    case (sharp rises at capture and at the stop, the hardest for the filter to resolve), one solve
    saved every 0.25 ms, its records taken every 2, 1, 0.5 and 0.25 ms (the saved grid does not move
    the adaptive steps), the filtered a_max and sigma_max change less and less. Measured: a_max
    4.1912, 4.1687, 4.1660, 4.1662 g (changes 2.2e-2, 2.8e-3, 2.5e-4 g), sigma_max 454.23, 449.64,
    448.84, 448.67 MPa (changes 4.6, 0.80, 0.17 MPa): 1 ms is within 0.07% / 0.2% of 0.25 ms.
    (The raw maxima converge differently: the raw stress peak, a few samples wide, keeps rising as
    the grid refines.)"""
    run = run_landing("rigid", t_end_s=1.0, save_spacing_s=2.5e-4, **STIFF)
    values = []
    for k in (8, 4, 2, 1):
        m = filtered_maxima(run.ts[::k], {key: run.probes[key][::k] for key in ("acceleration_m_s2", "stress_max_pa")})
        values.append([float(m["a_max_g"]), float(m["sigma_max_mpa"])])
    values = np.array(values)
    changes = np.abs(np.diff(values, axis=0))  # (3, 2): 2 -> 1 ms, 1 -> 0.5 ms, 0.5 -> 0.25 ms
    assert np.all(changes[1] < changes[0] / 3) and np.all(changes[2] < changes[1] / 3), changes
    np.testing.assert_allclose(values[1], values[3], rtol=3e-3)  # the scenes' 1 ms against 0.25 ms
    assert run.outputs["a_max_g"] == pytest.approx(values[3, 0], rel=1e-12)  # the run's own output


@pytest.mark.slow
def test_full_level_converges_to_one_dof_with_stiff_massless_cables_and_stiff_hooks(one_dof):
    """The full level's rocket (5 flexible bodies) and hinged, sprung hooks, with the cables' mass
    taken to zero (the massless cable component), 1000x stiffer damped cables and 100x stiffer
    hook springs, reproduce the 1-DOF model to 1% (z_max, the stop and the unfiltered a_max and sigma_max;
    measured 0.07-0.34% at rtol 1e-5). The 1-DOF model has no
    cable mass and no hook compliance: with Table 1's hook spring (1.5e5 N/m) the hooks' rotation
    under load adds stroke (z_max +1.2%, a_max -1.3%, stop time +3.6%, measured), and
    the ALE cable's own mass has kinetic energy of the counterweights' order (docs/arresting_design.md)."""
    from jaxcable.arresting.landing_rocket import LandingRocketParams

    # rtol 1e-5, not the level's 1e-4: the 1000x stiffer, damped cables are a stiffer problem than the
    # default scene, and at 1e-4 Bosh3's error in sigma_max (which carries the damping force
    # EA beta eps_dot) is 2.0% there (measured), against 2.4e-4 on the default scenes
    run = run_landing(
        "full", cable_model="massless", layout=ArrestingLayout(EA_N=2.64e11), cable_damping_s=1e-2,
        rocket_params=LandingRocketParams(hook_stiffness_N_per_m=1.5e7), t_end_s=1.0, rtol=1e-5, atol=1e-5,
    )  # fmt: skip
    o = run.outputs
    assert o["solver_status"] == "successful"
    assert o["energy_budget_error"] < 1e-4
    for key in ("z_max_m", "a_max_raw_g", "sigma_max_raw_mpa", "stop_time_s"):
        assert o[key] == pytest.approx(one_dof[key], rel=0.01), key
    # the filtered maxima. sigma_max as at the rigid level (test above; measured 0.8%). a_max: the
    # sprung hooks and the flexible rocket soften the stop further than the stiff cables alone, so
    # the filter hardly rings here (filtered 4.095 g, raw 4.090 g), while the rigid cable's sudden
    # stop rings by 3.4% (4.23 g): the filtered a_max lies between the level's raw one and the
    # 1-DOF model's filtered one
    assert o["sigma_max_mpa"] == pytest.approx(one_dof["sigma_max_mpa"], rel=0.02)
    assert o["a_max_raw_g"] <= o["a_max_g"] <= one_dof["a_max_g"]


def test_cable_model_is_a_component_choice():
    """``cable_model`` picks the cable component at any level; an unknown name, and a scene for the
    1dof level (which has none), get errors naming the field."""
    from jaxcable.arresting.cable_sets import AleCables, MasslessCables

    assert isinstance(passive_landing_scene("rigid").cables, MasslessCables)
    assert isinstance(passive_landing_scene("full", cable_model="massless", t_end_s=0.1).cables, MasslessCables)
    assert isinstance(passive_landing_scene("rigid", cable_model="ale", t_end_s=0.1).cables, AleCables)
    with pytest.raises(ValueError, match="cable_model"):
        passive_landing_scene("full", cable_model="rope")
    with pytest.raises(ValueError, match="1dof"):
        passive_landing_scene("1dof")


# slow tier: 110-185 s on 2 cores; the default tier keeps gradients against central differences of the
# design objective (tests/test_design.py), the brake profile and the two-phase forward mode
@pytest.mark.slow
def test_smooth_outputs_gradients_match_finite_differences():
    """d(z_max, a_max, sigma_max)/d(m_w, F_f) through the diffrax solve (rigid level), float64,
    against central differences; the soft maxima are within their stated bias of the hard ones."""
    scene = passive_landing_scene("rigid", t_end_s=1.0)

    def outputs(params):
        m_w, F_f = params
        s = eqx.tree_at(
            lambda sc: (sc.cables.buffer.counterweight_mass_kg, sc.cables.buffer.brake_force_N), scene, (m_w, F_f)
        )
        res = simulate(s, 1.0, rtol=1e-8, atol=1e-8, max_steps=100_000)
        out = smooth_landing_outputs(res.ts, res.probes)
        return jnp.stack([out["z_max_m"], out["a_max_g"], out["sigma_max_mpa"]]), res.outputs

    x0 = jnp.array([920.0, 3.13e5])
    f = eqx.filter_jit(lambda p: outputs(p)[0])
    jac = np.asarray(jax.jit(jax.jacrev(f))(x0))  # one program (differentiating op by op costs more)
    assert np.all(np.isfinite(jac))
    steps = np.array([5.0, 1.0e3])
    for j in range(2):
        e = np.zeros(2)
        e[j] = steps[j]
        fd = (np.asarray(f(x0 + e)) - np.asarray(f(x0 - e))) / (2 * steps[j])
        scale = np.abs(np.asarray(f(x0))) / np.asarray(x0)[j]
        # central differences in float64 with steps ~0.3-0.5% of the parameter: truncation plus the
        # solver's adaptive-step noise (rtol 1e-8); 2% of the output's own scale
        assert np.allclose(jac[:, j], fd, rtol=0.02, atol=0.02 * scale), (j, jac[:, j], fd)
    soft, hard = outputs(x0)
    n = scene.default_save_ts(1.0).shape[0]  # one sample per ms: 1001
    # each soft maximum is within its bias (width log n) above the hard one: a_max and sigma_max
    # over the same CFC-filtered histories
    widths = (0.05, 0.05, 5.0)
    for i, key in enumerate(("z_max_m", "a_max_g", "sigma_max_mpa")):
        assert float(hard[key]) <= float(soft[i]) <= float(hard[key]) + widths[i] * np.log(n), key


def test_bad_input_gets_clear_errors():
    with pytest.raises(ValueError, match="counterweight_mass_kg"):
        run_landing("rigid", buffer=BufferDevice(counterweight_mass_kg=-1.0))
    with pytest.raises(ValueError, match="EA_N"):
        ArrestingLayout(EA_N=0.0)
    with pytest.raises(ValueError, match="x_m"):
        CaptureState(x_m=float("nan"))
    with pytest.raises(ValueError, match="outside the capture frame"):
        run_landing("rigid", capture=CaptureState(x_m=22.0))
    with pytest.raises(ValueError, match="theta_z_deg"):
        CaptureState(theta_z_deg=50.0)
    with pytest.raises(ValueError, match="fidelity"):
        run_landing("medium")
    with pytest.raises(ValueError, match="cable_damping_s"):
        run_landing("rigid", cable_damping_s=-1e-3)
    with pytest.raises(ValueError, match="n_fine"):
        passive_landing_scene("ale", n_fine=0)
    with pytest.raises(ValueError, match="n_span_elements"):
        passive_landing_scene("ale", n_span_elements=8, n_fine=7)
    from jaxcable.cli import main as cli_main

    assert cli_main(["land", "--fidelity", "ale", "--fine-elements", "0"]) == 2
    # the passive phase's mesh at a level without cable nodes, and an impossible mesh, before any solve
    assert cli_main(["land", "--phase", "full", "--fidelity", "rigid", "--fine-elements", "4"]) == 2
    assert cli_main(["land", "--phase", "full", "--fine-elements", "79"]) == 2
    with pytest.raises(ValueError, match="vertical central"):
        run_landing("1dof", capture=CaptureState(x_m=3.0))


def test_saved_grid_has_a_fixed_spacing_so_the_maxima_do_not_depend_on_the_duration():
    """The criteria are maxima over the saved samples. With a fixed spacing (1 ms) the grid of a 1 s
    run is the first half of a 2 s run's grid, and the adaptive steps over the first second are the
    same (the step controller does not see t1 until the last step), so a_max and sigma_max, whose
    peaks lie in the first second (the descent stops at 0.81 s), agree to rounding (measured: equal).
    The old fixed count (401 samples: 2.5 ms at 1 s, 5 ms at 2 s) gave 7.0359 / 7.0286 g and
    631.21 / 630.91 MPa (1.0e-3 and 4.8e-4 apart), so 1e-9 separates the two by 5 orders."""
    assert SAVE_SPACING_S == 1e-3
    runs = {t: run_landing("rigid", t_end_s=t) for t in (1.0, 2.0)}
    for t, run in runs.items():
        assert run.ts.shape == (round(t / SAVE_SPACING_S) + 1,)
        np.testing.assert_allclose(np.diff(run.ts), SAVE_SPACING_S, rtol=1e-9)
        assert run.outputs["stop_time_s"] < 0.9
    for key in ("a_max_g", "sigma_max_mpa"):
        assert runs[1.0].outputs[key] == pytest.approx(runs[2.0].outputs[key], rel=1e-9), key
    # an explicit spacing or count still sets the grid
    assert passive_landing_scene("rigid", save_spacing_s=2e-3).default_save_ts(1.0).shape == (501,)
    assert passive_landing_scene("rigid", n_save=1001).default_save_ts(2.0).shape == (1001,)
    # but not one too coarse for the criteria's CFC 60 filter (design frequency 124.65 Hz below the
    # Nyquist frequency: a spacing below 4.01 ms)
    with pytest.raises(ValueError, match="n_save = 401 gives saved samples 0.005 s apart"):
        passive_landing_scene("rigid", n_save=401).default_save_ts(2.0)


def test_bad_save_grid_gets_clear_errors():
    for bad in (0.0, -1e-3, float("nan"), float("inf"), 5e-3):
        with pytest.raises(ValueError, match="save_spacing_s"):
            passive_landing_scene("rigid", save_spacing_s=bad)
    for bad in (0.0, -60.0, float("nan")):
        with pytest.raises(ValueError, match="filter_cfc_hz"):
            LandingCriteria(filter_cfc_hz=bad)
    for bad in (1, 0, 2.5, True):
        with pytest.raises(ValueError, match="n_save"):
            passive_landing_scene("rigid", n_save=bad)
    scene = passive_landing_scene("rigid")
    with pytest.raises(ValueError, match="save_spacing_s"):
        dataclasses.replace(scene, save_spacing_s=0.0)  # the scene itself checks, not only the builder
    # the spacing rule needs a concrete t1; a fixed n_save does not
    with pytest.raises(ValueError, match="t1 is traced"):
        jax.jit(lambda t1: scene.default_save_ts(t1))(1.0)
    fixed = dataclasses.replace(scene, n_save=11)
    assert jax.jit(lambda t1: fixed.default_save_ts(t1))(1.0).shape == (11,)


def test_deviated_capture_rigid_level_is_finite_and_recentres():
    """A capture 17 m off-centre with 16 deg tilt (Table 8's extremes): finite, budget closes, the
    asymmetric cable forces pull the rocket back toward the centre (section IV.A)."""
    cap = CaptureState(x_m=17.0, y_m=-17.0, vx_m_s=2.0, theta_x_deg=16.0, theta_y_deg=-16.0, theta_z_deg=26.0)
    run = run_landing("rigid", capture=cap, t_end_s=2.0)
    o = run.outputs
    assert o["solver_status"] == "successful"
    assert o["energy_budget_error"] < 1e-2
    xy = run.probes["centre_xy_m"]
    ok = np.isfinite(run.ts)
    assert np.linalg.norm(xy[ok][-1]) < np.linalg.norm(xy[0]) - 1.0


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", ["ale", "full"])
def test_ale_and_full_levels_start_of_capture(fidelity):
    """First 0.1 s of the design case with ALE cables and hook contact: every hook carries a contact
    force, the budget (with contact work, damping and brakes) closes within 1%, the cable mass is
    conserved over the pulleys. The ale case runs in a 20 m/s wind with 20% gust (air loads on the
    rocket and the spans, the air's work in the budget)."""
    kw = {}
    if fidelity == "ale":
        kw = dict(wind=WindField(speed_m_s=20.0, angle_deg=90.0, gust_intensity=0.2, key=jax.random.PRNGKey(1)))
    run = run_landing(fidelity, t_end_s=0.1, **kw)
    o = run.outputs
    if fidelity == "ale":
        assert run.probes["energy"]["aero_work"][-1] != 0.0
    assert o["solver_status"] == "successful", o
    assert o["energy_budget_error"] < 1e-2
    force = run.probes["hook_normal_force_N"]
    ok = np.isfinite(run.ts)
    assert np.all(np.max(force[ok], axis=0) > 1e4)
    assert np.all(np.isfinite(run.probes["drop_m"][ok]))
    assert run.probes["drop_m"][ok][-1] > 1.5  # still falling at ~20 m/s


def test_wind_in_passive_phase_rigid_level_drifts_downwind_and_closes_budget():
    """Eqs 43-44 on the free rocket after capture: in still air the rocket's own drag only removes
    energy (negative air work); a 20 m/s wind from the east (90 deg) with 20% gust pushes it west
    (-x); the budget with the air's work closes in both."""
    out = {}
    for speed in (0.0, 20.0):
        wind = WindField(speed_m_s=speed, angle_deg=90.0, gust_intensity=0.2, key=jax.random.PRNGKey(0))
        scene = passive_landing_scene("rigid", t_end_s=1.0, wind=wind, wind_time_offset_s=3.0)
        res = simulate(scene, 1.0, rtol=1e-7, atol=1e-7, max_steps=100_000)
        assert res.status_message == "successful"
        assert float(res.outputs["energy_budget_error"]) < 1e-5
        out[speed] = res
    assert float(out[0.0].probes["energy"]["aero_work"][-1]) < 0.0
    assert np.max(np.abs(out[0.0].probes["centre_xy_m"])) < 1e-6  # still air: stays central
    # 0.05 m (0.1 m before the calibration of the rocket's coefficients): with the calibrated C_n = 0
    # (eq 44 as printed, jaxcable.arresting.tracking_calibration) the side force is eq 44's normal
    # force alone, proportional to the descent speed, which falls to zero in this second; measured
    # 0.072 m west (more than 0.1 m with the textbook cross-flow drag C_n = 0.8)
    assert float(out[20.0].probes["centre_xy_m"][-1, 0]) < -0.05
    assert abs(float(out[20.0].probes["centre_xy_m"][-1, 1])) < abs(float(out[20.0].probes["centre_xy_m"][-1, 0]))


def test_cable_span_drag_matches_cylinder_closed_form():
    """Eq 45 on the ALE spans: a steady 15 m/s wind from the east on the design case's spans at rest.
    Each span is draped in two straight legs (slider -> hook throat -> slider); a leg of length ``l``
    at angle ``phi`` to the wind's normal carries the cylinder's cross-flow drag
    ``rho/2 d l C_n (v cos phi)^2`` along its normal plus skin friction ``rho/2 d l C_t pi (v sin phi)^2``
    along it. Cables 0, 1 run (nearly) north-south, across the flow; cables 2, 3 along it. The sum
    over the meshed elements must equal the two legs' closed form; the tower runs and block strands
    (inside the towers) carry none."""
    wind = WindField(speed_m_s=15.0, angle_deg=90.0, gust_intensity=0.0, key=jax.random.PRNGKey(0))
    scene = passive_landing_scene("ale", wind=wind)
    cables = scene.cables
    q0 = cables.q0
    zero = jax.tree_util.tree_map(jnp.zeros_like, q0)
    forces, power = jax.vmap(lambda sub, q, qd: cables._span_drag(sub.kinematics(q, qd), 0.0))(
        cables.subsystems, q0, zero
    )
    lo, hi = cables.span_slice
    kin = jax.vmap(lambda sub, q, qd: sub.kinematics(q, qd))(cables.subsystems, q0, zero)
    a, d, rho = scene.aero, 2.0 * float(cables.cable_radius_m), float(wind.air_density_kg_m3)
    air = np.array([-15.0, 0.0, 0.0])  # from the east (90 deg), blowing west
    total = np.asarray(jnp.sum(forces, axis=(1, 2)))  # (4, 3)
    for k in range(4):
        nodes = np.asarray(kin.r)[k, lo : hi + 1]
        pa, pb = nodes[0], nodes[-1]
        line = (pb - pa) / np.linalg.norm(pb - pa)
        off = nodes - pa - np.outer((nodes - pa) @ line, line)
        c = nodes[np.argmax(np.linalg.norm(off, axis=1))]  # the throat: the drape's kink
        expect = np.zeros(3)
        for p1, p2 in ((pa, c), (c, pb)):
            length = np.linalg.norm(p2 - p1)
            tangent = (p2 - p1) / length
            rel = -air  # cable at rest: velocity relative to the air
            u = rel @ tangent
            w = rel - u * tangent
            expect -= 0.5 * rho * d * length * (
                float(a.cable_normal_drag_coefficient) * np.linalg.norm(w) * w
                + float(a.cable_tangential_drag_coefficient) * np.pi * abs(u) * u * tangent
            )
        np.testing.assert_allclose(total[k], expect, rtol=1e-9, atol=1e-9 * np.linalg.norm(expect))
    # across the flow the drag is C_n / (pi C_t) = 38x the along-flow skin friction (default coefficients)
    assert abs(total[0, 0]) > 30 * abs(total[2, 0])
    outside = np.concatenate([np.asarray(forces)[:, :lo], np.asarray(forces)[:, hi:]], axis=1)
    assert np.all(outside == 0.0)
    np.testing.assert_allclose(np.asarray(power), 0.0, atol=1e-12)  # cable at rest: no power


def test_cli_land_json():
    out = subprocess.run(
        [sys.executable, "-m", "jaxcable.cli", "land", "--fidelity", "rigid", "--t-end", "1.0", "--json"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    for k in KEYS:
        assert k in data
    assert isinstance(data["criteria_met"], bool) and isinstance(data["solve_ok"], bool)
    assert data["filter_cfc_hz"] == 60.0
    assert data["criteria_met"] == all(data[f] for f in FLAGS)
    # --cable-damping reaches the cables: against the default (calibrated, 6.3e-3 s) a lightly damped
    # 1e-5 s lets the cable-counterweight mode ring (docs/arresting_design.md: a_max 7.04 g at the
    # rigid level against 4.28 g at 1e-2 s; the calibrated default gives 4.70 g), and the budget,
    # which books the damping's dissipation, closes
    light = subprocess.run(
        [sys.executable, "-m", "jaxcable.cli", "land", "--fidelity", "rigid", "--t-end", "1.0", "--json",
         "--cable-damping", "1e-5"],
        capture_output=True,
        text=True,
        timeout=600,
    )  # fmt: skip
    assert light.returncode == 0, light.stderr
    light = json.loads(light.stdout)
    assert light["a_max_g"] > data["a_max_g"] + 1.0
    assert data["energy_budget_error"] < 1e-4 and light["energy_budget_error"] < 1e-4
    bad = subprocess.run(
        [sys.executable, "-m", "jaxcable.cli", "land", "--fidelity", "1dof", "--x", "3"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert bad.returncode == 2 and "vertical central" in bad.stderr
